//! Checking endpoints and wording zenoh's errors for our users.
//!
//! Why here: every program that takes a zenoh endpoint (the orchestrator's
//! `launch` and `bridge`, `sim-agent`, the gateway) must refuse a bad one
//! the same way and before it starts anything (a usage error), and zenoh
//! itself accepts almost any `x/y` as an endpoint until the session fails
//! to open. And zenoh's errors end in the location of the zenoh source
//! line that raised them (` at /home/…/.cargo/registry/src/…/zenoh-…/src/
//! lib.rs:62.`), which tells a lab user nothing; [`zenoh_error`] drops it.

use super::BusError;
use core::fmt;

/// The links this build's zenoh backend speaks.
pub const LINKS: [&str; 3] = ["tcp", "tls", "quic"];

/// A zenoh endpoint that is not `LINK/HOST:PORT` with a link of [`LINKS`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EndpointError {
    /// The endpoint as given.
    pub endpoint: String,
}

impl fmt::Display for EndpointError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let endpoint = shown(&self.endpoint);
        write!(f, "endpoint {endpoint}: expected tcp/HOST:PORT, quic/HOST:PORT or tls/HOST:PORT")?;
        if self.endpoint.len() > MAX_HOST_LEN {
            write!(f, " (a HOST of at most {MAX_HOST_LEN} characters)")?;
        }
        Ok(())
    }
}

/// The longest endpoint said whole in a message, in characters.
const SHOWN_WHOLE: usize = 100;

/// `endpoint` for a message: quoted, and past [`SHOWN_WHOLE`] characters
/// its start and its length (a 200 000-character host is not echoed whole).
pub fn shown(endpoint: &str) -> String {
    let n = endpoint.chars().count();
    if n <= SHOWN_WHOLE {
        return format!("{endpoint:?}");
    }
    let start: String = endpoint.chars().take(SHOWN_WHOLE / 2).collect();
    format!("{start:?}… ({n} characters)")
}

/// The longest host name DNS takes (RFC 1035: 253 characters written out).
const MAX_HOST_LEN: usize = 253;

impl core::error::Error for EndpointError {}

/// Whether zenoh authenticates and encrypts `endpoint` (`quic/` and `tls/`,
/// with the TLS settings of the configs `orchestrator certs` writes).
pub fn is_secured(endpoint: &str) -> bool {
    endpoint.starts_with("quic/") || endpoint.starts_with("tls/")
}

/// Checks that `endpoint` is `LINK/HOST:PORT` (optionally followed by
/// zenoh's `?metadata` or `#config`), LINK one of [`LINKS`], HOST not empty
/// and PORT a number 0..=65535. Whether HOST resolves is for the session to
/// find out.
pub fn check_endpoint(endpoint: &str) -> Result<(), EndpointError> {
    let bad = || EndpointError { endpoint: endpoint.to_owned() };
    let (link, rest) = endpoint.split_once('/').ok_or_else(bad)?;
    let address = &rest[..rest.find(['?', '#']).unwrap_or(rest.len())];
    let (host, port) = address.rsplit_once(':').ok_or_else(bad)?;
    let host_ok = !host.is_empty()
        && host.len() <= MAX_HOST_LEN + 2
        && !host.contains(char::is_whitespace)
        && host != "[]";
    if !LINKS.contains(&link) || !host_ok || port.parse::<u16>().is_err() {
        return Err(bad());
    }
    // zenoh's own parser: the metadata and config parts must be well formed.
    endpoint.parse::<::zenoh::config::EndPoint>().map_err(|_| bad())?;
    Ok(())
}

/// A zenoh error as text, without the zenoh source locations it carries
/// (`… not known at /…/zenoh-link-commons-1.10.2/src/lib.rs:62.`).
pub fn zenoh_error(e: &dyn fmt::Display) -> String {
    without_source_locations(&e.to_string())
}

