//! The deployment files in `deploy/systemd/` and `deploy/k8s/` stay true to
//! the program: every command line they run parses with the orchestrator's
//! real command-line parser (after substituting what systemd or Kubernetes
//! would), the exit codes they accept exist, and the Kubernetes Job is an
//! Indexed Job whose shard count matches its completions.

use bycoms_orchestrator::commands::{Cli, Command};
use bycoms_runtime::exit;
use clap::Parser;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use yaml_rust2::{Yaml, YamlLoader};

fn deploy() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../deploy")
}

fn read(rel: &str) -> String {
    let path = deploy().join(rel);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A unit file as `section → key → values` (keys may repeat).
type Unit = HashMap<String, HashMap<String, Vec<String>>>;

fn parse_unit(text: &str) -> Unit {
    let mut unit = Unit::new();
    let mut section = String::new();
    for line in text.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#')) {
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            section = name.to_owned();
            continue;
        }
        let (key, value) = line.split_once('=').unwrap_or_else(|| panic!("not key=value: {line}"));
        assert!(!section.is_empty(), "key outside a section: {line}");
        unit.entry(section.clone()).or_default().entry(key.to_owned()).or_default().push(value.to_owned());
    }
    unit
}

fn one<'u>(unit: &'u Unit, section: &str, key: &str) -> &'u str {
    let values = unit.get(section).and_then(|s| s.get(key)).unwrap_or_else(|| panic!("no {section}.{key}"));
    assert_eq!(values.len(), 1, "{section}.{key} given {} times", values.len());
    &values[0]
}

/// The orchestrator's arguments in a unit's `ExecStart=`, with systemd's
/// `%i`, `%%` and `${VAR}` and the shell's `$VAR`/`$(…)` substituted.
fn exec_args(exec: &str, instance: &str, env: &HashMap<String, String>) -> Vec<String> {
    program_args(exec, instance, env, "/usr/local/bin/orchestrator")
}

/// `program`'s arguments in a unit's `ExecStart=` (see [`exec_args`]).
fn program_args(exec: &str, instance: &str, env: &HashMap<String, String>, program: &str) -> Vec<String> {
    let mut line = exec.replace("%%", "%").replace("%i", instance);
    for (k, v) in env {
        line = line.replace(&format!("${{{k}}}"), v);
    }
    line = line.replace("$STATE_DIRECTORY", "/var/lib/bycoms");
    // The shell's command substitution (the recording's time stamp).
    while let Some(start) = line.find("$(") {
        let end = line[start..].find(')').map(|e| start + e + 1).expect("closed $(");
        line.replace_range(start..end, "20260101T000000Z");
    }
    let words: Vec<String> =
        line.split_whitespace().map(|w| w.trim_matches(|c| c == '\'' || c == '"').to_owned()).collect();
    let at = words.iter().position(|w| w == program).unwrap_or_else(|| panic!("runs {program}"));
    words[at..].to_vec()
}

fn env_file(text: &str) -> HashMap<String, String> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            let (k, v) = l.split_once('=').unwrap_or_else(|| panic!("not KEY=value: {l}"));
            (k.to_owned(), v.to_owned())
        })
        .collect()
}

fn parse_cli(args: &[String]) -> Cli {
    Cli::try_parse_from(args).unwrap_or_else(|e| panic!("{args:?} does not parse:\n{e}"))
}

fn success_codes(unit: &Unit) -> Vec<i32> {
    one(unit, "Service", "SuccessExitStatus")
        .split_whitespace()
        .map(|c| c.parse().expect("numeric exit status"))
        .collect()
}

