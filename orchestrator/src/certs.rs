//! A lab's certificates for zenoh over QUIC (or TLS over TCP) with mutual
//! authentication, and the zenoh configurations with the matching
//! access-control list.
//!
//! Why QUIC by default: zenoh's `tls/` link (zenoh-link-tls 1.10.2) reads
//! and writes one rustls connection from two tasks at once. While the
//! reader decrypts a record, rustls holds the connection's state as
//! "handshake not complete"; a write at that instant fails, the link is
//! closed and what was in flight is lost. We saw it as a robot's message
//! that never arrived (2 runs in 30 of `zenoh_security`, on an idle
//! machine). QUIC (`quic/`, quinn) carries the same TLS 1.3 certificates,
//! the same mTLS and the same common-name ACL subjects, and has no such
//! sharing. `tls/` endpoints still work (for networks that block UDP), with
//! that caveat; the configs are the same, only the endpoints differ.
//!
//! Why generated here: a lab should not have to learn openssl to deploy
//! securely. [`generate`] makes a lab CA, the orchestrator's certificate
//! (common name `orchestrator`, the given host names / addresses as
//! subject alternative names) and one client certificate per robot (common
//! name `robot-<k>`), all signed by the CA, with `rcgen` (the rustls
//! project's generator; ring, like zenoh's rustls). Private keys are
//! written with mode 0600 and never leave the output directory.
//!
//! The access-control list (zenoh's `access_control`, subjects matched by
//! certificate common name, default deny) lets robot `k` publish only on
//! `bycoms/*/robot/<k>/**` (its pose and its reports, `from_agent`) and
//! declare only its own liveliness token `bycoms/*/alive/robot/<k>`, lets
//! every robot subscribe to and receive anything under `bycoms/**` and see
//! the orchestrator's liveliness token (`bycoms/*/alive/orchestrator`), and
//! ask for the run's settings (`bycoms/*/settings`) and the
//! orchestrator's clock (`bycoms/*/clock`, to measure their offset). The orchestrator
//! drops a report whose robot id is not its key's, so no certificate can
//! speak for another robot.
//! A lab's CA is its trust: every robot provisioned with it is locked out
//! once it is replaced, and without `ca-key.pem` no more robots can join.
//! So [`generate`] never replaces an existing CA unless told to
//! (`--force`), and [`add_robots`] issues certificates for more robots with
//! the CA already there (`--add-robots`). Every file goes through the
//! overwrite rule of all outputs (`bycoms_runtime::out::files`): all are checked
//! before the first is written, and each is written whole or not at all.
//!
//! A lost or stolen robot's certificate is withdrawn with [`revoke`]
//! (`--revoke K`): the ACL gives robot K no permission and denies its
//! common name everything. zenoh checks no certificate revocation list,
//! so the ACL is where a revocation lives; expired certificates and those
//! of another CA are refused by TLS itself. A running zenoh router keeps
//! the ACL it started with: until the orchestrator restarts, the revoked
//! robot still connects, and the launch itself drops its traffic
//! (`orchestrator revoke`, or `certs --revoke` asking a running launch of
//! this lab: `orchestrator/launch-core/src/revoke.rs`).

use anyhow::{Context, Result};
use bycoms_runtime::exit;
use bycoms_runtime::out::kind::ZENOH_CONFIG_MARK;
use bycoms_runtime::out::{self, usage_unless_io, Kind, Outputs};
use rcgen::{BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair};
use serde_json::{json, Value};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Common name of the orchestrator's certificate.
pub const ORCHESTRATOR_CN: &str = "orchestrator";

/// Largest file of the set read back (a config, a certificate, a key),
/// bytes: through the one capped reader, so a file linked to `/dev/zero`
/// is refused one byte past it.
const MAX_READ_BYTES: u64 = bycoms_protocol::bus::zenoh::certs::MAX_CERTIFICATE_FILE_LEN;

/// The text of `path`, capped ([`MAX_READ_BYTES`]); the error names the file.
fn read_text(path: &Path) -> Result<String> {
    bycoms_runtime::capped::read_capped_file(path, MAX_READ_BYTES)
        .with_context(|| format!("cannot read {}", path.display()))
}

