//! `orchestrator doctor`: the checks of `crate::doctor` for a planned
//! launch, said as findings (text, or `--json`), exit 1 on any error.

use crate::doctor::{self, host, Finding};
use anyhow::Result;
use bycoms_lab::robots::RobotsFile;
use bycoms_launch::agents::choice::AgentSourceKind;
use bycoms_launch::agents::gateways::GatewaysAt;
use bycoms_launch::config::{check_endpoints, check_robot_count, check_swarm, LaunchConfig};
use bycoms_mocap::MocapSource;
use bycoms_runtime::exit;
use bycoms_runtime::words::count;
use std::path::PathBuf;
use std::time::{Duration, SystemTime};

/// `orchestrator doctor`'s flags (its help is the `Command::Doctor` variant's).
#[derive(Clone, Debug, clap::Args)]
pub struct Args {
    /// The launch config of the lab day (its robots, transport, robots file, [mocap]).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Planned robot count [default: the config's].
    #[arg(long, value_name = "N")]
    pub robots: Option<u32>,
    /// The directory `orchestrator certs` wrote (ca.pem, orchestrator.json5,
    /// robot-K.pem) [default: the directory of the config's transport.zenoh_config].
    #[arg(long, value_name = "DIR")]
    pub certs: Option<PathBuf>,
    /// Print the findings as JSON: {"findings": [{check, level, cause, fix}], "errors", "warnings"}.
    #[arg(long)]
    pub json: bool,
    /// Remove iceoryx2 files of dead processes and unheld swarm locks first.
    #[arg(long)]
    pub clean: bool,
    /// Reach this zenoh endpoint as a robot's host would (client mode), e.g.
    /// quic/orchestrator.lab:7447, and with --swarm (or the config's swarm)
    /// see the orchestrator's liveliness there and measure this host's clock
    /// offset to it (warn past supervision.clock_warn, 100 ms; error past
    /// supervision.clock_limit, 500 ms).
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Option<String>,
    /// With --connect: the robot's zenoh config read first (certs/robot-1.json5).
    #[arg(long, value_name = "FILE", requires = "connect")]
    pub zenoh_config: Option<PathBuf>,
    /// With --connect: the swarm whose orchestrator must be alive [default: the config's swarm].
    #[arg(long, value_name = "NAME", requires = "connect")]
    pub swarm: Option<String>,
    /// How long the NatNet server (and with --connect, the zenoh session and
    /// the orchestrator's liveliness) may take to answer each of 3 attempts, ms.
    #[arg(long, value_name = "MS", default_value_t = 500, value_parser = bycoms_runtime::seconds::millis)]
    pub timeout_ms: u64,
}

/// The findings for the plan of `args` (read config, robot count).
pub fn findings(args: &Args, now: SystemTime) -> Result<Vec<Finding>> {
    let config = match &args.config {
        Some(path) => LaunchConfig::load(path)?,
        None => LaunchConfig::default(),
    };
    let robots = args.robots.unwrap_or(config.robots);
    check_robot_count("--robots", robots)?;
    let mut found = vec![host::open_files_here(robots, config.transport.kind)];
    if let Some(path) = &args.config {
        found.extend(config_refused(path, &config, robots));
    }
    found.extend(host::available_mb().map(|mb| host::memory(robots, mb)));
    let zenoh_dir = config.transport.zenoh_config.as_deref().and_then(std::path::Path::parent);
    if let Some(dir) = args.certs.as_deref().or(zenoh_dir) {
        found.extend(doctor::certs::check(dir, robots, now));
    }
    let agents = &config.agents;
    if agents.source == AgentSourceKind::Real && agents.gateways == GatewaysAt::Here {
        if let Some(path) = &agents.robots_file {
            match RobotsFile::read(path) {
                Ok(file) if file.robots.len() < robots as usize => found.push(Finding::error(
                    "robots-file",
                    format!("{} names {} robots, the plan {robots}", path.display(), file.robots.len()),
                    "add the missing robots to the robots file, or plan fewer (--robots)",
                )),
                Ok(file) => {
                    let gateways: Vec<_> = file.robots.iter().map(|r| (r.id, r.gateway)).collect();
                    found.extend(host::udp_ports(&gateways));
                }
                Err(e) => found.push(Finding::error("udp-ports", e.to_string(), "fix agents.robots_file")),
            }
        }
    }
    found.push(host::iceoryx2_leftovers());
    if let (MocapSource::Natnet, Some(natnet)) = (config.mocap.source, &config.mocap.natnet) {
        found.push(host::natnet(&natnet.client, Duration::from_millis(args.timeout_ms)));
    }
    if let Some(endpoint) = &args.connect {
        check_endpoints("--connect", std::slice::from_ref(endpoint))?;
        let swarm = args.swarm.as_ref().or(config.swarm.as_ref()).map(|s| check_swarm(s)).transpose()?;
        let reach = doctor::zenoh::Reach {
            endpoint: endpoint.clone(),
            zenoh_config: args.zenoh_config.clone(),
            swarm,
            timeout: Duration::from_millis(args.timeout_ms),
            clocks: bycoms_launch::setup::clock_limits(&config),
        };
        found.extend(doctor::zenoh::check(&reach));
    }
    Ok(found)
}

