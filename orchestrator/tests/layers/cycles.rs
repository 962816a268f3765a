//! No file cycles and no module cycles, in any crate of the workspace.
//!
//! The same reader (`code_only`, `tokens`) builds the graph of files of each
//! crate that has a `src/`: file F has an edge to file G when F's code names
//! an item that G defines (or module G itself), by a path from `crate::`,
//! `super::`, `self::`, a child module or a name F imported. A path is
//! followed through the imports and re-exports of the modules it crosses
//! (`crate::launch::LaunchConfig` is an edge to `orchestrator/launch/src/config.rs`, not to
//! `orchestrator/launch/src/lib.rs`), so a facade re-export is not a dependency.
//!
//! Parent and child: `mod x;` is no edge. A parent's `pub use` of its own
//! descendant's items (its facade) is no edge either. A child using its
//! parent's own items (`super::Thing` defined in the parent file) is an edge,
//! and so is a parent's code using a child's item; both together are a
//! cycle — two files whose items depend on each other (cargo-modules's
//! rule). Test code (`#[cfg(test)]` modules, inline or in their own file)
//! is not read, as cargo-modules does not unless asked (`--cfg-test`): a
//! test may use the harness that uses the code it tests. Binary roots (`main.rs` beside a `lib.rs`, `src/bin/`) use the
//! library by its crate name (an edge Cargo keeps acyclic); they must
//! declare no modules, which the test checks.

use super::{code_only, rust_files, tokens};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// One crate's sources: path under `src/` → text.
type Tree = BTreeMap<PathBuf, String>;

/// A module path, root first (`[]` is the crate root).
type ModPath = Vec<String>;

/// Where a name imported from another crate leads (no file of this one).
const EXTERN: &str = "<another crate>";

/// What one file says: its module, the items it defines, its imports
/// (local name → absolute path; `*` entries are globs), and the paths its
/// code names (absolute, with the line and whether it is a facade re-export).
#[derive(Default)]
struct FileFacts {
    items: BTreeSet<String>,
    imports: Vec<(String, ModPath)>,
    named: Vec<(ModPath, usize, bool)>,
}

/// A module path from a file's path under `src/` (see `super::module_path`).
fn module_path_rel(rel: &Path) -> ModPath {
    let mut path: Vec<String> = rel.iter().map(|s| s.to_string_lossy().into_owned()).collect();
    let last = path.pop().expect("a file name");
    let stem = last.trim_end_matches(".rs");
    if !(stem == "mod" || (path.is_empty() && (stem == "lib" || stem == "main"))) {
        path.push(stem.to_string());
    }
    path
}

/// The files of the crate's module tree: the library's (or the binary's
/// when there is no library), with binary roots beside a library left out.
fn tree_files(tree: &Tree) -> Vec<&PathBuf> {
    let has_lib = tree.contains_key(Path::new("lib.rs"));
    let binary_root = |p: &Path| p.starts_with("bin") || (has_lib && p == Path::new("main.rs"));
    for (p, text) in tree.iter().filter(|(p, _)| binary_root(p)) {
        let toks = tokens(&code_only(text));
        let declares = toks.windows(3).any(|w| w[0].0 == "mod" && w[2].0 == ";");
        assert!(!declares, "{}: a binary root beside the library declares modules (not read)", p.display());
    }
    tree.keys().filter(|p| !binary_root(p)).collect()
}

/// Parses one use tree at token `i` under `prefix`; returns the index after it.
fn use_tree(
    t: &[(String, usize)],
    mut i: usize,
    mut prefix: ModPath,
    out: &mut Vec<(String, ModPath)>,
) -> usize {
    let word = |k: usize| t.get(k).map_or("", |w| w.0.as_str());
    loop {
        match word(i) {
            "{" => {
                i += 1;
                while !matches!(word(i), "}" | "") {
                    i = use_tree(t, i, prefix.clone(), out);
                    if word(i) == "," {
                        i += 1;
                    }
                }
                return i + 1;
            }
            "*" => {
                out.push(("*".into(), prefix));
                return i + 1;
            }
            "::" => i += 1,
            "" | ";" | "}" | "," => return i,
            w => {
                prefix.push(w.to_string());
                i += 1;
                if word(i) == "::" {
                    i += 1;
                    continue;
                }
                let name = if word(i) == "as" {
                    i += 2;
                    word(i - 1).to_string()
                } else if w == "self" {
                    prefix.pop();
                    prefix.last().cloned().unwrap_or_default()
                } else {
                    w.to_string()
                };
                out.push((name, prefix));
                return i;
            }
        }
    }
}

