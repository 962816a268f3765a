//! A doctor's finding (one result of one check, with its level, cause and
//! fix) and the report of all of them, as text or JSON.
//!
//! Why a file of its own: every check (`certs.rs`, `host.rs`, `zenoh.rs`)
//! makes findings, and `mod.rs` runs them all (no file cycles).

use serde::Serialize;

/// A certificate expiring within this many days is a warning.
pub const WARN_DAYS: i64 = 30;

/// How bad a finding is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Level {
    /// Checked and fine.
    Ok,
    /// Works today, needs attention soon (e.g. a certificate expiring within 30 days).
    Warn,
    /// The launch would fail or misbehave.
    Error,
}

impl Level {
    /// The word of the text report.
    pub fn word(self) -> &'static str {
        match self {
            Level::Ok => "ok",
            Level::Warn => "warn",
            Level::Error => "error",
        }
    }
}

/// One result of one check.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Finding {
    /// The check (`certs`, `open-files`, `memory`, `udp-ports`, `iceoryx2`, `natnet`, `zenoh`, `clock`).
    pub check: &'static str,
    /// How bad.
    pub level: Level,
    /// What was found (for `ok`: what was checked).
    pub cause: String,
    /// What to do (empty for `ok`).
    pub fix: String,
}

impl Finding {
    /// A check that passed.
    pub fn ok(check: &'static str, cause: impl Into<String>) -> Self {
        Self { check, level: Level::Ok, cause: cause.into(), fix: String::new() }
    }

    /// A warning with its fix.
    pub fn warn(check: &'static str, cause: impl Into<String>, fix: impl Into<String>) -> Self {
        Self { check, level: Level::Warn, cause: cause.into(), fix: fix.into() }
    }

    /// An error with its fix.
    pub fn error(check: &'static str, cause: impl Into<String>, fix: impl Into<String>) -> Self {
        Self { check, level: Level::Error, cause: cause.into(), fix: fix.into() }
    }
}

/// Whether any finding is an error (the doctor then exits 1).
pub fn any_error(findings: &[Finding]) -> bool {
    findings.iter().any(|f| f.level == Level::Error)
}

/// The findings as lines of text: `LEVEL check: cause` and, below a
/// finding that is not ok, `  fix: …`.
pub fn text(findings: &[Finding]) -> Vec<String> {
    let mut lines = Vec::new();
    for f in findings {
        lines.push(format!("{:<5} {}: {}", f.level.word(), f.check, f.cause));
        if !f.fix.is_empty() {
            lines.push(format!("      fix: {}", f.fix));
        }
    }
    let count = |l: Level| findings.iter().filter(|f| f.level == l).count();
    lines.push(format!(
        "doctor: {} errors, {} warnings, {} ok",
        count(Level::Error),
        count(Level::Warn),
        count(Level::Ok)
    ));
    lines
}

/// The findings as the JSON `--json` prints: `{"findings": [...], "errors": n, "warnings": n}`.
pub fn json(findings: &[Finding]) -> serde_json::Value {
    let count = |l: Level| findings.iter().filter(|f| f.level == l).count();
    serde_json::json!({ "findings": findings, "errors": count(Level::Error), "warnings": count(Level::Warn) })
}
