//! The one finiteness check of every float of a launch config.
//!
//! Why one walk over the whole config and not a check per key: a key
//! checked by hand is a key that can be forgotten. `[mocap.ros2.arena]
//! origin = [nan, 1e308, -inf]` passed every check, and the operator was
//! then asked for 600 s to place a robot at a start that no pose can ever
//! reach. The config is walked as the TOML it serialises to (NaN and the
//! infinities survive as TOML floats), so a key added tomorrow is checked
//! without anyone remembering to.

/// The first float of `value` that is NaN or infinite, by its key (as
/// written in the config file, `mocap.ros2.arena.origin[0]`) and value.
pub fn first_non_finite(value: &toml::Value) -> Option<(String, f64)> {
    walk(value, String::new())
}

fn walk(value: &toml::Value, key: String) -> Option<(String, f64)> {
    match value {
        toml::Value::Float(f) if !f.is_finite() => Some((key, *f)),
        toml::Value::Array(items) => {
            items.iter().enumerate().find_map(|(i, item)| walk(item, format!("{key}[{i}]")))
        }
        toml::Value::Table(table) => table.iter().find_map(|(name, item)| {
            let key = if key.is_empty() { name.clone() } else { format!("{key}.{name}") };
            walk(item, key)
        }),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_non_finite_float_is_named_by_its_key() {
        let text = "a = 1.0\n[b.c]\norigin = [0.0, 1e308, -inf]\n[[d]]\nx = nan\n";
        let value: toml::Value = toml::from_str(text).expect("toml");
        assert_eq!(first_non_finite(&value), Some(("b.c.origin[2]".into(), f64::NEG_INFINITY)));
        let found = first_non_finite(&toml::from_str("[[d]]\nx = 1.0\n[[d]]\ny = nan\n").expect("toml"));
        assert!(matches!(found, Some((ref k, v)) if k == "d[1].y" && v.is_nan()), "{found:?}");
        assert_eq!(first_non_finite(&toml::from_str("a = 1e308\nb = \"nan\"").expect("toml")), None);
    }
}
