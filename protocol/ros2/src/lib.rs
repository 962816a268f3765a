//! The ROS 2 wire format as rmw_zenoh (ROS 2's zenoh middleware) speaks it,
//! sans-IO: no zenoh session here, only types and pure functions, so every
//! byte is pinned by tests without a network and the launch puts them on
//! the session it already has.
//!
//! * [`cdr`]: XCDR1 little-endian encoding and decoding (the payload);
//! * [`types`]: type descriptions and their REP-2016 hashes (`RIHS01_…`);
//! * [`bycoms_msgs`]: our own gate events and robot states (`deploy/ros2/bycoms_msgs/`);
//! * [`display`]: the terrain map, beacon markers and diagnostics;
//! * [`msgs`]: the messages bycoms publishes (poses, `/tf`, paths, `/clock`,
//!   the `Twist` / `TwistStamped` velocity commands of a ground robot) and
//!   the `PoseStamped` a ROS 2 motion-capture driver sends;
//! * [`rmw_zenoh`]: key expressions, liveliness tokens, GIDs, attachments,
//!   with the rmw_zenoh sources (file and commit) each follows;
//! * [`latched`]: a transient-local publisher's cache for late joiners
//!   (zenoh-ext's advanced publisher, as zenoh's stable API can make it).
//!
//! Why its own crate: it is std but needs none of the bus, and the no_std
//! protocol core stays as it is. Checked against independent
//! implementations (PyPI `rosbags`, `xxhash`, eclipse-zenoh's serializer)
//! by `tests/golden.rs` and `tests/python/ros2_golden.py` at the root.

/// A `pub static` type description: `description!(NAME, "pkg/msg/Type", [fields…])`.
macro_rules! description {
    ($static:ident, $name:literal, [$($field:expr),* $(,)?]) => {
        #[doc = concat!("The description of `", $name, "`.")]
        pub static $static: TypeDescription = TypeDescription { name: $name, fields: &[$($field),*] };
    };
}

pub mod bycoms_msgs;
pub mod cdr;
pub mod display;
pub mod latched;
pub mod msgs;
pub mod rmw_zenoh;
pub mod types;
pub mod velocity;
