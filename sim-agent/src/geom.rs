//! Plain 2-D points in world units (one unit = one terrain cell).

use serde::{Deserialize, Serialize};

/// A point or vector in the world frame: x to the right, y up.
#[derive(Clone, Copy, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct Vec2 {
    pub x: f64,
    pub y: f64,
}

impl Vec2 {
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// Euclidean distance to `other`.
    #[inline]
    pub fn distance(self, other: Vec2) -> f64 {
        libm::hypot(self.x - other.x, self.y - other.y)
    }

    /// Direction from `self` towards `other`, rad in (−π, π].
    #[inline]
    pub fn bearing_to(self, other: Vec2) -> f64 {
        libm::atan2(other.y - self.y, other.x - self.x)
    }
}
