//! Live progress of a launch on the terminal.
//!
//! Why two modes: on a terminal, one live line per robot (state, mode,
//! position) redrawn at most 10 times a second shows the run as it happens;
//! when stderr is not a terminal (CI logs, pipes) redrawn lines would be
//! noise, so only events (spawned, deployed, stopped, died) are printed, one
//! plain line each. Everything goes to stderr: stdout is for the summary or
//! the JSON.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// Least time between two redraws of the live lines.
const REDRAW: Duration = Duration::from_millis(100);

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
