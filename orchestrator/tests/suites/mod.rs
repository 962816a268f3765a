//! The conformance suites of the launch's seams, shared by the test files
//! that run them against each implementation.
#![allow(dead_code)] // each test binary uses only its own suite

pub mod agents;
pub mod poses;
