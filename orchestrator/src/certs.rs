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
//! `bycoms/*/robot/<k>/**` and on the shared `bycoms/*/from_agents`, and
//! lets every robot subscribe to and receive anything under `bycoms/**`.
//! Limit: `from_agents` is one key for all agents, so the ACL cannot stop
//! robot 1 from putting robot 2's id *inside* a `FromAgent` payload; the
//! orchestrator has to check the id against the sender (or the naming has
//! to give each agent its own `from_agents` key) — not done yet.

use anyhow::{Context, Result};
use rcgen::{BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// Common name of the orchestrator's certificate.
pub const ORCHESTRATOR_CN: &str = "orchestrator";

/// Common name of robot `k`'s certificate.
pub fn robot_cn(k: u32) -> String {
    format!("robot-{k}")
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
}

/// The files [`generate`] wrote.
#[derive(Clone, Debug)]
pub struct Generated {
    /// The lab CA's certificate.
    pub ca: PathBuf,
    /// zenoh config of the orchestrator (router, TLS listener, ACL).
    pub orchestrator_config: PathBuf,
    /// zenoh config of each robot's host (client of the orchestrator), in
    /// robot order 1..=N.
    pub robot_configs: Vec<PathBuf>,
}

struct Pair {
    cert: PathBuf,
    key: PathBuf,
}

fn write_private(path: &Path, text: &str) -> Result<()> {
    use std::io::Write as _;
    use std::os::unix::fs::OpenOptionsExt as _;
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o600)
        .open(path)
        .with_context(|| format!("cannot write {}", path.display()))?;
    f.write_all(text.as_bytes()).with_context(|| format!("cannot write {}", path.display()))
}

