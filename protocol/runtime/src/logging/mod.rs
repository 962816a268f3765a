//! One logging setup shared by every BYCOMS binary (`orchestrator`,
//! `sim-agent`, `natnet-serve` and the `gateway`): diagnostics are
//! `tracing` events, written to stderr, filtered by `RUST_LOG`, as text or
//! as JSON lines.
//!
//! Why in the runtime: the binaries live in different crates and the
//! gateway of a real robot must not depend on the simulator to log the
//! same way. Why stderr: stdout carries the programs' results (summaries,
//! tables, JSON), which must stay parseable.
//!
//! * `RUST_LOG` takes `tracing-subscriber`'s `EnvFilter` syntax
//!   (`debug`, `bycoms_sim=trace,info`, …). Unset, or for targets it does
//!   not name, the level is [`DEFAULT_LEVEL`], except the libraries'
//!   targets in [`QUIET_TARGETS`] (zenoh's, the Foxglove server's), which
//!   say only warnings unless `RUST_LOG` names them or sets a level for all.
//!   Invalid directives are skipped with a note on stderr rather than
//!   silencing the program.
//! * `--log-format text|json` (flatten [`LogArgs`] into a clap parser, it is
//!   `global`) or the environment variable [`FORMAT_ENV`]. [`init`] exports
//!   the chosen format in [`FORMAT_ENV`] so that child processes (the
//!   `sim-agent`s that `launch` starts) log in the same format.
//! * [`status_line`] is for the human-facing lines a program prints on
//!   stderr besides its logs (the launch's plain progress lines, a summary
//!   line next to JSON on stdout): unchanged text in the text format, an
//!   `info` event of target [`STATUS_TARGET`] in the JSON format, so that a
//!   log shipper reading stderr sees nothing but JSON lines.
//! * [`error_text`] renders the error that ends a program: its causes
//!   joined, each said once (the one place that formats an error chain).
//! * Feature `iceoryx2`: [`iceoryx2::forward_to_tracing`] routes iceoryx2's
//!   own log lines through the same subscriber.
//! * zenoh's warnings and errors are said in our words (`zenoh_words`):
//!   what failed (a certificate, an address in use, a host not found, a
//!   refused connection), without its source paths or misleading hints.
//! * Text lines have no timestamp (a terminal or journald adds its own);
//!   JSON lines have one, plus the level, target, fields and spans, as log
//!   shippers expect.

mod error_text;
#[cfg(feature = "iceoryx2")]
pub mod iceoryx2;
mod zenoh_words;

pub use error_text::error_text;

use std::io::IsTerminal;
use std::sync::OnceLock;
use tracing_subscriber::filter::{EnvFilter, LevelFilter};

/// The level of every target that `RUST_LOG` does not mention.
pub const DEFAULT_LEVEL: LevelFilter = LevelFilter::INFO;

/// The environment variable that carries the format to child processes
/// (and that a user may set instead of the flag).
pub const FORMAT_ENV: &str = "BYCOMS_LOG_FORMAT";

/// The target of the events [`status_line`] emits in the JSON format.
pub const STATUS_TARGET: &str = "status";

static FORMAT: OnceLock<LogFormat> = OnceLock::new();

/// How log lines look on stderr.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum LogFormat {
    /// One human-readable line per event: `LEVEL span{fields}: message key=value`.
    #[default]
    Text,
    /// One JSON object per line (timestamp, level, target, fields, spans).
    Json,
}

impl LogFormat {
    /// The flag's spelling (`text` or `json`).
    pub fn as_str(self) -> &'static str {
        match self {
            LogFormat::Text => "text",
            LogFormat::Json => "json",
        }
    }
}

/// The logging flags of a binary; flatten into its clap parser.
#[derive(Debug, Clone, Copy, Default, clap::Args)]
pub struct LogArgs {
    /// Log line format on stderr (filter lines with RUST_LOG, e.g. RUST_LOG=debug).
    #[arg(long, global = true, value_enum, env = FORMAT_ENV, default_value_t = LogFormat::Text)]
    pub log_format: LogFormat,
}

/// Installs the global subscriber for `format`; call once, first thing in
/// `main`, before any thread starts (it exports [`FORMAT_ENV`]). A second
/// call (e.g. a command run in-process by a test) leaves the first in place.
pub fn init(format: LogFormat) {
    // Before any thread exists: children inherit the format.
    std::env::set_var(FORMAT_ENV, format.as_str());
    let _ = FORMAT.set(format);
    let rust_log = std::env::var("RUST_LOG").unwrap_or_default();
    let filter = EnvFilter::builder().parse_lossy(filter_directives(&rust_log));
    // A closed stderr drops events quietly: by default tracing-subscriber
    // reports its own write failures with `eprintln!`, which panics on EPIPE.
    let builder = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(filter)
        .log_internal_errors(false);
    // zenoh's warnings and errors in our words (`zenoh_words`).
    let installed = match format {
        LogFormat::Text => builder
            .without_time()
            .with_target(false)
            .with_ansi(std::io::stderr().is_terminal())
            .map_event_format(zenoh_words::Reworded)
            .try_init(),
        LogFormat::Json => builder
            .json()
            .with_current_span(true)
            .with_span_list(false)
            .map_event_format(zenoh_words::Reworded)
            .try_init(),
    };
    // Err only when a subscriber is already installed: keep that one.
    drop(installed);
}

