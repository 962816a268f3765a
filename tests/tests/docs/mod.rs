//! Docs that cannot go stale: each test fails when a doc stops telling the
//! truth about the code.
//!
//! * docs/ENVIRONMENT.md's table of environment variables lists exactly the
//!   variables the code reads (every `env::var`/`var_os` of a literal or a
//!   constant, every clap `env = "…"`, every `${NAME:-…}` of the CI
//!   scripts), and nothing the code no longer reads.
//!   A read whose name the scan cannot see (`env::var(name)` outside a
//!   reader helper) fails it, so a new way of reading is noticed.
//! * ARCHITECTURE.md names every crate of the workspace and every
//!   subcommand of the binaries, and every file or folder it names exists;
//!   each crate's row of its crate table names every top-level module
//!   (`src/*.rs`, `src/*/`) and binary of the crate, and the `fuzz/` row
//!   every fuzz target.
//! * PROTOCOL.md's limits are the code's constants.
//! * ARCHITECTURE.md's layout tree names every top-level folder, and
//!   everything it names exists.
//! * deploy/README.md's table names every file of `deploy/`, and only those.
//! * Every document (`….md`) a source, doc or script cites is in the
//!   repository (a brief or design note kept elsewhere cannot be cited).
//!
//! Why tests and not care: these docs are what a newcomer reads first, and
//! each was found false at least once in review (issue 15).

use regex::Regex;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

mod env_vars;
mod generated;

/// The repository's root.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate is in the repository")
        .to_path_buf()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Every file under `dir` whose name ends with `suffix`, build outputs left out.
fn files(dir: &Path, suffix: &str, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if path.is_dir() {
            if name != "target" && !name.starts_with('.') {
                files(&path, suffix, out);
            }
        } else if name.ends_with(suffix) {
            out.push(path);
        }
    }
}

/// The workspace's members, as written in the root Cargo.toml.
fn members() -> Vec<String> {
    let manifest = read(&root().join("Cargo.toml"));
    let line = manifest.lines().find(|l| l.starts_with("members")).expect("members = [...]");
    Regex::new(r#""([^"]+)""#).expect("regex").captures_iter(line).map(|c| c[1].to_string()).collect()
}

/// The subcommands `--help` lists for binary `name`.
fn subcommands(name: &str) -> Vec<String> {
    let out = std::process::Command::new(bycoms_tests::bin(name)).arg("--help").output().expect("run --help");
    let help = String::from_utf8_lossy(&out.stdout).into_owned();
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        // A command's line; wrapped descriptions are indented further.
        .filter(|l| !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_owned))
        .filter(|c| c != "help")
        .collect()
}

/// Whether a name ARCHITECTURE.md gives as a path exists: from the root,
/// from a crate, or from a crate's `src/` at any depth (the doc names
/// modules by their path inside their crate), as a file, a folder or a
/// module (`x` for `x.rs`).
fn exists(name: &str, roots: &[PathBuf]) -> bool {
    let name = name.split("::").next().unwrap_or(name).trim_end_matches('/');
    let candidates = [name.to_string(), format!("{name}.rs")];
    roots.iter().any(|r| candidates.iter().any(|c| r.join(c).exists()))
}

/// Every folder a name of ARCHITECTURE.md may be relative to.
fn path_roots() -> Vec<PathBuf> {
    let root = root();
    let mut roots = vec![root.clone()];
    let mut folders: Vec<PathBuf> = std::fs::read_dir(&root)
        .expect("root")
        .flatten()
        .filter(|e| {
            e.path().is_dir()
                && !e.file_name().to_string_lossy().starts_with('.')
                && e.file_name() != "target"
        })
        .map(|e| e.path())
        .collect();
    // Nested crates (`protocol/runtime/`) as the top-level ones: their
    // modules from their `src/`.
    folders.extend(members().iter().map(|m| root.join(m)));
    for folder in folders {
        roots.push(folder.clone());
        let mut stack = vec![folder.join("src"), folder.join("tests")];
        while let Some(dir) = stack.pop() {
            let Ok(entries) = std::fs::read_dir(&dir) else { continue };
            roots.push(dir.clone());
            stack.extend(entries.flatten().map(|e| e.path()).filter(|p| p.is_dir()));
        }
    }
    roots
}

