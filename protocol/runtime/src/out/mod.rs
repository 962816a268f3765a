//! Everything a command puts out: lines on stdout ([`stdout`]) and files
//! ([`files`]: the one overwrite rule every output of every command
//! follows, and the atomic write that goes with it).

pub mod files;
pub mod kind;
pub mod stdout;

pub use files::{
    check_target, replaces, usage_unless_io, write, write_atomic, write_private, write_with, writing,
    OutputError, Outputs,
};
pub use kind::Kind;
pub use stdout::line;

/// `n` and the noun, singular or plural: "1 robot", "3 robots" — for every
/// count a command says (the study's verdicts, the recording's damage).
pub fn count(n: u64, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}
