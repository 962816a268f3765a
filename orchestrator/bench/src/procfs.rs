//! The one reader of `/proc` the benches share: a process's memory, its
//! CPU time, its open files, its descendants.
//!
//! Why one module: `bench scale` reads each agent's memory and `bench
//! crowd` the memory and open files of a whole launch (the orchestrator and
//! every agent it started); both must read the same lines the same way, so
//! a figure of one bench means what it means in the other. Memory is read
//! from `/proc/<pid>/status` (RSS, split into anonymous, file and
//! shared-memory pages) and `/proc/<pid>/smaps_rollup` (PSS: shared pages
//! divided among the processes sharing them, so the PSS of a set of
//! processes adds up to what they use together). A process that is gone
//! reads as nothing (zeros, `None`, not listed): the benches sample
//! processes that may end at any moment.

use serde::Serialize;
use std::collections::BTreeMap;

/// Memory of one process, kB.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Memory {
    pub rss_kb: u64,
    pub rss_anon_kb: u64,
    pub rss_file_kb: u64,
    pub rss_shmem_kb: u64,
    pub pss_kb: u64,
}

/// The number after `key` on the line of `text` that starts with it
/// (`"Pss:   399 kB"` → 399); 0 when there is no such line.
pub fn field(text: &str, key: &str) -> u64 {
    text.lines()
        .find_map(|l| l.strip_prefix(key))
        .and_then(|rest| rest.split_whitespace().next()?.parse().ok())
        .unwrap_or(0)
}

/// Memory of `status` and `smaps_rollup` texts.
pub fn memory_of(status: &str, rollup: &str) -> Memory {
    Memory {
        rss_kb: field(status, "VmRSS:"),
        rss_anon_kb: field(status, "RssAnon:"),
        rss_file_kb: field(status, "RssFile:"),
        rss_shmem_kb: field(status, "RssShmem:"),
        pss_kb: field(rollup, "Pss:"),
    }
}

/// Reads a process's memory from `/proc` (zeros when it is gone).
pub fn memory(pid: u32) -> Memory {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    memory_of(&status, &rollup(pid))
}

/// A process's PSS, kB (0 when it is gone): `smaps_rollup` only, the
/// cheaper half of [`memory`] for a bench that samples many processes.
pub fn pss_kb(pid: u32) -> u64 {
    field(&rollup(pid), "Pss:")
}

fn rollup(pid: u32) -> String {
    std::fs::read_to_string(format!("/proc/{pid}/smaps_rollup")).unwrap_or_default()
}

/// A process's open files (the entries of `/proc/<pid>/fd`); `None` when
/// it is gone.
pub fn open_files(pid: u32) -> Option<usize> {
    Some(std::fs::read_dir(format!("/proc/{pid}/fd")).ok()?.count())
}

/// The parent pid in a `/proc/<pid>/stat` line. The command name (second
/// field, in parentheses) may hold spaces and parentheses itself, so the
/// fields are counted from its last `)`: state, then the parent's pid.
pub fn parent_in_stat(stat: &str) -> Option<u32> {
    let (_, rest) = stat.rsplit_once(')')?;
    rest.split_whitespace().nth(1)?.parse().ok()
}

/// The CPU time (user + system) in a `/proc/<pid>/stat` line, clock ticks
/// (100 a second on Linux): fields 14 and 15 of stat(5), counted after the
/// command name's last `)` as [`parent_in_stat`] does.
pub fn cpu_in_stat(stat: &str) -> Option<u64> {
    let (_, rest) = stat.rsplit_once(')')?;
    let mut fields = rest.split_whitespace().skip(11);
    let user: u64 = fields.next()?.parse().ok()?;
    let system: u64 = fields.next()?.parse().ok()?;
    Some(user + system)
}

/// The CPU time process `pid` has used so far, clock ticks; `None` when
/// it is gone. `"self"` is this process.
pub fn cpu_ticks(pid: &str) -> Option<u64> {
    cpu_in_stat(&std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?)
}

/// `root` and every process below it (children, their children, ...),
/// root first, from one pass over `/proc/*/stat`. A process that has
/// already been reparented (its parent ended) is no longer found.
pub fn tree(root: u32) -> Vec<u32> {
    let mut children: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
    let Ok(dir) = std::fs::read_dir("/proc") else { return vec![root] };
    for entry in dir.flatten() {
        let Some(pid) = entry.file_name().to_str().and_then(|n| n.parse::<u32>().ok()) else { continue };
        let Ok(stat) = std::fs::read_to_string(entry.path().join("stat")) else { continue };
        if let Some(parent) = parent_in_stat(&stat) {
            children.entry(parent).or_default().push(pid);
        }
    }
    let mut out = vec![root];
    let mut i = 0;
    while i < out.len() {
        if let Some(kids) = children.get(&out[i]) {
            out.extend(kids.iter().copied().filter(|k| *k != root));
        }
        i += 1;
    }
    out
}

