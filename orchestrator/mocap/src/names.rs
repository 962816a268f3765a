//! Rigid-body names (from Motive's model definitions) → robot ids.
//!
//! Why by name: streaming ids change whenever bodies are re-created in
//! Motive, names are what the operator sees and types into the config.
//! An unknown body (the goal plate, a visitor's wand) is ignored with a
//! warning; a configured body absent from the definitions is reported by
//! name, so a wrong name fails loudly before the run.

use bycoms_protocol::natnet::ModelDefinitions;
use bycoms_protocol::RobotId;
use std::collections::BTreeMap;

/// Streaming id → robot, resolved from the model definitions.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BodyMap {
    by_streaming_id: BTreeMap<i32, RobotId>,
    names: BTreeMap<RobotId, String>,
    /// Configured names the definitions lack.
    pub missing: Vec<String>,
    /// Defined bodies no robot is mapped to.
    pub unknown: Vec<String>,
}

impl BodyMap {
    /// Resolves `robots` (name → robot id) against `defs`.
    pub fn resolve(defs: &ModelDefinitions, robots: &BTreeMap<String, RobotId>) -> Self {
        let mut map = Self::default();
        for rb in defs.rigid_bodies() {
            match robots.get(&rb.name) {
                Some(&robot) => {
                    map.by_streaming_id.insert(rb.id, robot);
                    map.names.insert(robot, rb.name.clone());
                }
                None => {
                    tracing::warn!(name = %rb.name, id = rb.id, "mocap body not mapped to a robot: ignored");
                    map.unknown.push(rb.name.clone());
                }
            }
        }
        for name in robots.keys() {
            if !defs.rigid_bodies().any(|rb| &rb.name == name) {
                tracing::warn!(%name, "configured mocap body not defined by the server");
                map.missing.push(name.clone());
            }
        }
        map
    }

    /// The robot streamed under `id`, if any.
    pub fn robot(&self, streaming_id: i32) -> Option<RobotId> {
        self.by_streaming_id.get(&streaming_id).copied()
    }

    /// The rigid-body name robot `robot` is tracked by ("?" if none).
    pub fn name(&self, robot: RobotId) -> &str {
        self.names.get(&robot).map_or("?", String::as_str)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bycoms_protocol::natnet::{DataDescription, RigidBodyDescription};

    #[test]
    fn names_map_to_robots_unknown_ignored_missing_reported() {
        let rb = |name: &str, id| {
            DataDescription::RigidBody(RigidBodyDescription {
                name: name.into(),
                id,
                parent_id: -1,
                offset: [0.0; 3],
                markers: vec![],
            })
        };
        let defs = ModelDefinitions { descriptions: vec![rb("robot1", 7), rb("goal", 9), rb("robot2", 3)] };
        let robots = BTreeMap::from([
            ("robot1".to_string(), RobotId(1)),
            ("robot2".to_string(), RobotId(2)),
            ("robot3".to_string(), RobotId(3)),
        ]);
        let map = BodyMap::resolve(&defs, &robots);
        assert_eq!((map.robot(7), map.robot(3), map.robot(9)), (Some(RobotId(1)), Some(RobotId(2)), None));
        assert_eq!(map.missing, ["robot3"]);
        assert_eq!((map.name(RobotId(2)), map.name(RobotId(3))), ("robot2", "?"));
        assert_eq!(map.unknown, ["goal"]);
    }
}