/// The paths of ARCHITECTURE.md's layout tree (the ```` ```text ```` block
/// of its "Layout" section), each from the root: `├── agent/` then
/// `│   ├── src/` gives `agent/` and `agent/src/`.
fn layout_tree(doc: &str) -> Vec<String> {
    let start = doc.find("## Layout").expect("ARCHITECTURE.md has a section \"Layout\"");
    let block = doc[start..].split("```").nth(1).expect("the layout's code block");
    let mut stack: Vec<String> = Vec::new();
    let mut paths = Vec::new();
    for line in block.lines() {
        let Some(at) = line.find("── ") else { continue };
        // Each level is four columns: "│   " or "    ", then "├── " or "└── ".
        let depth = line[..at].chars().count() / 4;
        let name = line[at + "── ".len()..].split_whitespace().next().expect("a name").to_string();
        stack.truncate(depth);
        stack.push(name.trim_end_matches('/').to_string());
        paths.push(stack.join("/") + if name.ends_with('/') { "/" } else { "" });
    }
    paths
}

#[test]
fn the_layout_tree_names_every_top_level_folder_and_only_what_exists() {
    let root = root();
    let paths = layout_tree(&read(&root.join("ARCHITECTURE.md")));
    assert!(paths.len() >= 10, "the layout tree is found: {paths:?}");
    for path in &paths {
        let exists = if path.ends_with('/') { root.join(path).is_dir() } else { root.join(path).is_file() };
        assert!(exists, "ARCHITECTURE.md's layout tree names `{path}`, which is not in the repository");
    }
    for entry in std::fs::read_dir(&root).expect("root").flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let hidden = name.starts_with('.') && name != ".ci";
        if entry.path().is_dir() && !hidden && name != "target" {
            assert!(
                paths.contains(&format!("{name}/")),
                "ARCHITECTURE.md's layout tree does not name the top-level folder `{name}/`"
            );
        }
    }
}

#[test]
fn the_layout_tree_is_read_as_drawn() {
    let doc = "## Layout\n\n```text\n.\n├── a/   x\n│   ├── b/   y\n│   └── c.rs\n└── d/\n    └── e/\n```\n";
    assert_eq!(layout_tree(doc), ["a/", "a/b/", "a/c.rs", "d/", "d/e/"]);
}

#[test]
fn architecture_names_every_crate_and_subcommand_and_every_path_it_names_exists() {
    let root = root();
    let doc = read(&root.join("ARCHITECTURE.md"));
    let package_name = Regex::new(r#"(?m)^name = "([^"]+)""#).expect("regex");
    for member in members() {
        assert!(
            doc.contains(&format!("`{member}/`")),
            "ARCHITECTURE.md has no row for the crate in `{member}/`"
        );
        let manifest = read(&root.join(&member).join("Cargo.toml"));
        let package = package_name.captures(&manifest).expect("a name")[1].to_string();
        assert!(doc.contains(&format!("`{package}`")), "ARCHITECTURE.md does not name the crate `{package}`");
    }
    for binary in ["orchestrator", "sim-agent", "gateway"] {
        let commands = subcommands(binary);
        assert!(!commands.is_empty(), "{binary} --help lists its subcommands");
        for command in commands {
            let named =
                doc.contains(&format!("`{command}`")) || doc.contains(&format!("`{binary} {command}"));
            assert!(named, "ARCHITECTURE.md does not name `{binary} {command}`");
        }
    }
    // Every path it names: tokens in backticks with a slash or a file suffix,
    // but topics (`bycoms/…`, `…/<id>/…`), globs and elisions.
    let token = Regex::new(r"`([^`\s]+)`").expect("regex");
    let file = Regex::new(r"\.(rs|md|toml|json5|py|html|sh)$").expect("regex");
    let roots = path_roots();
    let mut checked = 0;
    let prose = generated::without_generated(&doc);
    for t in token.captures_iter(&prose).map(|c| c[1].to_string()) {
        let pathlike = t.contains('/') || file.is_match(t.split("::").next().unwrap_or(&t));
        let not_a_path = t.starts_with("bycoms/")
            || t.starts_with("http")
            || t.contains(['<', '{', '*', '…', '='])
            || t.starts_with('-');
        if pathlike && !not_a_path {
            checked += 1;
            assert!(exists(&t, &roots), "ARCHITECTURE.md names `{t}`, which is not in the repository");
        }
    }
    assert!(checked >= 50, "the paths of ARCHITECTURE.md are checked ({checked})");
}

/// The row of ARCHITECTURE.md's crate table for the crate in `dir/`.
fn crate_row<'a>(doc: &'a str, dir: &str) -> &'a str {
    let start = format!("| `{dir}/` |");
    doc.lines()
        .find(|l| l.starts_with(&start))
        .unwrap_or_else(|| panic!("ARCHITECTURE.md's crate table has no row `{start}`"))
}