/// An absolute module path from a path written in module `here`, or None
/// for another crate's path (or a name this reader cannot place).
fn absolute(
    seg: &[String],
    here: &[String],
    known: &dyn Fn(&[String]) -> bool,
    imports: &[(String, ModPath)],
) -> Option<ModPath> {
    let first = seg.first()?.as_str();
    match first {
        "crate" | "$crate" => Some(seg[1..].to_vec()),
        "self" => Some(here.iter().chain(&seg[1..]).cloned().collect()),
        "super" => {
            let climbs = seg.iter().take_while(|s| *s == "super").count();
            let base = here.get(..here.len().checked_sub(climbs)?)?;
            Some(base.iter().chain(&seg[climbs..]).cloned().collect())
        }
        _ => {
            let child: ModPath = here.iter().chain(std::iter::once(&seg[0])).cloned().collect();
            if known(&child) {
                return Some(here.iter().chain(seg).cloned().collect());
            }
            let (_, to) = imports.iter().find(|(name, _)| name == first)?;
            Some(to.iter().chain(&seg[1..]).cloned().collect())
        }
    }
}

/// The facts of one file (module `path`), given the crate's known modules.
fn facts_of(text: &str, path: &[String], known: &dyn Fn(&[String]) -> bool) -> FileFacts {
    let toks = tokens(&code_only(text));
    let word = |k: usize| toks.get(k).map_or("", |w| w.0.as_str());
    let mut facts = FileFacts::default();
    // Imports first (written relative to the module they are in), then paths.
    let mut raw: Vec<(ModPath, ModPath, usize, bool, bool)> = Vec::new(); // (here, path, line, is_use, public)
    let mut rel_imports: Vec<(String, ModPath, ModPath)> = Vec::new(); // (name, here, path)
    let mut inline: Vec<(usize, String)> = Vec::new();
    let mut depth = 0usize;
    let mut i = 0;
    while i < toks.len() {
        let here: ModPath = path.iter().cloned().chain(inline.iter().map(|m| m.1.clone())).collect();
        let line = toks[i].1;
        match word(i) {
            "{" => depth += 1,
            "}" => {
                depth = depth.saturating_sub(1);
                if inline.last().is_some_and(|m| m.0 == depth + 1) {
                    inline.pop();
                }
            }
            "mod" if word(i + 2) == "{" && test_only(&toks, i) => {
                // Test code is not read: step over its braces.
                let mut open = 0usize;
                i += 2;
                while i < toks.len() {
                    match word(i) {
                        "{" => open += 1,
                        "}" => open -= 1,
                        _ => {}
                    }
                    i += 1;
                    if open == 0 {
                        break;
                    }
                }
                continue;
            }
            "mod" if word(i + 2) == "{" => {
                facts.items.insert(word(i + 1).to_string());
                inline.push((depth + 1, word(i + 1).to_string()));
            }
            "fn" | "struct" | "enum" | "trait" | "type" | "const" | "static" | "union" => {
                facts.items.insert(word(i + 1).to_string());
            }
            "macro_rules" if word(i + 1) == "!" => {
                facts.items.insert(word(i + 2).to_string());
            }
            "use" => {
                let public = (1..=4).any(|b| i >= b && word(i - b) == "pub");
                let mut found = Vec::new();
                i = use_tree(&toks, i + 1, Vec::new(), &mut found);
                for (name, p) in found {
                    rel_imports.push((name, here.clone(), p.clone()));
                    raw.push((here.clone(), p, line, true, public));
                }
                continue;
            }
            w if (w == "crate"
                || w == "$crate"
                || w == "super"
                || w == "self"
                || known(&[here.clone(), vec![w.to_string()]].concat()))
                && word(i + 1) == "::"
                && (i == 0 || word(i - 1) != "::") =>
            {
                let mut seg = vec![w.to_string()];
                let mut j = i + 1;
                while word(j) == "::"
                    && toks.get(j + 1).is_some_and(|t| t.0.chars().all(|c| c.is_alphanumeric() || c == '_'))
                {
                    seg.push(word(j + 1).to_string());
                    j += 2;
                }
                raw.push((here, seg, line, false, false));
                i = j;
                continue;
            }
            _ => {}
        }
        i += 1;
    }
    // Paths through a name this file imported are written in code as `name::…`.
    for (k, w) in toks.windows(2).enumerate() {
        let imported = rel_imports.iter().any(|(n, _, _)| *n == w[0].0);
        if imported
            && w[1].0 == "::"
            && (k == 0 || toks[k - 1].0 != "::")
            && !raw.iter().any(|r| r.2 == w[0].1 && r.1[0] == w[0].0)
        {
            let mut seg = vec![w[0].0.clone()];
            let mut j = k + 1;
            while word(j) == "::"
                && toks.get(j + 1).is_some_and(|t| t.0.chars().all(|c| c.is_alphanumeric() || c == '_'))
            {
                seg.push(word(j + 1).to_string());
                j += 2;
            }
            raw.push((path.to_vec(), seg, w[0].1, false, false));
        }
    }
    let direct: Vec<(String, ModPath)> = rel_imports
        .iter()
        .filter_map(|(n, here, p)| Some((n.clone(), absolute(p, here, known, &[])?)))
        .collect();
    // A name imported from another crate (or re-exported from one) leads out.
    facts.imports = rel_imports
        .iter()
        .map(|(n, here, p)| {
            (n.clone(), absolute(p, here, known, &direct).unwrap_or_else(|| vec![EXTERN.into()]))
        })
        .collect();
    for (here, seg, line, _is_use, public) in raw {
        let Some(abs) = absolute(&seg, &here, known, &facts.imports) else { continue };
        // A facade: a `pub use` of the file's own descendants.
        let facade = public && abs.len() > path.len() + 1 && abs.starts_with(path);
        facts.named.push((abs, line, facade));
    }
    facts
}

