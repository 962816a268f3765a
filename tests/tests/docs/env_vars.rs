//! docs/ENVIRONMENT.md's table of environment variables against what the
//! code reads (see the module docs of `docs`).

use super::{files, read, root};

/// The document that holds the table.
const ENVIRONMENT_MD: &str = "docs/ENVIRONMENT.md";
use regex::Regex;
use std::collections::BTreeSet;
use std::path::PathBuf;

/// Variables that cargo or the shell set for a program, not settings of ours.
fn is_cargos_own(name: &str) -> bool {
    name.starts_with("CARGO") || matches!(name, "OUT_DIR" | "TMPDIR" | "HOME" | "PATH")
}

/// Variables that third-party code reads when our code calls one of its
/// functions: (the function, the variable).
const READ_BY_DEPENDENCIES: [(&str, &str); 1] = [
    // iceoryx2's log level (`bycoms_runtime::cli::quiet_iceoryx2`).
    ("set_log_level_from_env_or(", "IOX2_LOG_LEVEL"),
];

/// The environment variables read by `sources` (path, text): every
/// `env::var`/`var_os` of a literal, or of a constant (`const X: &str =
/// "NAME";`, from the same file when it defines one, else from the one file
/// that does), every clap `env = "NAME"` or `env = X`, every literal handed
/// to a reader helper (`env_u64("NAME", …)`), and [`READ_BY_DEPENDENCIES`].
/// A read of any other expression (`env::var(name)`) is allowed only inside
/// such a helper (`fn env_…(name: &str…)`); otherwise it is an error, since
/// this scan could not see its name.
fn scan_sources(sources: &[(PathBuf, String)]) -> Result<BTreeSet<String>, String> {
    let literal = Regex::new(r#"env::var(?:_os)?\(\s*"([A-Za-z_][A-Za-z0-9_]*)"\s*\)"#).expect("regex");
    let constant =
        Regex::new(r#"env::var(?:_os)?\(\s*(?:[a-z_0-9]+::)*([A-Z][A-Z0-9_]*)\s*\)"#).expect("regex");
    let any_read = Regex::new(r#"env::var(?:_os)?\(\s*([^)]*)\)"#).expect("regex");
    let clap_env = Regex::new(r#"\benv\s*=\s*"([A-Z][A-Z0-9_]*)""#).expect("regex");
    let clap_const = Regex::new(r#"\benv\s*=\s*([A-Z][A-Z0-9_]*)\b"#).expect("regex");
    let const_value = Regex::new(r#"const ([A-Z][A-Z0-9_]*): &str = "([A-Z][A-Z0-9_]*)";"#).expect("regex");
    let helper_fn = Regex::new(r#"fn env_[a-z0-9_]+\(\s*([a-z_]+)\s*:\s*&str"#).expect("regex");
    let helper_arg = Regex::new(r#"\benv_[a-z0-9_]+\(\s*"([A-Z][A-Z0-9_]*)""#).expect("regex");
    let mut names = BTreeSet::new();
    // Every file's constants, and the constant reads still to resolve.
    let mut everywhere: std::collections::BTreeMap<String, BTreeSet<String>> = Default::default();
    let mut wanted = Vec::new();
    let mut errors = Vec::new();
    for (path, text) in sources {
        let mut own = std::collections::BTreeMap::new();
        for c in const_value.captures_iter(text) {
            own.insert(c[1].to_string(), c[2].to_string());
            everywhere.entry(c[1].to_string()).or_default().insert(c[2].to_string());
        }
        for re in [&literal, &clap_env, &helper_arg] {
            names.extend(re.captures_iter(text).map(|c| c[1].to_string()));
        }
        for re in [&constant, &clap_const] {
            for c in re.captures_iter(text) {
                match own.get(&c[1]) {
                    Some(value) => {
                        names.insert(value.clone());
                    }
                    None => wanted.push((path.clone(), c[1].to_string())),
                }
            }
        }
        let helper_params: BTreeSet<String> =
            helper_fn.captures_iter(text).map(|c| c[1].to_string()).collect();
        for c in any_read.captures_iter(text) {
            let arg = c[1].trim();
            let known = literal.is_match(&c[0]) || constant.is_match(&c[0]) || helper_params.contains(arg);
            if !known {
                errors.push(format!(
                    "{}: `{}` reads a variable this scan cannot name",
                    path.display(),
                    &c[0]
                ));
            }
        }
        for (function, variable) in READ_BY_DEPENDENCIES {
            if text.contains(function) {
                names.insert(variable.to_string());
            }
        }
    }
    for (path, c) in wanted {
        match everywhere.get(&c).map(|v| v.iter().collect::<Vec<_>>()).as_deref() {
            Some([value]) => {
                names.insert(value.to_string());
            }
            Some(values) => errors.push(format!("{}: `{c}` is ambiguous: {values:?}", path.display())),
            None => errors.push(format!("{}: no `const {c}: &str = \"…\"` found", path.display())),
        }
    }
    names.retain(|n| !is_cargos_own(n));
    if errors.is_empty() {
        Ok(names)
    } else {
        Err(errors.join("\n"))
    }
}

/// Every environment variable the code reads: the workspace's Rust sources
/// (`target/` left out) and the CI scripts' `${NAME:-default}`.
fn variables_read() -> BTreeSet<String> {
    let root = root();
    let mut paths = Vec::new();
    for dir in ["agent", "protocol", "sim-agent", "orchestrator", "gateway", "tests", "fuzz"] {
        files(&root.join(dir), ".rs", &mut paths);
    }
    // These tests feed the scan made-up reads and cite made-up documents.
    let sources: Vec<(PathBuf, String)> = paths
        .into_iter()
        .filter(|p| !p.starts_with(root.join("tests/tests/docs")))
        .map(|p| (p.clone(), read(&p)))
        .collect();
    let mut names = scan_sources(&sources).unwrap_or_else(|e| panic!("{e}"));
    let shell = Regex::new(r#"\$\{([A-Z][A-Z0-9_]*):-"#).expect("regex");
    let mut scripts = Vec::new();
    files(&root.join(".ci"), "", &mut scripts);
    for path in scripts.iter().filter(|p| p.extension().is_none()) {
        names.extend(shell.captures_iter(&read(path)).map(|c| c[1].to_string()));
    }
    names.retain(|n| !is_cargos_own(n));
    names
}

#[test]
fn the_scan_finds_every_way_the_code_reads_a_variable() {
    let source = |path: &str, text: &str| (PathBuf::from(path), text.to_string());
    let sources = [
        source("a.rs", r#"let x = std::env::var("A_LITERAL"); let y = env::var_os( "B_OS" );"#),
        source("b.rs", r#"const CHILD_ENV: &str = "C_FILE_B"; fn f() { std::env::var(CHILD_ENV); }"#),
        source("c.rs", r#"const CHILD_ENV: &str = "D_FILE_C"; fn f() { std::env::var_os(CHILD_ENV); }"#),
        source("d.rs", r#"pub const SHARED: &str = "E_SHARED";"#),
        source("e.rs", r#"use d::SHARED; fn f() { std::env::var(d::SHARED); }"#),
        source(
            "f.rs",
            r#"#[arg(long, env = "F_CLAP")] x: u8, #[arg(env = FMT)] y: u8, const FMT: &str = "G_FMT";"#,
        ),
        source(
            "g.rs",
            r#"fn env_u64(name: &str, d: u64) -> u64 { std::env::var(name) } env_u64("H_HELPER", 1);"#,
        ),
        source("h.rs", "set_log_level_from_env_or(LogLevel::Error);"),
        source("i.rs", r#"std::env::var("CARGO_PKG_NAME"); std::env::var_os("PATH");"#),
    ];
    let found = scan_sources(&sources).expect("every read is named");
    let expected = [
        "A_LITERAL",
        "B_OS",
        "C_FILE_B",
        "D_FILE_C",
        "E_SHARED",
        "F_CLAP",
        "G_FMT",
        "H_HELPER",
        "IOX2_LOG_LEVEL",
    ];
    assert_eq!(found, expected.iter().map(|s| s.to_string()).collect::<BTreeSet<_>>());
    // A read whose name the scan cannot see fails it, as does an unknown constant.
    let hidden = [source("x.rs", "let n = name(); std::env::var(n);")];
    assert!(scan_sources(&hidden).is_err());
    let unknown = [source("y.rs", "std::env::var(NOWHERE);")];
    assert!(scan_sources(&unknown).is_err());
    let ambiguous = [sources[1].clone(), sources[2].clone(), source("z.rs", "std::env::var(CHILD_ENV);")];
    assert!(scan_sources(&ambiguous).is_err());
}

/// The variables of docs/ENVIRONMENT.md's table ("Every environment variable the code reads").
fn variables_documented() -> BTreeSet<String> {
    let readme = read(&root().join(ENVIRONMENT_MD));
    let start =
        readme.find("Every environment variable the code reads").expect("docs/ENVIRONMENT.md's table");
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
fn the_environment_doc_lists_exactly_the_variables_the_code_reads() {
    let read = variables_read();
    let documented = variables_documented();
    assert!(read.len() >= 15, "the scan finds the variables: {read:?}");
    let missing: Vec<_> = read.difference(&documented).collect();
    let stale: Vec<_> = documented.difference(&read).collect();
    assert!(missing.is_empty(), "read by the code but not in docs/ENVIRONMENT.md's table: {missing:?}");
    assert!(stale.is_empty(), "in docs/ENVIRONMENT.md's table but read nowhere: {stale:?}");
}

/// `a/{b,c}_d.rs` → `a/b_d.rs`, `a/c_d.rs` (one brace group at most).
fn expand_braces(path: &str) -> Vec<String> {
    match (path.find('{'), path.find('}')) {
        (Some(open), Some(close)) if open < close => path[open + 1..close]
            .split(',')
            .map(|alt| format!("{}{alt}{}", &path[..open], &path[close + 1..]))
            .collect(),
        _ => vec![path.to_string()],
    }
}

#[test]
fn the_environment_doc_names_where_each_variable_is_read() {
    let root = root();
    let readme = read(&root.join(ENVIRONMENT_MD));
    let start =
        readme.find("Every environment variable the code reads").expect("docs/ENVIRONMENT.md's table");
    let token = Regex::new(r"`([^`]+)`").expect("regex");
    let mut checked = 0;
    for row in
        readme[start..].lines().skip_while(|l| !l.starts_with('|')).take_while(|l| l.starts_with('|')).skip(2)
    {
        let cells: Vec<&str> = row.split('|').collect();
        let (Some(variables), Some(read_by)) = (cells.get(1), cells.get(3)) else {
            panic!("a row of docs/ENVIRONMENT.md's table without its columns: {row}");
        };
        let files: Vec<String> = token
            .captures_iter(read_by)
            .map(|c| c[1].to_string())
            .filter(|t| t.contains('/'))
            .flat_map(|t| expand_braces(&t))
            .collect();
        for file in &files {
            assert!(
                root.join(file).is_file(),
                "docs/ENVIRONMENT.md's table names `{file}`, which is not in the repository"
            );
        }
        for variable in token.captures_iter(variables).map(|c| c[1].to_string()) {
            if files.is_empty() {
                continue;
            }
            checked += 1;
            assert!(
                files.iter().any(|f| read(&root.join(f)).contains(&variable)),
                "docs/ENVIRONMENT.md says {files:?} read `{variable}`, and none of them names it"
            );
        }
    }
    assert!(checked >= 15, "the table's files are checked ({checked})");
}
