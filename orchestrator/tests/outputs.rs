//! The overwrite rule, end to end through the binary: an output never
//! replaces one of the command's inputs, another output of the same run or
//! a file of another kind, and replaces its own kind only with `--force`
//! (`crate::out::files`); "not a recording" is one error (exit 1) for every
//! command that reads recordings; `certs` never silently replaces a lab's CA.

use std::path::Path;
use std::process::{Command, Output};

use bycoms_record::Recorder;

fn orchestrator_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_orchestrator"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("spawn orchestrator")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A small finished recording with the run metadata `draw` needs.
fn launch_recording(path: &Path) {
    let mut recorder = Recorder::create(path).expect("create");
    let meta = serde_json::json!({
        "terrain": "tiny", "terrain_text": "S....\n.....\n....G\n",
        "start": { "x": 0.5, "y": 2.5 }, "goal": { "x": 4.5, "y": 0.5 }, "swarm": "t",
        "config": { "eps": 1.0, "clock": "lockstep" },
    });
    recorder.record_json("bycoms/t/run", "bycoms.LaunchConfig", 0, &meta).expect("run metadata");
    for i in 0..20u64 {
        recorder.record_bytes("bycoms/t/tick", "bycoms.Tick", i, i, &i.to_le_bytes()).expect("record");
    }
    recorder.finish().expect("finish");
}

/// Asserts a refusal: exit 2, the message contains `says`, every file in `kept` unchanged.
fn refused(out: &Output, says: &str, kept: &[(&Path, &[u8])]) {
    assert_eq!(out.status.code(), Some(2), "{}", stderr(out));
    assert!(stderr(out).contains(says), "expected {says:?} in: {}", stderr(out));
    for (path, bytes) in kept {
        assert_eq!(std::fs::read(path).expect("still there"), *bytes, "{} was changed", path.display());
    }
}