/// Whether the `mod` at token `i` is under `#[cfg(test)]` (test code).
fn test_only(toks: &[(String, usize)], i: usize) -> bool {
    let start = if i > 0 && toks[i - 1].0 == "pub" { i - 1 } else { i };
    let attribute = ["#", "[", "cfg", "(", "test", ")", "]"];
    start >= attribute.len()
        && toks[start - attribute.len()..start].iter().map(|t| t.0.as_str()).eq(attribute)
}

/// The crate's files by module path (inline modules by their file's),
/// with their facts.
struct Crate {
    files: BTreeMap<ModPath, PathBuf>,
    facts: BTreeMap<PathBuf, FileFacts>,
}

impl Crate {
    fn of(tree: &Tree) -> Crate {
        let mut files: BTreeMap<ModPath, PathBuf> =
            tree_files(tree).into_iter().map(|p| (module_path_rel(p), p.clone())).collect();
        // Files of test code (`#[cfg(test)] mod tests;`) and all below them are not read.
        let mut tests: Vec<ModPath> = Vec::new();
        for (path, file) in &files {
            let toks = tokens(&code_only(&tree[file]));
            for (i, w) in toks.windows(3).enumerate() {
                if w[0].0 == "mod" && w[2].0 == ";" && test_only(&toks, i) {
                    tests.push(path.iter().chain(std::iter::once(&w[1].0)).cloned().collect());
                }
            }
        }
        files.retain(|path, _| !tests.iter().any(|t| path.starts_with(t)));
        // Inline modules are known too, as parts of their file.
        let mut all: BTreeSet<ModPath> = files.keys().cloned().collect();
        for (path, file) in &files {
            let toks = tokens(&code_only(&tree[file]));
            for w in toks.windows(3).filter(|w| w[0].0 == "mod" && w[2].0 == "{") {
                all.insert(path.iter().chain(std::iter::once(&w[1].0)).cloned().collect());
            }
        }
        let known = |p: &[String]| all.contains(p);
        let facts =
            files.iter().map(|(path, file)| (file.clone(), facts_of(&tree[file], path, &known))).collect();
        Crate { files, facts }
    }

