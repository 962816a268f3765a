//! One robot's bookkeeping in the launch core.
//!
//! Why a plain record: every decision about robot `k` (is it ready, may it
//! be deployed, is it a beacon) reads these fields, and the summary is built
//! from them at the end. Only the core writes them; the shells read them
//! through [`super::LaunchCore::slots`].

use super::ClockReading;
use crate::records::{Death, Outage};
use crate::Gone;
use bycoms_protocol::msg::Pose;

/// Where a robot is in the launch: the run's view's (`bycoms_gate::view`),
/// which every renderer reads, re-exported.
pub use bycoms_gate::view::SlotState;

/// One robot's bookkeeping (read-only outside the core).
#[derive(Clone, Debug)]
pub struct Slot {
    pub(super) id: u32,
    pub(super) state: SlotState,
    pub(super) pid: Option<u32>,
    pub(super) alive: bool,
    /// Lockstep ticks started when its registration was handled.
    pub(super) registered_before_tick: Option<u64>,
    /// The instance of the agent that registered it (the one kept).
    pub(super) instance: Option<u64>,
    /// When its registration was handled, µs of launch time.
    pub(super) registered_at: Option<u64>,
    /// A protocol version other than ours seen in a `Register` for it.
    pub(super) foreign_version: Option<u16>,
    pub(super) mode: u8,
    pub(super) last_pose: Option<Pose>,
    pub(super) deployed_tick: Option<u64>,
    pub(super) decided_tick: Option<u64>,
    pub(super) steps: u64,
    /// From the previous robot's verdict to this robot's start pose, µs.
    pub(super) reaction_us: Option<u64>,
    pub(super) death: Option<Death>,
    pub(super) frames: FrameCount,
    pub(super) outages: Vec<Outage>,
    /// Times its agent was started again after it died unregistered.
    pub(super) restarts: u32,
    /// It registered after its turn was skipped and took a later one.
    pub(super) late: bool,
    /// Its agent's last error before it was gone (`Input::Said`).
    pub(super) last_error: Option<String>,
    /// Why its agent is gone, typed (its death's reason in words is
    /// [`Gone::said`]).
    pub(super) gone: Option<Gone>,
    /// Its agent said that its failsafe stopped it.
    pub(super) failsafe_fired: bool,
    /// Its host's last reported clock offset (`clocks.rs`).
    pub(super) clock: Option<ClockReading>,
    /// Lockstep: its agent said its robot will never move again
    /// (`Parked`), so it is ticked no more unless the gate watches it.
    pub(super) parked: bool,
    /// The beacon table's version its agent was sent everything up to.
    pub(super) beacons_synced: u64,
    /// Beacon messages sent to its agent (the last one's `seq`).
    pub(super) beacon_seq: u32,
    /// Distinct robots its agent was sent a beacon of.
    pub(super) beacon_robots: usize,
    /// Lockstep: the tick whose `Tick` followed the last beacon sent (its
    /// agent holds them once it answered that tick). Real time: when the
    /// last new robot was sent, µs.
    pub(super) beacons_sent_at: u64,
    /// Lockstep: `beacons_synced`, `beacon_seq` and `beacon_robots` before
    /// the last beacons sent, so that a re-sent tick re-sends them too.
    pub(super) beacons_before: (u64, u32, usize),
    /// Lockstep: the first and last step of the last run of periods its
    /// agent was sent at once (`ToAgent::Ticks`, `ahead.rs`).
    pub(super) ran_ahead: Option<(u64, u64)>,
}

impl Slot {
    pub(super) fn new(id: u32) -> Self {
        Self {
            id,
            state: SlotState::Waiting,
            pid: None,
            alive: false,
            registered_before_tick: None,
            instance: None,
            registered_at: None,
            foreign_version: None,
            mode: 1,
            last_pose: None,
            deployed_tick: None,
            decided_tick: None,
            steps: 0,
            reaction_us: None,
            death: None,
            frames: FrameCount::default(),
            outages: Vec::new(),
            restarts: 0,
            late: false,
            failsafe_fired: false,
            clock: None,
            parked: false,
            beacons_synced: 0,
            beacon_seq: 0,
            beacon_robots: 0,
            beacons_sent_at: 0,
            beacons_before: (0, 0, 0),
            ran_ahead: None,
            last_error: None,
            gone: None,
        }
    }

    /// The robot's number.
    pub fn id(&self) -> u32 {
        self.id
    }
    /// Tests only (`testing`): the tick before which it registered, if it did.
    #[cfg(feature = "testing")]
    pub fn registered_before_tick(&self) -> Option<u64> {
        self.registered_before_tick
    }
    /// Where it is in the launch.
    pub fn state(&self) -> SlotState {
        self.state
    }
    /// Its agent's pid, when it is a process on this host.
    pub fn pid(&self) -> Option<u32> {
        self.pid
    }
    /// Whether its agent is started and not gone.
    pub fn alive(&self) -> bool {
        self.alive
    }
    /// Its controller's mode from its last status.
    pub fn mode(&self) -> u8 {
        self.mode
    }
    /// Its last accepted pose.
    pub fn last_pose(&self) -> Option<Pose> {
        self.last_pose
    }
    /// The tick (or frame) after its start pose.
    pub fn deployed_tick(&self) -> Option<u64> {
        self.deployed_tick
    }
    /// The step of the gate's verdict on it.
    pub fn decided_tick(&self) -> Option<u64> {
        self.decided_tick
    }
    /// Its active steps (charged to the time budget).
    pub fn steps(&self) -> u64 {
        self.steps
    }
    /// From the previous verdict to its start pose, µs.
    pub fn reaction_us(&self) -> Option<u64> {
        self.reaction_us
    }
    /// Why its agent is gone, if it is.
    pub fn gone(&self) -> Option<Gone> {
        self.gone
    }
    /// How its agent's death was noticed, in words and time.
    pub fn death(&self) -> Option<&Death> {
        self.death.as_ref()
    }
    /// Real time: the periods its poses show.
    pub fn frames(&self) -> FrameCount {
        self.frames
    }
    /// Times its agent was unreachable.
    pub fn outages(&self) -> &[Outage] {
        &self.outages
    }
    /// Its host's last reported clock offset to the orchestrator's.
    pub fn clock(&self) -> Option<ClockReading> {
        self.clock
    }
    /// Whether it registered after its turn had been skipped (and so took
    /// a later turn, out of id order).
    pub fn joined_late(&self) -> bool {
        self.late
    }
}

/// Real-time periods of one agent as its poses show them.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameCount {
    /// Poses seen (periods stepped).
    pub seen: u64,
    /// Frame numbers skipped between them (periods missed).
    pub missed: u64,
    last: Option<u64>,
}

impl FrameCount {
    /// Counts the pose of frame `step` (only plausible poses reach here, so
    /// a gap is bounded by the time the poses say passed).
    pub fn observe(&mut self, step: u64) {
        if let Some(last) = self.last {
            if step <= last {
                return;
            }
            self.missed = self.missed.saturating_add(step - last - 1);
        }
        self.seen += 1;
        self.last = Some(step);
    }
}
