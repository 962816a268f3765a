//! Ending a launch in order, however it ended, and its summary.
//!
//! Why always the same path: a won run, a time limit, Ctrl-C and an error
//! all leave agent processes and an open recording behind. Each ends the
//! same way: `Shutdown` to every agent still running, a grace period, a kill
//! for the ones that did not exit, the recording finished (summary and
//! footer written), then the summary built from the slots.

use super::config::Clock;
use super::engine::{Launch, SlotState};
use super::summary::{Outcome, RealtimeReport, RecordingSummary, RobotEnd, RobotSummary, Summary};
use bycoms_protocol::msg::ToAgent;
use bycoms_sim::Vec2;
use std::time::Duration;

impl Launch {
    /// Shuts every agent down, finishes the recording, builds the summary.
    pub fn finish(mut self, result: anyhow::Result<Outcome>) -> Summary {
        let (mut outcome, mut error) = match result {
            Ok(o) => (o, None),
            Err(e) => (Outcome::Error, Some(format!("{e:#}"))),
        };
        if let Some(e) = self.fatal.take() {
            outcome = Outcome::Error;
            error.get_or_insert(format!("{e:#}"));
        }
        if let Some((id, watch)) = self.watch.take() {
            let steps = watch.active_steps();
            self.spent += steps;
            if let Some(slot) = self.slot(id) {
                slot.state = SlotState::Unfinished;
                slot.steps = steps;
                slot.last_pose = Some(watch.last());
            }
        }
        let running: Vec<u32> =
            self.slots.iter().filter(|s| self.agents.is_running(s.id)).map(|s| s.id).collect();
        for id in running {
            // A failure to send only means it is killed after the grace period.
            let _ = self.ports.send(id, &ToAgent::Shutdown);
        }
        let killed = self.agents.wind_down(Duration::from_secs_f64(self.cfg.supervision.shutdown_grace));
        // Killed agents leave their iceoryx2 nodes behind: remove them now
        // rather than at the next launch.
        self.ports.cleanup_dead_nodes();
        if !killed.is_empty() {
            let ids: Vec<String> = killed.iter().map(u32::to_string).collect();
            let whose = if ids.len() == 1 { "robot" } else { "robots" };
            // Remote agents cannot be killed from here: they are dropped.
            let fate = match self.agents.kind() {
                "remote" => "still alive on their hosts, dropped from the launch",
                _ => "killed",
            };
            self.progress.event(&format!(
                "the agents of {whose} {} did not exit after Shutdown: {fate}",
                ids.join(", ")
            ));
        }
        self.redraw();
        self.progress.finish();
        let robots: Vec<RobotSummary> = self.slots.iter().map(robot_summary).collect();
        let beacons = self
            .slots
            .iter()
            .filter(|s| matches!(s.state, SlotState::Stuck | SlotState::Died))
            .filter_map(|s| s.last_pose.map(|p| Vec2::new(p.x, p.y)))
            .collect();
        let dt = self.template.run_config().kinematics.dt;
        let wall_s = self.started.elapsed().as_secs_f64();
        let realtime = (self.cfg.clock == Clock::Realtime).then(|| {
            let (seen, missed) =
                self.slots.iter().fold((0, 0), |(s, m), slot| (s + slot.frames.seen, m + slot.frames.missed));
            RealtimeReport::new(self.cfg.speed, seen, missed)
        });
        if let Some(rt) = realtime.as_ref().filter(|rt| !rt.faithful) {
            tracing::warn!(
                missed_periods = rt.missed_periods,
                periods = rt.periods,
                achieved_speed = rt.achieved_speed,
                "the agents could not keep up with {}× real time: {} of {} periods missed, \
                 achieved {:.1}×; the run is not faithful (lower --speed)",
                self.cfg.speed,
                rt.missed_periods,
                rt.periods + rt.missed_periods,
                rt.achieved_speed
            );
        }
        let mut summary = Summary {
            swarm: self.template.swarm.clone(),
            terrain: self.world.name.clone(),
            eps: self.cfg.eps,
            noise: self.cfg.noise,
            seed: self.cfg.seed,
            clock: self.cfg.clock.as_str().into(),
            speed: (self.cfg.clock == Clock::Realtime).then_some(self.cfg.speed),
            success: outcome == Outcome::Arrived,
            outcome,
            error,
            robots_used: robots.iter().filter(|r| r.deployed_tick.is_some()).count() as u32,
            steps: self.spent,
            time_s: self.template.run_config().kinematics.time_of(self.spent),
            ticks: self.ticks,
            wall_s,
            sim_speed: match self.cfg.clock {
                Clock::Lockstep if wall_s > 0.0 => self.ticks as f64 * dt / wall_s,
                Clock::Lockstep => 0.0,
                Clock::Realtime => realtime.as_ref().map_or(self.cfg.speed, |rt| rt.achieved_speed),
            },
            realtime,
            beacons,
            robots,
            bad_traffic: self.ports.traffic,
            recording: None,
            picture: None,
            transport: self.cfg.transport.kind.as_str().into(),
            endpoints: std::mem::take(&mut self.endpoints),
            first_moving_s: self.first_moving.map(|d| d.as_secs_f64()),
            resends: self.resends,
        };
        if let Some(trace) = self.ports.recording.take_trace() {
            summary.picture = self.picture(&trace, &summary);
        }
        if self.ports.recording.is_on() {
            let topic = format!("bycoms/{}/summary", summary.swarm);
            self.ports.recording.json(&topic, super::events::SUMMARY_SCHEMA, &summary);
        }
        let recording = std::mem::replace(&mut self.ports.recording, super::recording::Recording::off());
        match recording.finish() {
            Ok(Some(rec)) => {
                summary.recording = Some(RecordingSummary {
                    path: rec.path.display().to_string(),
                    messages: rec.messages,
                    counts: rec.counts,
                });
            }
            Ok(None) => {}
            Err(e) => {
                summary.outcome = Outcome::Error;
                summary.success = false;
                summary.error.get_or_insert(format!("recording failed: {e}"));
            }
        }
        summary
    }
}