#[test]
fn the_launch_unit_runs_a_valid_launch_command() {
    let unit = parse_unit(&read("systemd/bycoms-launch@.service"));
    assert!(!one(&unit, "Unit", "Description").is_empty());
    assert_eq!(one(&unit, "Install", "WantedBy"), "multi-user.target");
    let args = exec_args(one(&unit, "Service", "ExecStart"), "exp1", &HashMap::new());
    let cli = parse_cli(&args);
    let Command::Launch(launch) = cli.command else { panic!("not a launch: {args:?}") };
    assert_eq!(launch.config.as_deref(), Some(Path::new("/etc/bycoms/exp1.toml")));
    let record = launch.record.expect("the unit records every run");
    assert!(record.starts_with("/var/lib/bycoms") && record.extension().is_some_and(|e| e == "mcap"));
    assert_eq!(cli.log.log_format, bycoms_runtime::logging::LogFormat::Json);
    assert_eq!(success_codes(&unit), [exit::NOT_ARRIVED, exit::INTERRUPTED]);
    assert_eq!(one(&unit, "Service", "KillMode"), "mixed", "SIGINT to the orchestrator, not its agents");
}

#[test]
fn the_gateway_unit_runs_a_valid_gateway_over_zenoh_for_its_instance() {
    #[derive(Parser)]
    struct AgentCli {
        #[command(flatten)]
        gateway: bycoms_agent::gateway::GatewayArgs,
        #[command(flatten)]
        log: bycoms_runtime::logging::LogArgs,
    }
    let unit = parse_unit(&read("systemd/bycoms-gateway@.service"));
    assert!(!one(&unit, "Unit", "Description").is_empty());
    assert_eq!(one(&unit, "Install", "WantedBy"), "multi-user.target");
    assert_eq!(one(&unit, "Service", "Restart"), "always", "ready for the next launch");
    let files = &unit["Service"]["EnvironmentFile"];
    assert_eq!(files, &["/etc/bycoms/gateway.env", "/etc/bycoms/gateway-%i.env"]);
    // The shipped examples fill in every variable the command line uses.
    let mut env = env_file(&read("systemd/gateway.env"));
    env.extend(env_file(&read("systemd/gateway-1.env")));
    let args = program_args(one(&unit, "Service", "ExecStart"), "1", &env, "/usr/local/bin/gateway");
    assert!(!args.iter().any(|a| a.contains('$')), "a variable is left: {args:?}");
    let cli = AgentCli::try_parse_from(&args).unwrap_or_else(|e| panic!("{args:?} does not parse:\n{e}"));
    let g = cli.gateway;
    g.validate().unwrap_or_else(|e| panic!("{args:?}: {e}"));
    assert_eq!(g.robot, 1);
    assert_eq!(g.bus.transport, bycoms_runtime::Transport::Zenoh);
    assert_eq!(g.bus.zenoh_config.as_deref(), Some(Path::new("/etc/bycoms/certs/robot-1.json5")));
    assert_eq!(g.key_file, Path::new("/etc/bycoms/keys/robot-1.key"));
    assert_eq!(cli.log.log_format, bycoms_runtime::logging::LogFormat::Json);
}

#[test]
fn the_sweep_unit_runs_shard_i_of_the_env_files_count() {
    let unit = parse_unit(&read("systemd/bycoms-sweep@.service"));
    assert_eq!(one(&unit, "Service", "EnvironmentFile"), "/etc/bycoms/sweep.env");
    let env = env_file(&read("systemd/sweep.env"));
    let shards: usize = env["SHARDS"].parse().expect("SHARDS is a number");
    let exec = one(&unit, "Service", "ExecStart");
    for var in ["SHARDS", "OUT", "SEED", "JOBS"] {
        assert!(exec.contains(&format!("${{{var}}}")), "ExecStart uses {var}");
    }
    let last = (shards - 1).to_string();
    let cli = parse_cli(&exec_args(exec, &last, &env));
    let Command::Sweep(sweep) = cli.command else { panic!("not a sweep") };
    let shard = sweep.shard.expect("a shard");
    assert_eq!((shard.index, shard.count), (shards - 1, shards));
    assert_eq!(sweep.out, Path::new(&env["OUT"]));
    // The instance must be a shard index below SHARDS: one past is refused.
    let past = Cli::try_parse_from(exec_args(exec, &shards.to_string(), &env));
    assert!(past.is_err(), "shard {shards}/{shards} must not parse");
    assert_eq!(success_codes(&unit), [exit::INTERRUPTED]);
}

