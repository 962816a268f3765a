//! "Hosts" on one machine: Linux network namespaces joined by veth pairs,
//! for tests and benchmarks of what crosses a network (zenoh sessions,
//! liveliness, partitions): [`TwoHosts`], two namespaces on one link, and
//! [`Star`], a hub (the orchestrator's host) with N spokes (agent hosts),
//! one link each; `TwoHosts` is the one-spoke star.
//!
//! Why namespaces: each namespace has its own interfaces, addresses and
//! routes, so a process started inside one (`ip netns exec`) talks to the
//! other only over the veth link, exactly as two hosts over a cable — and
//! the test can cut that cable (`ip link set … down`) and plug it back in.
//! Nothing touches the machine's real interfaces: the veth ends live only
//! inside the namespaces, with private addresses `10.231.N.1/30` and
//! `10.231.N.2/30` (N per star; link k of a star has `10.231.N.4k+1/30`
//! and `…4k+2/30`; the namespaces are isolated, so the hosts of parallel
//! tests never see each other).
//!
//! Why `ip` (iproute2) and not netlink from Rust: it is the tool every
//! admin reads, its errors are clear, and a test creates a handful of
//! objects, so a process per command costs nothing. A cut is a link set
//! down on both ends (the kernel's `netem` qdisc, which could drop 100 %,
//! is not available on every CI kernel); for TCP that is silence, as on a
//! cut cable: established sockets stay open, packets go nowhere.
//!
//! Clean-up: names are unique per test process (`bycoms-<pid>-<n>-a` for
//! the hub, `-b`, `-c`, … for the spokes); [`Star`] (and so [`TwoHosts`])
//! kills every process still inside its namespaces and deletes them on
//! drop, also when the test panics. Namespaces left by a test process
//! that was killed (no drop ran) are removed by the next
//! [`Star::create`] once their pid is gone.
//!
//! The tests that use namespaces are `#[ignore = "needs root …"]`; where
//! they are asked for and namespaces are not permitted (not root, no `ip`),
//! [`two_hosts`] fails them with the reason.

mod pair;
mod peer;
pub use pair::{seqs, Pair, PORT, START};
pub use peer::{mono_ns, PeerEvent, PeerProc};

use std::net::Ipv4Addr;
use std::process::Command;
use std::sync::atomic::{AtomicU32, Ordering};

/// Prefix of every namespace this module creates.
const PREFIX: &str = "bycoms-";

/// Why a namespace operation failed.
#[derive(Debug, thiserror::Error)]
pub enum NetnsError {
    /// `ip` could not be started.
    #[error("cannot run `{command}`: {source}")]
    Spawn {
        /// The command line.
        command: String,
        /// Why.
        source: std::io::Error,
    },
    /// `ip` ran and failed.
    #[error("`{command}` failed ({status}): {stderr}")]
    Failed {
        /// The command line.
        command: String,
        /// Its exit status.
        status: std::process::ExitStatus,
        /// What it printed on stderr.
        stderr: String,
    },
}

