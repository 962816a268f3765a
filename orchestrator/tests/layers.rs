//! Imports inside the orchestrator run one way: its crates down the table
//! of ARCHITECTURE.md's section "Crates of the orchestrator" (read against
//! each crate's `Cargo.toml`), and the modules of its binary's own crate
//! down the table of "Layers inside the orchestrator's crate".
//!
//! The tables are read from ARCHITECTURE.md, so the doc and the rule cannot
//! disagree. Each row is a layer, top first; a top-level module
//! (`src/*.rs`, `src/*/`, and `lib.rs`'s inline modules) may use only
//! modules of the rows below its own. Two modules of one row use neither
//! the other, so no two folders can use each other (no loop).
//!
//! A use is any path into another top-level module, in code (comments and
//! string literals are not code): `crate::x`, a group `crate::{x, y::z}`,
//! `super::` that climbs out of the file's top-level module (inline
//! modules counted), and an exported macro (`crate::outln!`, counted as a
//! use of the module that defines it).
//!
//! The same reader also sees files: in every workspace crate with a `src/`,
//! no two files may use each other, directly or round a loop (see "No file
//! cycles" below for what a use between files is).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The section of ARCHITECTURE.md that holds the table of modules.
const SECTION: &str = "## Layers inside the orchestrator's crate";
/// The section of ARCHITECTURE.md that holds the table of crates.
const CRATES: &str = "## Crates of the orchestrator";

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// The layers of the modules, top first: each row's module names (in
/// backticks in the table's second column).
fn layers() -> Vec<Vec<String>> {
    table(SECTION)
}

/// The rows of the first table of `section`, top first: the names in
/// backticks of each row's second column.
fn table(section: &str) -> Vec<Vec<String>> {
    let doc = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../ARCHITECTURE.md"))
        .expect("ARCHITECTURE.md");
    let start = doc.find(section).unwrap_or_else(|| panic!("ARCHITECTURE.md has no section {section:?}"));
    let rows: Vec<&str> = doc[start..]
        .lines()
        .skip(1)
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2) // header and separator
        .collect();
    let layers: Vec<Vec<String>> = rows
        .iter()
        .map(|row| {
            let cell =
                row.split('|').nth(2).unwrap_or_else(|| panic!("a row of two columns at least: {row}"));
            cell.split('`').skip(1).step_by(2).map(str::to_owned).collect()
        })
        .collect();
    assert!(
        layers.len() >= 3 && layers.iter().all(|l| !l.is_empty()),
        "the table of {section:?}: {layers:?}"
    );
    layers
}

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("a source folder").flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// A file's module path from the crate root: `orchestrator/launch/src/poses/mod.rs` →
/// `[launch, poses]`, `gate.rs` → `[gate]`, `lib.rs` → `[]`.
fn module_path(file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src()).expect("under src/");
    let mut path: Vec<String> = rel.iter().map(|s| s.to_string_lossy().into_owned()).collect();
    let last = path.pop().expect("a file name");
    let stem = last.trim_end_matches(".rs");
    if !(stem == "mod" || (path.is_empty() && (stem == "lib" || stem == "main"))) {
        path.push(stem.to_string());
    }
    path
}

