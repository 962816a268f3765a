//! A whole launch in one process: the in-memory bus (`transport.kind =
//! "memory"`), its agents as threads (`orchestrator/launch/src/agents/threads.rs`), the real
//! driver, ports and core — no shared memory, no sockets, no processes.
//! Lockstep gives `simulate`'s result bit for bit, as the launches over
//! iceoryx2 and zenoh do (`tests/tests/parity.rs`).

use bycoms_launch::config::Transport;
use bycoms_launch::{self as launch, Clock, LaunchConfig, Outcome, RobotEnd};
use bycoms_orchestrator::commands::launch::world;
use bycoms_sim::terrain::parse;

fn memory_launch(clock: Clock) -> (LaunchConfig, launch::Summary) {
    let mut cfg = LaunchConfig { robots: 3, clock, speed: 50.0, ..Default::default() };
    cfg.transport.kind = Transport::Memory;
    cfg.swarm = Some(format!("memory-{}-{}", std::process::id(), clock.as_str()));
    let world = world(&cfg).expect("the default scenario");
    // Agents are threads: no executable is started.
    let agent = launch::agent_command(Some(std::path::Path::new("/nonexistent")), None).expect("command");
    let summary = launch::run(cfg.clone(), world, agent).expect("the launch runs");
    (cfg, summary)
}

#[test]
fn a_lockstep_launch_over_the_memory_bus_equals_simulate_bit_for_bit() {
    let (cfg, summary) = memory_launch(Clock::Lockstep);
    let w = world(&cfg).expect("world");
    let terrain = parse(&w.terrain_text).expect("terrain");
    let mut run = cfg.run_config();
    run.max_robots = Some(cfg.robots);
    let expected = bycoms_sim::run(&terrain, &run);
    assert_eq!(summary.error, None);
    let outcome = match expected.outcome {
        bycoms_sim::RunOutcome::Arrived => Outcome::Arrived,
        bycoms_sim::RunOutcome::TimeLimit => Outcome::TimeLimit,
        bycoms_sim::RunOutcome::RobotsExhausted => Outcome::RobotsExhausted,
    };
    assert_eq!(summary.outcome, outcome);
    assert_eq!(summary.steps, expected.steps);
    for r in &expected.robots {
        let got = &summary.robots[r.id as usize - 1];
        let want = match r.end {
            bycoms_sim::runner::RobotRunEnd::Stuck => RobotEnd::Stuck,
            bycoms_sim::runner::RobotRunEnd::Arrived => RobotEnd::Arrived,
            bycoms_sim::runner::RobotRunEnd::Moving => RobotEnd::Moving,
        };
        assert_eq!(got.end, want, "robot {}", r.id);
        assert_eq!(got.steps, r.steps, "robot {}", r.id);
        assert_eq!(
            (got.x_bits, got.y_bits),
            (Some(r.position.x.to_bits()), Some(r.position.y.to_bits())),
            "robot {}",
            r.id
        );
    }
}

#[test]
fn a_real_time_launch_over_the_memory_bus_ends_with_every_robot_judged() {
    let (_, summary) = memory_launch(Clock::Realtime);
    assert_eq!(summary.error, None);
    assert!(matches!(summary.outcome, Outcome::Arrived | Outcome::RobotsExhausted), "{:?}", summary.outcome);
    assert!(summary.robots.iter().all(|r| r.end != RobotEnd::Moving), "{:?}", summary.robots);
}