#[test]
fn record_recover_never_truncates_its_input_however_out_is_spelled() {
    let dir = tempfile::tempdir().expect("temp dir");
    let input = dir.path().join("X.mcap");
    launch_recording(&input);
    let bytes = std::fs::read(&input).expect("read");
    std::os::unix::fs::symlink(&input, dir.path().join("link.mcap")).expect("symlink");
    let absolute = input.to_str().expect("utf-8").to_string();
    for out in ["./X.mcap", absolute.as_str(), "link.mcap", "sub/../X.mcap"] {
        std::fs::create_dir_all(dir.path().join("sub")).expect("sub");
        let o = orchestrator_in(dir.path(), &["record", "recover", "X.mcap", "--out", out, "--force"]);
        refused(&o, "refusing to overwrite an input", &[(&input, &bytes)]);
    }
    // A good copy still works, and leaves no temporary file behind.
    let o = orchestrator_in(dir.path(), &["record", "recover", "X.mcap", "--out", "copy.mcap"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn draw_never_replaces_its_recording_or_another_recording() {
    let dir = tempfile::tempdir().expect("temp dir");
    let a = dir.path().join("a.mcap");
    let b = dir.path().join("b.mcap");
    launch_recording(&a);
    launch_recording(&b);
    let (a_bytes, b_bytes) = (std::fs::read(&a).expect("a"), std::fs::read(&b).expect("b"));
    let kept: [(&Path, &[u8]); 2] = [(&a, &a_bytes), (&b, &b_bytes)];
    for force in [&[][..], &["--force"][..]] {
        let o = orchestrator_in(dir.path(), &[&["draw", "a.mcap", "--out", "a.mcap"], force].concat());
        refused(&o, "refusing to overwrite an input", &kept);
        let o = orchestrator_in(dir.path(), &[&["draw", "a.mcap", "--out", "b.mcap"], force].concat());
        refused(&o, "is an MCAP recording, not an SVG picture", &kept);
    }
    // Its own default picture (FILE.svg) it replaces, as `simulate` does
    // (issue 31): drawing a recording twice in one folder works.
    for _ in 0..2 {
        let o = orchestrator_in(dir.path(), &["draw", "a.mcap"]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    // Another picture of its kind: a new one, then again only with --force.
    let o = orchestrator_in(dir.path(), &["draw", "a.mcap", "--out", "mine.svg"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let svg = std::fs::read(dir.path().join("mine.svg")).expect("mine.svg");
    let o = orchestrator_in(dir.path(), &["draw", "a.mcap", "--out", "mine.svg"]);
    refused(&o, "give --force to replace it", &[(&dir.path().join("mine.svg"), &svg)]);
    let o = orchestrator_in(dir.path(), &["draw", "a.mcap", "--out", "mine.svg", "--force"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn simulate_runs_twice_in_one_folder_replacing_its_own_default_picture_only() {
    let dir = tempfile::tempdir().expect("temp dir");
    let svg = dir.path().join("simulate.svg");
    for _ in 0..2 {
        let o = orchestrator_in(dir.path(), &["simulate"]);
        assert_eq!(o.status.code(), Some(0), "the README's `simulate`, again: {}", stderr(&o));
    }
    assert!(std::fs::read_to_string(&svg).expect("simulate.svg").contains("<svg"));
    // Spelled as the default, it is the default.
    let o = orchestrator_in(dir.path(), &["simulate", "--svg", "./simulate.svg"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // Another kind at the default name is still never replaced.
    let terrain = b"S.......\n........\n.......G\n";
    std::fs::write(&svg, terrain).expect("a terrain named simulate.svg");
    let o = orchestrator_in(dir.path(), &["simulate"]);
    refused(&o, "is a terrain, not an SVG picture", &[(&svg, terrain)]);
}

#[test]
fn simulate_never_draws_over_its_terrain_or_its_other_picture() {
    let dir = tempfile::tempdir().expect("temp dir");
    let terrain = dir.path().join("t.txt");
    let text = b"S.......\n........\n.......G\n";
    std::fs::write(&terrain, text).expect("terrain");
    let o = orchestrator_in(dir.path(), &["simulate", "--terrain", "t.txt", "--svg", "t.txt", "--force"]);
    refused(&o, "refusing to overwrite an input", &[(&terrain, text)]);
    let o = orchestrator_in(
        dir.path(),
        &["simulate", "--terrain", "t.txt", "--svg", "s.svg", "--animate", "./s.svg"],
    );
    refused(&o, "are the same file", &[(&terrain, text)]);
    assert!(!dir.path().join("s.svg").exists(), "nothing was written");
    let o = orchestrator_in(dir.path(), &["simulate", "--terrain", "t.txt", "--svg", "s.svg"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let svg = std::fs::read(dir.path().join("s.svg")).expect("s.svg");
    let o = orchestrator_in(dir.path(), &["simulate", "--terrain", "t.txt", "--svg", "s.svg"]);
    refused(&o, "give --force to replace it", &[(&dir.path().join("s.svg"), &svg)]);
    assert!(stdout_is_empty(&o), "refused before the run: {}", String::from_utf8_lossy(&o.stdout));
    let o = orchestrator_in(dir.path(), &["simulate", "--terrain", "t.txt", "--svg", "s.svg", "--force"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

fn stdout_is_empty(o: &Output) -> bool {
    o.stdout.is_empty()
}

#[test]
fn launch_outputs_are_checked_before_anything_starts() {
    let dir = tempfile::tempdir().expect("temp dir");
    let swarm = format!("outputs-{}", std::process::id());
    // Two outputs, one file: refused before any agent starts (nothing is created).
    let o =
        orchestrator_in(dir.path(), &["launch", "--swarm", &swarm, "--record", "r.mcap", "--svg", "r.mcap"]);
    refused(&o, "are the same file", &[]);
    assert!(!dir.path().join("r.mcap").exists(), "nothing was written");
    // A picture over a recording: never, not even with --force.
    let old = dir.path().join("old.mcap");
    launch_recording(&old);
    let bytes = std::fs::read(&old).expect("old");
    for force in [&[][..], &["--force"][..]] {
        let o = orchestrator_in(
            dir.path(),
            &[&["launch", "--swarm", &swarm, "--svg", "old.mcap"], force].concat(),
        );
        refused(&o, "is an MCAP recording, not an SVG picture", &[(&old, &bytes)]);
    }
    // The recording over its own terrain.
    let terrain = dir.path().join("t.txt");
    std::fs::write(&terrain, b"S.......\n.......G\n").expect("terrain");
    let o = orchestrator_in(
        dir.path(),
        &["launch", "--swarm", &swarm, "--terrain", "t.txt", "--record", "t.txt", "--force"],
    );
    refused(&o, "refusing to overwrite an input", &[(&terrain, b"S.......\n.......G\n")]);
    // A picture no one can write (its folder is a file): said before the run, not after it.
    let o = orchestrator_in(dir.path(), &["launch", "--swarm", &swarm, "--svg", "t.txt/run.svg"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("cannot write t.txt/run.svg"), "{}", stderr(&o));
    assert!(stdout_is_empty(&o), "refused before the run: {}", String::from_utf8_lossy(&o.stdout));
}

#[test]
fn a_file_that_is_not_a_recording_is_one_error_for_every_reader() {
    let dir = tempfile::tempdir().expect("temp dir");
    let cases: [(&str, &[u8]); 4] = [
        ("empty.mcap", b""),
        ("text.mcap", b"just some text\n"),
        ("short.mcap", b"\x89MC"),
        ("garbage.mcap", &[0x13, 0x37, 0x00, 0xff, 0x42, 0x00, 0x01, 0x02, 0x03, 0x04, 0x05]),
    ];
    for (name, bytes) in cases {
        std::fs::write(dir.path().join(name), bytes).expect("write");
        let export = ["record", "export", "--ros2", name, "--out", "bag.mcap"];
        for command in
            [&["record", "recover", name][..], &["draw", name][..], &["replay", name][..], &export[..]]
        {
            let o = orchestrator_in(dir.path(), command);
            assert_eq!(o.status.code(), Some(1), "{command:?}: {}", stderr(&o));
            assert!(
                stderr(&o).contains(&format!("{name} is not an MCAP file")),
                "{command:?}: {}",
                stderr(&o)
            );
        }
        let stem = name.trim_end_matches(".mcap");
        for made in [format!("{stem}.recovered.mcap"), format!("{stem}.svg"), "bag.mcap".into()] {
            assert!(!dir.path().join(&made).exists(), "{made} was written for {name}");
        }
    }
}

/// Random bytes are not "an empty file"; a valid MCAP file without the run
/// metadata is one message and one exit code (1) for every reader (`record
/// recover`, `draw`, `replay`, `record export --ros2`), and none writes an
/// empty file.
#[test]
fn random_bytes_and_a_foreign_mcap_file_are_one_error_for_every_reader() {
    let dir = tempfile::tempdir().expect("temp dir");
    let foreign = dir.path().join("foreign.mcap");
    // Written by another tool: the mcap crate's writer, as the `mcap` CLI writes.
    let file = std::io::BufWriter::new(std::fs::File::create(&foreign).expect("create"));
    let mut writer = mcap::Writer::new(file).expect("writer");
    let schema = writer.add_schema("sensor_msgs/Image", "ros2msg", b"").expect("schema");
    let channel = writer.add_channel(schema, "camera/image", "cdr", &Default::default()).expect("channel");
    let header =
        mcap::records::MessageHeader { channel_id: channel, sequence: 0, log_time: 1, publish_time: 1 };
    writer.write_to_known_channel(&header, b"pixels").expect("message");
    writer.finish().expect("finish");
    let (copy, svg) = (dir.path().join("copy.mcap"), dir.path().join("picture.svg"));
    let (copy, svg) = (copy.to_str().expect("utf-8"), svg.to_str().expect("utf-8"));
    let o = |file: &str| {
        let commands = [
            &["record", "recover", file, "--out", copy][..],
            &["draw", file, "--out", svg][..],
            &["replay", file][..],
            &["record", "export", "--ros2", file, "--out", copy][..],
        ];
        for command in commands {
            let o = orchestrator_in(dir.path(), command);
            assert_eq!(o.status.code(), Some(1), "{command:?}: {}", stderr(&o));
            let text = stderr(&o);
            let expected = match file {
                "foreign.mcap" => {
                    "foreign.mcap is an MCAP file but not a bycoms launch recording: it holds no run metadata"
                        .to_string()
                }
                _ => format!("{file} is not an MCAP file: it does not start with the MCAP magic bytes"),
            };
            assert!(text.contains(&expected), "{command:?}: {text}");
        }
        assert!(!Path::new(copy).exists() && !Path::new(svg).exists(), "{file}: nothing is written");
    };
    o("foreign.mcap");
    o("/dev/urandom");
}

/// The certificate in a PEM file.
fn cert_der(path: &Path) -> Vec<u8> {
    let bytes = std::fs::read(path).expect("read pem");
    let (_, pem) = x509_parser::pem::parse_x509_pem(&bytes).expect("a PEM");
    pem.contents
}

/// Whether the certificate at `cert` is signed by the CA at `ca`.
fn signed_by(cert: &Path, ca: &Path) -> bool {
    let (cert, ca) = (cert_der(cert), cert_der(ca));
    let (_, cert) = x509_parser::parse_x509_certificate(&cert).expect("certificate");
    let (_, ca) = x509_parser::parse_x509_certificate(&ca).expect("CA certificate");
    cert.verify_signature(Some(ca.public_key())).is_ok()
}

#[test]
fn certs_never_replaces_a_lab_ca_unasked_and_adds_robots_to_it() {
    let dir = tempfile::tempdir().expect("temp dir");
    let made = |extra: &[&str]| orchestrator_in(dir.path(), &[&["certs", "--out", "c"], extra].concat());
    let o = made(&["--robots", "2"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let c = dir.path().join("c");
    let files = |names: &[&str]| -> Vec<(std::path::PathBuf, Vec<u8>)> {
        names.iter().map(|n| (c.join(n), std::fs::read(c.join(n)).expect(n))).collect()
    };
    let set = [
        "ca.pem",
        "ca-key.pem",
        "orchestrator.pem",
        "orchestrator-key.pem",
        "robot-1.pem",
        "robot-1-key.pem",
    ];
    let before = files(&set);
    let kept: Vec<(&Path, &[u8])> = before.iter().map(|(p, b)| (p.as_path(), b.as_slice())).collect();

    // Run again: refused, nothing written.
    let o = made(&["--robots", "2"]);
    refused(&o, "already holds a lab CA", &kept);
    assert!(stderr(&o).contains("--add-robots") && stderr(&o).contains("--force"), "{}", stderr(&o));

    // More robots for the same CA: the old files stay, the new ones are signed by the kept CA.
    let o = made(&["--robots", "4", "--add-robots"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for (path, bytes) in &kept {
        assert_eq!(std::fs::read(path).expect("kept"), *bytes, "{} changed", path.display());
    }
    for k in [3, 4] {
        assert!(signed_by(&c.join(format!("robot-{k}.pem")), &c.join("ca.pem")), "robot {k}");
        let key = c.join(format!("robot-{k}-key.pem"));
        use std::os::unix::fs::PermissionsExt;
        assert_eq!(std::fs::metadata(&key).expect("key").permissions().mode() & 0o777, 0o600);
        assert!(c.join(format!("robot-{k}.json5")).is_file());
    }
    let acl = std::fs::read_to_string(c.join("orchestrator.json5")).expect("orchestrator.json5");
    assert!(acl.contains("\"robot-4\"") && acl.contains("quic/0.0.0.0:7447"), "{acl}");

    // --force makes a new CA (the old robots' certificates no longer verify).
    let o = made(&["--robots", "1", "--force"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_ne!(std::fs::read(c.join("ca-key.pem")).expect("new key"), before[1].1, "a new CA key");
    assert!(!signed_by(&c.join("robot-3.pem"), &c.join("ca.pem")), "robot 3 belonged to the old CA");

    // Adding robots to a directory without a CA is a usage error.
    let o = orchestrator_in(dir.path(), &["certs", "--out", "none", "--robots", "1", "--add-robots"]);
    refused(&o, "ca.pem is missing", &[]);
}

#[test]
fn terrain_replaces_its_own_files_only_with_force() {
    let dir = tempfile::tempdir().expect("temp dir");
    let make = |extra: &[&str]| {
        orchestrator_in(
            dir.path(),
            &[&["terrain", "--width", "3", "--count", "1", "--out", "t"], extra].concat(),
        )
    };
    let o = make(&[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let index = dir.path().join("t/terrains.csv");
    let bytes = std::fs::read(&index).expect("index");
    refused(&make(&[]), "give --force to replace it", &[(&index, &bytes)]);
    assert_eq!(make(&["--force"]).status.code(), Some(0));
    // Never over a file of another kind, even with --force.
    launch_recording(&index);
    let rec = std::fs::read(&index).expect("recording");
    refused(&make(&["--force"]), "is an MCAP recording, not a CSV table", &[(&index, &rec)]);
}
