//! The orchestrator's own checks, each fault injected in a temporary
//! directory or on a loopback socket of the test's own (the checks every
//! host shares are tested where they live, `bycoms_runtime::doctor`).

use super::{certs, host, Finding, Level};
use crate::certs::{access_control, generate, robot_cn, Plan};
use bycoms_launch::config::Transport;
use rcgen::{CertificateParams, DnType, Issuer, KeyPair};
use std::collections::BTreeSet;
use std::net::{Ipv4Addr, UdpSocket};
use std::path::Path;
use std::time::{Duration, SystemTime};

/// A lab set for `robots` robots in a new temporary directory.
fn lab(robots: u32) -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("temp dir");
    let plan = Plan {
        robots,
        hosts: vec!["localhost".into()],
        listen: "quic/0.0.0.0:7447".into(),
        connect: "quic/localhost:7447".into(),
        out: dir.path().to_path_buf(),
        force: false,
    };
    generate(&plan).expect("certs");
    dir
}

/// Replaces `dir/<file>.pem` by a certificate of common name `cn`, signed
/// by the set's CA, valid until `until` (year, month, day).
fn reissue(dir: &Path, file: &str, cn: &str, until: (i32, u8, u8)) {
    let ca_pem = std::fs::read_to_string(dir.join("ca.pem")).expect("ca");
    let key =
        KeyPair::from_pem(&std::fs::read_to_string(dir.join("ca-key.pem")).expect("ca key")).expect("key");
    let issuer = Issuer::from_ca_cert_pem(&ca_pem, key).expect("issuer");
    let mut params = CertificateParams::new(vec![cn.to_string()]).expect("params");
    params.distinguished_name.push(DnType::CommonName, cn);
    params.not_before = rcgen::date_time_ymd(2020, 1, 1);
    params.not_after = rcgen::date_time_ymd(until.0, until.1, until.2);
    let cert = params.signed_by(&KeyPair::generate().expect("key"), &issuer).expect("sign");
    std::fs::write(dir.join(format!("{file}.pem")), cert.pem()).expect("write");
}

/// 2026-06-01, a fixed "today" for the dates.
fn today() -> SystemTime {
    SystemTime::UNIX_EPOCH + Duration::from_secs(1_780_272_000)
}

fn problems(found: &[Finding]) -> Vec<&Finding> {
    found.iter().filter(|f| f.level != Level::Ok).collect()
}

#[test]
fn a_fresh_set_is_all_ok_and_a_missing_robot_is_an_error_with_its_fix() {
    let dir = lab(2);
    let found = certs::check(dir.path(), 2, today());
    assert!(problems(&found).is_empty(), "{found:#?}");
    assert_eq!(found.iter().map(|f| f.check).collect::<Vec<_>>(), ["certs", "acl"]);
    let found = certs::check(dir.path(), 3, today());
    let p = problems(&found);
    assert_eq!(p.len(), 2, "{found:#?}");
    assert!(p.iter().all(|f| f.level == Level::Error && f.fix.contains("--add-robots --robots 3")), "{p:#?}");
    assert!(p[0].cause.contains("robot-3.pem") && p[1].cause.contains("does not name robot-3"), "{p:#?}");
}

#[test]
fn an_expired_certificate_is_an_error_and_one_expiring_within_30_days_a_warning() {
    let dir = lab(2);
    reissue(dir.path(), "robot-1", "robot-1", (2026, 5, 1));
    reissue(dir.path(), "robot-2", "robot-2", (2026, 6, 21));
    let found = certs::check(dir.path(), 2, today());
    let p = problems(&found);
    assert_eq!(p.len(), 2, "{found:#?}");
    assert_eq!(p[0].level, Level::Error);
    assert!(p[0].cause.contains("robot-1.pem expired on 2026-05-01"), "{}", p[0].cause);
    assert_eq!(p[1].level, Level::Warn);
    assert!(p[1].cause.contains("robot-2.pem expires in 20 days (2026-06-21)"), "{}", p[1].cause);
    assert!(p[1].fix.contains("orchestrator certs --add-robots"), "{}", p[1].fix);
}

