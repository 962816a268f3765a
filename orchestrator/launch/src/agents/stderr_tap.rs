//! What a child process said last: its standard error, passed through to
//! ours line by line, with its last error line kept.
//!
//! Why: an agent or gateway that cannot start says why on its standard
//! error ("cannot listen for robot 1 on …: Address already in use") and
//! exits 1. With its stderr simply inherited, a person reading the terminal
//! sees that line among others, but the launch only knew "its process
//! ended (exit status: 1)", and that is what the summary and the recording
//! said of an absent robot. Tapped, the launch can give the real reason.
//!
//! One reader thread per child (a small stack): it forwards each line as it
//! comes, so the terminal shows what it showed before, and remembers the
//! last line at level ERROR (our processes log with `tracing`, as text —
//! `ERROR agent{robot=1}: message` — or JSON — `"level":"ERROR"`). Writes to
//! our stderr that fail (a closed terminal) are ignored: the child must
//! never block on a full pipe.

use std::io::{BufRead, BufReader, Read, Write};
use std::sync::mpsc::{self, Receiver};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

/// Stack of a reader thread: it only moves lines.
const STACK: usize = 64 * 1024;

/// The tap on one child's standard error.
pub struct StderrTap {
    last_error: Arc<Mutex<Option<String>>>,
    /// Closed when the child's stderr reached its end.
    done: Receiver<()>,
}

impl StderrTap {
    /// Starts passing `stderr` through to this process's standard error.
    pub fn start(stderr: impl Read + Send + 'static, name: String) -> std::io::Result<Self> {
        let last_error = Arc::new(Mutex::new(None));
        let (tx, done) = mpsc::channel::<()>();
        let kept = Arc::clone(&last_error);
        std::thread::Builder::new().name(name).stack_size(STACK).spawn(move || {
            let _done = tx; // dropped (the channel closes) at the end of the stream
            for line in BufReader::new(stderr).lines() {
                let Ok(line) = line else { break };
                let _ = writeln!(std::io::stderr().lock(), "{line}");
                if let Some(message) = error_message(&line) {
                    *kept.lock().unwrap_or_else(PoisonError::into_inner) = Some(message);
                }
            }
        })?;
        Ok(Self { last_error, done })
    }

    /// The child's last error line, once its stream ended (it exited);
    /// waits up to `timeout` for the end, as the child's last words may
    /// still be in the pipe right after it exited.
    pub fn last_error(&self, timeout: Duration) -> Option<String> {
        let _ = self.done.recv_timeout(timeout);
        self.last_error.lock().unwrap_or_else(PoisonError::into_inner).clone()
    }
}

/// The message of a `tracing` line at level ERROR, text or JSON.
pub fn error_message(line: &str) -> Option<String> {
    let line = line.trim();
    if line.starts_with('{') {
        let v: serde_json::Value = serde_json::from_str(line).ok()?;
        if v["level"].as_str()? != "ERROR" {
            return None;
        }
        return v["fields"]["message"].as_str().map(str::to_owned);
    }
    // Text: an optional time stamp, the level, the spans, ": ", the
    // message. Only a span with fields (`agent{robot=1}`) is told apart
    // from a message's own "word: " and cut; a bare span name stays.
    let at = line.find("ERROR ")?;
    let rest = &line[at + "ERROR ".len()..];
    let message = match rest.find("}: ") {
        Some(end) if !rest[..end].contains(' ') => &rest[end + 3..],
        _ => rest,
    };
    Some(message.trim().to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::process::{Command, Stdio};

    #[test]
    fn text_and_json_error_lines_give_their_message_and_others_nothing() {
        let text = "ERROR agent{robot=1}: cannot listen for robot 1 on 127.0.0.1:1: Address already in use";
        assert_eq!(
            error_message(text).as_deref(),
            Some("cannot listen for robot 1 on 127.0.0.1:1: Address already in use")
        );
        assert_eq!(error_message("2026-11-24T23:00:00Z ERROR bus: closed").as_deref(), Some("bus: closed"));
        let json = r#"{"level":"ERROR","fields":{"message":"bus: closed"},"span":{"robot":1}}"#;
        assert_eq!(error_message(json).as_deref(), Some("bus: closed"));
        assert_eq!(error_message(r#"{"level":"WARN","fields":{"message":"x"}}"#), None);
        assert_eq!(error_message(" WARN sim-agent{robot=2}: exiting: bad messages: 3"), None);
        assert_eq!(error_message("INFO agent{robot=1}: gateway listening"), None);
    }

    #[test]
    fn a_child_s_last_error_is_kept_once_it_exited() {
        let script = "echo 'INFO agent{robot=1}: starting' >&2; \
                      echo 'ERROR agent{robot=1}: first' >&2; \
                      echo 'ERROR agent{robot=1}: cannot listen: Address already in use' >&2; \
                      echo ' WARN agent{robot=1}: after' >&2; exit 1";
        let mut child = Command::new("sh").args(["-c", script]).stderr(Stdio::piped()).spawn().expect("sh");
        let tap = StderrTap::start(child.stderr.take().expect("piped"), "tap".into()).expect("tap");
        assert!(!child.wait().expect("wait").success());
        assert_eq!(
            tap.last_error(Duration::from_secs(10)).as_deref(),
            Some("cannot listen: Address already in use")
        );
    }
}