/// Common name of robot `k`'s certificate (the one every agent checks its
/// own against before it connects, `bus::zenoh::certs`).
pub fn robot_cn(k: u32) -> String {
    use bycoms_protocol::{bus::zenoh::certs::common_name, naming::Member, RobotId};
    common_name(Member::Agent(RobotId(k)))
}

/// What to generate.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Robots 1..=robots get a certificate each.
    pub robots: u32,
    /// Names and addresses the orchestrator is reached at (its
    /// certificate's subject alternative names).
    pub hosts: Vec<String>,
    /// The orchestrator's listen endpoint, e.g. `quic/0.0.0.0:7447`.
    pub listen: String,
    /// The endpoint robots connect to, e.g. `quic/orchestrator.lab:7447`.
    pub connect: String,
    /// Output directory (created).
    pub out: PathBuf,
    /// Replace an existing CA and every file of the set (`--force`).
    pub force: bool,
}

/// The files [`generate`] wrote.
#[derive(Clone, Debug)]
pub struct Generated {
    /// The lab CA's certificate.
    pub ca: PathBuf,
    /// zenoh config of the orchestrator (router, TLS listener, ACL).
    pub orchestrator_config: PathBuf,
    /// zenoh config of each robot's host (client of the orchestrator), in
    /// robot order 1..=N ([`add_robots`]: the new robots' only).
    pub robot_configs: Vec<PathBuf>,
}

struct Pair {
    cert: PathBuf,
    key: PathBuf,
}

fn write_private(path: &Path, text: &str, force: bool) -> Result<()> {
    out::write_private(path, Kind::Pem, force, text.as_bytes()).map_err(usage_unless_io)
}

fn write_public(path: &Path, kind: Kind, text: &str, force: bool) -> Result<()> {
    out::write(path, kind, force, text.as_bytes()).map_err(usage_unless_io)
}

/// The files of the orchestrator's (`name` = [`ORCHESTRATOR_CN`]) or a robot's set.
fn files_of(out: &Path, name: &str) -> [(PathBuf, Kind); 3] {
    [
        (out.join(format!("{name}.pem")), Kind::Pem),
        (out.join(format!("{name}-key.pem")), Kind::Pem),
        (out.join(format!("{name}.json5")), Kind::ZenohConfig),
    ]
}

fn leaf(
    issuer: &Issuer<'_, KeyPair>,
    out: &Path,
    name: &str,
    sans: Vec<String>,
    usages: Vec<ExtendedKeyUsagePurpose>,
    force: bool,
) -> Result<Pair> {
    let mut params = CertificateParams::new(sans).context("bad subject alternative name")?;
    params.distinguished_name.push(DnType::CommonName, name);
    params.extended_key_usages = usages;
    let key = KeyPair::generate().context("cannot generate a key")?;
    let cert = params.signed_by(&key, issuer).context("cannot sign a certificate")?;
    let pair = Pair { cert: out.join(format!("{name}.pem")), key: out.join(format!("{name}-key.pem")) };
    write_public(&pair.cert, Kind::Pem, &cert.pem(), force)?;
    write_private(&pair.key, &key.serialize_pem(), force)?;
    Ok(pair)
}