impl Launch {
    /// The snapshot picture of the run from what crossed the bus (`--svg`).
    fn picture(&self, trace: &crate::draw::trace::Trace, summary: &Summary) -> Option<String> {
        let heading = format!(
            "{} — ε = {}, {} launch, swarm {}",
            summary.terrain, summary.eps, summary.clock, summary.swarm
        );
        let dt = self.template.run_config().kinematics.dt;
        match bycoms_sim::terrain::parse(&self.world.terrain_text) {
            Ok(mut terrain) => {
                terrain.set_start(self.world.start);
                terrain.set_goal(self.world.goal);
                Some(crate::draw::trace::picture(&terrain, trace, self.cfg.eps, dt, &heading))
            }
            Err(e) => {
                tracing::error!("no picture: the launch's terrain does not parse: {e}");
                None
            }
        }
    }
}

fn robot_summary(s: &super::engine::Slot) -> RobotSummary {
    let end = match s.state {
        SlotState::Stuck => RobotEnd::Stuck,
        SlotState::Arrived => RobotEnd::Arrived,
        SlotState::Died => RobotEnd::Died,
        SlotState::Unfinished | SlotState::Moving => RobotEnd::Moving,
        _ => RobotEnd::NotDeployed,
    };
    let deployed = end != RobotEnd::NotDeployed;
    let pose = s.last_pose.filter(|_| deployed);
    RobotSummary {
        id: s.id,
        pid: s.pid,
        end,
        x: pose.map(|p| p.x),
        y: pose.map(|p| p.y),
        x_bits: pose.map(|p| p.x.to_bits()),
        y_bits: pose.map(|p| p.y.to_bits()),
        steps: s.steps,
        deployed_tick: s.deployed_tick.filter(|_| deployed),
        decided_tick: s.decided_tick,
        mode: s.mode,
        gate_reaction_us: s.reaction.map(|d| d.as_micros() as u64),
        death: s.death.clone(),
        outages: s.outages.clone(),
    }
}
