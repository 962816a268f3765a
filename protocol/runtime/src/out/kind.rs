//! What kind of file an output is, and whether a file already on disk is of
//! that kind: the overwrite rule ([`super::files`]) replaces a file only with
//! one of its own kind, so it has to recognise files by their first bytes
//! (names lie: `--svg run.mcap`).

/// The kinds of file the orchestrator writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// An MCAP recording (`launch --record`, `record recover --out`).
    Recording,
    /// An SVG picture (`--svg`, `--animate`, `draw --out`).
    Svg,
    /// A CSV table (a header line of comma-separated names first).
    Csv,
    /// A terrain in the text format (`#`, `.`, `S`, `G` rows).
    Terrain,
    /// A PEM certificate or key (`certs`).
    Pem,
    /// A zenoh config written by `orchestrator certs`.
    ZenohConfig,
}

/// How many bytes of a file [`Kind::matches`] looks at.
pub const HEAD: usize = 512;

/// The marker line `orchestrator certs` writes into every zenoh config.
pub const ZENOH_CONFIG_MARK: &str = "// Written by `orchestrator certs`";

/// The first bytes of every MCAP file (the MCAP specification's magic):
/// written out here so the outputs need no MCAP library; the recording's
/// crate checks it equals `mcap::MAGIC` (`bycoms-record`'s tests).
pub const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";

impl Kind {
    /// The kind in words, for messages ("an SVG picture").
    pub fn name(self) -> &'static str {
        match self {
            Kind::Recording => "an MCAP recording",
            Kind::Svg => "an SVG picture",
            Kind::Csv => "a CSV table",
            Kind::Terrain => "a terrain",
            Kind::Pem => "a PEM certificate or key",
            Kind::ZenohConfig => "a zenoh config made by `orchestrator certs`",
        }
    }

    /// Whether a file starting with `head` (its first [`HEAD`] bytes, or all
    /// of a shorter file) is of this kind.
    pub fn matches(self, head: &[u8]) -> bool {
        if self == Kind::Recording {
            return head.starts_with(MCAP_MAGIC);
        }
        // Every other kind is text; a cut in the middle of a UTF-8 sequence is fine.
        let text = match std::str::from_utf8(head) {
            Ok(text) => text,
            Err(e) => match std::str::from_utf8(&head[..e.valid_up_to()]) {
                Ok(text) if head.len() == HEAD && head.len() - e.valid_up_to() < 4 => text,
                _ => return false,
            },
        };
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        match self {
            Kind::Recording => false,
            Kind::Svg => text.trim_start().starts_with('<') && text.contains("<svg"),
            Kind::Pem => text.starts_with("-----BEGIN "),
            Kind::ZenohConfig => text.lines().take(3).any(|l| l.starts_with(ZENOH_CONFIG_MARK)),
            Kind::Terrain => {
                let mut rows = text.lines().filter(|l| !l.is_empty()).peekable();
                rows.peek().is_some()
                    && rows
                        .all(|l| l.trim_end_matches('\r').chars().all(|c| matches!(c, '#' | '.' | 'S' | 'G')))
            }
            Kind::Csv => {
                let header = text.lines().next().unwrap_or("");
                header.contains(',')
                    && !header.starts_with(['<', '#', '{', '[', '/', '-'])
                    && !header.contains(['=', '\0'])
            }
        }
    }

    /// The first kind of [`Kind::ALL`] that `head` matches, if any.
    pub fn of(head: &[u8]) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.matches(head))
    }

    /// Every kind.
    pub const ALL: [Kind; 6] =
        [Kind::Recording, Kind::Svg, Kind::Pem, Kind::ZenohConfig, Kind::Terrain, Kind::Csv];
}

#[cfg(test)]
mod tests {
    use super::Kind;

    #[test]
    fn each_kind_is_recognised_by_its_first_bytes_and_not_taken_for_another() {
        let mut mcap = super::MCAP_MAGIC.to_vec();
        mcap.extend_from_slice(b"\x01rest");
        let samples: [(&[u8], Option<Kind>); 12] = [
            (&mcap, Some(Kind::Recording)),
            (&[0x89, b'M'], None),
            (b"<?xml version=\"1.0\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\">", Some(Kind::Svg)),
            (b"  <svg width=\"10\"></svg>", Some(Kind::Svg)),
            (b"<html><body>not a picture</body></html>", None),
            (b"-----BEGIN CERTIFICATE-----\nMIIB\n", Some(Kind::Pem)),
            (b"// robot 1\n// Written by `orchestrator certs`; JSON5\n{}", Some(Kind::ZenohConfig)),
            (b"{ mode: \"client\" }", None),
            (b"S....\n.##..\n....G\n", Some(Kind::Terrain)),
            (b"index,eps,width\n0,1,2\n", Some(Kind::Csv)),
            (b"eps = 3.0\nrobots = [1, 2]\n", None),
            (b"\x00\x01\x02garbage", None),
        ];
        for (bytes, kind) in samples {
            assert_eq!(Kind::of(bytes), kind, "{:?}", String::from_utf8_lossy(bytes));
        }
    }
}