fn path_str(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

/// The access-control list: default deny; see the module doc. A robot of
/// `revoked` has no permission at all, and its common name is listed in a
/// `revoked` subject denied everything (so the list survives in the config:
/// [`revoked_in`]).
pub fn access_control(robots: u32, revoked: &BTreeSet<u32>) -> Value {
    let mut rules = vec![
        json!({ "id": "orchestrator-all", "messages": ["put", "delete", "declare_subscriber", "query",
            "declare_queryable", "reply", "liveliness_token", "declare_liveliness_subscriber", "liveliness_query"],
            "flows": ["ingress", "egress"], "permission": "allow", "key_exprs": ["bycoms/**"] }),
        json!({ "id": "robots-listen", "messages": ["declare_subscriber", "declare_liveliness_subscriber",
            "liveliness_query"],
            "flows": ["ingress", "egress"], "permission": "allow", "key_exprs": ["bycoms/**"] }),
        json!({ "id": "robots-receive", "messages": ["put", "delete"], "flows": ["egress"],
            "permission": "allow", "key_exprs": ["bycoms/**"] }),
        // The orchestrator's liveliness token reaches the robots (their
        // failsafe, `doctor --connect`): without it zenoh's ACL withholds
        // the token's declaration from them.
        json!({ "id": "robots-see-orchestrator", "messages": ["liveliness_token"], "flows": ["egress"],
            "permission": "allow", "key_exprs": ["bycoms/*/alive/orchestrator"] }),
        // The run's settings and the orchestrator's clock: a robot asks,
        // the orchestrator answers.
        json!({ "id": "robots-settings", "messages": ["query", "reply"], "flows": ["ingress", "egress"],
            "permission": "allow", "key_exprs": ["bycoms/*/settings", "bycoms/*/clock"] }),
    ];
    let mut subjects = vec![json!({ "id": ORCHESTRATOR_CN, "cert_common_names": [ORCHESTRATOR_CN] })];
    let mut policies = vec![json!({ "rules": ["orchestrator-all"], "subjects": [ORCHESTRATOR_CN] })];
    for k in (1..=robots).filter(|k| !revoked.contains(k)) {
        let cn = robot_cn(k);
        rules.push(
            json!({ "id": format!("{cn}-publish"), "messages": ["put", "delete"], "flows": ["ingress"],
            "permission": "allow", "key_exprs": [format!("bycoms/*/robot/{k}/**")] }),
        );
        rules.push(json!({ "id": format!("{cn}-alive"), "messages": ["liveliness_token"],
            "flows": ["ingress", "egress"], "permission": "allow", "key_exprs": [format!("bycoms/*/alive/robot/{k}")] }));
        subjects.push(json!({ "id": cn, "cert_common_names": [cn] }));
        policies.push(json!({ "rules": [format!("{cn}-publish"), format!("{cn}-alive"), "robots-listen",
            "robots-receive", "robots-see-orchestrator", "robots-settings"], "subjects": [cn] }));
    }
    if !revoked.is_empty() {
        rules.push(json!({ "id": REVOKED, "messages": ["put", "delete", "declare_subscriber", "query",
            "declare_queryable", "reply", "liveliness_token", "declare_liveliness_subscriber", "liveliness_query"],
            "flows": ["ingress", "egress"], "permission": "deny", "key_exprs": ["**"] }));
        let names: Vec<String> = revoked.iter().map(|&k| robot_cn(k)).collect();
        subjects.push(json!({ "id": REVOKED, "cert_common_names": names }));
        policies.push(json!({ "rules": [REVOKED], "subjects": [REVOKED] }));
    }
    json!({ "enabled": true, "default_permission": "deny", "rules": rules, "subjects": subjects, "policies": policies })
}

/// Name of the ACL rule and subject of revoked robots.
const REVOKED: &str = "revoked";

/// The robots an orchestrator config's ACL revokes.
pub fn revoked_in(config: &Value) -> BTreeSet<u32> {
    let subjects = config["access_control"]["subjects"].as_array().cloned().unwrap_or_default();
    subjects
        .iter()
        .filter(|s| s["id"] == REVOKED)
        .flat_map(|s| s["cert_common_names"].as_array().cloned().unwrap_or_default())
        .filter_map(|cn| cn.as_str()?.strip_prefix("robot-")?.parse().ok())
        .collect()
}

/// The highest robot k of a set in `out` (robot-1.pem, robot-2.pem, …).
fn robots_in(out: &Path) -> u32 {
    let has_cert = |k: u32| out.join(format!("{}.pem", robot_cn(k))).exists();
    (1..=u32::MAX).take_while(|&k| has_cert(k)).last().unwrap_or(0)
}

/// Withdraws robots `ids`' certificates (`certs --revoke`, a lost or stolen
/// robot): the orchestrator's config in `out` keeps its settings, and its
/// ACL gives those robots no permission and denies them everything. Their
/// certificates stay valid TLS-wise (zenoh checks no revocation list), so
/// they can still open a session, in which nothing they send or ask for is
/// let through. It reaches a launch when the launch starts: a running one
/// keeps the ACL it started with (a running launch drops the robot when
/// asked: `orchestrator revoke`, `orchestrator/launch-core/src/revoke.rs`). `dir_flag` is the
/// command's flag naming `out` and `flag` the one naming the robots, for
/// usage errors. Returns the config's path.
pub fn revoke(out: &Path, ids: &[u32], dir_flag: &str, flag: &str) -> Result<PathBuf> {
    let config_path = out.join("orchestrator.json5");
    if !config_path.is_file() {
        return Err(exit::usage(format!(
            "{dir_flag} {}: {} is missing; give the directory `orchestrator certs` wrote",
            out.display(),
            config_path.display()
        )));
    }
    let robots = robots_in(out);
    if let Some(k) = ids.iter().find(|&&k| k == 0 || k > robots) {
        return Err(exit::usage(format!(
            "{flag} {k}: {} holds certificates for robots 1..={robots}",
            out.display()
        )));
    }
    out::check_target(&config_path, Kind::ZenohConfig, true).map_err(usage_unless_io)?;
    let mut config = read_config(&config_path)?;
    let mut revoked = revoked_in(&config);
    revoked.extend(ids);
    config["access_control"] = access_control(robots, &revoked);
    write_config(&config_path, ORCHESTRATOR_HEADER, &config, true)?;
    Ok(config_path)
}

fn tls(ca: &Path, me: &Pair) -> Value {
    json!({ "link": { "tls": {
        "root_ca_certificate": path_str(ca),
        "listen_certificate": path_str(&me.cert),
        "listen_private_key": path_str(&me.key),
        "connect_certificate": path_str(&me.cert),
        "connect_private_key": path_str(&me.key),
        "enable_mtls": true,
        "verify_name_on_connect": true,
    } } })
}

fn write_config(path: &Path, header: &str, config: &Value, force: bool) -> Result<()> {
    let text = serde_json::to_string_pretty(config).context("cannot format a zenoh config")?;
    let text = format!("// {header}\n{ZENOH_CONFIG_MARK}; JSON5 for zenoh 1.10.\n{text}\n");
    write_public(path, Kind::ZenohConfig, &text, force)
}

/// A zenoh config this module wrote, read back: its comment lines dropped,
/// the rest is JSON.
pub fn read_config(path: &Path) -> Result<Value> {
    let text = read_text(path)?;
    let json: String =
        text.lines().filter(|l| !l.trim_start().starts_with("//")).collect::<Vec<_>>().join("\n");
    serde_json::from_str(&json)
        .with_context(|| format!("{} is not a config written by `orchestrator certs`", path.display()))
}

/// Checks what every call checks: robots, hosts, secured endpoints.
fn check_plan(plan: &Plan) -> Result<()> {
    anyhow::ensure!(plan.robots >= 1, "--robots must be at least 1");
    anyhow::ensure!(!plan.hosts.is_empty(), "the orchestrator needs at least one host name or address");
    for host in &plan.hosts {
        check_host(host)?;
    }
    for (flag, endpoint) in [("--listen", &plan.listen), ("--connect", &plan.connect)] {
        anyhow::ensure!(
            bycoms_protocol::bus::zenoh::is_secured(endpoint),
            "{flag} {endpoint}: certificates are for secured endpoints, quic/HOST:PORT or tls/HOST:PORT"
        );
    }
    Ok(())
}

/// A name the orchestrator's certificate may carry (`--host`): an IP
/// address, or a DNS name of dot-separated labels of letters, digits and
/// `-` (not first or last), 1 to 63 characters each, at most 253 in all.
/// Anything else (`''`, `a b;rm`) is a usage error: no robot could ever
/// reach the orchestrator by it, and the name would land in its config.
pub fn check_host(host: &str) -> Result<()> {
    if host.parse::<std::net::IpAddr>().is_ok() {
        return Ok(());
    }
    let label = |l: &str| {
        (1..=63).contains(&l.len())
            && l.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-')
            && !l.starts_with('-')
            && !l.ends_with('-')
    };
    if host.len() <= 253 && host.split('.').all(label) {
        return Ok(());
    }
    Err(exit::usage(format!(
        "--host {host:?} is neither an IP address nor a host name (dot-separated labels of letters, digits \
         and '-')"
    )))
}

/// The lab CA's certificate and key in `out`.
fn ca_files(out: &Path) -> [PathBuf; 2] {
    [out.join("ca.pem"), out.join("ca-key.pem")]
}

/// Writes the lab CA, the orchestrator's and every robot's certificate and
/// key, and the zenoh configs (see the module doc). An existing CA in the
/// output directory is replaced only with [`Plan::force`] (a usage error
/// otherwise, before anything is written).
pub fn generate(plan: &Plan) -> Result<Generated> {
    check_plan(plan)?;
    let [ca, ca_key] = ca_files(&plan.out);
    if !plan.force && [&ca, &ca_key].iter().any(|p| p.metadata().is_ok_and(|m| m.len() > 0)) {
        return Err(exit::usage(format!(
            "{} already holds a lab CA (ca.pem, ca-key.pem): replacing it locks out every robot \
             provisioned with it. Add robots to it with --add-robots, or give --force to make a new \
             CA (keep a copy of ca-key.pem first)",
            plan.out.display()
        )));
    }
    let mut rule = Outputs::new(plan.force).making_folders().output("--out", &ca, Kind::Pem).output(
        "--out",
        &ca_key,
        Kind::Pem,
    );
    for name in std::iter::once(ORCHESTRATOR_CN.to_string()).chain((1..=plan.robots).map(robot_cn)) {
        for (path, kind) in files_of(&plan.out, &name) {
            rule = rule.output("--out", path, kind);
        }
    }
    rule.check().map_err(usage_unless_io)?;
    std::fs::create_dir_all(&plan.out).with_context(|| format!("cannot create {}", plan.out.display()))?;
    let out = plan.out.canonicalize().with_context(|| format!("cannot resolve {}", plan.out.display()))?;

    let mut ca_params = CertificateParams::new(Vec::new()).context("CA parameters")?;
    ca_params.distinguished_name.push(DnType::CommonName, "BYCOMS lab CA");
    ca_params.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    let ca_key = KeyPair::generate().context("cannot generate the CA key")?;
    let ca_cert = ca_params.self_signed(&ca_key).context("cannot self-sign the CA")?;
    let [ca, ca_key_path] = ca_files(&out);
    write_private(&ca_key_path, &ca_key.serialize_pem(), plan.force)?;
    write_public(&ca, Kind::Pem, &ca_cert.pem(), plan.force)?;
    let issuer = Issuer::new(ca_params, ca_key);

    let orchestrator = leaf(
        &issuer,
        &out,
        ORCHESTRATOR_CN,
        plan.hosts.clone(),
        vec![
            ExtendedKeyUsagePurpose::ServerAuth,
            // It also connects out (to a lab router) with the same pair.
            ExtendedKeyUsagePurpose::ClientAuth,
        ],
        plan.force,
    )?;
    let orchestrator_config = out.join("orchestrator.json5");
    write_config(
        &orchestrator_config,
        ORCHESTRATOR_HEADER,
        &json!({
            "mode": "router",
            "listen": { "endpoints": [plan.listen] },
            "scouting": { "multicast": { "enabled": false }, "delay": 0 },
            "transport": tls(&ca, &orchestrator),
            "access_control": access_control(plan.robots, &BTreeSet::new()),
        }),
        plan.force,
    )?;
    let robot_configs = (1..=plan.robots)
        .map(|k| robot(&issuer, &out, &ca, k, &plan.connect, plan.force))
        .collect::<Result<_>>()?;
    Ok(Generated { ca, orchestrator_config, robot_configs })
}

const ORCHESTRATOR_HEADER: &str =
    "The orchestrator's zenoh session: router (the rendezvous), mutual TLS authentication, ACL.";

/// Robot `k`'s certificate, key and zenoh config; returns the config's path.
fn robot(
    issuer: &Issuer<'_, KeyPair>,
    out: &Path,
    ca: &Path,
    k: u32,
    connect: &str,
    force: bool,
) -> Result<PathBuf> {
    let cn = robot_cn(k);
    let pair = leaf(issuer, out, &cn, vec![cn.clone()], vec![ExtendedKeyUsagePurpose::ClientAuth], force)?;
    let path = out.join(format!("{cn}.json5"));
    write_config(
        &path,
        &format!(
            "Robot {k}'s host (agent / bridge): a client of the orchestrator, mutual TLS authentication."
        ),
        &json!({
            "mode": "client",
            "connect": { "endpoints": [connect] },
            "scouting": { "multicast": { "enabled": false } },
            "transport": tls(ca, &pair),
        }),
        force,
    )?;
    Ok(path)
}

/// Adds robots to the lab CA already in [`Plan::out`] (`certs
/// --add-robots`): robots of `1..=plan.robots` without a certificate get
/// one, signed by `ca-key.pem`, with their config; robots that have one
/// keep it, as do the CA and the orchestrator's certificate. The
/// orchestrator's config keeps its settings and gets an ACL for all robots
/// (restart the orchestrator with it). New robots connect to the endpoint
/// the existing robot configs name (else [`Plan::connect`]).
pub fn add_robots(plan: &Plan) -> Result<Generated> {
    check_plan(plan)?;
    let [ca, ca_key] = ca_files(&plan.out);
    for file in [&ca, &ca_key] {
        if !file.is_file() {
            return Err(exit::usage(format!(
                "--add-robots: {} is missing; make the lab's CA first (`orchestrator certs` without --add-robots)",
                file.display()
            )));
        }
    }
    let out = plan.out.canonicalize().with_context(|| format!("cannot resolve {}", plan.out.display()))?;
    let [ca, ca_key] = ca_files(&out);
    let orchestrator_config = out.join("orchestrator.json5");
    let mut config = read_config(&orchestrator_config)?;
    let has_cert = |k: u32| out.join(format!("{}.pem", robot_cn(k))).exists();
    let existing = robots_in(&out);
    let new: Vec<u32> = (1..=plan.robots).filter(|&k| !has_cert(k)).collect();
    let mut rule = Outputs::new(plan.force).input(&ca).input(&ca_key);
    for &k in &new {
        for (path, kind) in files_of(&out, &robot_cn(k)) {
            rule = rule.output("--out", path, kind);
        }
    }
    rule.check().map_err(usage_unless_io)?;
    // The orchestrator's config is ours to update (its own kind, replaced), nothing else is.
    out::check_target(&orchestrator_config, Kind::ZenohConfig, true).map_err(usage_unless_io)?;
    let connect = (1..=existing)
        .find_map(|k| read_config(&out.join(format!("{}.json5", robot_cn(k)))).ok())
        .and_then(|c| c["connect"]["endpoints"][0].as_str().map(str::to_string))
        .unwrap_or_else(|| plan.connect.clone());

    let key_pem = read_text(&ca_key)?;
    let key =
        KeyPair::from_pem(&key_pem).with_context(|| format!("{} is not a private key", ca_key.display()))?;
    let ca_pem = read_text(&ca)?;
    let issuer = Issuer::from_ca_cert_pem(&ca_pem, key)
        .with_context(|| format!("{} is not a CA certificate", ca.display()))?;
    let robot_configs = new
        .iter()
        .map(|&k| robot(&issuer, &out, &ca, k, &connect, plan.force))
        .collect::<Result<Vec<_>>>()?;
    // Revoked robots stay revoked.
    config["access_control"] = access_control(plan.robots.max(existing), &revoked_in(&config));
    write_config(&orchestrator_config, ORCHESTRATOR_HEADER, &config, true)?;
    Ok(Generated { ca, orchestrator_config, robot_configs })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn host_names_that_no_robot_could_reach_are_usage_errors() {
        for good in ["localhost", "127.0.0.1", "::1", "orchestrator.lab", "lab-1.example.org", "fe80::1"] {
            assert!(check_host(good).is_ok(), "{good}");
        }
        let long = format!("{}.lab", "a".repeat(64));
        for bad in ["", "a b;rm", "a..b", "-lab", "lab-", "lab_1", "ünï", long.as_str(), "lab.", "1.2.3.4:80"]
        {
            let e = check_host(bad).expect_err(bad);
            assert_eq!(exit::code_of(&e), exit::USAGE, "{bad}");
            assert!(e.to_string().contains(&format!("--host {bad:?} is neither")), "{e}");
        }
        let dir = tempfile::tempdir().expect("temp dir");
        let plan = Plan {
            robots: 1,
            hosts: vec!["localhost".into(), "a b;rm".into()],
            listen: "quic/0.0.0.0:7447".into(),
            connect: "quic/localhost:7447".into(),
            out: dir.path().to_path_buf(),
            force: false,
        };
        assert!(generate(&plan).is_err());
        assert!(std::fs::read_dir(dir.path()).expect("dir").next().is_none(), "nothing written");
    }
}
