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

/// Closes every open file descriptor above standard error (those listed
/// in `/proc/self/fd` at the call); returns how many. Call it before
/// anything opens a file of its own.
pub fn close_inherited_files() -> usize {
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
        let text = String::from_utf8_lossy(&out.stdout);
        let at = text.find("closed=").unwrap_or_else(|| panic!("{text}"));
        let line = text[at..].lines().next().unwrap_or_default();
        let closed: usize =
            line["closed=".len()..].split(' ').next().and_then(|n| n.parse().ok()).expect("count");
        assert!(closed >= kept.len(), "{line}");
        assert!(line.starts_with(&format!("closed={closed} left=4")), "0, 1, 2 and the listing: {line}");
    }
}
