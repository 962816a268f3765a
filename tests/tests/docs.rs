//! Docs that cannot go stale: each test fails when a doc stops telling the
//! truth about the code.
//!
//! * The README's table of environment variables lists exactly the
//!   variables the code reads (every `env::var`/`var_os` of a literal or a
//!   constant, every clap `env = "…"`, every `${NAME:-…}` of the CI
//!   scripts), and nothing the code no longer reads.
//! * ARCHITECTURE.md names every crate of the workspace and every
//!   subcommand of the binaries, and every file or folder it names exists.
//! * PROTOCOL.md's limits are the code's constants.
//!
//! Why tests and not care: these docs are what a newcomer reads first, and
//! each was found false at least once in review (issue 15).

use regex::Regex;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

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

/// Variables that cargo or the shell set for a program, not settings of ours.
fn is_cargos_own(name: &str) -> bool {
    name.starts_with("CARGO") || matches!(name, "OUT_DIR" | "TMPDIR" | "HOME" | "PATH")
}

/// Every environment variable the code reads.
fn variables_read() -> BTreeSet<String> {
    let root = root();
    let mut sources = Vec::new();
    for dir in ["agent", "protocol", "sim-agent", "orchestrator", "gateway", "logging", "tests", "fuzz"] {
        files(&root.join(dir), ".rs", &mut sources);
    }
    let literal = Regex::new(r#"env::var(?:_os)?\(\s*"([A-Z][A-Z0-9_]*)"\s*\)"#).expect("regex");
    let constant = Regex::new(r#"env::var(?:_os)?\(\s*([A-Z][A-Z0-9_]*)\s*\)"#).expect("regex");
    let clap_env = Regex::new(r#"\benv\s*=\s*"([A-Z][A-Z0-9_]*)""#).expect("regex");
    let const_value = Regex::new(r#"const ([A-Z][A-Z0-9_]*): &str = "([A-Z][A-Z0-9_]*)";"#).expect("regex");
    // Names handed to a reader through a helper (`env_u64("BYCOMS_…", …)`).
    let helper_arg = Regex::new(r#"env_[a-z0-9]+\(\s*"([A-Z][A-Z0-9_]*)""#).expect("regex");
    let mut names = BTreeSet::new();
    let mut constants = std::collections::BTreeMap::new();
    let mut wanted_constants = BTreeSet::new();
    for path in &sources {
        let text = read(path);
        for c in const_value.captures_iter(&text) {
            constants.insert(c[1].to_string(), c[2].to_string());
        }
        for re in [&literal, &clap_env, &helper_arg] {
            names.extend(re.captures_iter(&text).map(|c| c[1].to_string()));
        }
        wanted_constants.extend(constant.captures_iter(&text).map(|c| c[1].to_string()));
    }
    for c in wanted_constants {
        let value =
            constants.get(&c).unwrap_or_else(|| panic!("env::var({c}): no `const {c}: &str = \"…\"` found"));
        names.insert(value.clone());
    }
    // The CI scripts: `${NAME:-default}`.
    let shell = Regex::new(r#"\$\{([A-Z][A-Z0-9_]*):-"#).expect("regex");
    let mut scripts = Vec::new();
    files(&root.join(".ci"), "", &mut scripts);
    for path in scripts.iter().filter(|p| p.extension().is_none()) {
        names.extend(shell.captures_iter(&read(path)).map(|c| c[1].to_string()));
    }
    names.retain(|n| !is_cargos_own(n));
    names
}

/// The variables of the README's table ("Every environment variable the code reads").
fn variables_documented() -> BTreeSet<String> {
    let readme = read(&root().join("README.md"));
    let start = readme.find("Every environment variable the code reads").expect("the README's table");
    let name = Regex::new(r"`([A-Z][A-Z0-9_]*)`").expect("regex");
    readme[start..]
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .filter_map(|l| l.split('|').nth(1))
        .flat_map(|cell| name.captures_iter(cell).map(|c| c[1].to_string()).collect::<Vec<_>>())
        .collect()
}

#[test]
fn the_readme_lists_exactly_the_environment_variables_the_code_reads() {
    let read = variables_read();
    let documented = variables_documented();
    assert!(read.len() >= 15, "the scan finds the variables: {read:?}");
    let missing: Vec<_> = read.difference(&documented).collect();
    let stale: Vec<_> = documented.difference(&read).collect();
    assert!(missing.is_empty(), "read by the code but not in the README's table: {missing:?}");
    assert!(stale.is_empty(), "in the README's table but read nowhere: {stale:?}");
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
    for entry in std::fs::read_dir(&root).expect("root").flatten() {
        let path = entry.path();
        if path.is_dir()
            && !entry.file_name().to_string_lossy().starts_with('.')
            && entry.file_name() != "target"
        {
            roots.push(path.clone());
            let mut stack = vec![path.join("src"), path.join("tests")];
            while let Some(dir) = stack.pop() {
                let Ok(entries) = std::fs::read_dir(&dir) else { continue };
                roots.push(dir.clone());
                stack.extend(entries.flatten().map(|e| e.path()).filter(|p| p.is_dir()));
            }
        }
    }
    roots
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
    for binary in ["orchestrator", "sim-agent"] {
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
    for t in token.captures_iter(&doc).map(|c| c[1].to_string()) {
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

/// `text` with every run of white space made one space (docs wrap lines).
fn flat(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[test]
fn protocol_md_states_the_limits_the_code_has() {
    use bycoms_protocol::naming::{SWARM_NAME_MAX, TOPIC_NAME_MAX};
    use bycoms_protocol::{MAX_MESSAGE_LEN, PROTOCOL_VERSION};
    let doc = flat(&read(&root().join("protocol/PROTOCOL.md")));
    let swarm_payload = bycoms_sim::agent_process::ipc_config(3).limits.max_payload;
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
