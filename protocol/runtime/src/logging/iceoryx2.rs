//! iceoryx2's own log lines, as `tracing` events of target `iceoryx2`.
//!
//! Why: iceoryx2 writes to stderr through its own console logger, in its
//! own format, which would break the one-JSON-object-per-line promise of
//! `--log-format json`. Its `set_logger` hook takes any `Log`; this one
//! forwards each line, with iceoryx2's `origin` as a field. iceoryx2's own
//! level (`IOX2_LOG_LEVEL`, or what the caller sets) still applies first.

use core::fmt::Arguments;
use iceoryx2_log::{Log, LogLevel};

/// The forwarder.
struct ToTracing;

impl Log for ToTracing {
    fn log(&self, level: LogLevel, origin: Arguments, message: Arguments) {
        match level {
            LogLevel::Trace => tracing::trace!(target: "iceoryx2", origin = %origin, "{message}"),
            LogLevel::Debug => tracing::debug!(target: "iceoryx2", origin = %origin, "{message}"),
            LogLevel::Info => tracing::info!(target: "iceoryx2", origin = %origin, "{message}"),
            LogLevel::Warn => tracing::warn!(target: "iceoryx2", origin = %origin, "{message}"),
            LogLevel::Error | LogLevel::Fatal => {
                tracing::error!(target: "iceoryx2", origin = %origin, "{message}");
            }
        }
    }
}

static TO_TRACING: ToTracing = ToTracing;

/// Sends iceoryx2's log lines to `tracing` from now on. iceoryx2 accepts a
/// logger once per process, before its first log line; returns whether this
/// call installed it.
pub fn forward_to_tracing() -> bool {
    iceoryx2_log::set_logger(&TO_TRACING)
}
