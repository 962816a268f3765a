//! Every crate of the workspace takes its outside dependencies from the
//! root manifest's `[workspace.dependencies]`, so a version is written once
//! and two crates cannot drift apart (issue 36: `nix`, `mcap`, `iceoryx2`,
//! `tungstenite`, `zenoh`… were each declared per crate, in up to three
//! places). A crate adds only its own features and `optional`.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate is in the repository")
        .to_path_buf()
}

fn manifest(path: &Path) -> toml::Table {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Every dependency table of a manifest: `[dependencies]`, `[dev-…]`,
/// `[build-…]` and their `[target.'cfg(…)'.…]` forms.
fn dependency_tables(manifest: &toml::Table) -> Vec<(String, &toml::Table)> {
    let kinds = ["dependencies", "dev-dependencies", "build-dependencies"];
    let mut tables = Vec::new();
    for kind in kinds {
        if let Some(t) = manifest.get(kind).and_then(toml::Value::as_table) {
            tables.push((kind.to_string(), t));
        }
    }
    let targets = manifest.get("target").and_then(toml::Value::as_table);
    for (cfg, target) in targets.into_iter().flatten() {
        for kind in kinds {
            if let Some(t) = target.get(kind).and_then(toml::Value::as_table) {
                tables.push((format!("target.{cfg}.{kind}"), t));
            }
        }
    }
    tables
}

/// A dependency written with its own version instead of `workspace = true`
/// (a path dependency is a crate of this repository: it is fine).
fn own_version(spec: &toml::Value) -> bool {
    match spec {
        toml::Value::String(_) => true,
        toml::Value::Table(t) => t.get("workspace").is_none() && t.get("path").is_none(),
        _ => true,
    }
}

#[test]
fn every_crate_takes_its_dependencies_from_the_workspace() {
    let root = root();
    let workspace = manifest(&root.join("Cargo.toml"));
    let members = workspace["workspace"]["members"].as_array().expect("members");
    assert!(members.len() >= 5, "the workspace's members are read");
    let mut own = Vec::new();
    for member in members {
        let member = member.as_str().expect("a member is a path");
        let crate_manifest = manifest(&root.join(member).join("Cargo.toml"));
        for (table, deps) in dependency_tables(&crate_manifest) {
            for (name, spec) in deps {
                if own_version(spec) {
                    own.push(format!("{member}/Cargo.toml [{table}] {name}"));
                }
            }
        }
    }
    assert!(
        own.is_empty(),
        "declare these in the root Cargo.toml's [workspace.dependencies] and write `{{ workspace = true, … }}`:\n{}",
        own.join("\n")
    );
}

#[test]
fn a_dependency_with_its_own_version_is_noticed() {
    let crate_manifest: toml::Table = toml::from_str(
        "[dependencies]\na = \"1\"\nb.workspace = true\nc = { path = \"../c\" }\n\
         [target.'cfg(unix)'.dev-dependencies]\nd = { version = \"2\", features = [\"x\"] }\n",
    )
    .expect("toml");
    let own: Vec<String> = dependency_tables(&crate_manifest)
        .into_iter()
        .flat_map(|(_, deps)| deps.iter().filter(|(_, s)| own_version(s)).map(|(n, _)| n.clone()))
        .collect();
    assert_eq!(own, ["a", "d"]);
}

/// Test-only features (`test-clock-skew`: a clock skewed from the
/// environment; `testing`: the launch harness) are turned on only by
/// dev-dependencies, so no release build has them (issue 53: the skew was
/// read by every agent's clock in production). Also in the root's
/// `[workspace.dependencies]`, which every crate inherits.
#[test]
fn test_only_features_are_turned_on_by_dev_dependencies_only() {
    let root = root();
    let workspace = manifest(&root.join("Cargo.toml"));
    let turns_on = |spec: &toml::Value, feature: &str| {
        spec.get("features")
            .and_then(toml::Value::as_array)
            .is_some_and(|f| f.iter().any(|v| v.as_str() == Some(feature)))
    };
    let mut found = Vec::new();
    let shared = workspace["workspace"]["dependencies"].as_table().expect("[workspace.dependencies]");
    for feature in ["test-clock-skew", "testing"] {
        found.extend(
            shared.iter().filter(|(_, s)| turns_on(s, feature)).map(|(n, _)| format!("Cargo.toml {n}")),
        );
    }
    let members = workspace["workspace"]["members"].as_array().expect("members");
    let mut seen_in_dev = 0;
    for member in members {
        let member = member.as_str().expect("a member is a path");
        let crate_manifest = manifest(&root.join(member).join("Cargo.toml"));
        for (table, deps) in dependency_tables(&crate_manifest) {
            for (name, spec) in deps {
                for feature in ["test-clock-skew", "testing"] {
                    if !turns_on(spec, feature) {
                        continue;
                    }
                    if table.ends_with("dev-dependencies") {
                        seen_in_dev += 1;
                    } else {
                        found.push(format!("{member}/Cargo.toml [{table}] {name}: {feature}"));
                    }
                }
            }
        }
    }
    assert!(seen_in_dev >= 2, "the tests turn both on through dev-dependencies");
    assert!(found.is_empty(), "a test-only feature in a product build:\n{}", found.join("\n"));
}
