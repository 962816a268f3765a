//! A one-host Slurm cluster for the tests, from Debian's packages: munge's
//! key and daemon, a MariaDB server with Slurm's accounting database,
//! `slurmdbd` (so `sacct` answers), `slurmctld` and one `slurmd` whose node
//! has this machine's CPUs, in one partition. Everything lives in a
//! temporary directory and on loopback ports picked free; the daemons run
//! in the foreground as children of the test and are killed on drop, after
//! every job of the cluster is cancelled.
//!
//! Why a real cluster: `deploy/slurm-sweep.sh` is for users who outgrow one
//! machine; only a running `sbatch`/`squeue`/`sacct` shows whether its array,
//! its resubmission and the merge's dependency do what its header says.

use bycoms_tests::{wait_for_every, Finished, Proc};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The programs the cluster needs, with the Debian package of each.
const PROGRAMS: [(&str, &str); 9] = [
    ("munged", "munge"),
    ("mariadb-install-db", "mariadb-server"),
    ("mariadb", "mariadb-client"),
    ("mariadbd", "mariadb-server"),
    ("slurmdbd", "slurmdbd"),
    ("slurmctld", "slurmctld"),
    ("slurmd", "slurmd"),
    ("sbatch", "slurm-client"),
    ("sacctmgr", "slurm-client"),
];

/// How long a daemon may take to come up, and a command to answer.
const START: Duration = Duration::from_secs(60);

/// A running one-host cluster (see the module doc).
pub struct Cluster {
    dir: tempfile::TempDir,
    /// Started in order, killed in reverse order.
    daemons: Vec<Proc>,
}

/// One job's (or array task's) line of `sacct`: its id, state, exit code
/// and the reason Slurm gives.
#[derive(Debug, Clone)]
pub struct Accounted {
    pub id: String,
    pub state: String,
    pub exit_code: String,
    pub reason: String,
}

impl Cluster {
    /// Starts the cluster; fails the test, saying what is missing, where it
    /// cannot (not root, a package not installed).
    pub fn start() -> Cluster {
        if let Some(missing) = missing() {
            panic!(
                "this test needs root and a one-host Slurm cluster, but: {missing} (.ci/run installs them)"
            );
        }
        let dir = tempfile::tempdir().expect("a temporary directory");
        // munged wants every directory above its socket searchable by all.
        set_mode(dir.path(), 0o755);
        let mut cluster = Cluster { dir, daemons: Vec::new() };
        let [db, dbd, ctld, slurmd] = free_tcp_ports();
        cluster.start_munge();
        cluster.start_database(db);
        cluster.write_configs(db, dbd, ctld, slurmd);
        cluster.start_slurm();
        cluster
    }

    /// The directory the cluster's files are in (jobs may work below it).
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    fn start_munge(&mut self) {
        let munge = self.path("munge");
        std::fs::create_dir(&munge).expect("munge dir");
        set_mode(&munge, 0o755);
        let key = munge.join("key");
        // A fixed key: it only has to be the same for every daemon here.
        std::fs::write(&key, [0x5au8; 1024]).expect("munge key");
        set_mode(&key, 0o400);
        let arg = |flag: &str, name: &str| format!("--{flag}={}", munge.join(name).display());
        let args =
            ["--foreground".into(), arg("key-file", "key"), arg("socket", "socket"), arg("pid-file", "pid")];
        let args = [&args[..], &[arg("log-file", "log"), arg("seed-file", "seed")]].concat();
        self.daemons.push(Proc::start(&"munged".into(), &args));
        let socket = munge.join("socket");
        wait_for_every(Duration::from_millis(50), START, || socket.exists().then_some(()))
            .unwrap_or_else(|| panic!("munged did not create {} within {START:?}", socket.display()));
    }

    fn start_database(&mut self, port: u16) {
        let data = self.path("db");
        let data_arg = format!("--datadir={}", data.display());
        run(
            "mariadb-install-db",
            &[&data_arg, "--user=root", "--auth-root-authentication-method=socket"],
            &[],
        );
        let socket = self.path("db.sock");
        let args: Vec<String> = [
            "--no-defaults".to_string(),
            data_arg,
            format!("--socket={}", socket.display()),
            format!("--port={port}"),
            "--bind-address=127.0.0.1".into(),
            "--skip-name-resolve".into(),
            "--user=root".into(),
            format!("--pid-file={}", self.path("db.pid").display()),
        ]
        .into();
        self.daemons.push(Proc::start(&"mariadbd".into(), &args));
        wait_for_every(Duration::from_millis(50), START, || socket.exists().then_some(()))
            .unwrap_or_else(|| panic!("mariadbd did not open {} within {START:?}", socket.display()));
        let grant = "CREATE USER 'slurm'@'127.0.0.1' IDENTIFIED BY 'bycoms'; \
                     GRANT ALL ON slurm_acct_db.* TO 'slurm'@'127.0.0.1';";
        run("mariadb", &[&format!("--socket={}", socket.display()), "-e", grant], &[]);
    }

