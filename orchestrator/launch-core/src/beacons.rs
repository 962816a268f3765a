//! The beacons of the simulated robots' field, as the launch tells them.
//!
//! Why here: a simulated robot senses the robots that stopped before it.
//! Each agent used to read every earlier robot's pose topic for that,
//! which made every agent's memory (iceoryx2 ports and their shared data
//! segments) and its work per period grow with the swarm: k × n pose
//! subscriptions in all. The launch already sees every pose, so it keeps
//! one table of beacons (a robot judged stuck or lost, at its latest pose,
//! bit for bit) and sends each agent that may still move what changed
//! since it was last told ([`bycoms_protocol::msg::Beacon`] on the robot's
//! command topic, in order with its ticks).
//!
//! Sizing the sends: the command topic buffers [`PER_SEND`] × 2 messages
//! per publisher, and the bus keeps no history, so an agent is sent at
//! most [`PER_SEND`] beacons before each `Tick` (lockstep) or each wall
//! period (real time). In lockstep an agent that answered a tick holds
//! everything sent before that tick (one ordered topic), which is how the
//! launch knows that a robot about to be deployed senses every beacon.
//!
//! Versions: every change of the table gets the next version number; an
//! agent is in sync when it was sent every change up to the current
//! version (except those of its own robot).

use super::beacon_table::PER_SEND;
use super::{LaunchCore, Output, Phase, Pose, SlotState, TickWait};
use bycoms_protocol::msg::{Beacon, Tick, ToAgent};
use bycoms_protocol::RobotId;

impl LaunchCore {
    /// Robot `id` stands at `pose` as a beacon: judged stuck, lost (where
    /// it was last seen), or a beacon that moved on. The table is kept in
    /// every launch, as the views show it ([`Output::Beacon`] on each
    /// change); only agents that sense beacons are sent it.
    pub(super) fn beacon_at(&mut self, id: u32, pose: &Pose) {
        if self.beacons.set(id, pose.x, pose.y) {
            self.shown_beacon(id, pose);
        }
    }

    /// Whether robot `id` is a beacon.
    pub(super) fn is_beacon(&self, id: u32) -> bool {
        self.beacons.contains(id)
    }

    /// Sends every agent that may still move the beacons it was not sent
    /// yet, at most [`PER_SEND`] each. `mark` is the tick whose `Tick`
    /// follows (lockstep) or the time (real time).
    ///
    /// In lockstep an agent whose robot is not deployed yet is sent none
    /// until it settles ([`Self::sync_beacons`] sends it what one send does
    /// not hold): its answer to a tick is what says it holds them, and a
    /// beacon that creeps changes the table every tick, so every agent
    /// waiting its turn (all of them, when they are started at once) was
    /// ticked every tick, for nothing it needed before its turn (issue 35).
    pub(super) fn send_beacons(&mut self, mark: u64) {
        if !self.setup.agents.beacons || self.beacons.version() == 0 {
            return;
        }
        let version = self.beacons.version();
        let settling = match self.phase {
            Phase::Settling(id, _) => Some(id),
            _ => None,
        };
        for i in 0..self.slots.len() {
            let slot = &self.slots[i];
            let may_move = match slot.state {
                SlotState::Registered => !self.setup.lockstep || settling == Some(slot.id),
                SlotState::Deploying | SlotState::Moving => true,
                _ => false,
            };
            if slot.alive
                && slot.registered_before_tick.is_some()
                && may_move
                && slot.beacons_synced != version
            {
                self.send_beacons_to(i, mark);
            }
        }
    }

