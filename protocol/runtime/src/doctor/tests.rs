//! The shared checks, each fault injected in a temporary directory or on a
//! loopback socket of the test's own; zenoh in-process on loopback.

use super::{certs, host, host_findings, json, text, zenoh, Finding, HostArgs, HostNeeds, Level};
use bycoms_protocol::bus::zenoh::clock::{ClockLimits, ClockSample};
use bycoms_protocol::bus::zenoh::{Mode, ZenohBus, ZenohConfig};
use bycoms_protocol::naming::Member;
use bycoms_protocol::Swarm;
use rcgen::{BasicConstraints, CertificateParams, DnType, IsCa, Issuer, KeyPair};
use std::net::{Ipv4Addr, SocketAddr, TcpListener, UdpSocket};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// 2026-06-01, a fixed "today" for the dates.
fn today() -> SystemTime {
    SystemTime::UNIX_EPOCH + Duration::from_secs(1_780_272_000)
}

/// A lab CA in `dir` (`ca.pem`) and its issuer.
fn ca(dir: &Path) -> Issuer<'static, KeyPair> {
    let key = KeyPair::generate().expect("key");
    let mut params = CertificateParams::new(Vec::new()).expect("params");
    params.distinguished_name.push(DnType::CommonName, "lab CA");
    params.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    params.not_before = rcgen::date_time_ymd(2020, 1, 1);
    params.not_after = rcgen::date_time_ymd(2040, 1, 1);
    std::fs::write(dir.join("ca.pem"), params.self_signed(&key).expect("sign").pem()).expect("write");
    Issuer::new(params, key)
}

/// A robot's certificate of common name `cn` valid until `until`, signed
/// by `issuer`, and its zenoh config naming it and `dir/ca.pem`, as
/// `orchestrator certs` writes them; the config's path.
fn robot_config(dir: &Path, issuer: &Issuer<'_, KeyPair>, cn: &str, until: (i32, u8, u8)) -> PathBuf {
    let key = KeyPair::generate().expect("key");
    let mut params = CertificateParams::new(vec![cn.to_string()]).expect("params");
    params.distinguished_name.push(DnType::CommonName, cn);
    params.not_before = rcgen::date_time_ymd(2020, 1, 1);
    params.not_after = rcgen::date_time_ymd(until.0, until.1, until.2);
    let cert = params.signed_by(&key, issuer).expect("sign");
    let (pem, key_pem) = (dir.join("robot.pem"), dir.join("robot-key.pem"));
    std::fs::write(&pem, cert.pem()).expect("write");
    std::fs::write(&key_pem, key.serialize_pem()).expect("write");
    let tls = serde_json::json!({ "transport": { "link": { "tls": {
        "root_ca_certificate": dir.join("ca.pem"),
        "connect_certificate": pem,
        "connect_private_key": key_pem,
    } } } });
    let path = dir.join("robot.json5");
    std::fs::write(&path, tls.to_string()).expect("write");
    path
}

#[test]
fn this_robots_certificate_is_judged_as_its_agent_judges_it_and_warned_about_30_days_ahead() {
    let dir = tempfile::tempdir().expect("temp dir");
    let issuer = ca(dir.path());
    let config = robot_config(dir.path(), &issuer, "robot-3", (2030, 1, 1));
    let found = certs::robot(&config, 3, today());
    assert_eq!(found.len(), 1, "{found:#?}");
    assert_eq!((found[0].check, found[0].level), ("certs", Level::Ok));
    assert!(found[0].cause.contains("robot-3's certificate signed by the lab's CA"), "{found:#?}");

    let wrong = certs::robot(&config, 4, today());
    assert_eq!(wrong.len(), 1, "{wrong:#?}");
    assert_eq!(wrong[0].level, Level::Error);
    assert!(wrong[0].cause.contains("\"robot-3\"'s, not \"robot-4\"'s"), "{}", wrong[0].cause);
    assert!(
        wrong[0].fix.contains("--add-robots") && wrong[0].fix.contains("robot-4.pem"),
        "{}",
        wrong[0].fix
    );

    robot_config(dir.path(), &issuer, "robot-3", (2026, 6, 21));
    let soon = certs::robot(&config, 3, today());
    assert_eq!(soon.len(), 1, "{soon:#?}");
    assert_eq!(soon[0].level, Level::Warn);
    assert!(soon[0].cause.contains("robot.pem expires in 20 days (2026-06-21)"), "{}", soon[0].cause);

    robot_config(dir.path(), &issuer, "robot-3", (2026, 5, 1));
    let expired = certs::robot(&config, 3, today());
    assert_eq!(expired[0].level, Level::Error);
    assert!(expired[0].cause.contains("expired on 2026-05-01"), "{}", expired[0].cause);

    let other = tempfile::tempdir().expect("temp dir");
    robot_config(dir.path(), &ca(other.path()), "robot-3", (2030, 1, 1));
    let foreign = certs::robot(&config, 3, today());
    assert_eq!(foreign[0].level, Level::Error);
    assert!(foreign[0].cause.contains("is not signed by the lab's CA"), "{}", foreign[0].cause);
}

