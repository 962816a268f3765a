//! Live progress of a launch on the terminal.
//!
//! Why two modes: on a terminal, one live line per robot (state, mode,
//! position) redrawn at most 10 times a second shows the run as it happens;
//! when stderr is not a terminal (CI logs, pipes) redrawn lines would be
//! noise, so only events (spawned, deployed, stopped, died) are printed, one
//! plain line each. Everything goes to stderr: stdout is for the summary or
//! the JSON.
//!
//! Why [`Waits`]: a launch that waits (a lost answer re-sent, an agent that
//! does not register, a robot cut off) showed nothing for as long as it
//! waited, and looked hung. A wait that lasts is said in one line, what it
//! is for and how often it was sent again, then again every few seconds.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// Least time between two redraws of the live lines.
const REDRAW: Duration = Duration::from_millis(100);

/// A wait is said once it lasted this long...
const SAY_AFTER: Duration = Duration::from_secs(2);

/// ...and again every this long while it lasts.
const SAY_EVERY: Duration = Duration::from_secs(5);

/// How often the launch is asked what it waits for.
const LOOK_EVERY: Duration = Duration::from_millis(250);

enum Mode {
    Live { multi: MultiProgress, lines: Vec<ProgressBar> },
    Plain,
}

/// The launch's terminal output.
pub struct Progress {
    mode: Mode,
    last_draw: Instant,
}

impl Progress {
    /// Live lines for `robots` robots when stderr is a terminal, else plain.
    pub fn new(robots: u32) -> Self {
        let mode = if std::io::stderr().is_terminal() && robots <= 64 {
            let multi = MultiProgress::with_draw_target(ProgressDrawTarget::stderr_with_hz(10));
            let style = ProgressStyle::with_template("{prefix:>9} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar());
            let lines = (1..=robots)
                .map(|id| {
                    let bar = multi.add(ProgressBar::new_spinner().with_style(style.clone()));
                    bar.set_prefix(format!("robot {id}"));
                    bar.set_message("waiting");
                    bar
                })
                .collect();
            Mode::Live { multi, lines }
        } else {
            Mode::Plain
        };
        Self { mode, last_draw: Instant::now() }
    }

    /// Whether redrawing the robot lines now would be worth it.
    pub fn due(&mut self) -> bool {
        if matches!(self.mode, Mode::Plain) || self.last_draw.elapsed() < REDRAW {
            return false;
        }
        self.last_draw = Instant::now();
        true
    }

    /// Sets robot `id`'s live line (ignored in plain mode).
    pub fn robot(&self, id: u32, text: String) {
        if let Mode::Live { lines, .. } = &self.mode {
            if let Some(line) = id.checked_sub(1).and_then(|i| lines.get(i as usize)) {
                line.set_message(text);
            }
        }
    }

    /// Prints one event line.
    pub fn event(&self, text: &str) {
        match &self.mode {
            Mode::Live { multi, .. } => {
                let _ = multi.println(text);
            }
            Mode::Plain => bycoms_runtime::logging::status_line(text),
        }
    }

    /// Leaves the live lines as they are and stops redrawing.
    pub fn finish(&self) {
        if let Mode::Live { lines, .. } = &self.mode {
            for line in lines {
                line.finish();
            }
        }
    }
}

/// Says what the launch waits for when a wait lasts (see the module docs).
pub struct Waits {
    what: Option<String>,
    since: Instant,
    said: Option<Instant>,
    looked: Instant,
}

impl Waits {
    /// Nothing awaited yet, at `now`.
    pub fn new(now: Instant) -> Self {
        Self { what: None, since: now, said: None, looked: now }
    }

    /// Whether to ask the launch what it waits for at `now` (a few times a
    /// second: asking builds words).
    pub fn due(&mut self, now: Instant) -> bool {
        if now.saturating_duration_since(self.looked) < LOOK_EVERY {
            return false;
        }
        self.looked = now;
        true
    }

    /// The launch waits for `what` (`None`: for nothing in particular), sent
    /// again `resent` times, at `now`: the line to print, when this wait has
    /// lasted [`SAY_AFTER`] and was not said in the last [`SAY_EVERY`].
    pub fn line(&mut self, what: Option<&str>, resent: u32, now: Instant) -> Option<String> {
        if what != self.what.as_deref() {
            self.what = what.map(str::to_owned);
            self.since = now;
            self.said = None;
        }
        let what = self.what.as_deref()?;
        let lasted = now.saturating_duration_since(self.since);
        let quiet = self.said.is_none_or(|said| now.saturating_duration_since(said) >= SAY_EVERY);
        if lasted < SAY_AFTER || !quiet {
            return None;
        }
        self.said = Some(now);
        let again = match resent {
            0 => String::new(),
            1 => " (sent again once)".into(),
            n => format!(" (sent again {n} times)"),
        };
        Some(format!("waiting {:.0} s for {what}{again}", lasted.as_secs_f64()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wait_that_lasts_is_said_then_again_every_few_seconds() {
        let t0 = Instant::now();
        let at = |ms| t0 + Duration::from_millis(ms);
        let mut w = Waits::new(t0);
        assert_eq!(w.line(Some("robot 2's answer to tick 7"), 0, at(0)), None);
        assert_eq!(w.line(Some("robot 2's answer to tick 7"), 3, at(1_999)), None, "not yet");
        assert_eq!(
            w.line(Some("robot 2's answer to tick 7"), 3, at(2_000)).as_deref(),
            Some("waiting 2 s for robot 2's answer to tick 7 (sent again 3 times)")
        );
        assert_eq!(w.line(Some("robot 2's answer to tick 7"), 4, at(6_999)), None, "said just now");
        assert_eq!(
            w.line(Some("robot 2's answer to tick 7"), 5, at(7_000)).as_deref(),
            Some("waiting 7 s for robot 2's answer to tick 7 (sent again 5 times)")
        );
        // Another wait starts the count again; no wait says nothing.
        assert_eq!(w.line(Some("robot 3's agent to register"), 0, at(8_000)), None);
        assert_eq!(w.line(None, 0, at(20_000)), None);
        assert_eq!(
            w.line(Some("robot 3's agent to register"), 0, at(22_000)),
            None,
            "a wait that came back starts again"
        );
        assert!(w
            .line(Some("robot 3's agent to register"), 1, at(24_000))
            .is_some_and(|l| l.ends_with("(sent again once)")));
    }
}