/// Targets whose `info` lines mislead at the default level, with the
/// level they get unless `RUST_LOG` names them or sets a level for all.
///
/// The Foxglove SDK's WebSocket server runs behind the live view's front
/// (`orchestrator launch --serve`) on an internal loopback port: its
/// "Started server on 127.0.0.1:PORT" names a port no viewer should use,
/// and it sees every viewer as 127.0.0.1. The front logs the real ones.
///
/// zenoh (every crate of it: `zenoh`, `zenoh_transport`, `zenoh_link_*`,
/// … — a target directive matches by prefix) says at `info` what every
/// healthy session does: its id, where it can be reached, each session
/// closed; over twenty lines in a three-robot launch. Our own lines say
/// what matters (the endpoint the orchestrator listens on, an agent that
/// cannot connect, and why); zenoh's warnings and errors still show.
pub const QUIET_TARGETS: [(&str, LevelFilter); 2] =
    [("foxglove::websocket", LevelFilter::WARN), ("zenoh", LevelFilter::WARN)];

/// The directives for `rust_log` (the value of `RUST_LOG`): as given, with
/// [`DEFAULT_LEVEL`] in front unless it sets a level for all targets, so
/// that `RUST_LOG=iceoryx2=debug` adds a target instead of silencing the
/// rest, and then [`QUIET_TARGETS`] that `rust_log` does not mention.
pub fn filter_directives(rust_log: &str) -> String {
    let sets_global_level =
        rust_log.split(',').any(|d| d.trim().parse::<LevelFilter>().is_ok() && !d.trim().is_empty());
    if sets_global_level {
        return rust_log.to_owned();
    }
    let mut directives = if rust_log.trim().is_empty() {
        DEFAULT_LEVEL.to_string()
    } else {
        format!("{DEFAULT_LEVEL},{rust_log}")
    };
    let crate_of = |target: &str| target.split("::").next().unwrap_or_default().to_owned();
    for (target, level) in QUIET_TARGETS {
        if !rust_log.contains(&crate_of(target)) {
            directives.push_str(&format!(",{target}={level}"));
        }
    }
    directives
}

/// The format [`init`] installed (text if it was never called).
pub fn format() -> LogFormat {
    FORMAT.get().copied().unwrap_or_default()
}

/// Writes one human-facing status line to stderr: as it is in the text
/// format, as an `info` event (target [`STATUS_TARGET`]) in the JSON format.
///
/// Never panics: a closed stderr (`orchestrator launch 2>&1 | head -1`)
/// drops the line, as `tracing`'s writer drops events, so the program still
/// ends in order (`eprintln!` would panic on `EPIPE`).
pub fn status_line(text: &str) {
    use std::io::Write;
    match format() {
        LogFormat::Text => {
            let _ = writeln!(std::io::stderr().lock(), "{text}");
        }
        LogFormat::Json => tracing::info!(target: STATUS_TARGET, "{text}"),
    }
}

#[cfg(test)]
mod tests {
    use super::filter_directives;
    use tracing_subscriber::layer::SubscriberExt as _;

    #[test]
    fn the_default_level_applies_unless_rust_log_sets_one() {
        let quiet = ",foxglove::websocket=warn,zenoh=warn";
        assert_eq!(filter_directives(""), format!("info{quiet}"));
        assert_eq!(filter_directives("debug"), "debug");
        assert_eq!(filter_directives("iceoryx2=trace,WARN"), "iceoryx2=trace,WARN");
        assert_eq!(filter_directives("iceoryx2=trace"), format!("info,iceoryx2=trace{quiet}"));
        assert_eq!(filter_directives("bycoms_sim"), format!("info,bycoms_sim{quiet}"));
    }

    #[test]
    fn the_live_views_internal_server_is_quiet_unless_asked_for() {
        // Its "Started server on 127.0.0.1:PORT" names an internal port.
        assert!(filter_directives("").contains(",foxglove::websocket=warn"));
        assert_eq!(filter_directives("foxglove=info"), "info,foxglove=info,zenoh=warn");
    }

    #[test]
    fn zenoh_s_own_info_lines_are_quiet_unless_asked_for() {
        // "Using ZID", "Zenoh can be reached at", "close session": per
        // session, in every process of a launch.
        let zenoh_info = |rust_log: &str| {
            let filter = tracing_subscriber::EnvFilter::builder().parse_lossy(filter_directives(rust_log));
            let subscriber = tracing_subscriber::registry().with(filter);
            tracing::subscriber::with_default(subscriber, || {
                (
                    tracing::enabled!(target: "zenoh::net::runtime", tracing::Level::INFO),
                    tracing::enabled!(target: "zenoh_transport::unicast", tracing::Level::WARN),
                    tracing::enabled!(target: "bycoms_launch::driver", tracing::Level::INFO),
                )
            })
        };
        assert_eq!(zenoh_info(""), (false, true, true), "zenoh's info quiet, its warnings and ours shown");
        assert_eq!(zenoh_info("zenoh=info"), (true, true, true), "named: as asked");
        assert_eq!(zenoh_info("debug"), (true, true, true), "a level for all: as asked");
    }
}
