//! The launch core's [`Setup`] from the config and the seams' properties.
//!
//! Why apart from the core: the core knows no config file and no kind of
//! agent, transport or mocap; it gets numbers and properties. Resolving
//! them (which placement settings apply, the budget in steps, the wall
//! period) happens once, here.

use super::agents::remote::QUIET_HEARTBEATS;
use super::agents::{AgentProperties, AgentSource, Joining};
use super::config::{Clock, LaunchConfig};
use super::core::{
    least_failsafe_grace_ms, AgentTraits, ClockLimits, Commands, Members, Setup, Starts, Supervision,
};
use super::poses::PoseSource;
use super::World;
use bycoms_runtime::failsafe::{FailsafeArgs, DEFAULT_GRACE_S};
use bycoms_runtime::BusArgs;
use bycoms_sim::Vec2;
use bycoms_sim_agent::RunSettings;
use bycoms_study::gate::GateParams;
use std::time::Duration;
use std::time::{SystemTime, UNIX_EPOCH};

/// What the seams say of themselves that the core's setup needs: the
/// agent source's properties and whether the pose source is on the bus, as
/// plain values (so the launch harness declares the seams it simulates,
/// with the sources' own `properties` functions, and gets the very setup a
/// launch with them gets).
#[derive(Clone, Debug, PartialEq)]
pub struct Seams {
    /// [`AgentSource::properties`].
    pub agents: AgentProperties,
    /// [`PoseSource::on_the_bus`].
    pub poses_on_the_bus: bool,
}

impl Seams {
    /// What `agents` and `poses` say of themselves.
    pub fn of(agents: &dyn AgentSource, poses: &dyn PoseSource) -> Self {
        Self { agents: agents.properties(), poses_on_the_bus: poses.on_the_bus() }
    }
}

/// The core's setup for a launch of `cfg` in `world`.
pub fn setup(
    cfg: &LaunchConfig,
    world: &World,
    settings: &RunSettings,
    agents: &dyn AgentSource,
    poses: &dyn PoseSource,
) -> Setup {
    let unix_ms = SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_millis() as u64).unwrap_or(0);
    setup_of(cfg, world, settings, &Seams::of(agents, poses), unix_ms)
}

/// The core's setup for a launch of `cfg` in `world` with seams `seams`,
/// started at `unix_base_ms` (ms since the Unix epoch).
pub fn setup_of(
    cfg: &LaunchConfig,
    world: &World,
    settings: &RunSettings,
    seams: &Seams,
    unix_base_ms: u64,
) -> Setup {
    let mut run = settings.run_config();
    run.time_limit = cfg.time_limit;
    let agents = &seams.agents;
    let placement = agents.needs_placement.then_some(cfg.placement);
    Setup {
        robots: cfg.robots,
        lockstep: cfg.clock == Clock::Lockstep,
        params: gate_params(cfg, world.goal),
        step_limit: run.step_limit(),
        wall_period_us: cfg.wall_period().as_micros() as u64,
        speed: cfg.speed,
        tick_timeout_us: (cfg.supervision.tick_timeout * 1e6) as u64,
        on_death: cfg.gate.on_agent_death,
        missing: cfg.supervision.missing,
        prespawn: cfg.gate.prespawn,
        start: world.start,
        goal: world.goal,
        max_speed: cfg.gate.max_speed,
        register_timeout_s: cfg.supervision.register_timeout,
        agents: AgentTraits {
            kind: agents.kind.to_string(),
            all_at_once: agents.all_at_once,
            stop_when_stuck: agents.stop_when_stuck,
            start_hint: agents.start_hint.to_string(),
            placement,
            forward_poses: !seams.poses_on_the_bus && agents.wants_poses,
            beacons: agents.senses_beacons,
        },
        unix_base_ms,
        settings: run_settings(cfg, world).fingerprint(),
        supervision: supervision(cfg, agents.held_when_unreachable, agents.robot_link_grace),
        clocks: clock_limits(cfg),
        // Injected faults lose and repeat answers: then ticks are re-sent.
        commands: Commands {
            ticks_at_once: agents.ticks_at_once,
            kept: agents.keeps_commands && !cfg.faults.is_on(),
        },
        starts: Starts { ahead: if cfg.clock == Clock::Lockstep { STARTS_AHEAD } else { 1 } },
        members: Members { simulated: agents.simulated.clone(), sim_speed: cfg.sim_speed },
    }
}