    fn write_configs(&self, db: u16, dbd: u16, ctld: u16, slurmd: u16) {
        let munge = self.path("munge/socket");
        let dbd_conf = format!(
            "AuthType=auth/munge\nAuthInfo=socket={munge}\nDbdHost=localhost\nDbdAddr=127.0.0.1\n\
             DbdPort={dbd}\nSlurmUser=root\nLogFile={log}\nPidFile={pid}\n\
             StorageType=accounting_storage/mysql\nStorageHost=127.0.0.1\nStoragePort={db}\n\
             StorageUser=slurm\nStoragePass=bycoms\nStorageLoc=slurm_acct_db\n",
            munge = munge.display(),
            log = self.path("slurmdbd.log").display(),
            pid = self.path("slurmdbd.pid").display(),
        );
        let dbd_path = self.path("slurmdbd.conf");
        std::fs::write(&dbd_path, dbd_conf).expect("slurmdbd.conf");
        // slurmdbd refuses a configuration others can read (it holds a password).
        set_mode(&dbd_path, 0o600);
        std::fs::write(self.path("slurm.conf"), self.slurm_conf(dbd, ctld, slurmd)).expect("slurm.conf");
    }

    fn slurm_conf(&self, dbd: u16, ctld: u16, slurmd: u16) -> String {
        let host = std::fs::read_to_string("/proc/sys/kernel/hostname").expect("the host name");
        let host = host.trim().split('.').next().unwrap_or("localhost").to_owned();
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let p = |name: &str| self.path(name).display().to_string();
        for dir in ["state", "spool"] {
            std::fs::create_dir(self.path(dir)).expect("a cluster dir");
        }
        // The accounting link (slurmdbd) takes its munge socket from
        // AccountingStoragePass, the rest from AuthInfo.
        format!(
            "ClusterName=bycoms\nSlurmctldHost={host}(127.0.0.1)\nSlurmctldPort={ctld}\nSlurmdPort={slurmd}\n\
             AuthType=auth/munge\nAuthInfo=socket={munge}\nSlurmUser=root\nSlurmdUser=root\n\
             StateSaveLocation={state}\nSlurmdSpoolDir={spool}\nSlurmctldPidFile={ctld_pid}\n\
             SlurmdPidFile={slurmd_pid}\nProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n\
             MpiDefault=none\nSchedulerType=sched/backfill\nSelectType=select/cons_tres\n\
             SelectTypeParameters=CR_CPU\nReturnToService=2\n\
             AccountingStorageType=accounting_storage/slurmdbd\nAccountingStorageHost=127.0.0.1\n\
             AccountingStoragePort={dbd}\nAccountingStoragePass={munge}\n\
             JobAcctGatherType=jobacct_gather/none\nJobCompType=jobcomp/none\n\
             NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} RealMemory={mem} State=UNKNOWN\n\
             PartitionName=bycoms Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
            munge = p("munge/socket"),
            state = p("state"),
            spool = p("spool"),
            ctld_pid = p("slurmctld.pid"),
            slurmd_pid = p("slurmd.pid"),
            mem = memory_mb(),
        )
    }

    fn start_slurm(&mut self) {
        let conf = self.path("slurm.conf").display().to_string();
        let env = [("SLURM_CONF", conf.as_str())];
        self.daemons.push(Proc::start_with_env(&"slurmdbd".into(), &["-D".into()], &env));
        // The accounting database knows the cluster before its controller starts.
        wait_for_every(Duration::from_millis(200), START, || {
            self.try_command("sacctmgr", &["-i", "add", "cluster", "bycoms"]).filter(|f| f.status.success())
        })
        .unwrap_or_else(|| panic!("slurmdbd did not answer within {START:?}"));
        let daemon_args = |extra: &[&str]| -> Vec<String> {
            [&["-D", "-f", conf.as_str()], extra].concat().into_iter().map(String::from).collect()
        };
        self.daemons.push(Proc::start_with_env(&"slurmctld".into(), &daemon_args(&["-i"]), &env));
        self.daemons.push(Proc::start_with_env(&"slurmd".into(), &daemon_args(&[]), &env));
        wait_for_every(Duration::from_millis(200), START, || {
            let up = self.try_command("sinfo", &["-h", "-o", "%T"])?;
            up.stdout.lines().any(|state| state.trim() == "idle").then_some(())
        })
        .unwrap_or_else(|| panic!("the node did not come up idle within {START:?}"));
    }

