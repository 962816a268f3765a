//! What the command line and `main` of every swarm binary share: the
//! real-time speed-up's one check, the assembly and the parser of a command
//! line whose own flags sit beside its subcommands (`sim-agent` and
//! `sim-agent lab` / `doctor`, `gateway` and `gateway bench` / `doctor`), and
//! the set-up of the iceoryx2 and zenoh libraries in a process of ours.

use crate::logging::LogArgs;
use clap::error::ErrorKind;
use clap::parser::ValueSource;
use clap::{Args, Command, FromArgMatches, Subcommand};
use std::sync::atomic::{AtomicBool, Ordering};

/// Fastest real-time speed-up: a control period of 0.1 s / 1000 = 100 µs
/// of wall time, about what an agent and the orchestrator turn around in
/// (step, publish, read, answer with a bearing) on one machine; see the
/// summary's achieved speed for what a machine really does. Why not more:
/// at `--speed 100000` (a period of 1 µs) a debug build achieved 978×,
/// every robot stood still for the gate's whole dwell (200 µs of wall time)
/// before its first bearing came and was judged stuck where it started,
/// then drove on as a beacon: no run at such a speed means anything.
pub const MAX_SPEED: f64 = 1_000.0;

/// Slowest real-time speed-up: a control period of 0.1 s / speed stays at
/// most 100 s, so every wall-time span divided by the speed-up is a valid
/// `Duration` (`--speed 1e-300` made one of 1e299 s: a panic).
pub const MIN_SPEED: f64 = 0.001;

/// The real-time speed-up must be a number in [[`MIN_SPEED`],
/// [`MAX_SPEED`]] (shared by `launch`, `bench scale` and the agent).
pub fn check_speed(speed: f64) -> Result<(), String> {
    if !(MIN_SPEED..=MAX_SPEED).contains(&speed) {
        return Err(format!(
            "the real-time speed-up must be a number in [{MIN_SPEED}, {MAX_SPEED}], got {speed:?}"
        ));
    }
    Ok(())
}

/// `--swarm-size` must hold robot `robot`: a swarm of 0, or one this robot
/// is not in, sizes the bus wrongly for every process of the swarm, so it
/// is said, not silently stretched (shared by `gateway` and `sim-agent`).
pub fn check_swarm_size(robot: u32, swarm_size: Option<u32>) -> Result<(), String> {
    match swarm_size.filter(|&n| n < robot.max(1)) {
        Some(n) => Err(format!(
            "--swarm-size {n}: robot {robot} is not one of the swarm's robots 1..={n}; give the swarm's size \
             (at least {robot})"
        )),
        None => Ok(()),
    }
}

/// The clap value parser of a robot link's fixed UDP address (`gateway
/// --bind`, `gateway doctor --bind`): host:port with a port other than 0.
/// A robot sends to the gateway address flashed into it; port 0 (any free
/// port) is an address no robot sends to.
pub fn fixed_port(text: &str) -> Result<std::net::SocketAddr, String> {
    let addr: std::net::SocketAddr =
        text.trim().parse().map_err(|_| format!("not an IP address and port: {text:?}"))?;
    if addr.port() == 0 {
        return Err(format!("{addr} has port 0: give the robot link's fixed port"));
    }
    Ok(addr)
}

/// The command line of a swarm binary `name` (`sim-agent`, `gateway`) whose
/// own flags `M` and the logging flags sit at the top level, next to the
/// subcommands of `S` (a `clap::Subcommand` enum: `lab` and `doctor`,
/// `bench` and `doctor`).
///
/// The top level's flags stay at the top level (launchers start
/// `sim-agent --swarm … --robot …`) next to the subcommands: one clap
/// command where a subcommand lifts the top level's required flags
/// (`subcommand_negates_reqs`) and the two exclude each other (checked by
/// [`parse_with_subcommands`]), so `--help` lists the subcommands and `NAME
/// SUB --help` has the subcommand's own usage line. The logging flags are
/// `global`: they go before or after the subcommand (clap's own
/// `args_conflicts_with_subcommands` would refuse them before it, as it
/// refuses any flag there). Assembled
/// from the argument structs rather than derived as one struct: clap's
/// derive cannot leave out a flattened struct that itself flattens another
/// (the bus and failsafe flags) when the subcommand is used. (The about
/// line is set last: `augment_args` applies each struct's doc comment as
/// the command's about.)
pub fn command_with_subcommands<M: Args, S: Subcommand>(
    name: &'static str,
    version: &'static str,
    about: &'static str,
) -> Command {
    let top = S::augment_subcommands(Command::new(name).subcommand_negates_reqs(true));
    LogArgs::augment_args(M::augment_args(top)).version(version).about(about).long_about(None::<&str>)
}