#[test]
fn an_unsecured_config_has_nothing_to_check_and_a_missing_one_is_an_error() {
    let dir = tempfile::tempdir().expect("temp dir");
    let plain = dir.path().join("plain.json5");
    std::fs::write(&plain, "{ mode: \"client\" }").expect("write");
    let found = certs::robot(&plain, 1, today());
    assert_eq!(found.iter().map(|f| f.level).collect::<Vec<_>>(), [Level::Ok]);
    assert!(found[0].cause.contains("names no certificates"), "{found:#?}");
    let missing = certs::robot(&dir.path().join("none.json5"), 1, today());
    assert_eq!(missing[0].level, Level::Error);
    assert!(missing[0].fix.contains("robot-1.json5"), "{missing:#?}");
}

#[test]
fn the_open_files_limit_is_judged_for_what_the_agent_needs() {
    assert_eq!(host::open_files(64, 1024, 4096).level, Level::Ok);
    let soft = host::open_files(64, 32, 4096);
    assert_eq!(soft.level, Level::Error);
    assert!(soft.cause.contains("needs about 64 open files and the limit is 32"), "{}", soft.cause);
    assert!(soft.fix.starts_with("ulimit -n 64"), "{}", soft.fix);
    assert!(host::open_files(64, 32, 48).fix.starts_with("ulimit -Hn 64"));
    assert_eq!(host::open_files_here(1).level, Level::Ok, "any process has one file");
}

#[test]
fn a_taken_gateway_port_is_an_error_that_names_the_robot_and_a_free_one_is_ok() {
    let taken = UdpSocket::bind((Ipv4Addr::LOCALHOST, 0)).expect("bind");
    let taken_addr = taken.local_addr().expect("addr");
    // Port 0: any free port, always bindable.
    let free_addr = SocketAddr::from((Ipv4Addr::LOCALHOST, 0));
    let found = host::udp_ports(&[(1, free_addr), (2, taken_addr)]);
    assert_eq!(found.len(), 1, "{found:#?}");
    assert_eq!(found[0].level, Level::Error);
    assert!(
        found[0].cause.contains(&format!("robot 2's gateway cannot bind {taken_addr}")),
        "{}",
        found[0].cause
    );
    assert!(found[0].fix.contains(&format!("sport = :{}", taken_addr.port())), "{}", found[0].fix);
    let one = &host::udp_ports(&[(1, free_addr)])[0];
    assert_eq!(one.level, Level::Ok);
    assert_eq!(
        one.cause,
        format!("robot 1's gateway UDP port {free_addr} is free"),
        "one gateway, in the singular"
    );
    let two = &host::udp_ports(&[(1, free_addr), (2, free_addr)])[0];
    assert_eq!(two.cause, "the 2 gateways' UDP ports are free");
}