/// Lockstep: agents started ahead of the robot that moves
/// ([`Starts::ahead`]). Why 4: a crowd's robot may be judged 2 to 3 ms of
/// wall time after it was deployed, and an agent process takes 3 to 6 ms
/// to register here; `launch --robots 300` on `bench crowd`'s terrain
/// spent 1.0 of its 1.8 s waiting for the next agent with one ahead, and
/// took 14 % less wall time with three (four leaves room for a slower
/// machine). Every robot's agent is started anyway before its turn, so
/// this only starts them sooner; the run is the same (lockstep results do
/// not depend on when agents register). Real time keeps one: a robot moves
/// for seconds there.
pub const STARTS_AHEAD: u32 = 4;

/// The limits of the agents' clock offsets: the config's, in µs.
pub fn clock_limits(cfg: &LaunchConfig) -> ClockLimits {
    let sup = &cfg.supervision;
    ClockLimits { warn_us: micros(sup.clock_warn), limit_us: micros(sup.clock_limit) }
}

/// A span of the config, s, in whole µs (rounded): the one conversion of
/// the core's settings.
fn micros(s: f64) -> u64 {
    (s * 1e6).round() as u64
}

/// The supervision timers' settings: the config's timeouts, with the link
/// grace and the quiet rule for agents that can come back (`held`,
/// [`AgentProperties::held_when_unreachable`]) and the robot-link grace for
/// sources of real robots ([`AgentProperties::robot_link_grace`]).
pub fn supervision(cfg: &LaunchConfig, held: bool, robot_link_grace: Option<Duration>) -> Supervision {
    let sup = &cfg.supervision;
    Supervision {
        register_timeout_us: micros(sup.register_timeout),
        heartbeat_timeout_us: micros(sup.heartbeat_timeout),
        unreachable_grace_us: micros(sup.unreachable_grace),
        held,
        quiet_us: if held { micros(sup.heartbeat_interval * f64::from(QUIET_HEARTBEATS)) } else { 0 },
        robot_link_grace_us: robot_link_grace.map(|g| g.as_micros() as u64),
    }
}

/// The run's settings: the one value the launch derives from its config
/// (ε, noise, seed, clock, speed, swarm size, heartbeat) and the terrain's
/// text. The agent sources are given them with how an agent joins
/// ([`Joining`]); a spawned agent gets them as flags
/// ([`Joining::sim_agent`], [`RunSettings::onto`]) and builds the same
/// value back; agents started elsewhere (over zenoh) are served their
/// encoding. One value, so one fingerprint.
pub fn run_settings(cfg: &LaunchConfig, world: &World) -> RunSettings {
    let (terrain, cell, robot_speed) = match &world.simulated {
        Some(arena) => (arena.terrain_text.clone(), arena.cell, arena.robot_speed),
        None => (world.terrain_text.clone(), 1.0, 1.0),
    };
    RunSettings {
        terrain,
        cell,
        robot_speed,
        eps: cfg.eps,
        noise: cfg.noise,
        seed: cfg.seed,
        clock: cfg.clock,
        speed: RunSettings::speed_of(cfg.clock, cfg.speed * cfg.sim_speed),
        swarm_size: cfg.robots,
        heartbeat_ms: heartbeat_ms(cfg),
    }
}

/// The gate's motion test for `cfg` with the goal at `goal`.
pub fn gate_params(cfg: &LaunchConfig, goal: Vec2) -> GateParams {
    GateParams {
        goal,
        goal_radius: cfg.goal_radius,
        stop_speed: cfg.gate.stop_speed,
        stop_turn_rate: cfg.gate.stop_turn_rate,
        dwell_us: (cfg.gate.dwell * 1e6).round() as u64,
        period_us: cfg.dt_us(),
    }
}

/// How every agent of this launch joins it: the bus and where the
/// orchestrator listens, and a failsafe grace no shorter than the launch's
/// unreachable grace. An agent that lost the orchestrator for longer than
/// its grace stops its robot and exits; with a shorter grace than the
/// launch's, a cut the launch would ride out (holding the robot, then
/// resuming) would cost the robot, and the core refuses such an agent.
pub fn joining(cfg: &LaunchConfig, swarm: String, endpoints: Vec<String>) -> Joining {
    Joining {
        swarm,
        parent_pid: Some(std::process::id() as i32),
        bus: BusArgs { transport: cfg.transport.kind, connect: endpoints, zenoh_config: None },
        failsafe: FailsafeArgs {
            grace_s: failsafe_grace_s(cfg.supervision.unreachable_grace),
            ..FailsafeArgs::default()
        },
        parked_heartbeat_ms: parked_heartbeat_ms(cfg),
    }
}

/// The failsafe grace the launch gives its agents, s, for an unreachable
/// grace of `grace_s`: the core's least ([`least_failsafe_grace_ms`], the
/// one decider), in whole ms so that the agent reads back no less
/// (`Failsafe::grace_ms` truncates: 2.0005 s would come back 2000 ms, under
/// the 2001 the core asks), and never under the agents' own default.
fn failsafe_grace_s(grace_s: f64) -> f64 {
    (f64::from(least_failsafe_grace_ms(micros(grace_s))) / 1000.0).max(DEFAULT_GRACE_S)
}

