//! The live view end to end: a real real-time launch with `--serve
//! 127.0.0.1:0`, its page opened in headless Chromium, and what the page
//! shows read through the DevTools protocol while the run goes on — robot 1
//! appears and moves, then stops and is drawn as a beacon with its ε circle
//! (read back from the canvas pixels), and the page ends with the launch's
//! own verdict.
//!
//! Chromium (Debian's `chromium`) is started first, so the page connects
//! within a moment of the launch printing its address: robot 1 needs
//! seconds to reach the obstacle, so the page sees it moving before it
//! stops. Every process is killed and reaped on drop (Chromium as a whole
//! process group); its profile is a temporary directory. It needs Chromium:
//! `#[ignore = "needs …"]`, run by `.ci/run` (which installs it) with
//! `--include-ignored`; asked for without Chromium it fails, saying so.

use bycoms_tests::{bin, swarm_name};
use nix::sys::signal::{killpg, Signal};
use nix::unistd::Pid;
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Read};
use std::net::TcpStream;
use std::os::unix::process::CommandExt;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};
use tungstenite::Message;

/// A process whose stderr lines arrive on a channel; its whole process
/// group is killed and the process reaped on drop.
struct Running {
    child: Child,
    lines: Receiver<String>,
    seen: Vec<String>,
}

impl Running {
    fn start(cmd: &mut Command) -> Running {
        let mut child = cmd
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .process_group(0)
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {cmd:?}: {e}"));
        let (tx, lines) = channel();
        let stderr = child.stderr.take().expect("stderr piped");
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                let _ = tx.send(line);
            }
        });
        Running { child, lines, seen: Vec::new() }
    }

    /// The first stderr line containing `marker` (within `timeout`).
    fn line_with(&mut self, marker: &str, timeout: Duration) -> String {
        let deadline = Instant::now() + timeout;
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            match self.lines.recv_timeout(left) {
                Ok(line) if line.contains(marker) => return line,
                Ok(line) => self.seen.push(line),
                Err(_) => break,
            }
        }
        panic!("no line with {marker:?} within {timeout:?}; stderr so far:\n{}", self.seen.join("\n"));
    }

    /// Waits for the exit (within `timeout`); returns the code and stdout.
    fn finish(&mut self, timeout: Duration) -> (Option<i32>, String) {
        let deadline = Instant::now() + timeout;
        let status = loop {
            if let Some(status) = self.child.try_wait().expect("try_wait") {
                break status;
            }
            assert!(Instant::now() < deadline, "did not end within {timeout:?}: {}", self.seen.join("\n"));
            // Polled: std's `Child` has no wait with a timeout.
            std::thread::sleep(Duration::from_millis(20));
        };
        let mut out = String::new();
        if let Some(mut stdout) = self.child.stdout.take() {
            let _ = stdout.read_to_string(&mut out);
        }
        (status.code(), out)
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        let _ = killpg(Pid::from_raw(self.child.id() as i32), Signal::SIGKILL);
        let _ = self.child.wait();
    }
}

fn chromium() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|dir| ["chromium", "chromium-browser"].map(|name| dir.join(name)))
        .find(|p| p.is_file())
}

/// A DevTools-protocol session with one page.
struct DevTools {
    ws: tungstenite::WebSocket<TcpStream>,
    next: u64,
    session: Option<String>,
}

impl DevTools {
    fn connect(url: &str) -> DevTools {
        let host = url.trim_start_matches("ws://").split('/').next().expect("host:port");
        let stream = TcpStream::connect(host).expect("DevTools port");
        stream.set_read_timeout(Some(Duration::from_secs(10))).expect("timeout");
        let (ws, _) = tungstenite::client(url, stream).expect("DevTools handshake");
        DevTools { ws, next: 1, session: None }
    }

    fn call(&mut self, method: &str, params: Value) -> Value {
        let id = self.next;
        self.next += 1;
        let mut msg = json!({ "id": id, "method": method, "params": params });
        if let Some(s) = &self.session {
            msg["sessionId"] = json!(s);
        }
        self.ws.send(Message::text(msg.to_string())).expect("send to DevTools");
        loop {
            let Message::Text(text) = self.ws.read().expect("DevTools answers within 10 s") else { continue };
            let reply: Value = serde_json::from_str(&text).expect("DevTools JSON");
            if reply["id"] == id {
                assert!(reply["error"].is_null(), "{method}: {reply}");
                return reply["result"].clone();
            }
        }
    }

    fn open(&mut self, url: &str) {
        let target = self.call("Target.createTarget", json!({ "url": url }));
        let attached =
            self.call("Target.attachToTarget", json!({ "targetId": target["targetId"], "flatten": true }));
        self.session = attached["sessionId"].as_str().map(str::to_owned);
        assert!(self.session.is_some(), "attached to the page: {attached}");
    }

    /// Evaluates `expr` (which returns a JSON string) in the page.
    fn eval(&mut self, expr: &str) -> Value {
        let r = self.call("Runtime.evaluate", json!({ "expression": expr, "returnByValue": true }));
        let text = r["result"]["value"].as_str().unwrap_or_else(|| panic!("no string from the page: {r}"));
        serde_json::from_str(text).expect("the page's JSON")
    }
}