#[test]
fn a_wrong_common_name_and_another_labs_certificate_are_errors() {
    let dir = lab(2);
    reissue(dir.path(), "robot-1", "robot-9", (2030, 1, 1));
    let other = lab(1);
    std::fs::copy(other.path().join("robot-1.pem"), dir.path().join("robot-2.pem")).expect("copy");
    let found = certs::check(dir.path(), 2, today());
    let causes: Vec<&str> = problems(&found).iter().map(|f| f.cause.as_str()).collect();
    assert_eq!(causes.len(), 3, "{found:#?}");
    assert!(
        causes[0].contains("robot-1.pem carries the common name \"robot-9\", not \"robot-1\""),
        "{causes:?}"
    );
    assert!(causes[1].contains("robot-2.pem is not signed by the lab's CA"), "{causes:?}");
    assert!(causes[2].contains("robot-2.pem carries the common name \"robot-1\""), "{causes:?}");
}

#[test]
fn an_acl_that_misses_a_robot_is_an_error_and_a_revoked_robot_a_warning() {
    let dir = lab(3);
    let path = dir.path().join("orchestrator.json5");
    let mut config = crate::certs::read_config(&path).expect("config");
    config["access_control"] = access_control(2, &BTreeSet::from([1]));
    std::fs::write(&path, serde_json::to_string(&config).expect("json")).expect("write");
    let found = certs::check(dir.path(), 3, today());
    let p = problems(&found);
    assert_eq!(p.len(), 2, "{found:#?}");
    assert_eq!((p[0].check, p[0].level), ("acl", Level::Warn));
    assert!(p[0].cause.contains("robot 1 is revoked"), "{}", p[0].cause);
    assert_eq!((p[1].check, p[1].level), ("acl", Level::Error));
    assert!(p[1].cause.contains(&format!("does not name {}", robot_cn(3))), "{}", p[1].cause);
}

#[test]
fn the_limits_say_what_the_launch_would_do() {
    assert_eq!(host::open_files(3, Transport::Ipc, 1024, 4096).level, Level::Ok);
    let raised = host::open_files(100, Transport::Ipc, 1024, 1 << 20);
    assert_eq!(raised.level, Level::Ok);
    assert!(raised.cause.contains("raises the limit from 1024"), "{}", raised.cause);
    let refused = host::open_files(1000, Transport::Ipc, 1024, 4096);
    assert_eq!(refused.level, Level::Error);
    assert!(refused.cause.contains("4096") && refused.fix.contains("ulimit -Hn"), "{refused:?}");
    assert_eq!(host::memory(100, 4096).level, Level::Ok);
    let short = host::memory(1000, 4096);
    assert_eq!(short.level, Level::Error);
    assert!(short.cause.contains("6256 MB"), "{}", short.cause);
}

#[test]
fn a_silent_natnet_server_is_an_error_within_the_bounded_wait() {
    let silent = UdpSocket::bind((Ipv4Addr::LOCALHOST, 0)).expect("bind");
    let client = bycoms_mocap::ClientConfig {
        server: silent.local_addr().expect("addr"),
        local: Ipv4Addr::LOCALHOST.into(),
        multicast: None,
        reply_timeout_ms: 60_000,
    };
    let started = std::time::Instant::now();
    let found = host::natnet(&client, Duration::from_millis(50));
    assert_eq!(found.level, Level::Error);
    assert!(found.cause.contains("did not answer NAT_CONNECT"), "{}", found.cause);
    assert!(started.elapsed() < Duration::from_secs(5), "bounded: {:?}", started.elapsed());
}

#[test]
fn an_answering_natnet_server_is_ok() {
    use bycoms_natnet_server::NatNetServer;
    let lab = bycoms_mocap::testing::lab(Default::default());
    let server = NatNetServer::start_any_port(lab, Ipv4Addr::LOCALHOST.into()).expect("server");
    let client = bycoms_mocap::ClientConfig {
        server: server.command_addr(),
        local: Ipv4Addr::LOCALHOST.into(),
        multicast: None,
        reply_timeout_ms: 1000,
    };
    let found = host::natnet(&client, Duration::from_secs(2));
    assert_eq!(found.level, Level::Ok, "{found:?}");
    assert!(found.cause.contains("answers (lab)"), "{}", found.cause);
}

#[test]
fn dead_iceoryx2_nodes_are_counted_in_the_singular_and_plural() {
    assert_eq!(host::leftovers(0).level, Level::Ok);
    let one = host::leftovers(1);
    assert_eq!(one.level, Level::Warn);
    assert_eq!(one.cause, "1 dead iceoryx2 node (killed launches or agents) left files in /dev/shm");
    assert!(host::leftovers(2).cause.starts_with("2 dead iceoryx2 nodes "), "{}", host::leftovers(2).cause);
}
