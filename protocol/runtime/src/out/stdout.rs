//! Lines on stdout and stderr, without panicking when they are closed.
//!
//! Why: `println!`/`eprintln!` panic when the stream is gone (`orchestrator
//! launch 2>&1 | head -1`, `simulate --json | true`): Rust ignores SIGPIPE,
//! so a write to a pipe whose reader has left fails with `EPIPE`, and the
//! macros turn that into a panic (exit 101) that skips the orderly end: no
//! `Shutdown` to the agents, no recording footer, iceoryx2 files left behind.
//! Here a closed stream means what it means for ripgrep: nobody reads any
//! more, so stop writing to it, quietly. The work itself ends the way it
//! would have anyway — a launch still shuts its agents down and finishes its
//! recording, and its exit code is still its outcome's.
//!
//! Every command prints its results through [`outln!`](crate::outln);
//! stderr carries `tracing` events and `bycoms_runtime::logging::status_line`s, which
//! drop their lines on a closed stderr the same way. Other write errors on
//! stdout (a full disk behind `> file`) are real errors and are returned.

use std::io::{ErrorKind, Write};
use std::sync::atomic::{AtomicBool, Ordering};

static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);

/// Writes `text` and a newline to stdout. A closed stdout is not an error
/// (nothing more is written to it); any other write error is, and says it
/// was stdout ("cannot write to stdout: No space left on device": `sweep >
/// /dev/full` said only the latter, as if one of its files had failed).
pub fn line(text: &str) -> std::io::Result<()> {
    if STDOUT_CLOSED.load(Ordering::Relaxed) {
        return Ok(());
    }
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{text}").and_then(|()| out.flush()) {
        Err(e) if e.kind() == ErrorKind::BrokenPipe => {
            STDOUT_CLOSED.store(true, Ordering::Relaxed);
            Ok(())
        }
        Err(e) => Err(std::io::Error::new(e.kind(), format!("cannot write to stdout: {e}"))),
        Ok(()) => Ok(()),
    }
}

/// `println!` that does not panic on a closed stdout; evaluates to
/// `std::io::Result<()>` (see [`out::stdout`](crate::out::stdout)).
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::out::line(&format!($($arg)*))
    };
}
