//! The `orchestrator` binary end to end: bad input, a reduced sweep that is
//! byte-identical on a second run, resume, shards + merge.

use bycoms_runtime::child::{wait_or_kill, Kill};
use std::path::Path;
use std::process::{Command, Output};

fn orchestrator(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_orchestrator")).args(args).output().expect("spawn orchestrator")
}

/// The orchestrator under its own iceoryx2 isolation `tag` (a launch
/// running in a parallel test is not this test's).
fn orchestrator_tagged(tag: &str, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_orchestrator"))
        .args(args)
        .env("BYCOMS_IPC_ISOLATION", tag)
        .output()
        .expect("spawn orchestrator")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A reduced sweep: 2 radii × 2 width bins × 3 terrains × noise on/off = 24 runs.
const REDUCED: &[&str] = &[
    "sweep",
    "--eps",
    "1,4",
    "--widths",
    "2,3",
    "--terrains-per-bin",
    "3",
    "--seed",
    "7",
    "--time-limit",
    "2000",
];

fn sweep_into(dir: &Path, extra: &[&str]) -> Output {
    let mut args: Vec<&str> = REDUCED.to_vec();
    let out = dir.to_str().unwrap();
    args.extend(["--out", out]);
    args.extend(extra);
    orchestrator(&args)
}

#[test]
fn reduced_sweep_is_byte_identical_on_a_second_run() {
    let a = tempfile::tempdir().unwrap();
    let b = tempfile::tempdir().unwrap();
    let oa = sweep_into(a.path(), &[]);
    assert!(oa.status.success(), "{}", stderr(&oa));
    let ob = sweep_into(b.path(), &["--jobs", "1"]);
    assert!(ob.status.success(), "{}", stderr(&ob));
    let ca = std::fs::read(a.path().join("runs.csv")).unwrap();
    let cb = std::fs::read(b.path().join("runs.csv")).unwrap();
    assert_eq!(ca, cb, "same seed, different thread count: same bytes");
    assert_eq!(String::from_utf8_lossy(&ca).lines().count(), 1 + 24);
    for f in
        ["success-noise-off.csv", "success-noise-on.csv", "heatmap-noise-off.svg", "heatmap-noise-on.svg"]
    {
        assert_eq!(std::fs::read(a.path().join(f)).unwrap(), std::fs::read(b.path().join(f)).unwrap(), "{f}");
    }
}

#[test]
fn rerun_resumes_and_a_torn_row_is_redone() {
    let a = tempfile::tempdir().unwrap();
    assert!(sweep_into(a.path(), &[]).status.success());
    let full = std::fs::read_to_string(a.path().join("runs.csv")).unwrap();
    // Keep the header, 10 rows and half of the 11th, as an interrupted run would.
    let lines: Vec<&str> = full.lines().collect();
    let mut cut = lines[..11].join("\n");
    cut.push('\n');
    cut.push_str(&lines[11][..5]);
    std::fs::write(a.path().join("runs.csv"), cut).unwrap();
    let o = sweep_into(a.path(), &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("resuming: 10 of 24"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(a.path().join("runs.csv")).unwrap(), full);
}

#[test]
fn shards_merge_into_the_same_tables() {
    let whole = tempfile::tempdir().unwrap();
    let ow = sweep_into(whole.path(), &[]);
    assert!(ow.status.success(), "{}", stderr(&ow));
    let parts = tempfile::tempdir().unwrap();
    for shard in ["0/3", "1/3", "2/3"] {
        let o = sweep_into(parts.path(), &["--shard", shard]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let merged = tempfile::tempdir().unwrap();
    let o =
        orchestrator(&["merge", parts.path().to_str().unwrap(), "--out", merged.path().to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The printed tables (success rates, then robot budgets) are the same too.
    let tables = |o: &Output, end: &str| {
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        // Everything before the line that holds `end`.
        let head = &text[..text.find(end).unwrap_or(text.len())];
        head[..head.rfind('\n').map_or(0, |i| i + 1)].to_owned()
    };
    let printed = tables(&ow, " runs in ");
    assert!(printed.contains("success within a robot budget N [%], noise on"), "{printed}");
    assert_eq!(printed, tables(&o, "merged "));
    for f in [
        "runs.csv",
        "success-noise-off.csv",
        "success-noise-on.csv",
        "heatmap-noise-on.svg",
        "budget-noise-off.csv",
        "budget-noise-on.csv",
        "robots-noise-off.csv",
        "robots-noise-on.csv",
        "budget-noise-off.svg",
        "budget-noise-on.svg",
    ] {
        assert_eq!(
            std::fs::read(whole.path().join(f)).unwrap(),
            std::fs::read(merged.path().join(f)).unwrap(),
            "{f}"
        );
    }
}

#[test]
fn merge_of_an_incomplete_sweep_says_what_is_missing() {
    let parts = tempfile::tempdir().unwrap();
    assert!(sweep_into(parts.path(), &["--shard", "0/2"]).status.success());
    let merged = tempfile::tempdir().unwrap();
    let o =
        orchestrator(&["merge", parts.path().to_str().unwrap(), "--out", merged.path().to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("12 of 24 runs are missing"), "{}", stderr(&o));
}

#[test]
fn bad_input_exits_non_zero_with_a_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    // Bad values are usage errors (2, like clap's); failures are errors (1).
    let cases: &[(&[&str], &str, i32)] = &[
        (
            &["simulate", "--terrain", "/nonexistent/t.txt", "--no-svg"],
            "cannot read terrain file /nonexistent/t.txt",
            1,
        ),
        (&["simulate", "--eps", "0", "--no-svg"], "must be a positive number", 2),
        (&["simulate", "--eps", "-1", "--no-svg"], "must be a positive number", 2),
        (&["simulate", "--eps", "1e-300", "--no-svg"], "bad --eps", 2),
        (&["launch", "--eps", "1e-300"], "bad eps (--eps)", 2),
        (&["launch", "--eps", "0"], "bad eps (--eps)", 2),
        // Issue 49: no robot was ever still, and a lockstep launch never ended.
        (&["launch", "--stop-speed", "0"], "gate.stop_speed (--stop-speed) must be a positive number (a robot slower than it is still), got 0", 2),
        // Issue 49: --seed is the noise seed, as in launch; with the old
        // --noise-seed it was a terrain's seed, and is refused naming the new flag.
        (&["simulate", "--seed", "1", "--noise-seed", "2", "--no-svg"], "generate a terrain with --terrain-seed 1 --seed 2", 2),
        (
            &["launch", "--clock", "realtime", "--speed", "1e9"],
            "bad speed (--speed): the real-time speed-up must be a number in [0.001, 1000]",
            2,
        ),
        // Issue 31: accepted, it started two agents per robot and judged
        // every robot stuck before its first bearing came.
        (
            &["launch", "--clock", "realtime", "--speed", "100000"],
            "bad speed (--speed): the real-time speed-up must be a number in [0.001, 1000], got 100000",
            2,
        ),
        (&["sweep", "--eps", "", "--out", "/tmp/x"], "--eps is empty", 2),
        (&["sweep", "--eps", "1e-300", "--out", "/tmp/x"], "bad --eps", 2),
        (&["sweep", "--widths", "1,,2"], "--widths", 2),
        (&["sweep", "--shard", "5/4"], "need 0 ≤ i < n", 2),
        (&["terrain", "--width", "0", "--count", "1", "--out", "/tmp/x"], "--width must lie", 2),
        // Issue 49: 1e300 said as given, not as a 301-digit number.
        (&["terrain", "--width", "1e300", "--count", "1", "--out", "/tmp/x"], "cells (feasible terrains measure at least 1), got 1e300", 2),
        (&["sweep", "--widths", "1e300", "--out", "/tmp/x"], "widths are measured up to 8), got 1e300", 2),
        (&["bench", "scale", "--speed", "0"], "bad --speed: the real-time speed-up must be a number in", 2),
        // Seconds past any run: the flag or key and its range, never a panic (issue 31).
        (&["launch", "--unreachable-grace", "1e300"], "supervision.unreachable_grace (--unreachable-grace) must be a number of seconds in [0, 100000000], got 1e300", 2),
        (&["launch", "--heartbeat-timeout", "1e20"], "supervision.heartbeat_timeout (--heartbeat-timeout) must be a number of seconds in (0, 100000000]", 2),
        (&["launch", "--register-timeout", "NaN"], "supervision.register_timeout (--register-timeout) must be a number of seconds in (0, ", 2),
        (&["launch", "--dwell", "1e300"], "gate.dwell (--dwell) must be a number of seconds in (0, ", 2),
        (&["launch", "--time-limit", "1e300"], "bad time_limit (--time-limit): the time limit must be at least one control period and at most 100000000 s", 2),
        (&["launch", "--clock", "realtime", "--speed", "1e-300"], "speed-up must be a number in [0.001, 1000]", 2),
        (&["sweep", "--time-limit", "inf", "--out", "/tmp/x"], "bad --time-limit", 2),
        (&["bench", "scale", "--seconds", "1e20"], "invalid value '1e20' for '--seconds <SECONDS>': must be a number of seconds in (0, 100000000]", 2),
        (&["bench", "crowd", "--timeout", "0"], "'--timeout <SECONDS>': must be a number of seconds in (0, ", 2),
        // Issue 49: refused up front as `launch` refuses them, not after 6 s
        // of iceoryx2 work, nor with NaN rows and exit 0.
        (&["bridge", "--swarm", "s", "--robots", "100000"], "--robots 100000: a launch deploys 1 to 1000 robots", 2),
        (&["bench", "crowd", "--robots", "100000"], "--robots 100000: a launch deploys 1 to 1000 robots", 2),
        (&["bench", "crowd", "--robots", "10,0"], "--robots 0: a launch deploys 1 to 1000 robots", 2),
        (&["bench", "stop", "--robots", "1001"], "--robots 1001: a launch deploys 1 to 1000 robots", 2),
        (&["bench", "launch", "--runs", "0"], "invalid value '0' for '--runs <RUNS>': 0 is not in 1..", 2),
        (&["bench", "stop", "--runs", "0"], "invalid value '0' for '--runs <RUNS>': 0 is not in 1..", 2),
        (&["launch", "--config", "/dev/zero"], "cannot read config /dev/zero: more than the limit of 1048576 bytes", 1),
        (
            &["simulate", "--svg", "/nonexistent/dir/out.svg"],
            "cannot write /nonexistent/dir/out.svg: No such file",
            1,
        ),
        (&["sweep", "--out", "/proc/forbidden"], "cannot create output directory", 1),
        (&["certs", "--robots", "1", "--out", "c", "--listen", "tcp/0.0.0.0:7447"], "--listen tcp/", 2),
        (&["certs", "--robots", "1", "--out", "c", "--connect", "tcp/lab:7447"], "--connect tcp/", 2),
    ];
    for (args, expected, code) in cases {
        let o = Command::new(env!("CARGO_BIN_EXE_orchestrator"))
            .args(*args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(*code), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(expected), "{args:?}: {}", stderr(&o));
    }
    let bad = dir.path().join("bad.txt");
    std::fs::write(&bad, "S..\n.#.\n..x\n").unwrap();
    let o = orchestrator(&["simulate", "--terrain", bad.to_str().unwrap(), "--no-svg"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("line 3, column 3"), "{}", stderr(&o));
}

/// Issue 49: `--seed` generated a terrain in `simulate` and seeded the
/// noise in `launch`; a launch's flags copied to `simulate` were refused
/// (`--terrain` with `--seed`) or ran another world. `--seed` is the noise
/// seed in both; `--terrain-seed` generates a terrain; `--noise-seed` is
/// still read as `--seed`.
#[test]
fn simulate_takes_a_launchs_seed_as_the_noise_seed() {
    let dir = tempfile::tempdir().unwrap();
    let terrain = dir.path().join("t.txt");
    std::fs::write(&terrain, "S.........\n..........\n..........\n.........G\n").unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["simulate", "--json", "--no-svg", "--noise", "--time-limit", "300"];
        args.extend(extra);
        let o = orchestrator(&args);
        assert!(matches!(o.status.code(), Some(0) | Some(3)), "{args:?}: {}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON on stdout");
        (v, stderr(&o))
    };
    let t = terrain.to_str().unwrap();
    let (seeded, _) = run(&["--terrain", t, "--seed", "4"]);
    let (old_name, _) = run(&["--terrain", t, "--noise-seed", "4"]);
    assert_eq!(seeded, old_name, "--noise-seed is --seed");
    // Noise shows once a robot senses a beacon: a scenario where robots stick.
    let walled = |seed: &str| run(&["--scenario", "long-wall", "--seed", seed]).0;
    assert_ne!(walled("4")["robots"], walled("5")["robots"], "the seed seeds the noise");
    let (scenario, said) = run(&["--seed", "4"]);
    assert_eq!(scenario["terrain"], "scenario long-wall", "{scenario}");
    assert!(said.contains("--seed 4 is the noise seed (as in launch)"), "{said}");
    assert!(said.contains("is --terrain-seed 4"), "{said}");
    let (generated, _) = run(&["--terrain-seed", "4"]);
    assert_ne!(generated["terrain"], "scenario long-wall", "{generated}");
}

#[test]
fn simulate_prints_json_and_draws_the_snapshot() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("snap.svg");
    let o = orchestrator(&["simulate", "--json", "--svg", svg.to_str().unwrap()]);
    assert!(matches!(o.status.code(), Some(0) | Some(3)), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON on stdout");
    for key in ["success", "time_s", "robots_used", "beacons"] {
        assert!(v.get(key).is_some(), "missing {key}: {v}");
    }
    assert_eq!(v["success"].as_bool().unwrap(), o.status.code() == Some(0));
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") && text.contains("<polyline"));
}

#[test]
fn ctrl_c_keeps_rows_and_a_rerun_resumes_to_the_same_bytes() {
    let whole = tempfile::tempdir().unwrap();
    let args =
        ["--eps", "1:5:0.5", "--widths", "2,3", "--terrains-per-bin", "5", "--seed", "3", "--jobs", "1"];
    let run = |dir: &Path| {
        let mut a = vec!["sweep", "--out", dir.to_str().unwrap()];
        a.extend(args);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    assert!(orchestrator(&run(whole.path()).iter().map(String::as_str).collect::<Vec<_>>()).status.success());
    let expected = std::fs::read(whole.path().join("runs.csv")).unwrap();

    let part = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_orchestrator"))
        .args(run(part.path()))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let csv = part.path().join("runs.csv");
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    // Wait for a few rows, then Ctrl-C.
    while std::fs::read_to_string(&csv).map_or(0, |t| t.lines().count()) < 4 {
        assert!(std::time::Instant::now() < deadline, "sweep wrote no rows in time");
        if child.try_wait().unwrap().is_some() {
            break;
        }
        // Polled: a file's rows have no event to block on.
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let _ = Command::new("kill").args(["-INT", &child.id().to_string()]).status();
    let left = deadline.saturating_duration_since(std::time::Instant::now());
    let waited = wait_or_kill(&mut child, left, Kill::Process).expect("wait");
    assert!(waited.in_time, "sweep did not stop after Ctrl-C");
    let status = waited.status;
    let kept = std::fs::read(&csv).unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(err.contains("run the same command again to resume"), "{err}");
    assert!(kept.len() < expected.len(), "interrupted before the end");
    assert!(expected.starts_with(&kept), "the rows kept are a prefix of the full CSV");
    let o = orchestrator(&run(part.path()).iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&csv).unwrap(), expected);
}

#[test]
fn terrain_command_writes_named_files_that_sweep_can_use() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    for w in ["2", "3"] {
        let o = orchestrator(&["terrain", "--width", w, "--count", "2", "--seed", "5", "--out", d]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".txt"))
        .collect();
    names.sort();
    assert_eq!(names.len(), 4, "{names:?}");
    // The index lists the terrains of both runs.
    let index = std::fs::read_to_string(dir.path().join("terrains.csv")).unwrap();
    assert_eq!(index.lines().count(), 1 + 4, "{index}");
    assert!(names.iter().all(|n| index.contains(n.as_str())), "{index}");
    for n in &names {
        // w<bin>_<id>_width<measured>.txt, and the measured width is in the bin.
        let measured: f64 = n.rsplit_once("_width").unwrap().1.trim_end_matches(".txt").parse().unwrap();
        let bin: f64 = n[1..].split('_').next().unwrap().parse().unwrap();
        assert!(bin <= measured && measured < bin + 0.5, "{n}");
        let text = std::fs::read_to_string(dir.path().join(n)).unwrap();
        bycoms_sim::terrain::parse(&text).unwrap();
    }
    let out = tempfile::tempdir().unwrap();
    let o = orchestrator(&[
        "sweep",
        "--terrains",
        d,
        "--widths",
        "2,3",
        "--terrains-per-bin",
        "2",
        "--eps",
        "1",
        "--noise",
        "off",
        "--out",
        out.path().to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.path().join("runs.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 4);
    // Asking for more terrains than the directory has is a clear error.
    let o = orchestrator(&[
        "sweep",
        "--terrains",
        d,
        "--widths",
        "2,3",
        "--terrains-per-bin",
        "3",
        "--out",
        out.path().join("x").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("fewer than 3 terrains"), "{}", stderr(&o));
}

#[test]
fn failed_start_does_not_claim_the_directory_and_odd_decimals_resume() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    // Cannot fill the bin with 10 candidates: fails before any run…
    let o = orchestrator(&[
        "sweep",
        "--widths",
        "3",
        "--terrains-per-bin",
        "5",
        "--max-candidates",
        "10",
        "--out",
        d,
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    // …so the corrected command may use the same directory.
    let args = [
        "sweep",
        "--eps",
        "1:2:0.3",
        "--widths",
        "2",
        "--terrains-per-bin",
        "2",
        "--noise",
        "off",
        "--out",
        d,
    ];
    let o = orchestrator(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    // ε = 1.9000000000000001 etc. survive sweep.json: the rerun resumes (nothing left to do).
    let o = orchestrator(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("resuming: 8 of 8"), "{}", stderr(&o));
    // A different sweep into the same directory is refused, and so is a merge over it.
    let o = orchestrator(&["sweep", "--eps", "2", "--widths", "2", "--terrains-per-bin", "2", "--out", d]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("holds a different sweep"), "{}", stderr(&o));
    let other = tempfile::tempdir().unwrap();
    let o2 = other.path().to_str().unwrap();
    assert!(orchestrator(&[
        "sweep",
        "--eps",
        "3",
        "--widths",
        "2",
        "--terrains-per-bin",
        "1",
        "--noise",
        "off",
        "--out",
        o2
    ])
    .status
    .success());
    let before = std::fs::read(dir.path().join("runs.csv")).unwrap();
    let o = orchestrator(&["merge", o2, "--out", d]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("holds a different sweep"), "{}", stderr(&o));
    assert_eq!(std::fs::read(dir.path().join("runs.csv")).unwrap(), before);
}

/// A tiny sweep (2 runs: ε = 3, one width bin, two terrains, noise off) of
/// `seed` in two shards into `dir`.
fn tiny_shards(dir: &Path, seed: &str) {
    for shard in ["0/2", "1/2"] {
        let o = orchestrator(&[
            "sweep",
            "--eps",
            "3",
            "--widths",
            "3",
            "--terrains-per-bin",
            "2",
            "--noise",
            "off",
            "--time-limit",
            "300",
            "--seed",
            seed,
            "--shard",
            shard,
            "--out",
            dir.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
}

#[test]
fn merge_refuses_a_shard_of_another_sweep_and_names_it() {
    let (ours, theirs, merged) =
        (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    tiny_shards(ours.path(), "7");
    tiny_shards(theirs.path(), "8");
    // Shard 1 of the seed-8 sweep copied over ours: same columns, other runs.
    let copied = ours.path().join("runs-shard-1-of-2.csv");
    std::fs::copy(theirs.path().join("runs-shard-1-of-2.csv"), &copied).unwrap();
    let out = merged.path().to_str().unwrap();
    let o = orchestrator(&["merge", ours.path().to_str().unwrap(), "--out", out]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let said = stderr(&o);
    assert!(said.contains(&format!("{} does not belong to the sweep", copied.display())), "{said}");
    assert!(said.contains("is it a shard of another sweep?"), "{said}");
    assert!(!merged.path().join("runs.csv").exists(), "nothing merged");

    // A row that contradicts itself: arrived in the outcome, not in `success`.
    tiny_shards(theirs.path(), "8");
    let file = theirs.path().join("runs-shard-0-of-2.csv");
    let text = std::fs::read_to_string(&file).unwrap();
    let (header, row) = text.split_once('\n').unwrap();
    let mut fields: Vec<String> = row.trim_end().split(',').map(str::to_owned).collect();
    fields[7] = "true".into();
    fields[8] = "time_limit".into();
    std::fs::write(&file, format!("{header}\n{}\n", fields.join(","))).unwrap();
    let o = orchestrator(&["merge", theirs.path().to_str().unwrap(), "--out", out]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("success=true with outcome=time_limit"), "{}", stderr(&o));
    assert!(stderr(&o).contains("runs-shard-0-of-2.csv: row 2"), "{}", stderr(&o));
}

#[test]
fn a_live_swarm_is_refused_whatever_the_temp_dir_with_a_usage_error() {
    use bycoms_launch::swarm_lock::SwarmLock;
    // The swarm held as a live launch holds it (this process, its TMPDIR;
    // the isolation tag, if any, is inherited by the launch below).
    let swarm = format!("lockscope{}", std::process::id());
    let held = SwarmLock::acquire(&swarm).expect("lock the swarm");
    // Another TMPDIR (another shell, or systemd's PrivateTmp=yes) still
    // shares the machine's shared memory, so the swarm is still in use.
    let other_tmp = tempfile::tempdir().unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_orchestrator"))
        .args(["launch", "--robots", "1", "--time-limit", "5", "--swarm", &swarm, "--json"])
        .env("TMPDIR", other_tmp.path())
        .output()
        .expect("spawn orchestrator");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let said = stderr(&o);
    assert!(said.contains(&format!("swarm \"{swarm}\" is in use by a running launch")), "{said}");
    assert!(o.stdout.is_empty(), "nothing ran: {}", String::from_utf8_lossy(&o.stdout));
    drop(held);
}

/// zenoh's runtime failing to start (here: a thread pool of no threads,
/// as a memory limit makes it fail) ends a launch at once with one error
/// line in our words and exit 1; it used to panic in zenoh's thread, then
/// wait for agents that could not come, or abort with a panic in a
/// destructor.
#[test]
fn a_zenoh_runtime_that_cannot_start_ends_the_launch_at_once() {
    let swarm = format!("zenoh-rt-{}", std::process::id());
    let begun = std::time::Instant::now();
    let o = Command::new(env!("CARGO_BIN_EXE_orchestrator"))
        .args(["launch", "--transport", "zenoh", "--agents", "remote", "--robots", "1", "--swarm", &swarm])
        .env("ZENOH_RUNTIME", "(acc: (worker_threads: 0))")
        .output()
        .expect("spawn orchestrator");
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("zenoh failed (thread main): Worker threads cannot be set to 0"), "{err}");
    assert!(!err.contains("panicked") && !err.contains(".cargo/registry"), "{err}");
    assert!(begun.elapsed() < std::time::Duration::from_secs(8), "took {:?}", begun.elapsed());
}

/// `--ros2-router` with no router there (a port taken from the OS and let
/// go): the launch ends at once, before any agent starts, exit 1, naming
/// the endpoint and the lab's router to start (never a silent run that
/// nobody in the ROS 2 graph sees).
#[test]
fn a_ros2_router_that_does_not_answer_ends_the_launch_naming_it() {
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let router = format!("tcp/127.0.0.1:{port}");
    let swarm = format!("ros2-norouter-{}", std::process::id());
    let begun = std::time::Instant::now();
    let o = Command::new(env!("CARGO_BIN_EXE_orchestrator"))
        .args(["launch", "--robots", "1", "--swarm", &swarm, "--ros2-router", &router])
        .output()
        .expect("spawn orchestrator");
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains(&format!("ros2: no zenoh router answers at {router}")), "{err}");
    assert!(err.contains("rmw_zenohd"), "{err}");
    assert!(!err.contains("registered"), "no agent was started: {err}");
    assert!(begun.elapsed() < std::time::Duration::from_secs(8), "took {:?}", begun.elapsed());
}

/// `sweep > /dev/full`: stdout is named as what failed, and every file of
/// the study is written all the same (issue 31).
#[test]
fn a_full_stdout_is_named_and_costs_no_file() {
    let sweep = |out: &Path| {
        let mut args =
            vec!["sweep", "--eps", "3", "--widths", "3", "--terrains-per-bin", "1", "--noise", "off"];
        args.extend(["--time-limit", "300", "--seed", "3", "--out", out.to_str().unwrap()]);
        args.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let files = |dir: &Path| {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sw");
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_orchestrator")).args(sweep(&out)).stdout(full).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("cannot write to stdout: No space left on device"), "{}", stderr(&o));
    let whole = tempfile::tempdir().unwrap();
    let args = sweep(whole.path());
    let o = orchestrator(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(files(&out), files(whole.path()), "the same files as with a working stdout");
}

/// A shard whose lines end in CR LF (a Windows transfer) merges as the same rows (issue 31).
#[test]
fn a_cr_lf_shard_merges_as_the_same_rows() {
    let dir = tempfile::tempdir().unwrap();
    tiny_shards(dir.path(), "5");
    let merged = tempfile::tempdir().unwrap();
    let o = orchestrator(&["merge", dir.path().to_str().unwrap(), "--out", merged.path().to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let shard = dir.path().join("runs-shard-0-of-2.csv");
    let text = std::fs::read_to_string(&shard).unwrap();
    assert!(!text.contains('\r'));
    std::fs::write(&shard, text.replace('\n', "\r\n")).unwrap();
    let again = tempfile::tempdir().unwrap();
    let o = orchestrator(&["merge", dir.path().to_str().unwrap(), "--out", again.path().to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let runs = |d: &Path| std::fs::read(d.join("runs.csv")).unwrap();
    assert_eq!(runs(again.path()), runs(merged.path()));
}

/// `orchestrator doctor`: exit 0 with a good certificate set, 1 when a
/// robot has none (its findings in the documented `--json` shape), 2 on a
/// usage error naming the flag.
#[test]
fn doctor_exits_0_1_2_and_prints_its_findings_as_json() {
    let dir = tempfile::tempdir().unwrap();
    let certs = dir.path().join("certs");
    let made = orchestrator(&["certs", "--robots", "2", "--out", certs.to_str().unwrap()]);
    assert!(made.status.success(), "{}", stderr(&made));
    let tag = format!("doctor-cli-{}", std::process::id());
    let doctor = |robots: &str| {
        orchestrator_tagged(
            &tag,
            &["doctor", "--json", "--robots", robots, "--certs", certs.to_str().unwrap()],
        )
    };
    let good = doctor("2");
    assert_eq!(good.status.code(), Some(0), "{}", stderr(&good));
    let json: serde_json::Value = serde_json::from_slice(&good.stdout).expect("JSON on stdout");
    assert_eq!(json["errors"], 0);
    let findings = json["findings"].as_array().expect("findings");
    for f in findings {
        assert!(["ok", "warn", "error"].contains(&f["level"].as_str().unwrap()), "{f}");
        assert!(f["check"].is_string() && f["cause"].is_string() && f["fix"].is_string(), "{f}");
    }
    assert!(findings.iter().any(|f| f["check"] == "certs" && f["level"] == "ok"), "{json}");
    let bad = doctor("3");
    assert_eq!(bad.status.code(), Some(1), "{}", stderr(&bad));
    let json: serde_json::Value = serde_json::from_slice(&bad.stdout).expect("JSON on stdout");
    assert_eq!(json["errors"], 2, "{json}");
    let usage = doctor("0");
    assert_eq!(usage.status.code(), Some(2));
    assert!(stderr(&usage).contains("--robots 0"), "{}", stderr(&usage));
}

/// `doctor --timeout-ms` takes the one range of every span, in
/// milliseconds (u64::MAX never returned, 0 was accepted), and `status
/// --interval` has one range, said the same for any value outside it
/// (issue 49).
#[test]
fn durations_in_any_unit_have_one_range() {
    for ms in ["18446744073709551615", "0"] {
        let o = orchestrator(&["doctor", "--timeout-ms", ms]);
        assert_eq!(o.status.code(), Some(2), "{ms}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("--timeout-ms") && stderr(&o).contains("milliseconds in (0, 100000000000]"),
            "{}",
            stderr(&o)
        );
    }
    for s in ["0", "0.01", "100", "1e300"] {
        let o = orchestrator(&["status", "--watch", "--interval", s]);
        assert_eq!(o.status.code(), Some(2), "{s}: {}", stderr(&o));
        let err = stderr(&o);
        assert!(err.contains("--interval") && err.contains("seconds in [0.1, 60]"), "{err}");
        assert!(!err.contains("100000000"), "one range only: {err}");
    }
}

/// `orchestrator revoke`: its help, usage errors (exit 2) naming the flag,
/// exit 1 when no launch runs (the ACL, with `--certs`, rewritten all the
/// same), and `certs --revoke` saying that no launch of the lab took it.
#[test]
fn revoke_exits_1_without_a_launch_2_on_usage_and_rewrites_the_acl() {
    let dir = tempfile::tempdir().unwrap();
    let certs = dir.path().join("certs");
    let certs = certs.to_str().unwrap();
    let made = orchestrator(&["certs", "--robots", "2", "--out", certs]);
    assert!(made.status.success(), "{}", stderr(&made));
    let tag = format!("revoke-cli-{}", std::process::id());
    let run = |args: &[&str]| orchestrator_tagged(&tag, args);
    let help = run(&["revoke", "--help"]);
    assert_eq!(help.status.code(), Some(0));
    let text = String::from_utf8_lossy(&help.stdout);
    for flag in ["--robot", "--swarm", "--connect", "--zenoh-config", "--certs", "--why", "Exit codes"] {
        assert!(text.contains(flag), "--help names {flag}:\n{text}");
    }
    for (args, says) in [
        (&["revoke"][..], "--robot"),
        (&["revoke", "--robot", "0"][..], "--robot 0"),
        (&["revoke", "--robot", "3", "--certs", certs][..], "--robot 3"),
        (&["revoke", "--robot", "1", "--swarm", "no/such"][..], "bad swarm name"),
        (&["revoke", "--robot", "1", "--certs", "/nonexistent"][..], "--certs /nonexistent: "),
    ] {
        let out = run(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(stderr(&out).contains(says), "{args:?}: {}", stderr(&out));
    }
    let config = dir.path().join("certs/orchestrator.json5");
    let before = std::fs::read_to_string(&config).unwrap();
    assert!(!before.contains("\"revoked\""), "a usage error writes nothing");
    let alone = run(&["revoke", "--robot", "2", "--certs", certs]);
    assert_eq!(alone.status.code(), Some(1), "{}", stderr(&alone));
    assert!(stderr(&alone).contains("no launch runs on this host"), "{}", stderr(&alone));
    // Its error says what was done all the same.
    let done = format!("the ACL of {} now denies robot 2 everything", config.display());
    assert!(
        stderr(&alone).lines().any(|l| l.starts_with("ERROR") && l.contains(&done)),
        "{}",
        stderr(&alone)
    );
    let acl = bycoms_orchestrator::certs::read_config(&config).unwrap();
    assert_eq!(bycoms_orchestrator::certs::revoked_in(&acl).into_iter().collect::<Vec<_>>(), [2]);
    let by_certs = run(&["certs", "--revoke", "1", "--out", certs]);
    assert_eq!(by_certs.status.code(), Some(0), "{}", stderr(&by_certs));
    assert!(stderr(&by_certs).contains("no launch of this lab runs on this host"), "{}", stderr(&by_certs));
}

/// `stop --why` and `revoke --why` are a sentence for the summary: longer
/// than 200 characters is a usage error (exit 2) naming the flag and the
/// length, before any launch is asked; 200 characters pass that check.
#[test]
fn a_why_longer_than_200_characters_is_a_usage_error() {
    let tag = format!("why-cli-{}", std::process::id());
    let run = |args: &[&str]| orchestrator_tagged(&tag, args);
    let long = "x".repeat(120_000);
    for command in [&["stop"][..], &["revoke", "--robot", "1"][..]] {
        let out = run(&[command, &["--why", &long]].concat());
        assert_eq!(out.status.code(), Some(2), "{command:?}: {}", stderr(&out));
        assert!(stderr(&out).contains("--why takes at most 200 characters, got 120000"), "{}", stderr(&out));
        let fits = "y".repeat(200);
        let out = run(&[command, &["--why", &fits]].concat());
        assert_eq!(out.status.code(), Some(1), "{command:?}: {}", stderr(&out));
        assert!(stderr(&out).contains("no launch runs on this host"), "{}", stderr(&out));
    }
}

/// `orchestrator status` (and `stop`) with no launch running: `--swarm`
/// named in the error, and `--json` prints `[]`.
#[test]
fn status_without_a_launch_names_the_swarm_and_prints_an_empty_json_list() {
    let tag = format!("status-cli-{}", std::process::id());
    let run = |args: &[&str]| orchestrator_tagged(&tag, args);
    let wrong = run(&["status", "--swarm", "wrong"]);
    assert_eq!(wrong.status.code(), Some(1), "{}", stderr(&wrong));
    let said = format!(
        "no launch of swarm \"wrong\" runs on this host (isolation tag {tag}) (it ended, or never started); \
         no other runs either"
    );
    assert!(stderr(&wrong).contains(&said), "{}", stderr(&wrong));
    let json = run(&["status", "--json"]);
    assert_eq!(json.status.code(), Some(1), "{}", stderr(&json));
    assert_eq!(String::from_utf8_lossy(&json.stdout), "[]\n");
    let stop = run(&["stop", "--swarm", "wrong"]);
    assert_eq!(stop.status.code(), Some(1), "{}", stderr(&stop));
    assert!(stderr(&stop).contains(&said), "{}", stderr(&stop));
}

/// `status`, `stop` and `revoke --connect quic/…` without `--zenoh-config`:
/// a usage error saying the endpoint needs the lab's certificates and
/// which file, at once (not a blame of "another lab's CA" after a failed
/// handshake).
#[test]
fn a_secured_connect_without_a_zenoh_config_names_the_certificates_it_needs() {
    let port = std::net::UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let endpoint = format!("quic/127.0.0.1:{port}");
    for command in [&["status"][..], &["stop"], &["revoke", "--robot", "1"]] {
        let args = [command, &["--connect", &endpoint]].concat();
        let begun = std::time::Instant::now();
        let o = orchestrator(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        let said = format!(
            "--connect {endpoint}: a secured endpoint needs the lab's certificates: give \
                            --zenoh-config the lab's orchestrator.json5"
        );
        assert!(err.contains(&said), "{args:?}: {err}");
        assert!(!err.contains("another lab"), "{args:?}: {err}");
        assert!(begun.elapsed() < std::time::Duration::from_secs(5), "{args:?}: took {:?}", begun.elapsed());
    }
}

/// A port nothing listens on: a TCP listener of the OS's, let go.
fn unused_tcp_endpoint() -> String {
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    format!("tcp/127.0.0.1:{port}")
}

/// `launch --connect` to an endpoint nothing answers at (issue 49): with
/// `--ros2` an error naming it, before any agent starts, exit 1 within the
/// start-up window; without, a warning, and the launch runs on.
#[test]
fn an_unreachable_connect_is_an_error_with_ros2_and_a_warning_without() {
    let endpoint = unused_tcp_endpoint();
    let swarm = format!("connect-ros2-{}", std::process::id());
    let zenoh = ["--transport", "zenoh", "--listen", "tcp/127.0.0.1:0", "--connect", &endpoint];
    let launch = |extra: &[&str]| {
        let args = [&["launch", "--robots", "1", "--swarm", &swarm][..], &zenoh, extra].concat();
        orchestrator_tagged(&swarm, &args)
    };
    let begun = std::time::Instant::now();
    let o = launch(&["--ros2"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    let said = format!("zenoh: nothing answered at \"{endpoint}\" (transport.connect, --connect) within 2 s");
    assert!(
        err.contains(&said) && err.contains("--ros2 (the ROS 2 graph is reached through it) needs it"),
        "{err}"
    );
    assert!(!err.contains("agent started"), "no agent was started: {err}");
    assert!(begun.elapsed() < std::time::Duration::from_secs(8), "took {:?}", begun.elapsed());
    let o = launch(&["--time-limit", "1"]);
    let err = stderr(&o);
    assert!(matches!(o.status.code(), Some(0) | Some(3)), "{err}");
    assert!(
        err.lines().any(|l| l.contains("WARN") && l.contains(&said) && l.contains("runs on without it")),
        "{err}"
    );
}