/// The agents' heartbeat period, ms.
fn heartbeat_ms(cfg: &LaunchConfig) -> u64 {
    (cfg.supervision.heartbeat_interval * 1000.0).round().max(1.0) as u64
}

/// A parked robot's agent's heartbeat period, ms: a quarter of the
/// heartbeat timeout (four beats per timeout, as the default 0.1 s beat
/// has twenty), at most 1 s, never faster than the heartbeat. Such a robot
/// gets no tick and will not move again; its agent only says it is alive.
fn parked_heartbeat_ms(cfg: &LaunchConfig) -> u64 {
    let quarter = (cfg.supervision.heartbeat_timeout * 1000.0 / 4.0).floor() as u64;
    quarter.min(1000).max(heartbeat_ms(cfg))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parked_agents_beat_four_times_per_heartbeat_timeout_at_most_once_a_second() {
        let parked = |interval: f64, timeout: f64| {
            let mut cfg = LaunchConfig::default();
            (cfg.supervision.heartbeat_interval, cfg.supervision.heartbeat_timeout) = (interval, timeout);
            joining(&cfg, "s".into(), Vec::new()).parked_heartbeat_ms
        };
        assert_eq!(parked(0.1, 2.0), 500, "the defaults");
        assert_eq!(parked(0.1, 10.0), 1000, "at most 1 s");
        assert_eq!(parked(0.1, 0.3), 100, "never faster than the heartbeat");
        let cfg = LaunchConfig::default();
        let flags = joining(&cfg, "s".into(), Vec::new())
            .sim_agent(1, &run_settings(&cfg, &World::tiny()))
            .to_flags();
        assert!(flags.windows(2).any(|w| w == ["--parked-heartbeat-ms", "500"]), "{flags:?}");
    }

    #[test]
    fn started_agents_hold_on_at_least_as_long_as_the_launch_holds_them() {
        let mut cfg = LaunchConfig::default();
        let grace = |cfg: &LaunchConfig| joining(cfg, "s".into(), Vec::new()).failsafe.grace_s;
        assert_eq!(grace(&cfg), DEFAULT_GRACE_S);
        cfg.supervision.unreachable_grace = 5.0;
        assert_eq!(grace(&cfg), 5.0);
        cfg.supervision.unreachable_grace = 0.0;
        assert_eq!(grace(&cfg), DEFAULT_GRACE_S);
        // Sub-millisecond: the agent's failsafe, read back as it does,
        // is what the core asks of it (it truncates to ms, the core rounds up).
        for g in [2.0005, 3.0001, 7.123_456] {
            cfg.supervision.unreachable_grace = g;
            let read_back = FailsafeArgs { grace_s: grace(&cfg), ..FailsafeArgs::default() };
            let ms = read_back.failsafe().expect("a usable grace").grace_ms();
            assert!(ms >= least_failsafe_grace_ms(micros(g)), "{g} s: the agent says {ms} ms");
        }
        let flags = joining(&cfg, "s".into(), Vec::new())
            .sim_agent(1, &run_settings(&cfg, &World::tiny()))
            .to_flags();
        assert!(flags.windows(2).any(|w| w[0] == "--orchestrator-grace"), "{flags:?}");
    }

    #[test]
    fn the_launch_s_fingerprint_is_what_its_spawned_agents_compute() {
        use bycoms_sim_agent::options::{parse_from, SimAgentRun};
        let world = World::tiny();
        let mut cfg =
            LaunchConfig { eps: 0.1 + 0.2, seed: 7, noise: true, speed: 2.5, ..LaunchConfig::default() };
        cfg.robots = 5;
        let launch = run_settings(&cfg, &world);
        // Robot 3 as spawned: how it joins, the settings, the terrain on stdin.
        let args = joining(&cfg, "s".into(), Vec::new()).sim_agent(3, &launch);
        let flags = std::iter::once("sim-agent".to_string()).chain(args.to_flags());
        let SimAgentRun::Robot(parsed) = parse_from(flags).expect("the flags parse").1 else {
            panic!("a robot's flags")
        };
        assert_eq!(parsed, args, "sim-agent reads what the launch means");
        let agent = RunSettings::of(&parsed, world.terrain_text.clone()).expect("settings");
        assert_eq!(agent, launch);
        assert_eq!(agent.fingerprint(), launch.fingerprint());
        assert_ne!(launch.fingerprint(), 0);
        assert_eq!(launch.swarm_size, 5);
        assert_eq!(launch.eps.to_bits(), (0.1f64 + 0.2).to_bits());
    }
}
