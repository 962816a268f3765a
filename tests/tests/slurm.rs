//! The study on a running Slurm cluster (`deploy/slurm-sweep.sh`), on a
//! one-host cluster the test starts ([`cluster::Cluster`]):
//!
//! * submitted as the script's header says (`sbatch --array=0-3`, then the
//!   merge with `--dependency=afterok`), the merged `runs.csv` and success
//!   tables equal a one-machine `sweep` of the same plan, byte for byte;
//! * one task cancelled (`scancel`) in the middle of its shard and
//!   resubmitted alone (`SHARDS=4 sbatch --array=1`) resumes it, and the
//!   merged result is still the same;
//! * tasks that fail (a `--terrains` directory that does not exist) keep
//!   the merge from ever running, and `sacct` says so.
//!
//! `#[ignore = "needs root and Slurm …"]`: `.ci/run` installs Debian's
//! `slurmctld`, `slurmd`, `slurmdbd`, `slurm-client`, `munge` and
//! `mariadb-server`; without them the tests fail, saying what is missing.
//! One cluster at a time (each test starts its own, about 10 s).

mod cluster;

use bycoms_tests::{bin, wait_for, Proc};
use cluster::{Accounted, Cluster};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Duration;

/// The study's plan for these tests: 1360 runs, a few seconds per shard.
const PLAN: [&str; 6] = ["--eps", "1:5:0.25", "--widths", "1,2", "--terrains-per-bin", "20"];

/// The files a merge writes that a one-machine sweep writes too, compared
/// byte for byte.
const COMPARED: [&str; 3] = ["runs.csv", "success-noise-off.csv", "success-noise-on.csv"];

/// How long the jobs of one case may take.
const JOBS: Duration = Duration::from_secs(300);

/// One cluster at a time: three at once would only crowd two cores.
static ONE_CLUSTER: Mutex<()> = Mutex::new(());

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy/slurm-sweep.sh")
}

/// A study directory's jobs: the shards' working directory and the
/// environment the script reads.
struct Study {
    work: PathBuf,
    orchestrator: String,
}

impl Study {
    fn new(cluster: &Cluster) -> Study {
        let work = cluster.dir().join("work");
        std::fs::create_dir(&work).expect("work dir");
        Study { work, orchestrator: bin("orchestrator").display().to_string() }
    }

    fn out(&self) -> PathBuf {
        self.work.join("study")
    }

    /// `sbatch --array=ARRAY deploy/slurm-sweep.sh SWEEP_ARGS` with `env`.
    fn submit_shards(
        &self,
        cluster: &Cluster,
        array: &str,
        sweep_args: &[&str],
        env: &[(&str, &str)],
    ) -> String {
        let script = script().display().to_string();
        let chdir = format!("--chdir={}", self.work.display());
        let args = [&[array, chdir.as_str(), script.as_str()], sweep_args].concat();
        let env = [&[("BIN", self.orchestrator.as_str()), ("OUT", "study")], env].concat();
        cluster.sbatch(&args, &env)
    }

    /// The merge, after `shards` succeeded, as the script's header says.
    fn submit_merge(&self, cluster: &Cluster, shards: &str) -> String {
        let after = format!("--dependency=afterok:{shards}");
        let chdir = format!("--chdir={}", self.work.display());
        let merge = format!("{} merge study/ --out study/", self.orchestrator);
        cluster.sbatch(
            &[after.as_str(), "--kill-on-invalid-dep=yes", chdir.as_str(), "--wrap", merge.as_str()],
            &[],
        )
    }
}

/// The same plan swept on one machine, into `dir/one`.
fn one_machine(dir: &Path) -> PathBuf {
    let out = dir.join("one");
    let out_arg = out.display().to_string();
    let args = [&["sweep"], &PLAN[..], &["--seed", "1", "--out", out_arg.as_str()]].concat();
    let done = Proc::orchestrator(&args).wait(JOBS);
    assert!(done.status.success(), "the one-machine sweep failed: {}", done.stderr);
    out
}

fn sweep_args() -> Vec<&'static str> {
    PLAN.to_vec()
}

fn assert_all(lines: &[Accounted], state: &str) {
    for line in lines {
        assert!(line.state == state && line.exit_code == "0:0", "expected {state} 0:0: {line:?}");
    }
}

fn assert_same_study(merged: &Path, one: &Path) {
    for name in COMPARED {
        let (a, b) = (merged.join(name), one.join(name));
        let read = |p: &Path| std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        assert!(read(&a) == read(&b), "{} differs from the one-machine sweep's {}", a.display(), b.display());
    }
}