fn yaml(rel: &str) -> Yaml {
    let docs = YamlLoader::load_from_str(&read(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"));
    assert_eq!(docs.len(), 1, "{rel}: one document");
    docs.into_iter().next().expect("one document")
}

fn str_of<'y>(y: &'y Yaml, what: &str) -> &'y str {
    y.as_str().unwrap_or_else(|| panic!("{what} is not a string: {y:?}"))
}

/// The only container of a Job, and its claim.
fn container(job: &Yaml) -> (&Yaml, &str) {
    assert_eq!(str_of(&job["apiVersion"], "apiVersion"), "batch/v1");
    assert_eq!(str_of(&job["kind"], "kind"), "Job");
    let pod = &job["spec"]["template"]["spec"];
    assert!(matches!(str_of(&pod["restartPolicy"], "restartPolicy"), "Never" | "OnFailure"));
    let containers = pod["containers"].as_vec().expect("containers");
    assert_eq!(containers.len(), 1);
    let claim = str_of(&pod["volumes"][0]["persistentVolumeClaim"]["claimName"], "claimName");
    (&containers[0], claim)
}

/// A container's command line with Kubernetes' `$(VAR)` expanded from `env`.
fn container_args(c: &Yaml, env: &HashMap<String, String>) -> Vec<String> {
    let words = c["command"].as_vec().into_iter().flatten().chain(c["args"].as_vec().into_iter().flatten());
    words
        .map(|w| {
            let mut s = str_of(w, "argument").to_owned();
            for (k, v) in env {
                s = s.replace(&format!("$({k})"), v);
            }
            assert!(!s.contains("$("), "unexpanded variable in {s}");
            s
        })
        .collect()
}

#[test]
fn the_kubernetes_job_is_indexed_and_its_shards_cover_the_completions() {
    let job = yaml("k8s/sweep-job.yaml");
    assert_eq!(str_of(&job["spec"]["completionMode"], "completionMode"), "Indexed");
    let completions = job["spec"]["completions"].as_i64().expect("completions");
    let parallelism = job["spec"]["parallelism"].as_i64().expect("parallelism");
    assert!(completions >= 1 && (1..=completions).contains(&parallelism));
    let (c, claim) = container(&job);
    let mut env: HashMap<String, String> = c["env"]
        .as_vec()
        .expect("env")
        .iter()
        .filter_map(|e| Some((e["name"].as_str()?.to_owned(), e["value"].as_str()?.to_owned())))
        .collect();
    let shards: i64 = env["SHARDS"].parse().expect("SHARDS is a number");
    assert_eq!(shards, completions, "one shard per completion index");
    let args = c["args"].as_vec().expect("args");
    assert!(args.iter().any(|a| a.as_str() == Some("$(JOB_COMPLETION_INDEX)/$(SHARDS)")));
    // Every index the Job controller hands out gives a valid shard of the same sweep.
    for index in [0, completions - 1] {
        env.insert("JOB_COMPLETION_INDEX".into(), index.to_string());
        let cli = parse_cli(&container_args(c, &env));
        let Command::Sweep(sweep) = cli.command else { panic!("not a sweep") };
        let shard = sweep.shard.expect("a shard");
        assert_eq!((shard.index as i64, shard.count as i64), (index, completions));
        let mount = str_of(&c["volumeMounts"][0]["mountPath"], "mountPath");
        assert_eq!(sweep.out, Path::new(mount), "shards write to the shared volume");
    }
    let pvc = yaml("k8s/study-pvc.yaml");
    assert_eq!(str_of(&pvc["metadata"]["name"], "claim name"), claim);
    assert_eq!(str_of(&pvc["spec"]["accessModes"][0], "access mode"), "ReadWriteMany");
}

