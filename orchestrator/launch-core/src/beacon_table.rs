//! The table of beacons the launch tells its simulated agents
//! (`beacons.rs` says why and how it is sent): every beacon at its latest
//! pose, bit for bit, versioned so each agent is sent only what changed
//! since it was last told. Kept in every launch: its changes are what the
//! views show of beacons (`Output::Beacon`, `moved.rs`).

use std::collections::BTreeMap;

/// Most beacons sent to one agent at a time (half its command buffer).
pub const PER_SEND: usize = 32;

/// One beacon: where it stands, and the versions of its first and latest
/// position.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Entry {
    x: f64,
    y: f64,
    first: u64,
    latest: u64,
}

/// Every beacon of the launch, versioned.
#[derive(Clone, Debug, Default)]
pub struct BeaconTable {
    at: BTreeMap<u32, Entry>,
    by_version: BTreeMap<u64, u32>,
    version: u64,
}

/// One beacon to send.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Change {
    /// The robot that stands there.
    pub robot: u32,
    /// Where, x.
    pub x: f64,
    /// Where, y.
    pub y: f64,
    /// Whether the receiver has never been sent this robot before.
    pub new_robot: bool,
}

impl BeaconTable {
    /// Robot `robot` stands at (`x`, `y`): a new beacon, or a new position
    /// of one (same bits: nothing changes). Returns whether it changed.
    pub fn set(&mut self, robot: u32, x: f64, y: f64) -> bool {
        if let Some(e) = self.at.get(&robot) {
            if e.x.to_bits() == x.to_bits() && e.y.to_bits() == y.to_bits() {
                return false;
            }
        }
        self.version += 1;
        let version = self.version;
        let entry = match self.at.get(&robot) {
            Some(e) => {
                self.by_version.remove(&e.latest);
                Entry { x, y, first: e.first, latest: version }
            }
            None => Entry { x, y, first: version, latest: version },
        };
        self.at.insert(robot, entry);
        self.by_version.insert(version, robot);
        true
    }

    /// Every beacon and where it stands, in robot order.
    pub fn all(&self) -> Vec<(u32, bycoms_sim::Vec2)> {
        self.at.iter().map(|(&robot, e)| (robot, bycoms_sim::Vec2::new(e.x, e.y))).collect()
    }

    /// Whether robot `robot` is a beacon.
    pub fn contains(&self, robot: u32) -> bool {
        self.at.contains_key(&robot)
    }

    /// The current version (0: no beacon yet).
    pub fn version(&self) -> u64 {
        self.version
    }

    /// The beacons other than `own` that changed after version `synced`,
    /// at most `max`, oldest change first, and the version the receiver is
    /// in sync with once it has them.
    pub fn changed_since(&self, synced: u64, own: u32, max: usize) -> (Vec<Change>, u64) {
        let mut out = Vec::new();
        let mut upto = synced;
        for (&version, &robot) in self.by_version.range(synced + 1..) {
            if out.len() == max {
                break;
            }
            upto = version;
            if robot == own {
                continue;
            }
            if let Some(e) = self.at.get(&robot) {
                out.push(Change { robot, x: e.x, y: e.y, new_robot: e.first > synced });
            }
        }
        if out.len() < max {
            upto = self.version.max(upto);
        }
        (out, upto)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_changes_are_sent_in_change_order_and_never_the_robots_own() {
        let mut t = BeaconTable::default();
        assert_eq!(t.changed_since(0, 9, PER_SEND), (vec![], 0));
        assert!(t.set(1, 1.0, 1.0));
        assert!(t.set(2, 2.0, 2.0));
        assert!(!t.set(1, 1.0, 1.0), "the same bits change nothing");
        assert!(t.set(3, 3.0, 3.0));
        let (first, synced) = t.changed_since(0, 2, PER_SEND);
        assert_eq!(
            first.iter().map(|c| c.robot).collect::<Vec<_>>(),
            [1, 3],
            "robot 2's own beacon is not sent"
        );
        assert!(first.iter().all(|c| c.new_robot));
        assert_eq!(synced, 3);
        assert!(t.set(1, 1.5, 1.0), "robot 1 crept on");
        let (again, synced) = t.changed_since(synced, 2, PER_SEND);
        assert_eq!(again, vec![Change { robot: 1, x: 1.5, y: 1.0, new_robot: false }]);
        assert_eq!(synced, 4);
        assert_eq!(t.changed_since(synced, 2, PER_SEND), (vec![], 4));
    }

    #[test]
    fn a_long_backlog_goes_in_slices() {
        let mut t = BeaconTable::default();
        for r in 1..=70 {
            t.set(r, f64::from(r), 0.0);
        }
        let (a, s1) = t.changed_since(0, 100, PER_SEND);
        let (b, s2) = t.changed_since(s1, 100, PER_SEND);
        let (c, s3) = t.changed_since(s2, 100, PER_SEND);
        assert_eq!((a.len(), b.len(), c.len()), (32, 32, 6));
        assert_eq!((s1, s2, s3), (32, 64, 70));
        assert_eq!(a[0].robot, 1);
        assert_eq!(c[5].robot, 70);
        assert_eq!(t.changed_since(s3, 100, PER_SEND), (vec![], 70));
    }
}