#[test]
#[ignore = "needs root and Slurm (Debian's slurmctld, slurmd, slurmdbd, slurm-client, munge, mariadb-server)"]
fn the_array_and_its_merge_equal_one_machine_sweep() {
    let _one = ONE_CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    let cluster = Cluster::start();
    let study = Study::new(&cluster);
    let shards = study.submit_shards(&cluster, "--array=0-3", &sweep_args(), &[]);
    let merge = study.submit_merge(&cluster, &shards);
    let ended = cluster.wait_ended(&[&shards, &merge], 5, JOBS);
    assert_all(&ended, "COMPLETED");
    assert_same_study(&study.out(), &one_machine(cluster.dir()));
}

/// The lines in a shard's runs file (its header and its rows).
fn lines_in(path: &Path) -> usize {
    std::fs::read_to_string(path).map_or(0, |text| text.lines().count())
}

#[test]
#[ignore = "needs root and Slurm (Debian's slurmctld, slurmd, slurmdbd, slurm-client, munge, mariadb-server)"]
fn a_cancelled_task_resubmitted_alone_resumes_its_shard() {
    let _one = ONE_CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    let cluster = Cluster::start();
    let study = Study::new(&cluster);
    let one = one_machine(cluster.dir());
    // Shard 1 of 4 holds every fourth run (the header is one line more).
    let shard_rows = (lines_in(&one.join("runs.csv")) - 1 + 2) / 4;
    let shards = study.submit_shards(&cluster, "--array=0-3", &sweep_args(), &[]);
    let csv = study.out().join("runs-shard-1-of-4.csv");
    wait_for(JOBS, || (lines_in(&csv) >= 2).then_some(()))
        .unwrap_or_else(|| panic!("shard 1 wrote no row within {JOBS:?}"));
    cluster.command("scancel", &[&format!("{shards}_1")], &[]);
    let ended = cluster.wait_ended(&[&shards], 4, JOBS);
    let task = ended.iter().find(|a| a.id == format!("{shards}_1")).expect("task 1 in sacct");
    assert!(task.state.starts_with("CANCELLED"), "task 1 was not cancelled mid-run: {task:?}");
    let kept = lines_in(&csv) - 1;
    assert!(kept < shard_rows, "task 1 had written all {shard_rows} rows before it was cancelled");
    let again = study.submit_shards(&cluster, "--array=1", &sweep_args(), &[("SHARDS", "4")]);
    let merge = study.submit_merge(&cluster, &again);
    assert_all(&cluster.wait_ended(&[&again, &merge], 2, JOBS), "COMPLETED");
    assert_eq!(lines_in(&csv) - 1, shard_rows, "the resubmitted task completed its shard");
    assert_same_study(&study.out(), &one);
}

#[test]
#[ignore = "needs root and Slurm (Debian's slurmctld, slurmd, slurmdbd, slurm-client, munge, mariadb-server)"]
fn failed_tasks_keep_the_merge_from_running_and_sacct_says_why() {
    let _one = ONE_CLUSTER.lock().unwrap_or_else(|e| e.into_inner());
    let cluster = Cluster::start();
    let study = Study::new(&cluster);
    let missing = cluster.dir().join("no-such-terrains");
    let missing_arg = missing.display().to_string();
    let shards = study.submit_shards(&cluster, "--array=0-3", &["--terrains", &missing_arg], &[]);
    let merge = study.submit_merge(&cluster, &shards);
    let ended = cluster.wait_ended(&[&shards, &merge], 5, JOBS);
    let (merged, tasks): (Vec<_>, Vec<_>) = ended.iter().partition(|a| a.id == merge);
    assert_eq!(tasks.len(), 4, "{ended:?}");
    for task in tasks {
        assert!(task.state == "FAILED" && task.exit_code != "0:0", "a task did not fail: {task:?}");
    }
    let merged = merged.first().expect("the merge in sacct");
    assert!(merged.state.starts_with("CANCELLED") && merged.reason.contains("Dependency"), "{merged:?}");
    assert!(!study.out().join("runs.csv").exists(), "the merge ran");
    // Each task's output names the directory it could not read.
    let log =
        std::fs::read_to_string(study.work.join(format!("slurm-{shards}_0.out"))).expect("task 0's output");
    assert!(log.contains(&missing_arg), "task 0's output does not name {missing_arg}: {log}");
}
