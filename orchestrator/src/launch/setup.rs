//! The launch core's [`Setup`] from the config and the seams' properties.
//!
//! Why apart from the core: the core knows no config file and no kind of
//! agent, transport or mocap; it gets numbers and properties. Resolving
//! them (which placement settings apply, the budget in steps, the wall
//! period) happens once, here.

use super::agents::AgentSource;
use super::config::{Clock, LaunchConfig};
use super::core::{AgentTraits, Setup};
use super::gate::GateParams;
use super::poses::PoseSource;
use super::World;
use crate::mocap::MocapSource;
use bycoms_sim::agent_process::AgentArgs;
use bycoms_sim::Vec2;
use std::time::{SystemTime, UNIX_EPOCH};

/// The core's setup for a launch of `cfg` in `world`.
pub fn setup(
    cfg: &LaunchConfig,
    world: &World,
    template: &AgentArgs,
    agents: &dyn AgentSource,
    poses: &dyn PoseSource,
) -> Setup {
    let mut run = template.run_config();
    run.time_limit = cfg.time_limit;
    let placement = agents.needs_placement().then(|| {
        let natnet = cfg.mocap.natnet.as_ref().filter(|_| cfg.mocap.source == MocapSource::Natnet);
        natnet.map_or(cfg.agents.placement, |n| n.placement)
    });
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
        link_grace_s: cfg.supervision.link_grace,
        register_timeout_s: cfg.supervision.register_timeout,
        agents: AgentTraits {
            kind: agents.kind().to_string(),
            all_at_once: agents.all_at_once(),
            stop_when_stuck: agents.stop_when_stuck(),
            start_hint: agents.start_hint().to_string(),
            placement,
            forward_poses: !poses.on_the_bus() && agents.wants_poses(),
        },
        unix_base_ms: SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_millis() as u64).unwrap_or(0),
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
