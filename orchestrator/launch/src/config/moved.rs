//! Config keys that moved, and what becomes of them.
//!
//! Why: a lab's config file written for an older orchestrator must fail
//! with the key's new place in the message, not with serde's bare
//! "unknown field"; and a recording keeps its whole configuration (its
//! `run` channel, JSON), so an older recording must still replay: its
//! moved keys are carried to their new place before it is read.
//!
//! Moved so far: the operator's placement was set in three tables (the
//! agents', NatNet's and the ROS 2 source's); it is one top-level
//! `[placement]`, whatever the pose source.

use serde_json::Value;

/// The tables a placement was configured in before it was one
/// `[placement]`. A mocap source's own table applied over the agents' one.
const OLD_PLACEMENTS: [[&str; 3]; 3] =
    [["mocap", "natnet", "placement"], ["mocap", "ros2", "placement"], ["agents", "placement", ""]];

/// The old placement tables `text` (a config file) sets, as TOML headers.
pub fn old_placement_tables(text: &str) -> Vec<String> {
    let Ok(table) = toml::from_str::<toml::Table>(text) else { return Vec::new() };
    OLD_PLACEMENTS
        .iter()
        .filter(|path| lookup(&table, path))
        .map(|path| {
            format!("[{}]", path.iter().filter(|k| !k.is_empty()).copied().collect::<Vec<_>>().join("."))
        })
        .collect()
}

fn lookup(table: &toml::Table, path: &[&str; 3]) -> bool {
    let mut at = table;
    for key in path.iter().filter(|k| !k.is_empty()) {
        match at.get(*key) {
            Some(toml::Value::Table(inner)) => at = inner,
            _ => return false,
        }
    }
    true
}

/// Carries the moved keys of a recorded configuration (JSON) to their new
/// place: the placement that applied (the mocap source's, else the
/// agents') becomes `placement`, unless the configuration has one already.
pub fn upgrade_recorded(config: &mut Value) {
    let mut found = None;
    for path in &OLD_PLACEMENTS {
        let keys: Vec<&str> = path.iter().filter(|k| !k.is_empty()).copied().collect();
        let (last, parents) = keys.split_last().expect("a path has a key");
        let parent = parents.iter().try_fold(&mut *config, |at, key| at.get_mut(*key));
        if let Some(taken) = parent.and_then(Value::as_object_mut).and_then(|p| p.remove(*last)) {
            found.get_or_insert(taken);
        }
    }
    if let (Some(placement), Some(top)) = (found, config.as_object_mut()) {
        top.entry("placement").or_insert(placement);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn an_old_files_placement_tables_are_named() {
        let text = "[agents.placement]\nradius = 0.2\n[mocap.natnet.placement]\nhold = 1.0\n";
        assert_eq!(old_placement_tables(text), ["[mocap.natnet.placement]", "[agents.placement]"]);
        assert!(old_placement_tables("[placement]\nradius = 0.2\n").is_empty());
        assert!(old_placement_tables("not toml [").is_empty());
    }

    #[test]
    fn a_recorded_placement_moves_to_the_top_the_mocap_sources_first() {
        let mut old = json!({
            "agents": {"source": "real", "placement": {"radius": 0.1, "hold": 0.5, "timeout": 600.0}},
            "mocap": {"natnet": {"placement": {"radius": 0.25, "hold": 1.0, "timeout": 60.0}}},
        });
        upgrade_recorded(&mut old);
        assert_eq!(old["placement"], json!({"radius": 0.25, "hold": 1.0, "timeout": 60.0}));
        assert_eq!(old["agents"], json!({"source": "real"}));
        assert_eq!(old["mocap"]["natnet"], json!({}));
        let mut new = json!({"placement": {"radius": 0.3}, "agents": {"placement": {"radius": 9.0}}});
        upgrade_recorded(&mut new);
        assert_eq!(new["placement"], json!({"radius": 0.3}), "a configuration's own placement stays");
    }
}
