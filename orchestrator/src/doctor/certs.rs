//! The lab's certificates, checked as the launch and the agents will use
//! them: every certificate of the set (`orchestrator`, `robot-1..=N`)
//! signed by the lab's CA (`ca.pem`), carrying the common name the
//! agents check their own against (`crate::certs::robot_cn`), valid today
//! and for 30 more days, and named by the orchestrator's ACL
//! (`orchestrator.json5`), as `orchestrator certs` writes them.
//!
//! Why here and not only in the agents (`bus::zenoh::certs`): that check
//! runs on the robot's host when its agent starts, one robot at a time,
//! and cannot see the ACL; the doctor sees the whole set before anyone
//! leaves for the lab.

use super::Finding;
use crate::certs::{read_config, revoked_in, robot_cn, ORCHESTRATOR_CN};
use bycoms_protocol::bus::zenoh::certs as zenoh_certs;
use std::collections::BTreeSet;
use std::path::Path;
use std::time::SystemTime;
use x509_parser::certificate::X509Certificate;

const CHECK: &str = "certs";

/// A certificate expiring within this many days is a warning (every doctor's).
pub use bycoms_runtime::doctor::WARN_DAYS;

/// The first certificate of the PEM file `path`, as DER, or why not (the
/// agents' own reader, `bus::zenoh::certs`).
fn read_der(path: &Path) -> Result<Vec<u8>, String> {
    zenoh_certs::read_der(path).map_err(|e| e.0)
}

fn parse<'a>(der: &'a [u8], path: &Path) -> Result<X509Certificate<'a>, String> {
    zenoh_certs::parse(der, path).map_err(|e| e.0)
}

fn unix_secs(now: SystemTime) -> i64 {
    now.duration_since(SystemTime::UNIX_EPOCH).map_or(0, |d| i64::try_from(d.as_secs()).unwrap_or(i64::MAX))
}

/// The expiry finding of `cert` (the file `path`) at `now`, if it is not fine.
fn dates(cert: &X509Certificate<'_>, path: &Path, now: SystemTime, renew: &str) -> Option<Finding> {
    let secs = unix_secs(now);
    let validity = cert.validity();
    let date = |t: &x509_parser::time::ASN1Time| t.to_datetime().date().to_string();
    let days_left = (validity.not_after.timestamp() - secs).div_euclid(86_400);
    if secs > validity.not_after.timestamp() {
        let cause = format!("{} expired on {}", path.display(), date(&validity.not_after));
        return Some(Finding::error(CHECK, cause, renew));
    }
    if secs < validity.not_before.timestamp() {
        let cause = format!("{} is valid only from {}", path.display(), date(&validity.not_before));
        return Some(Finding::error(CHECK, cause, "check this host's clock (timedatectl; NTP)"));
    }
    (days_left < WARN_DAYS).then(|| {
        let cause = format!("{} expires in {days_left} days ({})", path.display(), date(&validity.not_after));
        Finding::warn(CHECK, cause, renew)
    })
}

/// Checks the set in `dir` for robots `1..=robots` at `now`.
pub fn check(dir: &Path, robots: u32, now: SystemTime) -> Vec<Finding> {
    let d = dir.display();
    let add = format!("orchestrator certs --add-robots --robots {robots} --out {d}");
    let new_ca = format!(
        "orchestrator certs --force --robots {robots} --out {d} (a new CA: every robot is provisioned anew)"
    );
    let ca_path = dir.join("ca.pem");
    let ca_der = match read_der(&ca_path) {
        Ok(der) => der,
        Err(e) => {
            return vec![Finding::error(CHECK, e, format!("orchestrator certs --robots {robots} --out {d}"))]
        }
    };
    let ca = match parse(&ca_der, &ca_path) {
        Ok(ca) => ca,
        Err(e) => return vec![Finding::error(CHECK, e, new_ca)],
    };
    let mut found: Vec<Finding> = dates(&ca, &ca_path, now, &new_ca).into_iter().collect();
    let names = std::iter::once(ORCHESTRATOR_CN.to_string()).chain((1..=robots).map(robot_cn));
    for name in names {
        let path = dir.join(format!("{name}.pem"));
        let der = match read_der(&path) {
            Ok(der) => der,
            Err(e) => {
                found.push(Finding::error(CHECK, e, add.clone()));
                continue;
            }
        };
        let cert = match parse(&der, &path) {
            Ok(cert) => cert,
            Err(e) => {
                found.push(Finding::error(CHECK, e, format!("remove it, then {add}")));
                continue;
            }
        };
        if cert.verify_signature(Some(ca.public_key())).is_err() {
            let cause = format!("{} is not signed by the lab's CA {}", path.display(), ca_path.display());
            found.push(Finding::error(CHECK, cause, format!("remove it, then {add}")));
        }
        let cn = zenoh_certs::name_of(&cert);
        if cn != name {
            let cause = format!("{} carries the common name {cn:?}, not {name:?}", path.display());
            found.push(Finding::error(CHECK, cause, format!("remove it, then {add}")));
        }
        found.extend(dates(&cert, &path, now, &format!("remove it, then {add}")));
    }
    if found.is_empty() {
        found.push(Finding::ok(
            CHECK,
            format!("{ORCHESTRATOR_CN} and robots 1..={robots}: signed by {}, common names right, valid 30 days and more", ca_path.display()),
        ));
    }
    found.extend(acl(dir, robots, &add));
    found
}

/// The ACL of `dir/orchestrator.json5` against robots `1..=robots`.
fn acl(dir: &Path, robots: u32, add: &str) -> Vec<Finding> {
    const ACL: &str = "acl";
    let path = dir.join("orchestrator.json5");
    let config = match read_config(&path) {
        Ok(config) => config,
        Err(e) => return vec![Finding::error(ACL, bycoms_runtime::exit::message(&e), add.to_string())],
    };
    let revoked = revoked_in(&config);
    let subjects = config["access_control"]["subjects"].as_array().cloned().unwrap_or_default();
    let allowed: BTreeSet<String> = subjects
        .iter()
        .filter(|s| s["id"] != "revoked")
        .flat_map(|s| s["cert_common_names"].as_array().cloned().unwrap_or_default())
        .filter_map(|cn| cn.as_str().map(str::to_string))
        .collect();
    let mut found = Vec::new();
    for k in 1..=robots {
        let cn = robot_cn(k);
        if revoked.contains(&k) {
            let cause = format!("robot {k} is revoked in {} (it will be refused)", path.display());
            found.push(Finding::warn(
                ACL,
                cause,
                format!("launch without robot {k}, or give it a new certificate"),
            ));
        } else if !allowed.contains(&cn) {
            let cause = format!(
                "{}'s access-control list does not name {cn}: its reports would be denied",
                path.display()
            );
            found.push(Finding::error(ACL, cause, add.to_string()));
        }
    }
    if found.is_empty() {
        found.push(Finding::ok(ACL, format!("{} names robots 1..={robots}", path.display())));
    }
    found
}