/// What the page shows: its data attributes, its robot list, and for each
/// beacon the colour of the canvas on its ε circle (a point 2 px into the
/// first dash, which starts at angle 0).
/// Before the page has loaded (no body or no arena yet) it reads as empty,
/// and the test keeps polling.
pub(crate) const READ_PAGE: &str = r#"(!document.body || !document.getElementById('arena')) ? JSON.stringify({ body: {} }) : JSON.stringify({
  body: Object.assign({}, document.body.dataset),
  robots: [...document.querySelectorAll('#robots li')].map(li => ({ id: +li.dataset.robot, state: li.dataset.state, real: li.dataset.real === "1" })),
  beacons: [...document.querySelectorAll('#beacons li')].map(li => {
    const px = +li.dataset.px, py = +li.dataset.py, pr = +li.dataset.pr, a = 2 / Math.max(pr, 1);
    const c = document.getElementById('arena').getContext('2d')
      .getImageData(Math.round(px + pr * Math.cos(a)), Math.round(py + pr * Math.sin(a)), 1, 1).data;
    return { robot: +li.dataset.robot, pr, rgb: [c[0], c[1], c[2]] };
  }),
})"#;

/// Headless Chromium with one page on a launch's live view, read through
/// the DevTools protocol; killed (with its profile) on drop. Started before
/// the launch, so the page connects within a moment of the launch's banner.
pub(crate) struct Browser {
    page: DevTools,
    _running: Running,
    _profile: tempfile::TempDir,
}

impl Browser {
    /// Starts Chromium (the test fails, saying so, without it).
    pub(crate) fn start() -> Browser {
        let chromium = chromium()
            .expect("the live view's browser test needs Debian's `chromium` (apt-get install chromium)");
        let profile = tempfile::tempdir().expect("temp dir");
        let mut running = Running::start(
            Command::new(chromium)
                .args(["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"])
                .args(["--no-first-run", "--remote-debugging-port=0", "about:blank"])
                .arg(format!("--user-data-dir={}", profile.path().display())),
        );
        let line = running.line_with("DevTools listening on ", Duration::from_secs(30));
        let devtools_url = line.rsplit(' ').next().expect("DevTools URL").to_owned();
        Browser { page: DevTools::connect(&devtools_url), _running: running, _profile: profile }
    }

    /// Opens the live view whose banner (`live view: http://…`) is `banner`.
    pub(crate) fn open(&mut self, banner: &str) {
        let url = banner.split_whitespace().find(|w| w.starts_with("http://")).expect("page URL");
        self.page.open(url);
    }

    /// Polls what the page shows ([`READ_PAGE`]), handing each reading to
    /// `each`, until the page shows the run's end (within `timeout`); the last reading.
    pub(crate) fn until_ended(&mut self, timeout: Duration, mut each: impl FnMut(&Value)) -> Value {
        let deadline = Instant::now() + timeout;
        let mut last = Value::Null;
        while last["body"]["ended"].as_str().is_none_or(str::is_empty) {
            assert!(Instant::now() < deadline, "the page never showed the end; last: {last}");
            // Polled: the page is read, not waited on.
            std::thread::sleep(Duration::from_millis(100));
            last = self.page.eval(READ_PAGE);
            each(&last);
        }
        last
    }
}

#[test]
#[ignore = "needs Debian's chromium (apt-get install chromium)"]
fn the_page_shows_robots_moving_then_a_beacon_with_its_eps_circle() {
    let mut browser = Browser::start();

    // Real time at 5×: robot 1 needs several seconds to reach the obstacle;
    // two robots, both stuck, keep the run short.
    let swarm = swarm_name("live");
    let mut launch = Running::start(Command::new(bin("orchestrator")).args([
        "launch",
        "--clock",
        "realtime",
        "--speed",
        "5",
        "--dwell",
        "5",
        "--robots",
        "2",
        "--eps",
        "3",
        "--serve",
        "127.0.0.1:0",
        "--swarm",
        &swarm,
        "--json",
    ]));
    browser.open(&launch.line_with("live view: http://", Duration::from_secs(30)));

    // Poll what the page shows until the run has ended on the page.
    let mut saw_moving_first = false;
    let last = browser.until_ended(Duration::from_secs(90), |page| {
        let beacons = page["beacons"].as_array().map_or(0, Vec::len);
        let moving = page["robots"].as_array().is_some_and(|r| r.iter().any(|r| r["state"] == "moving"));
        if beacons == 0 && moving && page["body"]["connected"] == "true" {
            saw_moving_first = true;
        }
    });
    assert!(saw_moving_first, "the page showed a moving robot before any beacon; end: {last}");

    let (code, stdout) = launch.finish(Duration::from_secs(60));
    let summary: Value = serde_json::from_str(&stdout).unwrap_or_else(|e| panic!("summary ({e}): {stdout}"));
    assert_eq!(code, Some(3), "two stuck robots: not arrived; {summary}");
    // The page shows the launch's outcome: both robots stuck, two beacons.
    let states: Vec<&str> =
        last["robots"].as_array().expect("robots").iter().filter_map(|r| r["state"].as_str()).collect();
    assert_eq!(states, ["stuck", "stuck"], "{last}");
    assert_eq!(last["body"]["ended"], "not-arrived");
    let beacons = last["beacons"].as_array().expect("beacons");
    assert_eq!(beacons.len(), summary["beacons"].as_array().map_or(0, Vec::len), "{last}");
    for b in beacons {
        // ε = 3 cells at ≥ 9 px per cell, drawn red (#cf222e, antialiased on white).
        let pr = b["pr"].as_f64().expect("radius");
        let rgb: Vec<i64> = b["rgb"].as_array().expect("rgb").iter().filter_map(Value::as_i64).collect();
        assert!(pr > 20.0, "the ε circle has a real radius: {b}");
        assert!(rgb[0] > rgb[1] + 40 && rgb[0] > rgb[2] + 40, "the ε circle is drawn in red there: {b}");
    }
}