/// A warning or error zenoh logged, in our words: what happened (an
/// address in use, a host not found, a refused connection, a certificate
/// the other end refused or that this end refused), without zenoh's source
/// locations or its hint to raise the open-file limit (which it gives for
/// every failed QUIC handshake). `None`: nothing to say (zenoh's summary
/// "Unable to connect to any of [...]" repeats the line before it, and the
/// session's error says it again).
pub fn zenoh_words(message: &str) -> Option<String> {
    let text = without_source_locations(message);
    if text.starts_with("Unable to connect to any of") {
        return None;
    }
    let endpoint = text
        .strip_prefix("Unable to connect to ")
        .and_then(|rest| rest.split_once('!'))
        .or_else(|| text.strip_prefix("Unable to open listener ").and_then(|rest| rest.split_once(": ")))
        .or_else(|| text.split_once(" bound to ").and_then(|(_, rest)| rest.split_once(": ")))
        .map(|(endpoint, _)| endpoint.to_owned());
    let at = format!(" {}", endpoint.as_deref().unwrap_or("its address"));
    let said = if text.contains("Address already in use") {
        format!("address in use: another process listens on{at} (another port, or port 0 for a free one)")
    } else if text.contains("failed to lookup address information")
        || text.contains("Name or service not known")
    {
        format!("host not found: cannot connect to{at} (is the host name right?)")
    } else if text.contains("Connection refused") {
        format!(
            "connection refused at{at}: nothing listens there (is the orchestrator, or the zenoh router \
             meant to be there, running on that port?)"
        )
    } else if let Some(said) = no_zenoh_words(&text, &at, endpoint.as_deref()) {
        said
    } else if let Some(why) = certificate_words(&text) {
        match (endpoint, text.contains("acceptor")) {
            (Some(e), _) => format!("cannot connect to {e}: the orchestrator's certificate {why}"),
            (None, true) => {
                format!("a connection was refused at its TLS handshake: the peer's certificate {why}")
            }
            (None, false) => format!("a TLS handshake failed: the peer's certificate {why}"),
        }
    } else {
        return Some(text.replace(" Hint: increase the system open file limit.", ""));
    };
    Some(said)
}

/// What zenoh says when what answered at an endpoint is no zenoh router
/// (or answered nothing in time), in words: what answered, and what is
/// missing. `at`: ` ENDPOINT`.
fn no_zenoh_words(text: &str, at: &str, endpoint: Option<&str>) -> Option<String> {
    let quic = endpoint.is_some_and(|e| e.starts_with("quic/"));
    Some(if text.contains("Decode error on link") {
        format!(
            "something answered at{at} that does not speak zenoh (what it sent is no zenoh message): \
             is that the port of a zenoh router (rmw_zenohd, zenohd, the orchestrator)?"
        )
    } else if text.contains("Connection reset by peer") {
        format!(
            "something at{at} took the connection and closed it without zenoh's handshake: no zenoh \
             router listens there (is that the router's port?)"
        )
    } else if text.contains("deadline has elapsed") && quic {
        format!(
            "no QUIC handshake with{at} completed within zenoh's 10 s: nothing answers QUIC there, or \
             it needs the lab's certificates (a zenoh config of `orchestrator certs`, --zenoh-config)"
        )
    } else if text.contains("deadline has elapsed") {
        format!(
            "something at{at} took the connection but did not answer zenoh's handshake within zenoh's \
             10 s: it does not speak zenoh (is that the port of a zenoh router?)"
        )
    } else {
        return None;
    })
}

/// What rustls said about a peer's certificate (`invalid peer
/// certificate: …`), in words.
fn certificate_words(text: &str) -> Option<&'static str> {
    let (_, why) = text.split_once("invalid peer certificate: ")?;
    Some(if why.starts_with("Expired") {
        "has expired"
    } else if why.starts_with("NotValidYet") {
        "is not valid yet (is either host's clock wrong?)"
    } else if why.starts_with("BadSignature") || why.starts_with("UnknownIssuer") {
        "is not signed by this lab's CA (another lab's, or made before the CA was made anew)"
    } else if why.starts_with("NotValidForName") {
        "does not name the host connected to (give `orchestrator certs --host` that name)"
    } else if why.starts_with("Revoked") {
        "is revoked"
    } else {
        "was refused"
    })
}