    /// `program args` against this cluster (`SLURM_CONF` set), with a
    /// deadline; `None` if it did not end in time.
    fn try_command(&self, program: &str, args: &[&str]) -> Option<Finished> {
        let conf = self.path("slurm.conf").display().to_string();
        let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
        let proc = Proc::start_with_env(&program.into(), &args, &[("SLURM_CONF", &conf)]);
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| proc.wait(START))).ok()
    }

    /// `program args` against this cluster with `env` added; its stdout,
    /// failing the test if it fails.
    pub fn command(&self, program: &str, args: &[&str], env: &[(&str, &str)]) -> String {
        let conf = self.path("slurm.conf").display().to_string();
        let env = [&[("SLURM_CONF", conf.as_str())], env].concat();
        run(program, args, &env).stdout
    }

    /// `sbatch --parsable ARGS` (with `env`): the job id.
    pub fn sbatch(&self, args: &[&str], env: &[(&str, &str)]) -> String {
        let out = self.command("sbatch", &[&["--parsable"], args].concat(), env);
        out.trim().split(';').next().unwrap_or_default().to_owned()
    }

    /// Waits until the jobs `ids` have ended, as `squeue` and `sacct` both
    /// see them, with a `sacct` line for each of their `jobs` jobs and array
    /// tasks (the accounting may lag behind the queue); those lines.
    pub fn wait_ended(&self, ids: &[&str], jobs: usize, timeout: Duration) -> Vec<Accounted> {
        let list = ids.join(",");
        wait_for_every(Duration::from_millis(250), timeout, || {
            let queued = self.command("squeue", &["-h", "-j", &list], &[]);
            if !queued.trim().is_empty() {
                return None;
            }
            let lines = self.accounted(&list);
            (lines.len() == jobs && lines.iter().all(|a| has_ended(&a.state))).then_some(lines)
        })
        .unwrap_or_else(|| panic!("jobs {list} did not end within {timeout:?}: {:?}", self.accounted(&list)))
    }

    fn accounted(&self, list: &str) -> Vec<Accounted> {
        let out =
            self.command("sacct", &["-X", "-n", "-P", "-j", list, "-o", "JobID,State,ExitCode,Reason"], &[]);
        out.lines()
            .filter_map(|line| {
                let mut f = line.split('|').map(str::to_owned);
                Some(Accounted { id: f.next()?, state: f.next()?, exit_code: f.next()?, reason: f.next()? })
            })
            .collect()
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        // Jobs first (their steps would outlive slurmd), then the daemons.
        let _ = self.try_command("scancel", &["--full", "--user=root"]);
        while let Some(mut daemon) = self.daemons.pop() {
            daemon.kill();
        }
    }
}

/// Whether a job state is final (`COMPLETED`, `FAILED`, `CANCELLED by 0`, …).
fn has_ended(state: &str) -> bool {
    let live = ["PENDING", "RUNNING", "REQUEUED", "RESIZING", "SUSPENDED", "COMPLETING", "CONFIGURING"];
    !live.iter().any(|s| state.starts_with(s))
}

/// Why the cluster cannot start here, if it cannot.
fn missing() -> Option<String> {
    if !nix::unistd::geteuid().is_root() {
        return Some("not running as root (the daemons run as root)".into());
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    let dirs: Vec<PathBuf> =
        std::env::split_paths(&path).chain(["/usr/sbin".into(), "/sbin".into()]).collect();
    let absent: Vec<String> = PROGRAMS
        .iter()
        .filter(|(program, _)| !dirs.iter().any(|d| d.join(program).is_file()))
        .map(|(program, package)| format!("{program} (Debian's {package})"))
        .collect();
    (!absent.is_empty()).then(|| format!("not installed: {}", absent.join(", ")))
}

/// `program args` with `env`, ended within [`START`] and successful; else
/// the test fails with its output.
fn run(program: &str, args: &[&str], env: &[(&str, &str)]) -> Finished {
    let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
    let done = Proc::start_with_env(&program.into(), &args, env).wait(START);
    assert!(
        done.status.success(),
        "{program} {args:?} failed ({}): {}{}",
        done.status,
        done.stdout,
        done.stderr
    );
    done
}

fn set_mode(path: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
        .unwrap_or_else(|e| panic!("chmod {mode:o} {}: {e}", path.display()));
}

/// Four free loopback TCP ports (all bound at once, so distinct, then
/// released; the small race with other programs is accepted).
fn free_tcp_ports() -> [u16; 4] {
    let listeners: Vec<std::net::TcpListener> =
        (0..4).map(|_| std::net::TcpListener::bind(("127.0.0.1", 0)).expect("a free TCP port")).collect();
    let port = |i: usize| listeners[i].local_addr().expect("bound").port();
    [port(0), port(1), port(2), port(3)]
}

/// This machine's memory, MiB (the node's `RealMemory`: Slurm's default of
/// 1 MiB would refuse the script's `--mem`).
fn memory_mb() -> u64 {
    let info = std::fs::read_to_string("/proc/meminfo").expect("/proc/meminfo");
    let kb = info
        .lines()
        .find_map(|l| l.strip_prefix("MemTotal:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        .expect("MemTotal in /proc/meminfo");
    kb / 1024
}