#[test]
fn the_merge_job_reads_and_writes_the_same_volume() {
    let job = yaml("k8s/merge-job.yaml");
    let (c, claim) = container(&job);
    let sweep_job = yaml("k8s/sweep-job.yaml");
    let (_, sweep_claim) = container(&sweep_job);
    assert_eq!(claim, sweep_claim);
    let cli = parse_cli(&container_args(c, &HashMap::new()));
    let Command::Merge(merge) = cli.command else { panic!("not a merge") };
    let mount = Path::new(str_of(&c["volumeMounts"][0]["mountPath"], "mountPath"));
    assert_eq!(merge.inputs, [mount]);
    assert_eq!(merge.out, mount);
}

/// `deploy/ros2/bycoms.rviz` parses as YAML, its fixed frame is the
/// launch's, and every display's topic is one `launch --ros2` publishes
/// (a 3-robot launch, default namespace), with the type that display shows
/// and the durability the topic is offered with.
#[test]
fn the_rviz_config_shows_only_topics_the_launch_publishes() {
    use bycoms_launch::ros2::{publish::RunMessages, Ros2Config, WORLD_FRAME};
    let doc = YamlLoader::load_from_str(&read("ros2/bycoms.rviz")).expect("bycoms.rviz is YAML");
    let manager = &doc[0]["Visualization Manager"];
    assert_eq!(manager["Global Options"]["Fixed Frame"].as_str(), Some(WORLD_FRAME));
    let run = RunMessages::new(&Ros2Config::default(), 3);
    let displays = manager["Displays"].as_vec().expect("displays");
    let mut shown = 0;
    for display in displays {
        let class = display["Class"].as_str().expect("class");
        let Some(topic) = display["Topic"]["Value"].as_str() else { continue };
        let ours = run.topics().iter().find(|t| t.name == topic);
        let ours =
            ours.unwrap_or_else(|| panic!("bycoms.rviz shows {topic}, which the launch does not publish"));
        let expected = match class {
            "rviz_default_plugins/Map" => "nav_msgs/msg/OccupancyGrid",
            "rviz_default_plugins/Pose" => "geometry_msgs/msg/PoseStamped",
            "rviz_default_plugins/Path" => "nav_msgs/msg/Path",
            "rviz_default_plugins/MarkerArray" => "visualization_msgs/msg/MarkerArray",
            other => panic!("{topic}: display class {other} not checked here"),
        };
        assert_eq!(ours.description.name, expected, "{topic}: {class}");
        let latched = ours.qos.durability == bycoms_ros2::rmw_zenoh::policy::TRANSIENT_LOCAL;
        let durability = display["Topic"]["Durability Policy"].as_str();
        assert_eq!(durability, Some(if latched { "Transient Local" } else { "Volatile" }), "{topic}");
        shown += 1;
    }
    assert_eq!(shown, 8, "the map, the beacons, 3 poses and 3 paths");
}

/// The oldest Kubernetes the sweep Job is written for (`backoffLimitPerIndex`).
const KUBERNETES: &str = "1.29.0";

/// `python3 -m kubernetes_validate --strict` (an unknown field is an error)
/// of `files` against [`KUBERNETES`]'s API schema: Ok, or its findings.
fn kubernetes_validate(files: &[PathBuf]) -> Result<(), String> {
    let out = std::process::Command::new("python3")
        .args(["-m", "kubernetes_validate", "--strict", "-k", KUBERNETES])
        .args(files)
        .output()
        .expect("python3 runs");
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(!text.contains("No module named"), "needs PyPI's kubernetes-validate: {text}");
    if out.status.success() {
        Ok(())
    } else {
        Err(text)
    }
}

