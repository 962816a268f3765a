//! Our own look at the certificates a zenoh config names, before zenoh
//! gets them.
//!
//! Why: zenoh checks certificates only during the TLS handshake, and says
//! what went wrong only in a warning of its own (`invalid peer
//! certificate: BadSignature at /…/.cargo/registry/src/…`), while the
//! session fails with "Unable to connect to any of [...]". A lab user with
//! an expired certificate, one of another lab's CA, or another robot's saw
//! only that. So a session that names certificates
//! (`transport/link/tls/*_certificate`) has them read and checked here
//! first — each parses, is valid today, is signed by the configured CA,
//! and (for a member of a swarm: [`ZenohConfig::identity`]) carries the
//! common name `orchestrator certs` gives that member — and a failure is
//! said in our words, naming the file and what to do.
//!
//! What it cannot see: the *other* end's certificate (the orchestrator's,
//! seen by an agent during the handshake); zenoh's warning about it is
//! reworded by the runtime's logging (`bycoms_runtime::logging`).
//!
//! [`ZenohConfig::identity`]: super::ZenohConfig::identity

use crate::naming::Member;
use std::path::{Path, PathBuf};
use std::time::SystemTime;
use x509_parser::certificate::X509Certificate;
use x509_parser::prelude::FromDer as _;

/// The common name of `member`'s certificate, as `orchestrator certs`
/// makes it: `orchestrator`, or `robot-<k>`.
pub fn common_name(member: Member) -> String {
    match member {
        Member::Orchestrator => "orchestrator".into(),
        Member::Agent(robot) => format!("robot-{}", robot.0),
    }
}

/// What is wrong with a certificate, in words for a lab user.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CertificateError(pub String);

impl core::fmt::Display for CertificateError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(&self.0)
    }
}

impl core::error::Error for CertificateError {}

/// The config's keys of this process's own certificates.
const OWN: [&str; 2] = ["transport/link/tls/connect_certificate", "transport/link/tls/listen_certificate"];

/// The config's key of the lab's CA.
const CA: &str = "transport/link/tls/root_ca_certificate";

/// The config's keys of this process's private keys (zenoh reads them
/// itself, without a cap: [`check`] reads them capped first).
const KEYS: [&str; 2] = ["transport/link/tls/connect_private_key", "transport/link/tls/listen_private_key"];

/// A path the config gives for `key`, if any.
fn path_of(config: &::zenoh::Config, key: &str) -> Option<PathBuf> {
    let json = config.get_json(key).ok()?;
    let text: String = serde_json_str(&json)?;
    (!text.is_empty()).then(|| PathBuf::from(text))
}

/// A JSON string's value (`"a/b.pem"` → `a/b.pem`); `None` for `null`.
fn serde_json_str(json: &str) -> Option<String> {
    let inner = json.trim().strip_prefix('"')?.strip_suffix('"')?;
    Some(inner.replace("\\\\", "\\").replace("\\\"", "\""))
}

/// Checks the certificates `config` names (see the module docs) at `now`;
/// `identity`: the common name this process's own certificate must carry.
pub fn check(
    config: &::zenoh::Config,
    identity: Option<&str>,
    now: SystemTime,
) -> Result<(), CertificateError> {
    let ca_path = path_of(config, CA);
    let mut own: Vec<PathBuf> = OWN.iter().filter_map(|k| path_of(config, k)).collect();
    own.dedup();
    if own.is_empty() && ca_path.is_none() {
        return Ok(());
    }
    for key in KEYS.iter().filter_map(|k| path_of(config, k)) {
        crate::capped::read_capped_file_bytes(&key, MAX_CERTIFICATE_FILE_LEN)
            .map_err(|e| CertificateError(format!("cannot read the private key {}: {e}", key.display())))?;
    }
    let ca_der = ca_path.as_deref().map(read_der).transpose()?;
    let ca = match (&ca_der, &ca_path) {
        (Some(der), Some(path)) => Some((parse(der, path)?, path.as_path())),
        _ => None,
    };
    if let Some((ca, path)) = &ca {
        check_dates(ca, path, "the lab's CA", now)?;
    }
    for path in &own {
        let der = read_der(path)?;
        let cert = parse(&der, path)?;
        let name = name_of(&cert);
        check_dates(&cert, path, &format!("the certificate of {name:?}"), now)?;
        if let Some((ca, ca_path)) = &ca {
            if cert.verify_signature(Some(ca.public_key())).is_err() {
                return Err(CertificateError(format!(
                    "{}: the certificate of {name:?} is not signed by the lab's CA {} (a certificate of \
                     another lab, or made before the CA was made anew with `orchestrator certs --force`)",
                    path.display(),
                    ca_path.display()
                )));
            }
        }
        if let Some(identity) = identity.filter(|i| *i != name) {
            return Err(CertificateError(format!(
                "{}: the certificate is {name:?}'s, not {identity:?}'s (this process's): give it the \
                 certificate `orchestrator certs` made for {identity}",
                path.display()
            )));
        }
    }
    Ok(())
}

