//! Identifiers.
//!
//! A robot id is its deployment order within a run, starting at 1 as in the
//! paper's figures ("robot 1 gets stuck, robot 2 ...").

use serde::{Deserialize, Serialize};

/// A robot's id: its 1-based deployment order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct RobotId(pub u32);

impl core::fmt::Display for RobotId {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "robot {}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn displays_one_based_order() {
        assert_eq!(RobotId(3).to_string(), "robot 3");
        assert!(RobotId(1) < RobotId(2));
    }
}
