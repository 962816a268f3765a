//! What a user gives and gets back, end to end: terrain files beyond the
//! size limit are refused before they are read, harmless oddities (a byte
//! order mark, blank lines at the end) are accepted, a picture with no
//! place to go is refused before the run, and nothing computed is lost to a
//! later error (too few terrains).

use std::process::{Command, Output};

fn orchestrator(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_orchestrator")).args(args).output().expect("spawn orchestrator")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn a_huge_terrain_file_is_refused_before_it_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("big.txt");
    // 300 MB on paper (sparse: nothing on disk), as in the report of 22.4 GB used.
    std::fs::File::create(&big).unwrap().set_len(300_000_000).unwrap();
    let o = orchestrator(&["simulate", "--terrain", big.to_str().unwrap(), "--no-svg"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let expected = format!(
        "cannot read terrain file {}: 300000000 bytes, more than the limit of 2097152 bytes",
        big.display()
    );
    assert!(stderr(&o).contains(&expected), "{}", stderr(&o));
    // The same file among a sweep's terrains.
    let out = tempfile::tempdir().unwrap();
    let o = orchestrator(&[
        "sweep",
        "--terrains",
        dir.path().to_str().unwrap(),
        "--out",
        out.path().to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("more than the limit"), "{}", stderr(&o));
}

/// Files without end (`/dev/zero`) given as a zenoh config or as the CA of
/// a certificate set are refused at their cap, naming the file, instead of
/// read until memory runs out (issue 49); a zenoh config that is no config
/// is the file's problem in `doctor --connect`, not the network's.
#[test]
fn a_zenoh_config_or_certificate_without_end_is_refused_at_its_cap() {
    let o = orchestrator(&["status", "--connect", "tcp/127.0.0.1:9", "--zenoh-config", "/dev/zero"]);
    assert_ne!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stderr(&o).contains("/dev/zero: more than the limit of 4194304 bytes"), "{}", stderr(&o));
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.path().join("ca.pem")).unwrap();
    let o = orchestrator(&["doctor", "--robots", "1", "--certs", dir.path().to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stdout(&o).contains("more than the limit of 1048576 bytes"), "{}", stdout(&o));
    for (config, says) in [("/dev/zero", "more than the limit"), ("/etc/passwd", "not a zenoh JSON5 config")]
    {
        let o = orchestrator(&[
            "doctor",
            "--robots",
            "1",
            "--connect",
            "tcp/127.0.0.1:9",
            "--zenoh-config",
            config,
        ]);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        let out = stdout(&o);
        assert!(out.contains(config) && out.contains(says), "{out}");
        assert!(!out.contains("firewall") && !out.contains("not reached"), "the file's problem: {out}");
    }
}

#[test]
fn a_byte_order_mark_and_trailing_blank_lines_are_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.txt");
    let mut text = String::from("\u{feff}");
    for row in 0..20 {
        let line: String = (0..20)
            .map(|col| {
                if (row, col) == (15, 4) {
                    'S'
                } else if (row, col) == (4, 15) {
                    'G'
                } else {
                    '.'
                }
            })
            .collect();
        text.push_str(&line);
        text.push_str("\r\n");
    }
    text.push_str("\r\n\r\n");
    std::fs::write(&path, text).unwrap();
    let o = orchestrator(&["simulate", "--terrain", path.to_str().unwrap(), "--no-svg"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(stdout(&o).contains("robot 1 arrived"), "{}", stdout(&o));
}

#[test]
fn a_snapshot_with_no_place_to_go_is_refused_before_the_run() {
    // Its folder is missing: said before the run (the place of every output
    // is checked with the overwrite rule, `crate::out::files`), as with --json.
    for json in [&[][..], &["--json"][..]] {
        let o = orchestrator(&[&["simulate", "--svg", "/nonexistent/dir/out.svg"], json].concat());
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(stdout(&o).is_empty(), "no run: {}", stdout(&o));
        assert!(stderr(&o).contains("cannot write /nonexistent/dir/out.svg: No such file"), "{}", stderr(&o));
    }
}

#[test]
fn terrain_keeps_what_it_found_when_the_candidates_run_out() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let o = orchestrator(&[
        "terrain",
        "--width",
        "2",
        "--count",
        "50",
        "--seed",
        "5",
        "--max-candidates",
        "300",
        "--out",
        d,
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let files: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".txt"))
        .collect();
    let found = files.len();
    assert!(found > 0 && found < 50, "{found} terrains");
    let index = std::fs::read_to_string(dir.path().join("terrains.csv")).unwrap();
    assert!(index.starts_with("file,terrain,width,threshold\n"), "{index}");
    assert_eq!(index.lines().count(), 1 + found);
    assert!(stdout(&o).contains(&format!("wrote {found} terrain")), "{}", stdout(&o));
    let missing = format!("{} of the 50 terrains asked for are missing", 50 - found);
    assert!(stderr(&o).contains(&missing), "{}", stderr(&o));
    // What was kept is what a request for exactly that many writes.
    let again = tempfile::tempdir().unwrap();
    let count = found.to_string();
    let o = orchestrator(&[
        "terrain",
        "--width",
        "2",
        "--count",
        &count,
        "--seed",
        "5",
        "--max-candidates",
        "300",
        "--out",
        again.path().to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(again.path().join("terrains.csv")).unwrap(), index);
}