    /// Lockstep: the beacons sent to robot `id` before tick `mark`'s
    /// `Tick` again, with the same numbers, when that tick is re-sent to it
    /// (they may have been lost with it, e.g. in a cut; an agent takes a
    /// repeat quietly). Why: an agent not deployed yet is ticked only when
    /// it is sent beacons, so the launch goes on while it is cut off, and
    /// what it was sent then must reach it before it is deployed.
    pub(super) fn resend_beacons(&mut self, id: u32, mark: u64) {
        let Some(i) = id.checked_sub(1).map(|i| i as usize).filter(|&i| i < self.slots.len()) else { return };
        let slot = &mut self.slots[i];
        if !self.setup.lockstep || slot.beacons_sent_at != mark || slot.beacon_seq == slot.beacons_before.1 {
            return;
        }
        (slot.beacons_synced, slot.beacon_seq, slot.beacon_robots) = slot.beacons_before;
        self.send_beacons_to(i, mark);
    }

    /// Lockstep: robot `id`'s agent, settling, is sent the beacons its
    /// settling tick's send did not hold, then the last tick again, to it
    /// alone; its answer says it holds them. Why not another tick: a tick
    /// steps every robot that creeps, and how many beacons are left depends
    /// on when the agent registered (a late one gets them all at once), so
    /// the robot's deployment, and every step after it, moved with how fast
    /// its agent started (`launch --robots 120` on the all-stuck terrain:
    /// 1383 to 1399 steps in three runs). A repeated tick steps nobody.
    pub(super) fn sync_beacons(&mut self, id: u32, now: u64) {
        let t = self.ticks;
        if let Some(i) = id.checked_sub(1).map(|i| i as usize).filter(|&i| i < self.slots.len()) {
            self.send_beacons_to(i, t);
        }
        self.outputs.push_back(Output::Send(id, ToAgent::Tick(Tick { step: t })));
        let wait = self.answer_wait(now);
        self.tick =
            Some(TickWait { step: t, awaiting: [id].into(), pose_of: None, wait, agents: 1, quiet: false });
    }

    /// Sends the agent of slot `i` the changes it was not sent, at most
    /// [`PER_SEND`].
    fn send_beacons_to(&mut self, i: usize, mark: u64) {
        let lockstep = self.setup.lockstep;
        let slot = &mut self.slots[i];
        let (changes, synced) = self.beacons.changed_since(slot.beacons_synced, slot.id, PER_SEND);
        let before = (slot.beacons_synced, slot.beacon_seq, slot.beacon_robots);
        slot.beacons_synced = synced;
        let sent = !changes.is_empty();
        let mut new_robot = false;
        for c in changes {
            slot.beacon_seq += 1;
            new_robot |= c.new_robot;
            slot.beacon_robots += usize::from(c.new_robot);
            let beacon = Beacon { robot: RobotId(c.robot), x: c.x, y: c.y, seq: slot.beacon_seq };
            self.outputs.push_back(Output::Send(slot.id, ToAgent::Beacon(beacon)));
        }
        if (sent && lockstep) || new_robot {
            slot.beacons_sent_at = mark;
        }
        if sent && lockstep {
            slot.beacons_before = before;
        }
    }

    /// Real time: when robot `id`'s agent will hold every beacon if nothing
    /// changes (the next send, or a period after the last one).
    pub(super) fn beacons_ready_at(&self, id: u32) -> u64 {
        match self.slot_ref(id) {
            Some(slot) if self.setup.agents.beacons && !self.setup.lockstep => {
                if slot.beacons_synced < self.beacons.version() {
                    self.relay_at
                } else {
                    slot.beacons_sent_at.saturating_add(self.setup.wall_period_us)
                }
            }
            _ => 0,
        }
    }

    /// Whether robot `id`'s agent senses every beacon: it was sent every
    /// change of the table and has (lockstep) answered a tick since, or
    /// (real time) had a wall period to take them.
    pub(super) fn beacons_held(&self, id: u32, now: u64) -> bool {
        if !self.setup.agents.beacons {
            return true;
        }
        let Some(slot) = self.slot_ref(id) else { return true };
        if slot.beacons_synced < self.beacons.version() {
            return false;
        }
        if self.setup.lockstep {
            slot.beacons_sent_at <= self.ticks
        } else {
            now >= slot.beacons_sent_at.saturating_add(self.setup.wall_period_us)
        }
    }
}
