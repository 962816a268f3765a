//! Which velocity message a ground robot's driver takes on its `cmd_vel`:
//! `geometry_msgs/msg/Twist` (TurtleBot 3's and most drivers') or
//! `TwistStamped` (ROS 2 Jazzy's `diff_drive_controller` by default).
//!
//! Why here: the robots file (`bycoms-lab`), the robot's agent's flags
//! (`bycoms-ros2-robot`) and the emulated lab's bodies name the same two
//! types by the same two words; this is the one place they are spelt.

use crate::msgs::{RosMessage, Twist, TwistStamped};
use crate::types::TypeDescription;
use std::fmt;
use std::str::FromStr;

/// A `cmd_vel` message type.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum VelocityMessage {
    /// `geometry_msgs/msg/Twist`.
    #[default]
    Twist,
    /// `geometry_msgs/msg/TwistStamped`.
    TwistStamped,
}

impl VelocityMessage {
    /// Both, in the order their words are listed.
    pub const ALL: [Self; 2] = [Self::Twist, Self::TwistStamped];

    /// Its word in files and flags: `twist`, `twist-stamped`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Twist => "twist",
            Self::TwistStamped => "twist-stamped",
        }
    }

    /// Its ROS 2 type description (name and hash).
    pub fn description(self) -> &'static TypeDescription {
        match self {
            Self::Twist => Twist::DESCRIPTION,
            Self::TwistStamped => TwistStamped::DESCRIPTION,
        }
    }
}

impl fmt::Display for VelocityMessage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for VelocityMessage {
    type Err = String;
    fn from_str(word: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|m| m.as_str() == word).ok_or_else(|| {
            format!("{word:?} is not a velocity message: `twist` (geometry_msgs/msg/Twist) or `twist-stamped` (TwistStamped)")
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_word_reads_back_and_names_its_type() {
        for m in VelocityMessage::ALL {
            assert_eq!(m.as_str().parse::<VelocityMessage>(), Ok(m));
        }
        assert_eq!(VelocityMessage::Twist.description().name, "geometry_msgs/msg/Twist");
        assert_eq!(VelocityMessage::TwistStamped.description().name, "geometry_msgs/msg/TwistStamped");
        let e = "Twist".parse::<VelocityMessage>().unwrap_err();
        assert!(e.contains("`twist` (geometry_msgs/msg/Twist) or `twist-stamped`"), "{e}");
    }
}