/// Whether `environ` (a `/proc/<pid>/environ` text: `KEY=value` entries
/// separated by NULs) sets `key` to `value`.
pub fn environ_has(environ: &[u8], key: &str, value: &str) -> bool {
    let wanted = format!("{key}={value}");
    environ.split(|b| *b == 0).any(|entry| entry == wanted.as_bytes())
}

/// The processes whose environment sets `key` to `value` (those this user
/// may read): how a bench finds what is left of a process tree whose
/// processes were reparented.
pub fn with_env(key: &str, value: &str) -> Vec<u32> {
    let Ok(dir) = std::fs::read_dir("/proc") else { return Vec::new() };
    dir.flatten()
        .filter_map(|e| {
            let pid = e.file_name().to_str()?.parse::<u32>().ok()?;
            let environ = std::fs::read(e.path().join("environ")).ok()?;
            environ_has(&environ, key, value).then_some(pid)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::process::{Command, Stdio};

    const ROLLUP: &str = "55e3547d4000-7ffd20f91000 ---p 00000000 00:00 0                          [rollup]
Rss:                1708 kB
Pss:                 399 kB
Pss_Dirty:           112 kB
Pss_Anon:            112 kB
Shared_Clean:       1548 kB
";
    const STATUS: &str = "Name:\tsim-agent\nVmRSS:\t    5120 kB\nRssAnon:\t    1024 kB\nRssFile:\t    3072 kB\nRssShmem:\t    1024 kB\n";

    #[test]
    fn memory_is_read_from_the_lines_that_name_it() {
        let m = memory_of(STATUS, ROLLUP);
        assert_eq!(
            m,
            Memory { rss_kb: 5120, rss_anon_kb: 1024, rss_file_kb: 3072, rss_shmem_kb: 1024, pss_kb: 399 }
        );
        // `Pss_Dirty:` is not `Pss:`; a missing line is 0.
        assert_eq!(field(ROLLUP, "Pss:"), 399);
        assert_eq!(field(ROLLUP, "Swap:"), 0);
        assert_eq!(memory_of("", ""), Memory::default());
    }

    #[test]
    fn the_parent_is_found_after_any_command_name() {
        assert_eq!(parent_in_stat("16346 (cat) R 16343 16343 10621 0 -1"), Some(16343));
        assert_eq!(parent_in_stat("7 (a) b (c) S 1 7 7 0"), Some(1));
        assert_eq!(parent_in_stat("7 (odd"), None);
    }

    #[test]
    fn cpu_time_is_user_plus_system_after_any_command_name() {
        // A real stat line of `(sleep) 1)`: utime 7, stime 5, cutime 3.
        let stat = "42 (sleep) 1) S 1 42 42 0 -1 4194304 90 0 0 0 7 5 3 0 20 0 1 0 100 0 0";
        assert_eq!(cpu_in_stat(stat), Some(12));
        assert_eq!(cpu_in_stat("42 (short) S 1"), None);
        assert!(cpu_ticks("self").is_some(), "this process has a CPU time");
    }

    #[test]
    fn an_environment_entry_matches_whole() {
        let environ = b"PATH=/bin\0TAG=crowd-1\0TAGS=crowd-1x\0";
        assert!(environ_has(environ, "TAG", "crowd-1"));
        assert!(!environ_has(environ, "TAG", "crowd"));
        assert!(!environ_has(environ, "TAGS", "crowd-1"));
    }

    /// A child this test started, killed and reaped when dropped.
    struct Sleeper(std::process::Child);

    impl Drop for Sleeper {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }

    #[test]
    fn the_tree_holds_a_child_with_its_files_and_memory() {
        let me = std::process::id();
        // `spawn` returns after the fork: the child is listed under us from then on.
        let child = Sleeper(
            Command::new("sleep")
                .arg("600")
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .spawn()
                .expect("sleep"),
        );
        let pid = child.0.id();
        let listed = tree(me);
        assert_eq!(listed[0], me);
        assert!(listed.contains(&pid), "child {pid} not in {listed:?}");
        assert!(open_files(me).is_some_and(|n| n >= 3));
        assert!(pss_kb(me) > 0 && memory(me).rss_kb > 0);
        drop(child);
        assert!(!tree(me).contains(&pid), "a reaped child is gone");
        assert_eq!(open_files(pid), None);
        assert_eq!(pss_kb(pid), 0);
    }
}