/// Parses `argv` (`argv[0]` first) with `command` (made by
/// [`command_with_subcommands`]): the logging flags, and the top level's
/// flags (`Err`) or the chosen subcommand's (`Ok`). A top-level flag given
/// with a subcommand is refused (an argument conflict, as clap's own
/// check says it); the logging flags, global, are not top-level flags.
/// Errors carry the usage line of the command they are about.
pub fn parse_with_subcommands<M: FromArgMatches, S: FromArgMatches, I, T>(
    command: fn() -> Command,
    argv: I,
) -> Result<(LogArgs, Result<S, M>), clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let matches = command().try_get_matches_from(argv)?;
    let formatted = |e: clap::Error| e.format(&mut command());
    if let Some((name, _)) = matches.subcommand() {
        // Built: an argument's text (`--robot <ROBOT>`) needs its value count.
        let mut top = command();
        top.build();
        let given = top.get_arguments().find(|arg| {
            !arg.is_global_set()
                && matches.value_source(arg.get_id().as_str()) == Some(ValueSource::CommandLine)
        });
        if let Some(arg) = given {
            let text = format!("the subcommand '{name}' cannot be used with '{arg}'");
            return Err(command().error(ErrorKind::ArgumentConflict, text));
        }
    }
    let log = LogArgs::from_arg_matches(&matches).map_err(formatted)?;
    let chosen = match matches.subcommand() {
        Some(_) => Ok(S::from_arg_matches(&matches).map_err(formatted)?),
        None => Err(M::from_arg_matches(&matches).map_err(formatted)?),
    };
    Ok((log, chosen))
}

/// The zenoh runtime of our processes (see
/// [`bycoms_protocol::bus::zenoh::tune_runtime`]), and what happens when
/// it fails: call first thing in `main` (after the logging).
///
/// Why the panic hook: zenoh starts its runtimes (thread pools) lazily and
/// panics when it cannot ("Failed to init rx", tokio's "OS can't spawn
/// worker thread"), often in one of its own threads. Under a memory limit
/// (`ulimit -v 300000`) a launch's orchestrator printed that panic and then
/// waited a minute for agents that could not come, its main thread waiting
/// on a runtime that was not there. Such a panic now ends the process at
/// once, exit 1, with one error line saying what failed in our words
/// ([`zenoh_failure`]); any other panic is left to the default hook.
pub fn tune_zenoh_runtime() {
    bycoms_protocol::bus::zenoh::tune_runtime();
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| (*s).to_owned())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_default();
        let thread = std::thread::current();
        let at = info.location().map(|l| l.file()).unwrap_or_default();
        match zenoh_failure(thread.name().unwrap_or_default(), at, &message) {
            Some(words) if DECIDED.load(Ordering::SeqCst) => {
                tracing::warn!("{words} (while closing, after the result was decided: the result stands)");
            }
            Some(words) => {
                tracing::error!("{words}");
                std::process::exit(1);
            }
            None => default(info),
        }
    }));
}

/// Whether the process's result is decided ([`result_decided`]).
static DECIDED: AtomicBool = AtomicBool::new(false);

/// Says that the process's result is decided (a launch's run has ended):
/// a zenoh panic after it, while zenoh closes its sessions, is said as a
/// warning and the result's exit code stands. Why: a launch stopped by
/// `/emergency` once printed its summary and then exited 1 instead of 130,
/// a zenoh runtime thread (`net-0`) having panicked on an `Option::unwrap`
/// while the sessions closed (zenoh's own kind of shutdown panic, e.g.
/// zenoh #1960). A runtime task's panic is caught by the runtime once the
/// hook returns, so the closing goes on.
pub fn result_decided() {
    DECIDED.store(true, Ordering::SeqCst);
}