/// [`BusError::Backend`] for a zenoh error `e` while doing `op`; `what`
/// (a topic, a key, a file) goes before zenoh's words when given.
pub(crate) fn backend(
    op: &'static str,
    topic: Option<String>,
    what: Option<&dyn fmt::Display>,
    e: &dyn fmt::Display,
) -> BusError {
    // zenoh's summary of failed connections says no cause: the warning
    // logged before it does (in our words, `zenoh_words`).
    let said = zenoh_words(&e.to_string()).unwrap_or_else(|| {
        "cannot connect to any endpoint it was given (the warning before says why)".to_owned()
    });
    let detail = match what {
        Some(w) => format!("{w}: {said}"),
        None => said,
    };
    BusError::Backend { op, topic, detail }
}

/// `text` with every ` at PATH.rs:LINE.` removed (PATH without spaces).
fn without_source_locations(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find(" at ") {
        let after = &rest[at + 4..];
        match location_len(after) {
            Some(n) => {
                out.push_str(&rest[..at]);
                rest = &after[n..];
            }
            None => {
                out.push_str(&rest[..at + 4]);
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// The length of `PATH.rs:LINE` (and a final `.`) at the start of `s`.
fn location_len(s: &str) -> Option<usize> {
    let path_end = s.find(".rs:")?;
    if path_end == 0 || s[..path_end].contains(char::is_whitespace) {
        return None;
    }
    let line = &s[path_end + 4..];
    let digits = line.bytes().take_while(u8::is_ascii_digit).count();
    if digits == 0 {
        return None;
    }
    let end = path_end + 4 + digits;
    Some(if s[end..].starts_with('.') { end + 1 } else { end })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn source_locations_are_dropped_and_nothing_else() {
        let raw = "failed to lookup address information: Name or service not known at \
                   /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/zenoh-link-commons-1.10.2/src/lib.rs:62.";
        assert_eq!(zenoh_error(&raw), "failed to lookup address information: Name or service not known");
        let caused = "open failed at src/a.rs:1. - Caused by refused at /x/b.rs:22.";
        assert_eq!(zenoh_error(&caused), "open failed - Caused by refused");
        let plain = "look at this: a.rs is a file, at 3 pm";
        assert_eq!(zenoh_error(&plain), plain);
        assert_eq!(zenoh_error(&"x at y.rs:z."), "x at y.rs:z.");
    }

    #[test]
    fn zenoh_s_warnings_are_said_in_our_words() {
        let registry = " at /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/zenoh-link-commons-1.10.2/src/quic/unicast.rs:597.";
        let cases = [
            (
                format!("Unable to connect to quic/127.0.0.1:17447! Can not create a new QUIC link bound to 127.0.0.1: the cryptographic handshake failed: error 51: invalid peer certificate: BadSignature{registry}"),
                "cannot connect to quic/127.0.0.1:17447: the orchestrator's certificate is not signed by this lab's CA (another lab's, or made before the CA was made anew)",
            ),
            (
                format!("QUIC acceptor failed: ConnectionClosed(ConnectionClose {{ error_code: Code::crypto(33), frame_type: None, reason: b\"invalid peer certificate: Expired\" }}){registry} Hint: increase the system open file limit."),
                "a connection was refused at its TLS handshake: the peer's certificate has expired",
            ),
            (
                format!("Unable to open listener tcp/127.0.0.1:17999: Can not create a new TCP listener bound to tcp/127.0.0.1:17999: [127.0.0.1:17999: Address already in use (os error 98){registry}]{registry}"),
                "address in use: another process listens on tcp/127.0.0.1:17999 (another port, or port 0 for a free one)",
            ),
            (
                format!("Unable to connect to tcp/no-such-host.invalid:7447! failed to lookup address information: Name or service not known{registry}"),
                "host not found: cannot connect to tcp/no-such-host.invalid:7447 (is the host name right?)",
            ),
            (
                format!("Unable to connect to tcp/127.0.0.1:17998! Can not create a new TCP link bound to tcp/127.0.0.1:17998: [127.0.0.1:17998: Connection refused (os error 111){registry}]{registry}"),
                "connection refused at tcp/127.0.0.1:17998: nothing listens there (is the orchestrator, or the zenoh router meant to be there, running on that port?)",
            ),
            // What answered is not zenoh (issue 49, item 14): said without
            // zenoh's Debug structs.
            (
                "Unable to connect to tcp/127.0.0.1:47395! Decode error on link: tcp/127.0.0.1:47680 => tcp/127.0.0.1:47395:TransportLinkUnicastConfig { direction: Outbound, batch: BatchConfig { mtu: 65480, is_streamed: true }, priorities: None, reliability: None }".to_owned(),
                "something answered at tcp/127.0.0.1:47395 that does not speak zenoh (what it sent is no zenoh message): is that the port of a zenoh router (rmw_zenohd, zenohd, the orchestrator)?",
            ),
            (
                "Unable to connect to tcp/127.0.0.1:47393! Read error on TCP link 127.0.0.1:49450 => 127.0.0.1:47393: Connection reset by peer (os error 104)".to_owned(),
                "something at tcp/127.0.0.1:47393 took the connection and closed it without zenoh's handshake: no zenoh router listens there (is that the router's port?)",
            ),
            (
                "Unable to connect to tcp/127.0.0.1:47394! deadline has elapsed".to_owned(),
                "something at tcp/127.0.0.1:47394 took the connection but did not answer zenoh's handshake within zenoh's 10 s: it does not speak zenoh (is that the port of a zenoh router?)",
            ),
            (
                "Unable to connect to quic/127.0.0.1:47392! deadline has elapsed".to_owned(),
                "no QUIC handshake with quic/127.0.0.1:47392 completed within zenoh's 10 s: nothing answers QUIC there, or it needs the lab's certificates (a zenoh config of `orchestrator certs`, --zenoh-config)",
            ),
        ];
        for (zenoh, ours) in cases {
            assert_eq!(zenoh_words(&zenoh).as_deref(), Some(ours), "{zenoh}");
        }
        let summary = format!("Unable to connect to any of [Single(quic/127.0.0.1:17447)]! {registry}");
        assert_eq!(zenoh_words(&summary), None, "a repeat of the line before");
        // The session's own error, after the warning.
        let listen = format!("Can not create a new TCP listener bound to tcp/127.0.0.1:17999: [127.0.0.1:17999: Address already in use (os error 98){registry}]");
        assert_eq!(
            zenoh_words(&listen).as_deref(),
            Some("address in use: another process listens on tcp/127.0.0.1:17999 (another port, or port 0 for a free one)")
        );
        let other = format!("Something else happened{registry} Hint: increase the system open file limit.");
        assert_eq!(zenoh_words(&other).as_deref(), Some("Something else happened"));
    }

    #[test]
    fn endpoints_are_link_host_port() {
        for good in [
            "tcp/127.0.0.1:7447",
            "tcp/0.0.0.0:0",
            "tls/lab-host:7447",
            "quic/[::1]:7447",
            "tcp/10.0.0.5:7447?prio=1",
            "tcp/10.0.0.5:7447#iface=eth0",
        ] {
            assert_eq!(check_endpoint(good), Ok(()), "{good}");
        }
        for bad in [
            "foo/bar",
            "tcp/",
            "udp/127.0.0.1:7447",
            "tcp/127.0.0.1:99999",
            "tcp/127.0.0.1",
            "tcp/:7447",
            "",
            "tcp",
        ] {
            assert!(check_endpoint(bad).is_err(), "{bad}");
        }
        // A host past DNS's 253 characters, said without echoing it whole.
        let long = format!("tcp/{}:7447", "h".repeat(200_000));
        let said = check_endpoint(&long).unwrap_err().to_string();
        assert!(said.contains("… (200009 characters)") && said.contains("at most 253 characters"), "{said}");
        assert!(said.len() < 300, "{said}");
        assert_eq!(check_endpoint(&format!("tcp/{}:7447", "h".repeat(253))), Ok(()));
        let e = check_endpoint("foo/bar").unwrap_err();
        assert_eq!(
            e.to_string(),
            "endpoint \"foo/bar\": expected tcp/HOST:PORT, quic/HOST:PORT or tls/HOST:PORT"
        );
    }
}