/// The certificates `config` names: this process's own, then the lab's
/// CA (empty: an unsecured config).
pub fn named(config: &::zenoh::Config) -> Vec<PathBuf> {
    let mut paths: Vec<PathBuf> = OWN.iter().filter_map(|k| path_of(config, k)).collect();
    paths.dedup();
    paths.extend(path_of(config, CA));
    paths
}

/// When the first certificate of the PEM file `path` expires: seconds
/// since the Unix epoch and the date (`2027-01-31`), for a doctor's
/// warning ahead of the expiry [`check`] refuses.
pub fn not_after(path: &Path) -> Result<(i64, String), CertificateError> {
    let der = read_der(path)?;
    let cert = parse(&der, path)?;
    let t = cert.validity().not_after;
    Ok((t.timestamp(), t.to_datetime().date().to_string()))
}

/// Largest certificate file read, bytes (a PEM certificate is a few
/// kilobytes; a chain a few of them): read through the one capped reader,
/// so a `ca.pem` linked to `/dev/zero` is refused one byte past it.
pub const MAX_CERTIFICATE_FILE_LEN: u64 = 1 << 20;

/// The first certificate of the PEM file `path`, as DER (also the
/// orchestrator's doctor's reader of the whole set).
pub fn read_der(path: &Path) -> Result<Vec<u8>, CertificateError> {
    let bytes = crate::capped::read_capped_file_bytes(path, MAX_CERTIFICATE_FILE_LEN)
        .map_err(|e| CertificateError(format!("cannot read the certificate {}: {e}", path.display())))?;
    let not_pem = || CertificateError(format!("{}: not a PEM certificate", path.display()));
    let pem =
        x509_parser::pem::Pem::iter_from_buffer(&bytes).next().ok_or_else(not_pem)?.map_err(|_| not_pem())?;
    Ok(pem.contents)
}

/// The certificate `der` read from `path` (named in the error).
pub fn parse<'a>(der: &'a [u8], path: &Path) -> Result<X509Certificate<'a>, CertificateError> {
    X509Certificate::from_der(der)
        .map(|(_, cert)| cert)
        .map_err(|e| CertificateError(format!("{}: not a valid certificate ({e})", path.display())))
}

/// The certificate's common name (empty if it has none).
pub fn name_of(cert: &X509Certificate<'_>) -> String {
    cert.subject().iter_common_name().next().and_then(|cn| cn.as_str().ok()).unwrap_or_default().to_owned()
}

/// Whether `cert` is valid at `now`; its dates named in the error.
fn check_dates(
    cert: &X509Certificate<'_>,
    path: &Path,
    what: &str,
    now: SystemTime,
) -> Result<(), CertificateError> {
    let secs = match now.duration_since(SystemTime::UNIX_EPOCH) {
        Ok(d) => i64::try_from(d.as_secs()).unwrap_or(i64::MAX),
        Err(_) => 0,
    };
    let validity = cert.validity();
    let date = |t: &x509_parser::time::ASN1Time| t.to_datetime().date().to_string();
    if secs > validity.not_after.timestamp() {
        return Err(CertificateError(format!(
            "{}: {what} expired on {}: make a new one with `orchestrator certs --add-robots` (robots) or \
             `--force` (a new CA)",
            path.display(),
            date(&validity.not_after)
        )));
    }
    if secs < validity.not_before.timestamp() {
        return Err(CertificateError(format!(
            "{}: {what} is valid only from {} (is this host's clock right?)",
            path.display(),
            date(&validity.not_before)
        )));
    }
    Ok(())
}