/// zenoh's runtime threads are named `<runtime>-<n>` (`zenoh-runtime`).
const ZENOH_THREADS: [&str; 5] = ["app-", "acc-", "tx-", "rx-", "net-"];

/// A panic (`message`, in thread `thread`, raised in source file `at`)
/// that is zenoh failing — in one of its threads, or in its code (its
/// runtime started lazily from ours) — in our words; `None` for any other.
pub fn zenoh_failure(thread: &str, at: &str, message: &str) -> Option<String> {
    let in_zenoh =
        ZENOH_THREADS.iter().any(|p| thread.strip_prefix(p).is_some_and(|n| n.parse::<u32>().is_ok()));
    let zenoh_code = at.contains("/zenoh-") || at.starts_with("zenoh-");
    let starting = message.starts_with("Failed to init ") || message.contains("can't spawn worker thread");
    if !(in_zenoh || zenoh_code || starting) {
        return None;
    }
    let memory = ["os error 11", "os error 12", "Resource temporarily unavailable", "Cannot allocate memory"]
        .iter()
        .any(|m| message.contains(m));
    let said = bycoms_protocol::bus::zenoh::zenoh_error(&message);
    Some(if memory || message.starts_with("Failed to init ") {
        format!(
            "out of memory: zenoh could not start its threads (is the process's memory limit, `ulimit -v`, \
             too small?): {said}"
        )
    } else {
        format!("zenoh failed (thread {thread}): {said}")
    })
}

/// iceoryx2 warns on every process start that it runs without a config
/// file (by design here: the defaults are what we want). Show only errors,
/// unless `IOX2_LOG_LEVEL` asks for more; as `tracing` events (target
/// `iceoryx2`), so they follow `--log-format`.
pub fn quiet_iceoryx2() {
    use iceoryx2_log::{set_log_level_from_env_or, LogLevel};
    crate::logging::iceoryx2::forward_to_tracing();
    set_log_level_from_env_or(LogLevel::Error);
}

