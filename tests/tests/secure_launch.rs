//! A launch that spawns its agents over a secured `quic/` endpoint, with the lab's
//! certificates and access-control list from `orchestrator certs`: each
//! agent reads its own `robot-K.json5` (`--agent-zenoh-config
//! DIR/robot-{robot}.json5`) and the run gives the same result as the
//! same launch over iceoryx2 (and the ACL lets each agent ask for the
//! run's settings). Without the agents' configs the launch refuses to start (exit 2)
//! instead of spawning agents that cannot connect. Certificates are
//! generated into a temporary directory; the port is the kernel's.

use bycoms_tests::{swarm_name, Proc};
use std::net::UdpSocket;
use std::time::Duration;

fn free_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0").and_then(|s| s.local_addr()).expect("free port").port()
}

#[test]
fn spawned_agents_join_a_secured_launch_with_their_own_certificates() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().to_str().expect("utf-8 path");
    let endpoint = format!("quic/127.0.0.1:{}", free_port());
    let certs = Proc::orchestrator(&[
        "certs",
        "--robots",
        "3",
        "--out",
        out,
        "--listen",
        &endpoint,
        "--connect",
        &endpoint,
    ])
    .wait(Duration::from_secs(30));
    assert_eq!(certs.status.code(), Some(0), "certs: {}", certs.stderr);
    let orchestrator_config = dir.path().join("orchestrator.json5");
    let agent_config = dir.path().join("robot-{robot}.json5");
    let (orchestrator_config, agent_config) =
        (orchestrator_config.to_str().expect("utf-8"), agent_config.to_str().expect("utf-8"));
    let common =
        ["launch", "--transport", "zenoh", "--listen", &endpoint, "--zenoh-config", orchestrator_config];

    // Without the agents' certificates: refused before anything starts.
    let swarm = swarm_name("quic-refused");
    let mut args = common.to_vec();
    args.extend(["--swarm", &swarm, "--json"]);
    let refused = Proc::orchestrator(&args).wait(Duration::from_secs(30));
    assert_eq!(refused.status.code(), Some(2), "{}", refused.stderr);
    assert!(refused.stderr.contains("agent_zenoh_config"), "{}", refused.stderr);

    // With them: the whole run of three robots over QUIC, as over iceoryx2
    // (about 3 s in a debug build).
    let swarm = swarm_name("quic");
    let mut args = common.to_vec();
    args.extend(["--agent-zenoh-config", agent_config, "--clock", "lockstep", "--swarm", &swarm, "--json"]);
    let run = Proc::orchestrator(&args).wait(Duration::from_secs(120));
    assert_eq!(run.status.code(), Some(0), "{}", run.stderr);
    let j = run.json();
    assert_eq!(j["transport"], "zenoh");
    assert_eq!(j["endpoints"][0], endpoint.as_str(), "{j}");
    assert_eq!(j["outcome"], "arrived", "{}", run.stderr);
    assert_eq!(j["bad_traffic"]["garbage"], 0, "{j}");
    // The ACL lets each robot ask for the run's settings, and each agent
    // found them the same as its own (spawned: flags and stdin).
    let checked = run.stderr.matches("got the run's settings from the orchestrator").count();
    assert_eq!(checked, 3, "every agent got the launch's settings over QUIC:\n{}", run.stderr);

    let swarm = swarm_name("plain");
    let plain = Proc::orchestrator(&["launch", "--clock", "lockstep", "--swarm", &swarm, "--json"])
        .wait(Duration::from_secs(120));
    let t = plain.json();
    for key in ["outcome", "steps", "ticks", "robots_used", "beacons"] {
        assert_eq!(j[key], t[key], "{key}: quic {} vs ipc {}", j[key], t[key]);
    }
}