    /// The file of the longest module prefix of `abs`, and that prefix's length.
    fn module_of(&self, abs: &[String]) -> (usize, &PathBuf) {
        (0..=abs.len()).rev().find_map(|k| self.files.get(&abs[..k]).map(|f| (k, f))).expect("the crate root")
    }

    /// The file that defines what `abs` names, following imports and
    /// re-exports; `true` when the file is sure to define it.
    fn resolve(&self, abs: &[String], depth: usize) -> (PathBuf, bool) {
        if abs.first().is_some_and(|s| s == EXTERN) {
            return (PathBuf::from(EXTERN), true);
        }
        let (k, file) = self.module_of(abs);
        let Some(name) = abs.get(k) else { return (file.clone(), true) };
        let facts = &self.facts[file];
        if facts.items.contains(name) || depth > 8 {
            return (file.clone(), facts.items.contains(name));
        }
        if let Some((_, to)) = facts.imports.iter().find(|(n, _)| n == name) {
            let to: ModPath = to.iter().chain(&abs[k + 1..]).cloned().collect();
            return self.resolve(&to, depth + 1);
        }
        for (_, glob) in facts.imports.iter().filter(|(n, g)| n == "*" && g.as_slice() != &abs[..k]) {
            let to: ModPath = glob.iter().chain(&abs[k..]).cloned().collect();
            if self.module_of(&to).0 > 0 || to.len() == abs.len() - k {
                let (f, sure) = self.resolve(&to, depth + 1);
                if sure {
                    return (f, true);
                }
            }
        }
        (file.clone(), false)
    }

    /// The edges between files: (from, to) → the first line of `from` that uses `to`.
    fn edges(&self) -> BTreeMap<(PathBuf, PathBuf), usize> {
        let mut edges = BTreeMap::new();
        for (file, facts) in &self.facts {
            for (abs, line, facade) in &facts.named {
                let (to, _) = self.resolve(abs, 0);
                if !facade && &to != file && to != Path::new(EXTERN) {
                    edges.entry((file.clone(), to)).or_insert(*line);
                }
            }
        }
        edges
    }
}

/// Every cycle of files (one per strongly connected set), each as the
/// files in order with the line of each use: `a.rs:3 → b.rs:9 → a.rs`.
fn cycles(tree: &Tree) -> Vec<(String, Vec<PathBuf>)> {
    cycles_of(&Crate::of(tree).edges())
}

/// Every cycle of a graph of `edges` ((from, to) → the line of `from` that
/// uses `to`), one per strongly connected set.
fn cycles_of(edges: &BTreeMap<(PathBuf, PathBuf), usize>) -> Vec<(String, Vec<PathBuf>)> {
    let mut next: BTreeMap<&PathBuf, Vec<&PathBuf>> = BTreeMap::new();
    for (from, to) in edges.keys() {
        next.entry(from).or_default().push(to);
    }
    let mut done: BTreeSet<&PathBuf> = BTreeSet::new();
    let mut found = Vec::new();
    for start in next.keys() {
        let seen = reached(&next, start);
        if done.contains(start) || !seen.contains_key(start) {
            continue;
        }
        // Walk back from `start` to itself: the shortest cycle through it.
        let mut back = Vec::new();
        let mut at = seen[start];
        while at != *start {
            back.push(at);
            at = seen[at];
        }
        let path: Vec<&PathBuf> = std::iter::once(*start).chain(back.into_iter().rev()).collect();
        let mut text = String::new();
        for (k, f) in path.iter().enumerate() {
            let to = path.get(k + 1).unwrap_or(&path[0]);
            text.push_str(&format!("{}:{} → ", f.display(), edges[&((*f).clone(), (*to).clone())]));
        }
        text.push_str(&start.display().to_string());
        // The files that reach `start` and that it reaches: one set, one report.
        let set: Vec<&PathBuf> =
            seen.keys().copied().filter(|f| reached(&next, f).contains_key(*start)).collect();
        if set.len() > path.len() {
            let names: Vec<String> = set.iter().map(|f| f.display().to_string()).collect();
            text.push_str(&format!(" (one cycle of the set {{{}}})", names.join(", ")));
        }
        done.extend(set.iter().copied());
        found.push((text, set.into_iter().cloned().collect()));
    }
    found
}