/// What `launch` says of the config at `path` for a plan of `robots`
/// robots: the one validation a launch makes (issue 49: a NaN arena
/// origin passed the doctor, and the launch then waited 600 s for a
/// placement that could never happen).
fn config_refused(path: &std::path::Path, config: &LaunchConfig, robots: u32) -> Option<Finding> {
    let planned = LaunchConfig { robots, ..config.clone() };
    let e = planned.validate().err()?;
    Some(Finding::error(
        "config",
        format!("launch refuses {}: {e:#}", path.display()),
        "fix the key it names (deploy/launch.toml documents every key)",
    ))
}

/// Removes what dead swarms left on this host's bus (`--clean`).
fn clean() -> Result<()> {
    use bycoms_protocol::bus::ipc::cleanup_stale_resources;
    bycoms_runtime::cli::quiet_iceoryx2();
    let report = cleanup_stale_resources::<iceoryx2::service::ipc::Service>()?;
    let locks = bycoms_launch::swarm_lock::sweep(&bycoms_launch::swarm_lock::lock_dir());
    bycoms_runtime::logging::status_line(&cleaned(report.cleaned, report.failed, locks as u64));
    Ok(())
}

/// What `--clean` removed, in words.
fn cleaned(nodes: u64, failed: u64, locks: u64) -> String {
    format!(
        "doctor: removed the files of {} ({failed} could not be removed) and {}",
        count(nodes, "dead iceoryx2 node"),
        count(locks, "unheld swarm lock")
    )
}

