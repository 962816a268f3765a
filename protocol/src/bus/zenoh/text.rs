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
        write!(f, "endpoint {:?}: expected tcp/HOST:PORT, quic/HOST:PORT or tls/HOST:PORT", self.endpoint)
    }
}

impl core::error::Error for EndpointError {}

/// Checks that `endpoint` is `LINK/HOST:PORT` (optionally followed by
/// zenoh's `?metadata` or `#config`), LINK one of [`LINKS`], HOST not empty
/// and PORT a number 0..=65535. Whether HOST resolves is for the session to
/// find out.
pub fn check_endpoint(endpoint: &str) -> Result<(), EndpointError> {
    let bad = || EndpointError { endpoint: endpoint.to_owned() };
    let (link, rest) = endpoint.split_once('/').ok_or_else(bad)?;
    let address = &rest[..rest.find(['?', '#']).unwrap_or(rest.len())];
    let (host, port) = address.rsplit_once(':').ok_or_else(bad)?;
    let host_ok = !host.is_empty() && !host.contains(char::is_whitespace) && host != "[]";
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

/// [`BusError::Backend`] for a zenoh error `e` while doing `op`; `what`
/// (a topic, a key, a file) goes before zenoh's words when given.
pub(crate) fn backend(
    op: &'static str,
    topic: Option<String>,
    what: Option<&dyn fmt::Display>,
    e: &dyn fmt::Display,
) -> BusError {
    let said = zenoh_error(e);
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
        let e = check_endpoint("foo/bar").unwrap_err();
        assert_eq!(
            e.to_string(),
            "endpoint \"foo/bar\": expected tcp/HOST:PORT, quic/HOST:PORT or tls/HOST:PORT"
        );
    }
}