/// Each file reached from `from`, breadth first → the file it was reached from.
fn reached<'a>(
    next: &BTreeMap<&'a PathBuf, Vec<&'a PathBuf>>,
    from: &'a PathBuf,
) -> BTreeMap<&'a PathBuf, &'a PathBuf> {
    let mut seen = BTreeMap::new();
    let mut queue = std::collections::VecDeque::from([from]);
    while let Some(f) = queue.pop_front() {
        for &t in next.get(f).into_iter().flatten() {
            if !seen.contains_key(t) {
                seen.insert(t, f);
                queue.push_back(t);
            }
        }
    }
    seen
}

/// The sources of one crate folder's `src/`.
fn tree_of(dir: &Path) -> Tree {
    let src = dir.join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    files
        .into_iter()
        .map(|f| {
            let text = std::fs::read_to_string(&f).expect("a source file");
            (f.strip_prefix(&src).expect("under src/").to_path_buf(), text)
        })
        .collect()
}

/// The workspace's member folders that have a `src/`.
fn members() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let manifest = std::fs::read_to_string(root.join("Cargo.toml")).expect("the workspace's Cargo.toml");
    let line = manifest.lines().find(|l| l.starts_with("members")).expect("members = [...]");
    let members: Vec<PathBuf> =
        line.split('"').skip(1).step_by(2).map(|m| root.join(m)).filter(|d| d.join("src").is_dir()).collect();
    assert!(members.len() >= 5, "the workspace's members: {members:?}");
    members
}

#[test]
fn no_file_cycles_in_any_crate() {
    let mut found = Vec::new();
    let mut edges = 0;
    for dir in members() {
        let tree = tree_of(&dir);
        edges += Crate::of(&tree).edges().len();
        let name = dir.file_name().expect("a folder").to_string_lossy().into_owned();
        for (text, _) in cycles(&tree) {
            found.push(format!("{name}: {text}"));
        }
    }
    assert!(edges > 300, "edges between files are found ({edges})");
    assert!(found.is_empty(), "cycles of files (each file uses the next):\n{}", found.join("\n"));
}

#[test]
fn a_cycle_of_files_is_seen_and_a_facade_is_not_one() {
    let tree = |files: &[(&str, &str)]| -> Tree {
        files.iter().map(|(p, t)| (PathBuf::from(p), t.to_string())).collect()
    };
    // config → faults → transport → config, through a re-export of `launch`.
    let cyclic = tree(&[
        ("lib.rs", "pub mod launch;"),
        ("launch/mod.rs", "mod config; mod faults; mod transport; pub use config::Config;"),
        ("launch/config.rs", "use super::faults::Fault;\npub struct Config;"),
        ("launch/faults.rs", "pub struct Fault(crate::launch::transport::Wire);"),
        (
            "launch/transport.rs",
            "// crate::launch::Config in a comment\n\nfn f(c: &crate::launch::Config) {}\npub struct Wire;",
        ),
    ]);
    let text = |c: Vec<(String, Vec<PathBuf>)>| c.into_iter().map(|c| c.0).collect::<Vec<_>>();
    assert_eq!(
        text(cycles(&cyclic)),
        ["launch/config.rs:1 → launch/faults.rs:1 → launch/transport.rs:3 → launch/config.rs"]
    );
    // The same without transport's use (but in its test module): a facade, a
    // child using its parent's re-export, test code and a parent using a child.
    let acyclic = tree(&[
        ("lib.rs", "pub mod launch; pub use launch::*;"),
        (
            "launch/mod.rs",
            "mod config; mod faults; mod transport; #[cfg(test)] mod tests;\n\
                           pub use config::Config; fn go() { faults::f(); }",
        ),
        ("launch/config.rs", "use super::faults::Fault;\npub struct Config;"),
        ("launch/faults.rs", "pub struct Fault(crate::launch::transport::Wire); pub fn f() {}"),
        (
            "launch/transport.rs",
            "fn f() { let s = \"crate::launch::Config\"; }\npub struct Wire;\n\
             #[cfg(test)]\nmod tests { use crate::launch::Config; }",
        ),
        ("launch/tests.rs", "use super::*; use crate::Config;"),
    ]);
    assert_eq!(text(cycles(&acyclic)), Vec::<String>::new());
    // A child using its parent's own item while the parent uses the child: a cycle.
    let pair = tree(&[
        ("lib.rs", "mod a; pub struct Own; fn g() { a::f(); }"),
        ("a.rs", "pub fn f(_: super::Own) {}"),
    ]);
    assert_eq!(text(cycles(&pair)), ["a.rs:1 → lib.rs:1 → a.rs"]);
    // But not when the parent's item is another crate's, re-exported.
    let external = tree(&[
        ("lib.rs", "mod a; pub use std::fmt::Write as Own; fn g() { a::f(); }"),
        ("a.rs", "pub fn f(_: &dyn super::Own) {}"),
    ]);
    assert_eq!(text(cycles(&external)), Vec::<String>::new());
}

