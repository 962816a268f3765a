//! ARCHITECTURE.md's module map: every module of every crate of the
//! workspace with the first sentence of its own `//!` doc.
//!
//! Why from the module docs: they sit next to the code and change with it,
//! so the map cannot name a module that is gone or miss one that came; a
//! module without a doc fails the test (every module says why it exists).
//! Test-only files (`tests.rs`, `tests/`) are left out.

use super::first_sentence;
use crate::docs::{files, members, read, root};

/// The first sentence of the `//!` block a file starts with, if any.
fn module_doc(source: &str) -> Option<String> {
    let doc: Vec<&str> = source
        .lines()
        .skip_while(|l| l.starts_with("#![") || l.trim().is_empty())
        .take_while(|l| l.starts_with("//!"))
        .map(|l| l.trim_start_matches("//!").trim())
        .take_while(|l| !l.is_empty())
        .collect();
    (!doc.is_empty()).then(|| first_sentence(&doc.join(" ")))
}

fn is_test_file(relative: &str) -> bool {
    relative.ends_with("/tests.rs") || relative == "tests.rs" || relative.contains("/tests/")
}

/// One crate's table: `| module | what it is |`, by path under `src/`.
fn crate_table(member: &str, missing: &mut Vec<String>) -> Option<String> {
    let dir = root().join(member);
    let manifest: toml::Table = toml::from_str(&read(&dir.join("Cargo.toml"))).expect("a crate's Cargo.toml");
    let name = manifest["package"]["name"].as_str().expect("package.name").to_string();
    let mut sources = Vec::new();
    files(&dir.join("src"), ".rs", &mut sources);
    let mut rows: Vec<(String, String)> = Vec::new();
    for path in &sources {
        let relative =
            path.strip_prefix(dir.join("src")).expect("under src").to_string_lossy().replace('\\', "/");
        if is_test_file(&relative) {
            continue;
        }
        match module_doc(&read(path)) {
            Some(doc) => rows.push((relative, doc)),
            None => missing.push(format!("{member}/src/{relative}")),
        }
    }
    if rows.is_empty() {
        return None;
    }
    rows.sort();
    let mut out = vec![
        format!("#### `{name}` (`{member}/src/`)\n"),
        "| module | what it is |".into(),
        "|---|---|".into(),
    ];
    out.extend(rows.into_iter().map(|(path, doc)| format!("| `{path}` | {doc} |")));
    Some(out.join("\n"))
}

/// The region's text: one table per crate, in the workspace's order.
pub fn map() -> String {
    let mut missing = Vec::new();
    let tables: Vec<String> = members().iter().filter_map(|m| crate_table(m, &mut missing)).collect();
    assert!(
        missing.is_empty(),
        "modules without a `//!` doc saying what they are and why:\n{}",
        missing.join("\n")
    );
    tables.join("\n\n")
}

#[test]
fn a_module_doc_is_its_first_sentence_after_the_crate_attributes() {
    let source = "#![no_std]\n\n//! The gate. It judges\n//! from poses.\n//!\n//! More.\nuse x;\n";
    assert_eq!(module_doc(source).as_deref(), Some("The gate"));
    assert_eq!(module_doc("use x;\n"), None);
    assert!(is_test_file("launch/crowd/tests.rs") && is_test_file("terrain/tests/read.rs"));
    assert!(!is_test_file("launch/crowd.rs"));
}