#[test]
fn the_report_counts_and_the_json_has_the_documented_shape() {
    let found = vec![
        Finding::ok("memory", "fine"),
        Finding::warn("acl", "revoked", "relaunch"),
        Finding::error("udp-ports", "taken", "stop it"),
    ];
    let lines = text(&found);
    assert_eq!(lines.last().map(String::as_str), Some("doctor: 1 errors, 1 warnings, 1 ok"));
    assert!(lines.contains(&"      fix: stop it".to_string()), "{lines:?}");
    let j = json(&found);
    assert_eq!((j["errors"].as_u64(), j["warnings"].as_u64()), (Some(1), Some(1)));
    assert_eq!(j["findings"][2]["level"], "error");
    assert_eq!(j["findings"][1]["fix"], "relaunch");
}

/// A reach of `endpoint` for swarm `swarm`, waiting `ms` per step.
fn reach(endpoint: &str, swarm: &str, ms: u64) -> zenoh::Reach {
    zenoh::Reach {
        endpoint: endpoint.into(),
        zenoh_config: None,
        swarm: Some(Swarm::new(swarm).expect("swarm")),
        timeout: Duration::from_millis(ms),
        clocks: ClockLimits::LAB,
    }
}

/// A zenoh router on a free loopback TCP port, and its endpoint. The port
/// is free when asked, but another process may take it before zenoh binds
/// it (tests run side by side): a few ports are tried.
fn router() -> (ZenohBus, String) {
    let config = |endpoint: &str| ZenohConfig {
        mode: Mode::Router,
        listen: vec![endpoint.to_owned()],
        ..ZenohConfig::default()
    };
    ZenohBus::loopback_router(config).expect("a router on a free loopback port")
}

#[test]
fn the_orchestrators_endpoint_is_reached_and_its_liveliness_seen_or_missed() {
    let (router, listen) = router();
    let swarm = Swarm::new("doctor-live").expect("swarm");
    let _alive = router.declare_alive(&swarm, Member::Orchestrator).expect("token");
    let found = zenoh::check(&reach(&listen, "doctor-live", 5_000));
    assert_eq!(found.iter().map(|f| f.level).collect::<Vec<_>>(), [Level::Ok, Level::Ok, Level::Error]);
    assert!(found[2].cause.contains("did not answer the clock query"), "{found:#?}");
    let _clock = router.serve_clock(&swarm).expect("clock");
    let found = zenoh::check(&reach(&listen, "doctor-live", 5_000));
    assert_eq!(found.iter().map(|f| f.level).collect::<Vec<_>>(), [Level::Ok, Level::Ok, Level::Ok]);
    assert_eq!(found[2].check, "clock");
    assert!(found[2].cause.contains("ms off the orchestrator's (round trip"), "{found:#?}");
    let found = zenoh::check(&reach(&listen, "doctor-other", 200));
    assert_eq!(found.iter().map(|f| f.level).collect::<Vec<_>>(), [Level::Ok, Level::Error], "{found:#?}");
    assert!(found[1].cause.contains("no orchestrator of swarm doctor-other"), "{}", found[1].cause);
}

/// A robot's host's doctor as `gateway doctor` runs it: a taken gateway port
/// and a live orchestrator; a bad endpoint or swarm is a usage error.
#[test]
fn a_hosts_doctor_runs_every_check_of_its_agent() {
    let (router, listen) = router();
    let swarm = Swarm::new("doctor-host").expect("swarm");
    let _alive = router.declare_alive(&swarm, Member::Orchestrator).expect("token");
    let _clock = router.serve_clock(&swarm).expect("clock");
    let taken = UdpSocket::bind((Ipv4Addr::LOCALHOST, 0)).expect("bind");
    let args = HostArgs {
        connect: listen,
        zenoh_config: None,
        swarm: "doctor-host".into(),
        robot: 2,
        timeout_ms: 5_000,
        json: true,
    };
    let needs = HostNeeds { files: 1, bind: Some(taken.local_addr().expect("addr")) };
    let found = host_findings(&args, needs, today()).expect("findings");
    let checks: Vec<_> = found.iter().map(|f| (f.check, f.level)).collect();
    assert_eq!(
        checks,
        [
            ("open-files", Level::Ok),
            ("udp-ports", Level::Error),
            ("zenoh", Level::Ok),
            ("zenoh", Level::Ok),
            ("clock", Level::Ok)
        ],
        "{found:#?}"
    );
    assert!(found[1].cause.starts_with("robot 2's gateway cannot bind"), "{}", found[1].cause);
    let bad = HostArgs { connect: "nowhere".into(), ..args.clone() };
    assert!(host_findings(&bad, needs, today()).expect_err("usage").starts_with("bad --connect"));
    let bad = HostArgs { swarm: "a/b".into(), ..args };
    assert!(host_findings(&bad, needs, today()).expect_err("usage").starts_with("bad --swarm"));
}