/// Runs `ip ARGS` (or `tc`, …) and returns its stdout.
fn run(program: &str, args: &[&str]) -> Result<String, NetnsError> {
    let command = format!("{program} {}", args.join(" "));
    let out = Command::new(program)
        .args(args)
        .output()
        .map_err(|source| NetnsError::Spawn { command: command.clone(), source })?;
    if !out.status.success() {
        return Err(NetnsError::Failed {
            command,
            status: out.status,
            stderr: String::from_utf8_lossy(&out.stderr).trim().to_owned(),
        });
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Why namespaces cannot be used here, or `None` when they can.
pub fn not_permitted() -> Option<String> {
    if !nix::unistd::geteuid().is_root() {
        return Some("not running as root (network namespaces need CAP_SYS_ADMIN)".into());
    }
    if let Err(e) = run("ip", &["netns", "list"]) {
        return Some(format!("iproute2 is not usable: {e}"));
    }
    None
}

/// Two namespaces joined by a veth pair; fails the test, saying why, where
/// namespaces are not permitted.
pub fn two_hosts(tag: &str) -> TwoHosts {
    if let Some(reason) = not_permitted() {
        panic!("this test needs network namespaces (root and iproute2), but: {reason}");
    }
    TwoHosts::create(tag).unwrap_or_else(|e| panic!("cannot create namespaces for {tag}: {e}"))
}

/// One end of the pair: a namespace with its veth and address.
#[derive(Clone, Debug)]
pub struct Host {
    /// The namespace's name (`ip netns exec NAME …`).
    pub netns: String,
    /// Its veth interface.
    pub veth: String,
    /// Its address on the link.
    pub addr: Ipv4Addr,
}

impl Host {
    /// `program args…` to run inside this host's namespace.
    pub fn command(&self, program: &std::path::Path) -> Command {
        let mut c = Command::new("ip");
        c.args(["netns", "exec", &self.netns]).arg(program);
        c
    }

    /// Starts our binary `program` with `args` inside this host's namespace
    /// (`ip netns exec` execs it, so the process is the program itself);
    /// killed and reaped on drop, as every [`crate::Proc`].
    pub fn start(&self, program: &str, args: &[&str]) -> crate::Proc {
        self.start_with_env(program, args, &[])
    }

    /// As [`Host::start`], with `env` (name, value) set for the program
    /// alone (through `env`, so the test process's environment is untouched).
    pub fn start_with_env(&self, program: &str, args: &[&str], env: &[(&str, &str)]) -> crate::Proc {
        let mut all: Vec<String> = vec!["netns".into(), "exec".into(), self.netns.clone()];
        if !env.is_empty() {
            all.push("env".into());
            all.extend(env.iter().map(|(name, value)| format!("{name}={value}")));
        }
        all.push(crate::bin(program).display().to_string());
        all.extend(args.iter().map(|s| s.to_string()));
        crate::Proc::start(&std::path::PathBuf::from("ip"), &all)
    }

    /// A zenoh tcp endpoint on this host's address.
    pub fn endpoint(&self, port: u16) -> String {
        format!("tcp/{}:{port}", self.addr)
    }

    fn set_link(&self, state: &str) -> Result<(), NetnsError> {
        run("ip", &["-n", &self.netns, "link", "set", &self.veth, state]).map(drop)
    }
}

/// One veth link between two namespaces: `hub` and `spoke` are its two
/// ends, each a [`Host`] (its namespace, its veth end, its address).
#[derive(Clone, Debug)]
pub struct Veth {
    /// The hub's end (`10.231.N.4k+1/30` for the hub's k-th link).
    pub hub: Host,
    /// The spoke's end (`10.231.N.4k+2/30`).
    pub spoke: Host,
}

impl Veth {
    /// Cuts the link (both ends down): from now on nothing crosses it.
    pub fn cut(&self) -> Result<(), NetnsError> {
        self.hub.set_link("down")?;
        self.spoke.set_link("down")
    }

    /// Plugs the link back in (both ends up).
    pub fn restore(&self) -> Result<(), NetnsError> {
        self.hub.set_link("up")?;
        self.spoke.set_link("up")
    }
}

/// N+1 hosts: a hub (the orchestrator's namespace) and N spokes (the agent
/// hosts), each spoke joined to the hub by its own veth link with its own
/// `/30`, as hosts each cabled to one machine with several interfaces. The
/// spokes reach only the hub (no routes between them: agents talk to the
/// orchestrator only). Removed on drop, as [`TwoHosts`] (its one-spoke
/// case).
///
/// Link k (0-based) is `links[k]`: the hub's end `10.231.N.4k+1`, spoke
/// k's `10.231.N.4k+2`. The hub is one namespace seen from each of its
/// links (every `links[k].hub` has the same `netns`): start a process in
/// it with [`Star::hub`]; a spoke reaches it at `links[k].hub.endpoint(…)`.
pub struct Star {
    /// One link per spoke, in order.
    pub links: Vec<Veth>,
}

impl Star {
    /// Most spokes a star may have (namespaces `…-b` to `…-z`).
    pub const MAX_SPOKES: usize = 25;

    /// Creates the hub, `spokes` spokes (1 to [`Star::MAX_SPOKES`]; panics
    /// otherwise), one veth pair per spoke and the addresses, links up.
    pub fn create(tag: &str, spokes: usize) -> Result<Self, NetnsError> {
        static NEXT: AtomicU32 = AtomicU32::new(0);
        assert!((1..=Self::MAX_SPOKES).contains(&spokes), "a star has 1 to 25 spokes, not {spokes}");
        remove_leftovers();
        let pid = std::process::id();
        let n = NEXT.fetch_add(1, Ordering::SeqCst);
        // Interface names are at most 15 bytes: "bc" + pid (≤ 7) + "x" + n
        // (≤ 3) + the spoke's letter, with "a" before it for the hub's end.
        let netns = |end: &str| format!("{PREFIX}{pid}-{n}-{end}");
        let veth = |end: &str| format!("bc{pid}x{}{end}", n % 1000);
        let addr = |last: usize| Ipv4Addr::new(10, 231, (n % 250) as u8, last as u8);
        let hub = netns("a");
        let links = (0..spokes)
            .map(|k| {
                let end = char::from(b'b' + k as u8).to_string();
                Veth {
                    hub: Host { netns: hub.clone(), veth: veth(&format!("a{end}")), addr: addr(4 * k + 1) },
                    spoke: Host { netns: netns(&end), veth: veth(&end), addr: addr(4 * k + 2) },
                }
            })
            .collect();
        let star = Star { links };
        tracing::debug!(tag, hub, spokes, "creating namespaces");
        // From here on, drop removes whatever was made.
        for ns in star.namespaces() {
            run("ip", &["netns", "add", ns])?;
            run("ip", &["-n", ns, "link", "set", "lo", "up"])?;
        }
        for link in &star.links {
            run("ip", &["link", "add", &link.hub.veth, "type", "veth", "peer", "name", &link.spoke.veth])?;
            for h in [&link.hub, &link.spoke] {
                run("ip", &["link", "set", &h.veth, "netns", &h.netns])?;
                run("ip", &["-n", &h.netns, "addr", "add", &format!("{}/30", h.addr), "dev", &h.veth])?;
                h.set_link("up")?;
            }
        }
        Ok(star)
    }

    /// The hub's namespace (as seen from link 0): where the orchestrator runs.
    pub fn hub(&self) -> &Host {
        &self.links[0].hub
    }

    /// The hub's namespace, then each spoke's.
    fn namespaces(&self) -> impl Iterator<Item = &str> {
        let hub = self.links.first().map(|l| l.hub.netns.as_str());
        hub.into_iter().chain(self.links.iter().map(|l| l.spoke.netns.as_str()))
    }
}

impl Drop for Star {
    fn drop(&mut self) {
        for ns in self.namespaces() {
            remove_netns(ns);
        }
        // A pair is only left in the root namespace if creation failed
        // before moving its ends (deleting one end deletes both).
        for link in &self.links {
            if run("ip", &["link", "show", &link.hub.veth]).is_ok() {
                let _ = run("ip", &["link", "del", &link.hub.veth]);
            }
        }
    }
}

/// Two namespaces `a` and `b` joined by one veth link: the one-spoke
/// [`Star`] (`a` its hub, `b` its spoke); removed on drop.
pub struct TwoHosts {
    /// First host (`10.231.N.1`).
    pub a: Host,
    /// Second host (`10.231.N.2`).
    pub b: Host,
    star: Star,
}

impl TwoHosts {
    /// Creates the namespaces, the veth pair and the addresses, links up.
    pub fn create(tag: &str) -> Result<Self, NetnsError> {
        let star = Star::create(tag, 1)?;
        let Veth { hub: a, spoke: b } = star.links[0].clone();
        Ok(TwoHosts { a, b, star })
    }

    /// Cuts the link (both ends down): from now on nothing crosses it.
    pub fn cut(&self) -> Result<(), NetnsError> {
        self.star.links[0].cut()
    }

    /// Plugs the link back in (both ends up).
    pub fn restore(&self) -> Result<(), NetnsError> {
        self.star.links[0].restore()
    }
}

/// Kills the processes still inside `netns` (only ours: the namespace is
/// ours) and deletes it; its veth end goes with it, and so the peer end.
fn remove_netns(netns: &str) {
    if let Ok(pids) = run("ip", &["netns", "pids", netns]) {
        for pid in pids.split_whitespace().filter_map(|p| p.parse::<i32>().ok()) {
            let _ =
                nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), nix::sys::signal::Signal::SIGKILL);
        }
    }
    if let Err(e) = run("ip", &["netns", "del", netns]) {
        // Absent already (creation failed half-way) is fine.
        tracing::debug!(netns, "not deleted: {e}");
    }
}

/// Deletes namespaces of this module whose creating process is gone.
fn remove_leftovers() {
    let Ok(list) = run("ip", &["netns", "list"]) else { return };
    for name in list.lines().filter_map(|l| l.split_whitespace().next()) {
        let Some(pid) = name.strip_prefix(PREFIX).and_then(|r| r.split('-').next()) else { continue };
        let Ok(pid) = pid.parse::<u32>() else { continue };
        if pid != std::process::id() && !std::path::Path::new(&format!("/proc/{pid}")).exists() {
            tracing::info!(netns = name, "removing a namespace left by a dead test process");
            remove_netns(name);
        }
    }
}