/// The names a text gives in backticks, each cut into its segments:
/// `orchestrator/launch/src/agents/` gives `launch` and `agents`, `bycoms_runtime::stats` gives
/// `bycoms_runtime` and `stats`, `lab/process.rs` gives `lab` and `process`.
fn named_segments(text: &str) -> BTreeSet<String> {
    let token = Regex::new(r"`([^`]+)`").expect("regex");
    token
        .captures_iter(text)
        .flat_map(|c| {
            c[1].split(|ch: char| ch.is_whitespace() || ch == '/' || ch == ':' || ch == ',')
                .map(|s| s.trim_end_matches(".rs").to_string())
                .filter(|s| !s.is_empty())
                .collect::<Vec<_>>()
        })
        .collect()
}

/// A crate's top-level modules (`src/*.rs` and `src/*/` but `lib.rs`,
/// `main.rs` and `bin/`) and its binaries (`[[bin]]` names and
/// `src/bin/*.rs`).
fn modules_and_binaries(krate: &Path) -> (BTreeSet<String>, BTreeSet<String>) {
    let mut modules = BTreeSet::new();
    let mut binaries = BTreeSet::new();
    for entry in std::fs::read_dir(krate.join("src")).expect("src/").flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if entry.path().is_dir() {
            if name == "bin" {
                for bin in std::fs::read_dir(entry.path()).expect("src/bin/").flatten() {
                    let bin = bin.file_name().to_string_lossy().into_owned();
                    binaries.extend(bin.strip_suffix(".rs").map(str::to_owned));
                }
            } else {
                modules.insert(name);
            }
        } else if let Some(module) = name.strip_suffix(".rs") {
            if module != "lib" && module != "main" {
                modules.insert(module.to_string());
            }
        }
    }
    let manifest = read(&krate.join("Cargo.toml"));
    let bin_name = Regex::new(r#"(?m)^\[\[bin\]\]\s*\nname = "([^"]+)""#).expect("regex");
    binaries.extend(bin_name.captures_iter(&manifest).map(|c| c[1].to_string()));
    (modules, binaries)
}

#[test]
fn architecture_names_every_top_level_module_binary_and_fuzz_target_in_its_crates_row() {
    let root = root();
    let doc = read(&root.join("ARCHITECTURE.md"));
    let mut missing = Vec::new();
    let mut checked = 0;
    for member in members() {
        let row = crate_row(&doc, &member);
        let named = named_segments(row);
        let (modules, binaries) = modules_and_binaries(&root.join(&member));
        for module in &modules {
            checked += 1;
            if !named.contains(module) {
                missing.push(format!("module `{member}/src/{module}`"));
            }
        }
        for binary in &binaries {
            checked += 1;
            if !named.contains(binary) {
                missing.push(format!("binary `{binary}` of `{member}/`"));
            }
        }
    }
    let fuzz_row = named_segments(crate_row(&doc, "fuzz"));
    let mut targets = Vec::new();
    files(&root.join("fuzz/fuzz_targets"), ".rs", &mut targets);
    assert!(targets.len() >= 5, "the fuzz targets are found: {targets:?}");
    for target in targets {
        let stem = target.file_stem().expect("a file name").to_string_lossy().into_owned();
        checked += 1;
        if !fuzz_row.contains(&stem) {
            missing.push(format!("fuzz target `{stem}`"));
        }
    }
    assert!(checked >= 50, "the crates' modules are found ({checked})");
    assert!(
        missing.is_empty(),
        "ARCHITECTURE.md's crate table does not name, in the crate's row:\n{}",
        missing.join("\n")
    );
}