#[test]
fn an_endpoint_that_never_answers_is_an_error_within_the_bounded_wait() {
    // Accepts TCP (the backlog) and never speaks zenoh.
    let mute = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).expect("bind");
    let endpoint = format!("tcp/{}", mute.local_addr().expect("addr"));
    let started = std::time::Instant::now();
    let found = zenoh::check(&reach(&endpoint, "doctor-mute", 300));
    assert_eq!(found.len(), 1, "{found:#?}");
    assert_eq!(found[0].level, Level::Error);
    assert!(found[0].cause.contains(&format!("{endpoint} not reached")), "{}", found[0].cause);
    assert!(found[0].fix.contains("firewall"), "{}", found[0].fix);
    assert!(started.elapsed() < Duration::from_secs(5), "bounded: {:?}", started.elapsed());
}

/// A `--zenoh-config` that is missing, not a zenoh config or without end
/// is the file's problem (named, with a fix about the file), not the
/// network's: no firewall advice, and said before any connection.
#[test]
fn a_zenoh_config_that_is_no_config_is_the_files_problem() {
    let dir = tempfile::tempdir().expect("temp dir");
    let passwd = dir.path().join("passwd");
    std::fs::write(&passwd, "root:x:0:0:root:/root:/bin/bash\n").expect("write");
    let missing = dir.path().join("none.json5");
    let zero = PathBuf::from("/dev/zero");
    for (path, says) in [
        (&missing, "No such file"),
        (&passwd, "not a zenoh JSON5 config"),
        (&zero, "more than the limit of 4194304 bytes"),
    ] {
        // Nothing listens there: a network check would say "not reached".
        let reach =
            zenoh::Reach { zenoh_config: Some(path.clone()), ..reach("tcp/127.0.0.1:9", "doctor-file", 300) };
        let found = zenoh::check(&reach);
        assert_eq!(found.len(), 1, "{found:#?}");
        assert_eq!(found[0].level, Level::Error);
        let cause = &found[0].cause;
        assert!(cause.contains(&path.display().to_string()) && cause.contains(says), "{cause}");
        assert!(!cause.contains("not reached") && !found[0].fix.contains("firewall"), "{found:#?}");
        assert!(found[0].fix.contains("--zenoh-config"), "{}", found[0].fix);
    }
}

/// A clock offset is judged by the launch's limits either way, and the fix
/// names chrony.
#[test]
fn a_clock_offset_is_ok_a_warning_or_an_error() {
    let at = |offset_us| {
        zenoh::clock_finding(Ok(Some(ClockSample { offset_us, round_trip_us: 1_200 })), ClockLimits::LAB)
    };
    let ok = at(-40_000);
    assert_eq!((ok.check, ok.level), ("clock", Level::Ok));
    assert!(ok.cause.contains("-40.0 ms off the orchestrator's (round trip 1.2 ms)"), "{}", ok.cause);
    let warn = at(250_000);
    assert_eq!(warn.level, Level::Warn);
    assert!(warn.cause.contains("more than 100 ms") && warn.fix.contains("chrony"), "{warn:?}");
    let error = at(-750_000);
    assert_eq!(error.level, Level::Error);
    assert!(error.cause.contains("more than 500 ms, the launch refuses"), "{}", error.cause);
    assert!(error.fix.contains("chronyc makestep"), "{}", error.fix);
    let silent = zenoh::clock_finding(Ok(None), ClockLimits::LAB);
    assert_eq!(silent.level, Level::Error);
}