/// The top-level module of a file under `src/` (`ros2.rs` and `ros2/bag.rs`
/// are `ros2`); the crate root's own file is none.
fn top_module(file: &Path) -> Option<PathBuf> {
    module_path_rel(file).into_iter().next().map(PathBuf::from)
}

/// Every cycle of top-level modules: the file graph with each file read as
/// its top-level module (`config` → `ros2` when a file of `config` uses one
/// of `ros2`), each use shown at the line of the first file that makes it.
/// The crate root's file is left out: it declares every module.
fn module_cycles(tree: &Tree) -> Vec<(String, Vec<PathBuf>)> {
    let mut folded = BTreeMap::new();
    for ((from, to), line) in Crate::of(tree).edges() {
        if let (Some(a), Some(b)) = (top_module(&from), top_module(&to)) {
            if a != b {
                folded.entry((a, b)).or_insert(line);
            }
        }
    }
    cycles_of(&folded)
}

/// No module cycles either: in every crate, no two top-level modules use
/// each other, directly or round a loop, through any of their files (the
/// issue's `config` ↔ `ros2` of the launch was one, with no file cycle:
/// `config.rs` used `ros2/config.rs` and `ros2.rs` used `config.rs`).
#[test]
fn no_module_cycles_in_any_crate() {
    let mut found = Vec::new();
    for dir in members() {
        let name = dir.file_name().expect("a folder").to_string_lossy().into_owned();
        for (text, _) in module_cycles(&tree_of(&dir)) {
            found.push(format!("{name}: {text}"));
        }
    }
    assert!(found.is_empty(), "cycles of top-level modules (each uses the next):\n{}", found.join("\n"));
}

#[test]
fn a_module_cycle_is_seen_through_files_that_make_no_file_cycle() {
    let tree = |files: &[(&str, &str)]| -> Tree {
        files.iter().map(|(p, t)| (PathBuf::from(p), t.to_string())).collect()
    };
    let files = [
        ("lib.rs", "mod config; mod ros2;"),
        ("config.rs", "pub struct Launch { pub ros2: crate::ros2::Ros2Config }"),
        ("ros2.rs", "mod config; pub use config::Ros2Config;\nfn world(_: &crate::config::Launch) {}"),
        ("ros2/config.rs", "pub struct Ros2Config;"),
    ];
    let cyclic = tree(&files);
    assert_eq!(cycles(&cyclic), Vec::new(), "no two files use each other");
    let text: Vec<String> = module_cycles(&cyclic).into_iter().map(|c| c.0).collect();
    assert_eq!(text, ["config:1 → ros2:2 → config"]);
    // Ros2Config moved into `config`: the output uses the config, not back.
    let moved = tree(&[
        ("lib.rs", "mod config; mod ros2;"),
        ("config.rs", "mod ros2; pub use ros2::Ros2Config;\npub struct Launch { pub ros2: Ros2Config }"),
        ("config/ros2.rs", "pub struct Ros2Config;"),
        ("ros2.rs", "pub use crate::config::Ros2Config;\nfn world(_: &crate::config::Launch) {}"),
    ]);
    assert_eq!(module_cycles(&moved), Vec::new());
}