#[test]
fn deploy_readme_names_every_file_of_deploy_and_nothing_else() {
    let deploy = root().join("deploy");
    let doc = read(&deploy.join("README.md"));
    let token = Regex::new(r"`([^`]+)`").expect("regex");
    // The table's first column: the files and folders it describes.
    let named: Vec<String> = doc
        .lines()
        .filter(|l| l.starts_with("| `"))
        .filter_map(|l| l.split('|').nth(1))
        .flat_map(|cell| token.captures_iter(cell).map(|c| c[1].to_string()).collect::<Vec<_>>())
        .collect();
    assert!(named.len() >= 15, "deploy/README.md's table is found: {named:?}");
    for name in &named {
        assert!(deploy.join(name).exists(), "deploy/README.md names `{name}`, which is not in deploy/");
    }
    let mut all = Vec::new();
    files(&deploy, "", &mut all);
    let mut missing = Vec::new();
    for path in all {
        let relative = path.strip_prefix(&deploy).expect("under deploy/").to_string_lossy().into_owned();
        let covered = relative == "README.md"
            || named.iter().any(|n| *n == relative || (n.ends_with('/') && relative.starts_with(n.as_str())));
        if !covered {
            missing.push(relative);
        }
    }
    assert!(missing.is_empty(), "deploy/README.md's table does not name: {missing:?}");
}

/// Whether `path` ends with `tail` at a path boundary (`protocol/LINK.md`
/// ends with `LINK.md`, not with `INK.md`).
fn ends_with_path(path: &str, tail: &str) -> bool {
    path.strip_suffix(tail).is_some_and(|head| head.is_empty() || head.ends_with('/'))
}

#[test]
fn every_document_the_tree_cites_is_in_the_repository() {
    let root = root();
    let mut documents = Vec::new();
    files(&root, ".md", &mut documents);
    let documents: Vec<String> = documents
        .iter()
        .map(|p| p.strip_prefix(&root).expect("in the repository").to_string_lossy().into_owned())
        .collect();
    assert!(documents.len() >= 8, "the repository's documents are found: {documents:?}");
    let mut texts = Vec::new();
    for suffix in [".rs", ".md", ".toml", ".sh", ".py", ".json5", ".yaml", ".service", ".env"] {
        files(&root, suffix, &mut texts);
    }
    files(&root.join(".ci"), "", &mut texts);
    let cited = Regex::new(r"[A-Za-z0-9_./-]*[A-Za-z0-9_-]+\.md\b").expect("regex");
    let mut checked = 0;
    let mut missing = BTreeSet::new();
    for path in texts.iter().filter(|p| !p.starts_with(root.join("tests/tests/docs"))) {
        let Ok(text) = std::fs::read_to_string(path) else { continue };
        for name in cited.find_iter(&text).map(|m| m.as_str()) {
            checked += 1;
            // From the root, from the citing file's folder, a bare name
            // (`LINK.md`), or an installed copy (`/usr/local/share/doc/bycoms/deploy/README.md`).
            let tail = name.trim_start_matches("../").trim_start_matches("./");
            let found = root.join(name).is_file()
                || path.parent().is_some_and(|dir| dir.join(name).is_file())
                || documents.iter().any(|d| ends_with_path(d, tail) || ends_with_path(tail, d));
            if !found {
                missing.insert(format!("{}: {name}", path.strip_prefix(&root).unwrap_or(path).display()));
            }
        }
    }
    assert!(checked >= 50, "the citations are found ({checked})");
    assert!(missing.is_empty(), "documents cited but not in the repository: {missing:#?}");
}

