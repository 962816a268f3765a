//! The conformance suites of the launch's seams, shared by the test files
//! that run them against each implementation.
//!
//! Why a [`Report`]: a check of a suite that cannot apply to an
//! implementation is not skipped silently. The suite names it with the
//! reason (printed on stderr, and returned), and each implementation's
//! `#[test]` asserts the exact list, so a check that stops running for an
//! implementation fails a test.
#![allow(dead_code)] // each test binary uses only its own suite

pub mod agents;
pub mod poses;

/// The checks of one suite's run that were not applicable, with why.
#[derive(Debug)]
pub struct Report {
    suite: &'static str,
    kind: &'static str,
    /// (check, why).
    pub not_applicable: Vec<(&'static str, String)>,
}

impl Report {
    /// An empty report of `suite` run against a source of `kind`.
    pub fn new(suite: &'static str, kind: &'static str) -> Self {
        Self { suite, kind, not_applicable: Vec::new() }
    }

    /// The names of the checks that were not applicable, in order.
    pub fn not_applicable(&self) -> Vec<&'static str> {
        self.not_applicable.iter().map(|(check, _)| *check).collect()
    }

    /// Notes (and prints) that `check` does not apply, and why.
    pub fn skip(&mut self, check: &'static str, why: impl Into<String>) {
        let why = why.into();
        eprintln!("{} suite [{}]: `{check}` is not applicable: {why}", self.suite, self.kind);
        self.not_applicable.push((check, why));
    }
}
