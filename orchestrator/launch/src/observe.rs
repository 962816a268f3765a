//! Observers of a launch: who else sees the run as the gate sees it.
//!
//! Why a tap and not a second pass over the recording: a live view must see
//! the run while it happens, and it must see exactly what the gate judged —
//! the world the launch was given, every agent report, every decoded pose of a robot on its own
//! topic, every gate event — at the very place they are recorded
//! ([`super::ports::Ports`]), so the recording and what a viewer shows
//! cannot disagree. Observers must not block: the launch loop calls them
//! inline (the live view only queues the message for its own threads).
//!
//! The Foxglove scene is not computed by observers: the run has one
//! [`SharedScene`], fed once per message where the message is recorded
//! (`launch::recording`), and observers get its output ([`Observer::scene`])
//! and the scene itself (for snapshots to late viewers). That output is the
//! live view's one stream: its Foxglove channels and its page's state are
//! both folded from it. The typed calls ([`Observer::pose`],
//! [`Observer::gate`], [`Observer::report`]) come at once, where the
//! message is received or sent, for an observer that must not wait for the
//! recording's hand-over ([`super::recording::HAND_OVER_EVERY`]): the ROS 2
//! output, whose pose latency is a target (`benches/ros2_latency.rs`).
//!
//! The live view itself (`launch --serve`, `bycoms_orchestrator::live`) sits above the
//! launch (it reads the launch's world, config and summary): the launch
//! knows it only as a [`View`] that a [`Serve`] function starts, handed in
//! by the command (ARCHITECTURE.md, "Crates of the orchestrator").

use super::config::LaunchConfig;
use super::{Summary, World};
use crate::core::SlotState;
use bycoms_protocol::msg::{FromAgent, GateEvent, Pose};
use bycoms_record::scene::{Out, SharedScene};
use bycoms_sim::Vec2;

/// Something that watches a launch; every method has an empty default.
pub trait Observer: Send {
    /// The run's swarm name, world, settings and scene, once, before any
    /// agent starts.
    fn world(&mut self, _swarm: &str, _world: &World, _cfg: &LaunchConfig, _scene: Option<&SharedScene>) {}
    /// What the run's scene produced for the messages since the last call.
    fn scene(&mut self, _outs: &[Out]) {}
    /// An agent's report (registration, heartbeat, status, tick done).
    fn report(&mut self, _report: &FromAgent) {}
    /// A robot's pose, as motion capture reported it on its own topic.
    fn pose(&mut self, _pose: &Pose) {}
    /// A gate decision, as published.
    fn gate(&mut self, _event: &GateEvent) {}
    /// Robot `robot`'s beacon stands at `at` (the launch core's beacon
    /// table changed: a new beacon, or one that crept on).
    fn beacon(&mut self, _robot: u32, _at: Vec2) {}
    /// Robot `robot`'s state changed to `state` (the launch core's slot).
    fn state(&mut self, _robot: u32, _state: SlotState) {}
}

/// A live view of the run (`launch --serve ADDR`): started once the
/// launch's ports are open, fed as an [`Observer`] for the whole run, told
/// the summary at the end.
pub trait View {
    /// Where a person points a browser or Foxglove, in one line.
    fn banner(&self) -> String;
    /// The observer that feeds the view, tapped like any other.
    fn observer(&self) -> Box<dyn Observer>;
    /// The run ended with `summary`: the view shows it, then stops serving.
    fn end(self: Box<Self>, summary: &Summary);
}

/// Starts a live view on an address (`bycoms_orchestrator::live::serve`).
pub type Serve = fn(&str) -> anyhow::Result<Box<dyn View>>;