fn write_public(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

fn leaf(
    issuer: &Issuer<'_, KeyPair>,
    out: &Path,
    name: &str,
    sans: Vec<String>,
    usages: Vec<ExtendedKeyUsagePurpose>,
) -> Result<Pair> {
    let mut params = CertificateParams::new(sans).context("bad subject alternative name")?;
    params.distinguished_name.push(DnType::CommonName, name);
    params.extended_key_usages = usages;
    let key = KeyPair::generate().context("cannot generate a key")?;
    let cert = params.signed_by(&key, issuer).context("cannot sign a certificate")?;
    let pair = Pair { cert: out.join(format!("{name}.pem")), key: out.join(format!("{name}-key.pem")) };
    write_public(&pair.cert, &cert.pem())?;
    write_private(&pair.key, &key.serialize_pem())?;
    Ok(pair)
}

fn path_str(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

/// The access-control list: default deny; see the module doc.
pub fn access_control(robots: u32) -> Value {
    let mut rules = vec![
        json!({ "id": "orchestrator-all", "messages": ["put", "delete", "declare_subscriber", "query",
            "declare_queryable", "reply", "liveliness_token", "declare_liveliness_subscriber", "liveliness_query"],
            "flows": ["ingress", "egress"], "permission": "allow", "key_exprs": ["bycoms/**"] }),
        json!({ "id": "robots-listen", "messages": ["declare_subscriber", "liveliness_token",
            "declare_liveliness_subscriber", "liveliness_query"],
            "flows": ["ingress", "egress"], "permission": "allow", "key_exprs": ["bycoms/**"] }),
        json!({ "id": "robots-receive", "messages": ["put", "delete"], "flows": ["egress"],
            "permission": "allow", "key_exprs": ["bycoms/**"] }),
    ];
    let mut subjects = vec![json!({ "id": ORCHESTRATOR_CN, "cert_common_names": [ORCHESTRATOR_CN] })];
    let mut policies = vec![json!({ "rules": ["orchestrator-all"], "subjects": [ORCHESTRATOR_CN] })];
    for k in 1..=robots {
        let cn = robot_cn(k);
        rules.push(
            json!({ "id": format!("{cn}-publish"), "messages": ["put", "delete"], "flows": ["ingress"],
            "permission": "allow", "key_exprs": [format!("bycoms/*/robot/{k}/**"), "bycoms/*/from_agents"] }),
        );
        subjects.push(json!({ "id": cn, "cert_common_names": [cn] }));
        policies.push(json!({ "rules": [format!("{cn}-publish"), "robots-listen", "robots-receive"], "subjects": [cn] }));
    }
    json!({ "enabled": true, "default_permission": "deny", "rules": rules, "subjects": subjects, "policies": policies })
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

fn write_config(path: &Path, header: &str, config: &Value) -> Result<()> {
    let text = serde_json::to_string_pretty(config).context("cannot format a zenoh config")?;
    write_public(
        path,
        &format!("// {header}\n// Written by `orchestrator certs`; JSON5 for zenoh 1.10.\n{text}\n"),
    )
}

/// Whether zenoh authenticates and encrypts `endpoint` with the TLS
/// settings of these configs (`quic/` and `tls/`).
pub fn is_secured(endpoint: &str) -> bool {
    endpoint.starts_with("quic/") || endpoint.starts_with("tls/")
}

/// Writes the lab CA, the orchestrator's and every robot's certificate and
/// key, and the zenoh configs (see the module doc).
pub fn generate(plan: &Plan) -> Result<Generated> {
    anyhow::ensure!(plan.robots >= 1, "--robots must be at least 1");
    anyhow::ensure!(!plan.hosts.is_empty(), "the orchestrator needs at least one host name or address");
    for (flag, endpoint) in [("--listen", &plan.listen), ("--connect", &plan.connect)] {
        anyhow::ensure!(
            is_secured(endpoint),
            "{flag} {endpoint}: certificates are for secured endpoints, quic/HOST:PORT or tls/HOST:PORT"
        );
    }
    std::fs::create_dir_all(&plan.out).with_context(|| format!("cannot create {}", plan.out.display()))?;
    let out = plan.out.canonicalize().with_context(|| format!("cannot resolve {}", plan.out.display()))?;

    let mut ca_params = CertificateParams::new(Vec::new()).context("CA parameters")?;
    ca_params.distinguished_name.push(DnType::CommonName, "BYCOMS lab CA");
    ca_params.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    let ca_key = KeyPair::generate().context("cannot generate the CA key")?;
    let ca_cert = ca_params.self_signed(&ca_key).context("cannot self-sign the CA")?;
    let ca = out.join("ca.pem");
    write_public(&ca, &ca_cert.pem())?;
    write_private(&out.join("ca-key.pem"), &ca_key.serialize_pem())?;
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
    )?;
    let orchestrator_config = out.join("orchestrator.json5");
    write_config(
        &orchestrator_config,
        "The orchestrator's zenoh session: router (the rendezvous), mutual TLS authentication, ACL.",
        &json!({
            "mode": "router",
            "listen": { "endpoints": [plan.listen] },
            "scouting": { "multicast": { "enabled": false }, "delay": 0 },
            "transport": tls(&ca, &orchestrator),
            "access_control": access_control(plan.robots),
        }),
    )?;
    let mut robot_configs = Vec::new();
    for k in 1..=plan.robots {
        let cn = robot_cn(k);
        let pair = leaf(&issuer, &out, &cn, vec![cn.clone()], vec![ExtendedKeyUsagePurpose::ClientAuth])?;
        let path = out.join(format!("{cn}.json5"));
        write_config(
            &path,
            &format!(
                "Robot {k}'s host (agent / bridge): a client of the orchestrator, mutual TLS authentication."
            ),
            &json!({
                "mode": "client",
                "connect": { "endpoints": [plan.connect] },
                "scouting": { "multicast": { "enabled": false } },
                "transport": tls(&ca, &pair),
            }),
        )?;
        robot_configs.push(path);
    }
    Ok(Generated { ca, orchestrator_config, robot_configs })
}