pub fn run(args: Args) -> Result<i32> {
    if args.clean {
        clean()?;
    }
    let found = findings(&args, SystemTime::now())?;
    if args.json {
        bycoms_runtime::outln!("{}", serde_json::to_string_pretty(&doctor::json(&found))?)?;
    } else {
        for line in doctor::text(&found) {
            bycoms_runtime::outln!("{line}")?;
        }
    }
    Ok(if doctor::any_error(&found) { exit::ERROR } else { exit::SUCCESS })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::doctor::Level;

    /// The doctor's arguments for `config` alone, with a short timeout.
    fn args_of(config: PathBuf) -> Args {
        Args {
            config: Some(config),
            robots: None,
            certs: None,
            json: false,
            clean: false,
            connect: None,
            zenoh_config: None,
            swarm: None,
            timeout_ms: 100,
        }
    }

    #[test]
    fn what_clean_removed_is_counted_in_the_singular_and_plural() {
        assert_eq!(
            cleaned(1, 0, 1),
            "doctor: removed the files of 1 dead iceoryx2 node (0 could not be removed) and 1 unheld swarm lock"
        );
        assert_eq!(
            cleaned(3, 1, 0),
            "doctor: removed the files of 3 dead iceoryx2 nodes (1 could not be removed) and 0 unheld swarm locks"
        );
    }

    /// A lab config's robots file is read for the gateways' ports: one
    /// held by this test is an error naming its robot.
    #[test]
    fn the_configs_robots_file_gives_the_gateway_ports_checked() {
        let taken = std::net::UdpSocket::bind("127.0.0.1:0").expect("bind");
        let port = taken.local_addr().expect("addr").port();
        // Robot 1's gateway port: free a moment ago (a robots file's ports are fixed, never 0).
        let free =
            std::net::UdpSocket::bind("127.0.0.1:0").and_then(|s| s.local_addr()).expect("free").port();
        let dir = tempfile::tempdir().expect("temp dir");
        let robots = format!(
            "[[robot]]\nid = 1\naddress = \"127.0.0.1:47101\"\ngateway = \"127.0.0.1:{free}\"\nkey_file = \"k1\"\n\n\
             [[robot]]\nid = 2\naddress = \"127.0.0.1:47102\"\ngateway = \"127.0.0.1:{port}\"\nkey_file = \"k2\"\n"
        );
        std::fs::write(dir.path().join("robots.toml"), robots).expect("robots file");
        let config = dir.path().join("launch.toml");
        std::fs::write(&config, "robots = 2\n[agents]\nsource = \"real\"\nrobots_file = \"robots.toml\"\n")
            .expect("config");
        let args = args_of(config);
        let found = findings(&args, SystemTime::now()).expect("findings");
        let ports: Vec<_> = found.iter().filter(|f| f.check == "udp-ports").collect();
        assert_eq!(ports.len(), 1, "{found:#?}");
        assert_eq!(ports[0].level, Level::Error);
        assert!(
            ports[0].cause.contains(&format!("robot 2's gateway cannot bind 127.0.0.1:{port}")),
            "{:?}",
            ports[0]
        );
        let more = findings(&Args { robots: Some(3), ..args.clone() }, SystemTime::now()).expect("findings");
        let short: Vec<_> = more.iter().filter(|f| f.check == "robots-file").collect();
        assert_eq!(short.len(), 1, "{more:#?}");
        assert!(short[0].cause.ends_with("names 2 robots, the plan 3"), "{:?}", short[0]);
        let usage = findings(&Args { robots: Some(1001), ..args }, SystemTime::now()).expect_err("too many");
        assert_eq!(exit::code_of(&usage), exit::USAGE);
    }

    /// Issue 49: a config the launch refuses (a NaN arena origin) passed
    /// the doctor. The doctor reports what the launch says, naming the key.
    #[test]
    fn a_config_the_launch_refuses_is_an_error_naming_the_key() {
        let dir = tempfile::tempdir().expect("temp dir");
        let lab = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy/lab");
        let text = std::fs::read_to_string(lab.join("launch-natnet.toml")).expect("the NatNet lab config");
        let origin = "origin = [0.0, 0.0, 0.0]\n";
        assert!(text.contains(origin), "the lab config sets the arena's origin");
        // The robots file stays where the lab's config names it, beside it.
        let robots = format!("robots_file = {:?}", lab.join("robots.toml").display().to_string());
        let text = text.replace("robots_file = \"robots.toml\"", &robots);
        let config = dir.path().join("launch.toml");
        std::fs::write(&config, text.replace(origin, "origin = [nan, 1e308, -inf]\n")).expect("config");
        let args = args_of(config.clone());
        let found = findings(&args, SystemTime::now()).expect("findings");
        let said: Vec<_> = found.iter().filter(|f| f.check == "config").collect();
        assert_eq!(said.len(), 1, "{found:#?}");
        assert_eq!(said[0].level, Level::Error);
        let launch =
            format!("{:#}", LaunchConfig::load(&config).and_then(|c| c.validate()).expect_err("refused"));
        assert_eq!(launch, "mocap.natnet.arena.origin[0] must be a finite number, got NaN");
        assert!(said[0].cause.ends_with(&launch), "the launch's words: {:?}", said[0]);
    }

    /// Without --certs, the certificates are those beside the config's
    /// zenoh config (where `orchestrator certs` put both).
    #[test]
    fn the_certs_beside_the_configs_zenoh_config_are_checked() {
        let dir = tempfile::tempdir().expect("temp dir");
        let certs = dir.path().join("certs");
        let plan = crate::certs::Plan {
            robots: 1,
            hosts: vec!["localhost".into()],
            listen: "quic/127.0.0.1:7447".into(),
            connect: "quic/localhost:7447".into(),
            out: certs,
            force: false,
        };
        crate::certs::generate(&plan).expect("certs");
        let config = dir.path().join("launch.toml");
        let toml = "robots = 2\n[transport]\nkind = \"zenoh\"\nzenoh_config = \"certs/orchestrator.json5\"\n";
        std::fs::write(&config, toml).expect("config");
        let args = Args {
            config: Some(config),
            robots: None,
            certs: None,
            json: true,
            clean: false,
            connect: None,
            zenoh_config: None,
            swarm: None,
            timeout_ms: 100,
        };
        let found = findings(&args, SystemTime::now()).expect("findings");
        let missing: Vec<_> = found.iter().filter(|f| f.level == Level::Error).collect();
        assert_eq!(missing.len(), 2, "robot 2 has no certificate and no ACL entry: {found:#?}");
        assert!(missing.iter().all(|f| f.fix.contains("--add-robots --robots 2")), "{missing:#?}");
    }
}