/// `text` with every run of white space made one space (docs wrap lines).
fn flat(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[test]
fn protocol_md_states_the_limits_the_code_has() {
    use bycoms_protocol::naming::{SWARM_NAME_MAX, TOPIC_NAME_MAX};
    use bycoms_protocol::{MAX_MESSAGE_LEN, PROTOCOL_VERSION};
    let doc = flat(&read(&root().join("protocol/PROTOCOL.md")));
    let swarm_payload = bycoms_runtime::ipc_config(3).limits.max_payload;
    let default_payload = bycoms_protocol::bus::Limits::default().max_payload;
    for claim in [
        format!("at most {MAX_MESSAGE_LEN} bytes (`MAX_MESSAGE_LEN`"),
        format!("(`Limits::max_payload` = {swarm_payload},"),
        format!("The {default_payload} bytes of `Limits::default()`"),
        format!("`<swarm>` is 1–{SWARM_NAME_MAX} bytes"),
        format!("at most {TOPIC_NAME_MAX} bytes, chunks"),
    ] {
        assert!(doc.contains(&claim), "PROTOCOL.md does not say {claim:?}");
    }
    let version = format!(
        "`PROTOCOL_VERSION`, currently **{PROTOCOL_VERSION}** (one byte, `0x{PROTOCOL_VERSION:02X}`)"
    );
    assert!(doc.contains(&version), "PROTOCOL.md does not say {version:?}");
}

/// The README and the documents of `docs/`: what a newcomer reads.
fn readers_documents() -> Vec<PathBuf> {
    let root = root();
    let mut docs = vec![root.join("README.md")];
    files(&root.join("docs"), ".md", &mut docs);
    assert!(docs.len() >= 5, "the README and docs/ are found: {docs:?}");
    docs
}

/// Every path the README and `docs/` name in backticks or link to, from
/// one of the repository's top-level folders (`orchestrator/gate/src/gate.rs`,
/// `deploy/lab/`), exists: moved text must not point at what is gone.
/// Names of outputs (`study/`, `run.mcap`) start elsewhere and are left out.
#[test]
fn the_readme_and_docs_name_only_paths_that_exist() {
    let root = root();
    let top: BTreeSet<String> = std::fs::read_dir(&root)
        .expect("root")
        .flatten()
        .filter(|e| e.path().is_dir() && e.file_name() != "target" && e.file_name() != ".git")
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    let code = Regex::new(r"`([^`\s]+)`").expect("regex");
    let link = Regex::new(r"\]\(([^)#\s]+)").expect("regex");
    let mut checked = 0;
    for doc in readers_documents() {
        let text = read(&doc);
        let dir = doc.parent().expect("a folder");
        let in_code = code.captures_iter(&text).map(|c| c.get(1).expect("a name").as_str());
        let from_top = in_code.map(|t| t.split("::").next().unwrap_or(t)).filter(|t| {
            let first = t.split('/').next().unwrap_or_default();
            t.contains('/') && top.contains(first) && !t.contains(['<', '{', '*', '…', '=', '%', '$'])
        });
        for t in from_top {
            checked += 1;
            let found = root.join(t).exists() || root.join(format!("{t}.rs")).exists();
            assert!(found, "{} names `{t}`, which is not in the repository", doc.display());
        }
        for target in link.captures_iter(&text).map(|c| c.get(1).expect("a target").as_str()) {
            if target.starts_with("http") {
                continue;
            }
            checked += 1;
            assert!(dir.join(target).exists(), "{} links to `{target}`, which is not there", doc.display());
        }
    }
    assert!(checked >= 60, "the paths of the README and docs/ are checked ({checked})");
}

/// Only the README's code blocks are run (`tests/tests/readme_commands.rs`):
/// a block marked runnable elsewhere would look tested and not be.
#[test]
fn only_the_readme_marks_blocks_runnable() {
    for doc in readers_documents().into_iter().filter(|d| !d.ends_with("README.md")) {
        let marked = read(&doc).lines().filter(|l| l.starts_with("```") && l.contains("runnable")).count();
        assert_eq!(marked, 0, "{} marks a code block runnable; only README.md's are run", doc.display());
    }
}