/// The code of a file with comments and the contents of string and
/// character literals blanked (line breaks kept, so lines still count).
fn code_only(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let blank = |ch: char| if ch == '\n' { '\n' } else { ' ' };
    let mut i = 0;
    while i < c.len() {
        let at = |k: usize| c.get(k).copied().unwrap_or('\0');
        if c[i] == '/' && at(i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if c[i] == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            loop {
                if i >= c.len() {
                    break;
                }
                if c[i] == '/' && at(i + 1) == '*' {
                    depth += 1;
                    i += 2;
                    out.push_str("  ");
                } else if c[i] == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    i += 2;
                    out.push_str("  ");
                    if depth == 0 {
                        break;
                    }
                } else {
                    out.push(blank(c[i]));
                    i += 1;
                }
            }
        } else if c[i] == 'r'
            && (at(i + 1) == '"' || (at(i + 1) == '#' && !at(i.wrapping_sub(1)).is_alphanumeric()))
            && (i == 0 || !(c[i - 1].is_alphanumeric() || c[i - 1] == '_'))
        {
            // A raw string: r"…", r#"…"#.
            let mut j = i + 1;
            let mut hashes = 0;
            while at(j) == '#' {
                hashes += 1;
                j += 1;
            }
            if at(j) != '"' {
                out.push(c[i]);
                i += 1;
                continue;
            }
            j += 1;
            out.push('"');
            loop {
                if j >= c.len() {
                    break;
                }
                if c[j] == '"' && (1..=hashes).all(|h| at(j + h) == '#') {
                    j += 1 + hashes;
                    break;
                }
                out.push(blank(c[j]));
                j += 1;
            }
            out.push('"');
            i = j;
        } else if c[i] == '"' {
            out.push('"');
            i += 1;
            while i < c.len() && c[i] != '"' {
                if c[i] == '\\' {
                    out.push(' ');
                    i += 1;
                }
                if i < c.len() {
                    out.push(blank(c[i]));
                    i += 1;
                }
            }
            out.push('"');
            i += 1;
        } else if c[i] == '\'' && (at(i + 1) == '\\' || at(i + 2) == '\'') {
            // A character literal ('x', '\n', '\''); a lifetime has no closing quote.
            let mut j = i + 1;
            if at(j) == '\\' {
                j += 2;
            } else {
                j += 1;
            }
            while j < c.len() && c[j] != '\'' {
                j += 1;
            }
            out.push_str("' '");
            i = j + 1;
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// A token of code: a word (identifier, keyword, `$crate`) or one other
/// character, with its line.
fn tokens(code: &str) -> Vec<(String, usize)> {
    let mut out = Vec::new();
    let mut line = 1;
    let mut chars = code.chars().peekable();
    while let Some(ch) = chars.next() {
        if ch == '\n' {
            line += 1;
        } else if ch.is_alphanumeric() || ch == '_' || ch == '$' {
            let mut word = ch.to_string();
            while let Some(&n) = chars.peek() {
                if n.is_alphanumeric() || n == '_' {
                    word.push(n);
                    chars.next();
                } else {
                    break;
                }
            }
            out.push((word, line));
        } else if ch == ':' && chars.peek() == Some(&':') {
            chars.next();
            out.push(("::".into(), line));
        } else if !ch.is_whitespace() {
            out.push((ch.to_string(), line));
        }
    }
    out
}

/// The first segments of the paths that start at token `i` (just after
/// `crate::` or a climb to the root): one name, or every name of a group
/// `{a, b::c, d::{e}}`.
fn first_segments(toks: &[(String, usize)], i: usize) -> Vec<String> {
    match toks.get(i).map(|t| t.0.as_str()) {
        Some("{") => {
            let mut names = Vec::new();
            let mut depth = 0;
            let mut expect_name = true;
            for (t, _) in &toks[i..] {
                match t.as_str() {
                    "{" => {
                        depth += 1;
                        if depth > 1 {
                            expect_name = false;
                        }
                    }
                    "}" => {
                        depth -= 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    "," if depth == 1 => expect_name = true,
                    word if expect_name && depth == 1 => {
                        names.push(word.to_string());
                        expect_name = false;
                    }
                    _ => {}
                }
            }
            names
        }
        Some(word) => vec![word.to_string()],
        None => Vec::new(),
    }
}

/// One use of another top-level module.
#[derive(Debug)]
struct Use {
    file: String,
    line: usize,
    from: String,
    to: String,
}

/// Every use, in `file`, of a top-level module other than its own.
fn uses_in(file: &Path, macros: &BTreeMap<String, String>) -> Vec<Use> {
    let text = std::fs::read_to_string(file).expect("a source file");
    uses_in_code(&file.display().to_string(), &module_path(file), &text, macros)
}

/// Every use, in `text` (the file of module `path`), of a top-level module
/// other than its own.
fn uses_in_code(file: &str, path: &[String], text: &str, macros: &BTreeMap<String, String>) -> Vec<Use> {
    let Some(own) = path.first().cloned() else { return Vec::new() };
    let toks = tokens(&code_only(text));
    let mut found = Vec::new();
    // Inline modules open at this point: (brace depth inside, name).
    let mut inline: Vec<usize> = Vec::new();
    let mut depth = 0usize;
    let push = |name: &str, line: usize, found: &mut Vec<Use>| {
        let to = macros.get(name).cloned().unwrap_or_else(|| name.to_string());
        if to != own && to != "self" && to != "*" {
            found.push(Use { file: file.to_string(), line, from: own.clone(), to });
        }
    };
    let mut i = 0;
    while i < toks.len() {
        let (t, line) = (&toks[i].0, toks[i].1);
        match t.as_str() {
            "{" => depth += 1,
            "}" => {
                depth = depth.saturating_sub(1);
                if inline.last() == Some(&(depth + 1)) {
                    inline.pop();
                }
            }
            "mod" if toks.get(i + 2).is_some_and(|n| n.0 == "{") => {
                inline.push(depth + 1);
            }
            "crate" | "$crate" if toks.get(i + 1).is_some_and(|n| n.0 == "::") => {
                for name in first_segments(&toks, i + 2) {
                    push(&name, line, &mut found);
                }
            }
            "super" if i == 0 || toks[i - 1].0 != "::" => {
                // `super::super::…`: the climb from the module this code is in.
                let mut climbs = 0;
                let mut j = i;
                while toks.get(j).is_some_and(|n| n.0 == "super")
                    && toks.get(j + 1).is_some_and(|n| n.0 == "::")
                {
                    climbs += 1;
                    j += 2;
                }
                let here = path.len() + inline.len();
                if climbs >= here {
                    // Climbed to the crate root: the next segment is a top-level module.
                    let rest = j + 2 * (climbs - here);
                    for name in first_segments(&toks, rest.min(toks.len())) {
                        push(&name, line, &mut found);
                    }
                }
                // `pub(super)` climbs nowhere: step over the word.
                i = j.max(i + 1);
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    found
}

/// The top-level modules: `src/*.rs` and `src/*/` but `lib.rs` and
/// `main.rs`, and `lib.rs`'s inline modules (`pub mod exit { … }`).
fn top_modules() -> BTreeSet<String> {
    let mut modules = BTreeSet::new();
    for entry in std::fs::read_dir(src()).expect("src/").flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if entry.path().is_dir() {
            modules.insert(name);
        } else if let Some(stem) = name.strip_suffix(".rs") {
            if stem != "lib" && stem != "main" {
                modules.insert(stem.to_string());
            }
        }
    }
    let lib = tokens(&code_only(&std::fs::read_to_string(src().join("lib.rs")).expect("lib.rs")));
    for w in lib.windows(3) {
        if w[0].0 == "mod" && w[2].0 == "{" {
            modules.insert(w[1].0.clone());
        }
    }
    modules
}

/// Exported macros (`#[macro_export] macro_rules! name`) by the top-level
/// module that defines them.
fn exported_macros(files: &[PathBuf]) -> BTreeMap<String, String> {
    let mut macros = BTreeMap::new();
    for file in files {
        let Some(own) = module_path(file).first().cloned() else { continue };
        let toks = tokens(&code_only(&std::fs::read_to_string(file).expect("a source file")));
        for (k, w) in toks.windows(3).enumerate() {
            let exported = toks[..k].iter().rev().take(12).any(|t| t.0 == "macro_export");
            if exported && w[0].0 == "macro_rules" && w[1].0 == "!" {
                macros.insert(w[2].0.clone(), own.clone());
            }
        }
    }
    macros
}

#[test]
fn the_table_names_every_top_level_module_once() {
    let named: Vec<String> = layers().into_iter().flatten().collect();
    let set: BTreeSet<String> = named.iter().cloned().collect();
    assert_eq!(set.len(), named.len(), "a module in two rows of the table: {named:?}");
    assert_eq!(set, top_modules(), "the table of {SECTION:?} and the modules of orchestrator/src differ");
}

#[test]
fn imports_run_down_the_layers() {
    let layers = layers();
    let rank: BTreeMap<&str, usize> =
        layers.iter().enumerate().flat_map(|(k, row)| row.iter().map(move |m| (m.as_str(), k))).collect();
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    files.sort();
    let macros = exported_macros(&files);
    let mut checked = 0;
    let mut wrong = Vec::new();
    for file in &files {
        for u in uses_in(file, &macros) {
            checked += 1;
            let (Some(&from), Some(&to)) = (rank.get(u.from.as_str()), rank.get(u.to.as_str())) else {
                wrong.push(format!("{}:{}: `{}` uses `{}`, not in the table", u.file, u.line, u.from, u.to));
                continue;
            };
            if to <= from {
                let how = if to == from { "in its own layer" } else { "in a layer above" };
                wrong.push(format!(
                    "{}:{}: `{}` (layer {}) uses `{}` ({how}, layer {})",
                    u.file,
                    u.line,
                    u.from,
                    from + 1,
                    u.to,
                    to + 1
                ));
            }
        }
    }
    assert!(checked >= 10, "uses between modules are found ({checked})");
    assert!(
        wrong.is_empty(),
        "imports that do not run down the layers of ARCHITECTURE.md:\n{}",
        wrong.join("\n")
    );
}

/// The orchestrator's crates (the workspace members in `orchestrator/`
/// and its sub-folders): each package's name and the names of its
/// dependencies (not its dev-dependencies).
fn orchestrator_crates() -> BTreeMap<String, Vec<String>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let read = |path: &Path| -> toml::Table {
        let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        text.parse().unwrap_or_else(|e| panic!("{}: {e}", path.display()))
    };
    let workspace = read(&root.join("Cargo.toml"));
    let members = workspace["workspace"]["members"].as_array().expect("workspace members");
    let mut crates = BTreeMap::new();
    for member in
        members.iter().filter_map(|m| m.as_str()).filter(|m| m.split('/').next() == Some("orchestrator"))
    {
        let manifest = read(&root.join(member).join("Cargo.toml"));
        let name = manifest["package"]["name"].as_str().expect("a package name").to_string();
        let deps =
            manifest.get("dependencies").and_then(|d| d.as_table()).map(|d| d.keys().cloned().collect());
        crates.insert(name, deps.unwrap_or_default());
    }
    assert!(crates.len() >= 3, "the orchestrator's crates: {crates:?}");
    crates
}

#[test]
fn the_orchestrators_crates_depend_down_their_table() {
    let table = table(CRATES);
    let rank: BTreeMap<&str, usize> =
        table.iter().enumerate().flat_map(|(k, row)| row.iter().map(move |c| (c.as_str(), k))).collect();
    let crates = orchestrator_crates();
    let named: BTreeSet<&str> = rank.keys().copied().collect();
    let real: BTreeSet<&str> = crates.keys().map(String::as_str).collect();
    assert_eq!(named, real, "the table of {CRATES:?} and the workspace's crates in orchestrator/ differ");
    let mut wrong = Vec::new();
    let mut checked = 0;
    for (krate, deps) in &crates {
        for dep in deps.iter().filter(|d| rank.contains_key(d.as_str())) {
            checked += 1;
            let (from, to) = (rank[krate.as_str()], rank[dep.as_str()]);
            if to <= from {
                let how = if to == from { "in its own layer" } else { "in a layer above" };
                wrong.push(format!(
                    "`{krate}` (layer {}) depends on `{dep}` ({how}, layer {})",
                    from + 1,
                    to + 1
                ));
            }
        }
    }
    assert!(checked >= 5, "dependencies between the orchestrator's crates are found ({checked})");
    assert!(wrong.is_empty(), "dependencies that do not run down {CRATES:?}:\n{}", wrong.join("\n"));
}

/// The launch core's own crate (`orchestrator/launch-core/`) depends on no
/// IO crate: every dependency is on this list, written out, so Cargo
/// itself proves the core sans-IO (no tokio, zenoh, iceoryx2, foxglove,
/// mcap, nix, libc, tracing-subscriber, …), and the workspace crates it
/// uses come without the features that bring IO (the protocol's bus
/// backends, the runtime's process pieces, the agent's gateway).
#[test]
fn the_launch_core_depends_on_no_io_crate() {
    /// Each allowed dependency, with the features it may turn on.
    const ALLOWED: &[(&str, &[&str])] = &[
        ("bycoms-gate", &[]),
        ("bycoms-protocol", &[]),
        ("bycoms-sim", &[]),
        ("bycoms-agent", &[]),
        ("bycoms-runtime", &[]),
        ("serde", &["std"]),
        ("postcard", &["alloc"]),
        ("schemars", &[]),
        ("thiserror", &[]),
        // The log facade only (no subscriber: the shell sets one up).
        ("tracing", &[]),
        // Optional (`clap` feature): `OnDeath` and `Missing` as command-line values.
        ("clap", &[]),
    ];
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("launch-core/Cargo.toml");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let manifest: toml::Table = text.parse().unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(manifest["package"]["name"].as_str(), Some("bycoms-launch-core"));
    let deps = manifest.get("dependencies").and_then(|d| d.as_table()).expect("[dependencies]");
    assert!(deps.len() >= 4, "the core's dependencies are read: {deps:?}");
    let mut wrong = Vec::new();
    for (name, spec) in deps {
        let Some((_, features)) = ALLOWED.iter().find(|(a, _)| a == name) else {
            wrong.push(format!("`{name}` is not on the launch core's allow-list"));
            continue;
        };
        let asked = spec.get("features").and_then(|f| f.as_array()).cloned().unwrap_or_default();
        for feature in asked.iter().filter_map(|f| f.as_str()) {
            if !features.contains(&feature) {
                wrong.push(format!("`{name}` with feature `{feature}`, not on the allow-list"));
            }
        }
        if spec.get("default-features").and_then(|d| d.as_bool()) == Some(true) {
            wrong.push(format!("`{name}` with its default features"));
        }
    }
    // Build and target-specific dependencies would escape the list.
    for table in ["build-dependencies", "target"] {
        if manifest.contains_key(table) {
            wrong.push(format!("a [{table}] table"));
        }
    }
    assert!(wrong.is_empty(), "{}:\n{}", path.display(), wrong.join("\n"));
}

/// The crates that do IO (or start threads, or watch signals): none may be
/// among the launch core's dependencies, direct or transitive. A name
/// ending in `*` is a family (`zenoh-transport`, `tokio-util`…).
const IO_CRATES: &[&str] = &[
    "tokio*",
    "mio",
    "socket2",
    "async-*",
    "zenoh*",
    "iceoryx2*",
    "nix",
    "libc",
    "signal-hook*",
    "tracing-subscriber",
    "foxglove",
    "mcap",
    "tempfile",
    "tungstenite",
    "rustls*",
    "quinn*",
    "hyper*",
    "httparse",
    "rcgen",
    "rayon*",
    "indicatif",
    "crossbeam*",
];

/// The packages `cargo tree` lists under `package` built with `args`
/// (normal dependencies only: what the product links), the package itself
/// included.
fn dependency_closure(package: &str, args: &[&str]) -> BTreeSet<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = std::process::Command::new(cargo)
        .args(["tree", "-p", package, "-e", "normal", "--prefix", "none", "--format", "{p}", "--offline"])
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo tree runs");
    assert!(out.status.success(), "cargo tree: {}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).expect("cargo tree's output is UTF-8");
    text.lines().filter_map(|l| l.split_whitespace().next()).map(str::to_owned).collect()
}

/// Whether `name` is one of [`IO_CRATES`].
fn does_io(name: &str) -> bool {
    IO_CRATES.iter().any(|io| match io.strip_suffix('*') {
        Some(family) => name.starts_with(family),
        None => name == *io,
    })
}

/// The allow-list above reads the core's own manifest; a dependency on it
/// could still pull an IO crate in (a default feature of a crate below,
/// a feature another turns on). Cargo's resolution of the core alone,
/// with every feature of its own on, holds none.
#[test]
fn no_io_crate_is_among_the_launch_cores_transitive_dependencies() {
    for args in [&[][..], &["--all-features"][..]] {
        let closure = dependency_closure("bycoms-launch-core", args);
        assert!(closure.contains("bycoms-protocol") && closure.contains("serde"), "read: {closure:?}");
        let io: Vec<&String> = closure.iter().filter(|name| does_io(name)).collect();
        assert!(io.is_empty(), "the launch core ({args:?}) depends on IO crates: {io:?}");
    }
    // The rule sees what it must: the launch above the core does IO.
    let launch = dependency_closure("bycoms-launch", &[]);
    assert!(launch.iter().any(|name| does_io(name)), "the launch's IO crates are seen: {launch:?}");
}

#[test]
fn the_reader_sees_groups_climbs_and_macros_but_not_comments_or_strings() {
    let code = "//! crate::a\nuse crate::{b, c::{d, e}, self};\nlet s = \"crate::f\";\n\
                fn x<'a>(c: char) { let q = '\"'; crate::g!(); }\n\
                use super::h;\nmod tests { use super::*; use super::super::i; }\n/* crate::j */ r#\"crate::k\"#;";
    let macros = BTreeMap::from([("g".to_string(), "out".to_string())]);
    let seen = |path: &[&str]| {
        let path: Vec<String> = path.iter().map(|s| s.to_string()).collect();
        uses_in_code("x.rs", &path, code, &macros).into_iter().map(|u| (u.to, u.line)).collect::<Vec<_>>()
    };
    let from_top = seen(&["top"]);
    let expected = [("b", 2), ("c", 2), ("out", 4), ("h", 5), ("i", 6)].map(|(m, l)| (m.to_string(), l));
    assert_eq!(from_top, expected);
    // One folder down, `super::h` and `super::super::i` stay in `top`.
    let expected = [("b", 2), ("c", 2), ("out", 4)].map(|(m, l)| (m.to_string(), l));
    assert_eq!(seen(&["top", "inner"]), expected);
}

/// No file cycles, in any crate (the file graph, read by the same reader).
#[path = "layers/cycles.rs"]
mod cycles;