/// Every manifest in `deploy/k8s/` validates against the Kubernetes API's
/// schema, and the validator refuses a misspelt field (the check can fail).
#[test]
#[ignore = "needs the Python package kubernetes-validate (PyPI; .ci/run installs it)"]
fn the_kubernetes_manifests_validate_against_the_api_schema() {
    let dir = deploy().join("k8s");
    let mut manifests: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("deploy/k8s")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "yaml"))
        .collect();
    manifests.sort();
    assert_eq!(manifests.len(), 3, "sweep and merge Jobs and their volume: {manifests:?}");
    if let Err(findings) = kubernetes_validate(&manifests) {
        panic!("deploy/k8s does not validate against Kubernetes {KUBERNETES}: {findings}");
    }
    let bad = tempfile::tempdir().expect("temp dir");
    let misspelt = bad.path().join("sweep-job.yaml");
    std::fs::write(&misspelt, read("k8s/sweep-job.yaml").replace("completionMode:", "completionMod:"))
        .expect("write");
    let findings = kubernetes_validate(&[misspelt]).expect_err("a misspelt field is refused");
    assert!(findings.contains("completionMod"), "{findings}");
}

/// The words of the Dockerfile's instruction lines that start with `what`.
fn dockerfile_lines(text: &str, what: &str) -> Vec<Vec<String>> {
    text.lines()
        .filter(|l| l.starts_with(what))
        .map(|l| l.split_whitespace().map(str::to_owned).collect())
        .collect()
}

/// The workspace's binary targets (`cargo metadata`).
fn workspace_binaries() -> Vec<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = std::process::Command::new(cargo)
        .args(["metadata", "--no-deps", "--format-version", "1", "--offline"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(out.status.success(), "cargo metadata: {}", String::from_utf8_lossy(&out.stderr));
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).expect("cargo metadata's JSON");
    let packages = meta["packages"].as_array().expect("packages").iter();
    let targets = packages.flat_map(|p| p["targets"].as_array().expect("targets").iter());
    targets
        .filter(|t| t["kind"].as_array().is_some_and(|k| k.iter().any(|k| k == "bin")))
        .map(|t| t["name"].as_str().expect("name").to_owned())
        .collect()
}

/// The image of the Kubernetes Jobs: it builds, from the workspace's own
/// binaries, every binary it copies; the Jobs' program is among them; its
/// Rust is the workspace's `rust-version`.
#[test]
fn the_dockerfile_builds_the_binaries_it_copies_and_the_jobs_run() {
    let text = read("k8s/Dockerfile");
    let builds: Vec<String> = dockerfile_lines(&text, "RUN cargo build")
        .concat()
        .windows(2)
        .filter(|w| w[0] == "--bin")
        .map(|w| w[1].clone())
        .collect();
    let workspace = workspace_binaries();
    for bin in &builds {
        assert!(workspace.contains(bin), "the Dockerfile builds {bin}, which no crate has: {workspace:?}");
    }
    let copies = dockerfile_lines(&text, "COPY --from=build");
    assert_eq!(copies.len(), 1, "one COPY of the binaries");
    let (to, from) = copies[0][2..].split_last().expect("COPY sources and a destination");
    assert_eq!(to, "/usr/local/bin/");
    for source in from {
        let bin = source.strip_prefix("/src/target/release/").expect("a release binary");
        assert!(builds.iter().any(|b| b == bin), "the Dockerfile copies {bin} but builds only {builds:?}");
    }
    for job in ["k8s/sweep-job.yaml", "k8s/merge-job.yaml"] {
        let manifest = yaml(job);
        let program = str_of(&container(&manifest).0["command"][0], "command");
        assert!(builds.iter().any(|b| b == program), "{job} runs {program}, not in the image");
    }
    let rust = dockerfile_lines(&text, "FROM rust:")[0][1].clone();
    let manifest = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../Cargo.toml"))
        .expect("Cargo.toml");
    let version = manifest.lines().find_map(|l| l.strip_prefix("rust-version = ")).expect("rust-version");
    assert!(
        rust.starts_with(&format!("rust:{}-", version.trim_matches('"'))),
        "{rust} is not Rust {version}"
    );
}
