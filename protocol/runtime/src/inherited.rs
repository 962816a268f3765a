//! Files a parent left open, closed before the agent opens its own.
//!
//! Why: the orchestrator holds a few iceoryx2 files for every robot of its
//! launch (service, port tag, event socket), and iceoryx2 does not open
//! them close-on-exec, so every agent it started inherited all of them:
//! robot 300's agent of a 300-robot launch held 3 587 open files, robot
//! 52's of a 100-robot launch 767, about six per earlier robot. That made
//! the agents' open files (and the `ulimit -n` a launch needs) grow with
//! the swarm for no use. An agent needs only standard input (the terrain
//! may come there), output and error (the orchestrator reads its last
//! error line there); it closes everything else first thing.
//!
//! A launch now starts its agents from a thread whose descriptor table
//! holds none of its files (`orchestrator/launch/src/agents/spawner.rs`),
//! so they find nothing to close; this stays for agents started by other
//! parents.

/// Closes every open file descriptor above standard error; returns how
/// many. Call it before anything opens a file of its own.
///
/// Why not list `/proc/self/fd`: listing it makes the kernel build an
/// inode and a dentry for every descriptor (thousands in a large launch's
/// agents) and tear them down at exit, which took a tenth of the CPU of
/// 300 agents starting at once. The size of the descriptor table
/// (`FDSize` in `/proc/self/status`, a power of two above the highest open
/// descriptor) bounds them instead, and a `close` of a free number is a
/// cheap failed system call. (No safe `close_range` is available: the
/// workspace forbids `unsafe`, and neither `nix` nor `rustix` wraps it.)
pub fn close_inherited_files() -> usize {
    let Some(table) = descriptor_table_size() else { return close_listed() };
    (3..table).filter(|&fd| nix::unistd::close(fd).is_ok()).count()
}

/// `FDSize` of `/proc/self/status`: one more than the highest descriptor
/// number the table holds now.
fn descriptor_table_size() -> Option<i32> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status.lines().find_map(|l| l.strip_prefix("FDSize:")).and_then(|n| n.trim().parse().ok())
}

/// The descriptors listed in `/proc/self/fd`, closed (when the status
/// cannot be read).
fn close_listed() -> usize {
    let Ok(dir) = std::fs::read_dir("/proc/self/fd") else { return 0 };
    // Listed first, closed after: the listing's own descriptor is among
    // them and is gone (closed by the iterator) by then.
    let listed: Vec<i32> =
        dir.filter_map(|e| e.ok()?.file_name().to_str()?.parse().ok()).filter(|&fd| fd > 2).collect();
    listed.into_iter().filter(|&fd| nix::unistd::close(fd).is_ok()).count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::fd::AsRawFd;

    /// Run in a child process: closing every descriptor of the test
    /// harness's own process would break it.
    #[test]
    fn a_child_closes_what_it_inherited_and_keeps_its_standard_streams() {
        if std::env::var_os("BYCOMS_INHERITED_CHILD").is_some() {
            let closed = close_inherited_files();
            let left: Vec<String> = std::fs::read_dir("/proc/self/fd")
                .expect("list")
                .filter_map(|e| e.ok()?.file_name().into_string().ok())
                .collect();
            // The listing's own descriptor is the only one above 2.
            println!("closed={closed} left={}", left.len());
            return;
        }
        // Files without close-on-exec, as iceoryx2 leaves them.
        let kept: Vec<std::fs::File> = (0..5).map(|_| tempfile::tempfile().expect("temp file")).collect();
        for f in &kept {
            nix::fcntl::fcntl(f, nix::fcntl::FcntlArg::F_SETFD(nix::fcntl::FdFlag::empty()))
                .expect("inheritable");
        }
        assert!(kept.iter().all(|f| f.as_raw_fd() > 2));
        // One far above the others, as in a large launch's orchestrator.
        // (Under the common `ulimit -n` of 1024.)
        let high = nix::fcntl::fcntl(&kept[0], nix::fcntl::FcntlArg::F_DUPFD(900)).expect("dup to 900+");
        assert!(high >= 900);
        let out = std::process::Command::new(std::env::current_exe().expect("test binary"))
            .args([
                "--exact",
                "inherited::tests::a_child_closes_what_it_inherited_and_keeps_its_standard_streams",
                "--nocapture",
                "--test-threads=1",
            ])
            .env("BYCOMS_INHERITED_CHILD", "1")
            .output()
            .expect("child");
        nix::unistd::close(high).expect("close the high copy");
        let text = String::from_utf8_lossy(&out.stdout);
        let at = text.find("closed=").unwrap_or_else(|| panic!("{text}"));
        let line = text[at..].lines().next().unwrap_or_default();
        let closed: usize =
            line["closed=".len()..].split(' ').next().and_then(|n| n.parse().ok()).expect("count");
        assert!(closed > kept.len(), "the five and the high copy: {line}");
        assert!(line.starts_with(&format!("closed={closed} left=4")), "0, 1, 2 and the listing: {line}");
    }
}