/// The body of every agent process's `main_with` (`sim-agent`, `gateway`,
/// `ros2-robot`), run inside the caller's span (`sim-agent{robot=3}: …`):
/// inherited files closed and iceoryx2 quietened first, then `run`; an end
/// is its cause's exit code (the runtime's one mapping,
/// [`ExitCause::exit_code`](crate::lifeline::ExitCause::exit_code)), an
/// error is logged once and its code is what `code_of` says (2 for a usage
/// error, 3 for a refusal, 1 for the rest, as each agent decides).
pub fn agent_main<E: std::fmt::Display>(
    run: impl FnOnce() -> Result<crate::lifeline::ExitCause, E>,
    code_of: impl FnOnce(&E) -> i32,
) -> i32 {
    crate::inherited::close_inherited_files();
    quiet_iceoryx2();
    match run() {
        Ok(cause) => {
            tracing::debug!(?cause, "exits");
            cause.exit_code()
        }
        Err(e) => {
            tracing::error!("{e}");
            code_of(&e)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_robot_links_address_has_a_fixed_port() {
        assert_eq!(fixed_port("127.0.0.1:47101"), Ok("127.0.0.1:47101".parse().unwrap()));
        assert_eq!(
            fixed_port("127.0.0.1:0").unwrap_err(),
            "127.0.0.1:0 has port 0: give the robot link's fixed port"
        );
        assert!(fixed_port("nowhere").unwrap_err().contains("\"nowhere\""));
    }

    /// A top level's flags.
    #[derive(Debug, PartialEq, clap::Args)]
    struct Top {
        #[arg(long)]
        robot: u32,
    }

    /// A subcommand's flags.
    #[derive(Debug, PartialEq, clap::Args)]
    struct SubArgs {
        #[arg(long, default_value_t = 1)]
        frames: u32,
    }

    /// The subcommands.
    #[derive(Debug, PartialEq, clap::Subcommand)]
    enum Sub {
        Sub(SubArgs),
        Other(SubArgs),
    }

    fn command() -> Command {
        command_with_subcommands::<Top, Sub>("swarm-binary", "0", "a test")
    }

    fn parse(args: &[&str]) -> Result<(LogArgs, Result<Sub, Top>), clap::Error> {
        parse_with_subcommands(command, std::iter::once("swarm-binary").chain(args.iter().copied()))
    }

    #[test]
    fn zenoh_s_runtime_failing_is_out_of_memory_in_our_words() {
        let spawn = "OS can't spawn worker thread: Resource temporarily unavailable (os error 11)";
        let tokio = "/root/.cargo/registry/src/x/tokio-1.48.0/src/runtime/blocking/pool.rs";
        let said = zenoh_failure("rx-0", tokio, spawn).expect("zenoh's runtime failed");
        assert!(said.starts_with("out of memory: zenoh could not start its threads"), "{said}");
        assert!(said.ends_with(spawn), "{said}");
        let lib = "/root/.cargo/registry/src/x/zenoh-runtime-1.10.2/src/lib.rs";
        let init = zenoh_failure("main", lib, "Failed to init net").expect("failed on the main thread");
        assert!(init.starts_with("out of memory"), "{init}");
        let zero = zenoh_failure("main", lib, "Worker threads cannot be set to 0").expect("zenoh's code");
        assert_eq!(zero, "zenoh failed (thread main): Worker threads cannot be set to 0");
        let other = zenoh_failure("tx-3", "src/ours.rs", "index out of bounds").expect("a zenoh thread");
        assert_eq!(other, "zenoh failed (thread tx-3): index out of bounds");
        assert_eq!(zenoh_failure("main", "src/ours.rs", "index out of bounds"), None, "our own panics stay");
        assert_eq!(zenoh_failure("rx-robot", "src/ours.rs", "index out of bounds"), None);
    }

    #[test]
    fn speed_ups_whose_periods_are_no_duration_are_refused() {
        for bad in [0.0, 1e-300, 1e-4, -1.0, f64::NAN, f64::INFINITY, 1e9] {
            let e = check_speed(bad).expect_err("refused");
            assert!(e.contains("in [0.001, 1000]"), "{e}");
        }
        for good in [MIN_SPEED, 1.0, MAX_SPEED] {
            assert!(check_speed(good).is_ok(), "{good}");
            assert!(std::time::Duration::try_from_secs_f64(0.5 / good).is_ok());
        }
    }

    #[test]
    fn the_command_is_consistent() {
        command().debug_assert();
    }

    #[test]
    fn the_logging_flags_go_anywhere_and_the_top_level_s_never_with_the_subcommand() {
        use crate::logging::LogFormat::Json;
        for args in [
            &["--log-format", "json", "sub", "--frames", "3"][..],
            &["sub", "--log-format", "json", "--frames", "3"],
            &["sub", "--frames", "3", "--log-format", "json"],
        ] {
            let (log, chosen) = parse(args).unwrap_or_else(|e| panic!("{args:?}: {e}"));
            assert_eq!((log.log_format, chosen), (Json, Ok(Sub::Sub(SubArgs { frames: 3 }))), "{args:?}");
        }
        for args in [&["--log-format", "json", "--robot", "2"][..], &["--robot", "2", "--log-format", "json"]]
        {
            let (log, chosen) = parse(args).unwrap_or_else(|e| panic!("{args:?}: {e}"));
            assert_eq!((log.log_format, chosen), (Json, Err(Top { robot: 2 })), "{args:?}");
        }
        let err = parse(&["--robot", "2", "sub"]).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::ArgumentConflict, "{err}");
        assert!(
            err.to_string().contains("the subcommand 'sub' cannot be used with '--robot <ROBOT>'"),
            "{err}"
        );
        assert!(parse(&["sub", "--robot", "2"]).is_err(), "the top level's flags are not the subcommand's");
        let (_, other) = parse(&["other", "--frames", "4"]).expect("the second subcommand");
        assert_eq!(other, Ok(Sub::Other(SubArgs { frames: 4 })));
        assert!(parse(&[]).unwrap_err().to_string().contains("--robot"), "required without the subcommand");
    }
}
