//! Links the `sim-agent` executable at a fixed address (not
//! position-independent) on Linux.
//!
//! Why: a launch runs hundreds of these processes from one file. A
//! position-independent executable is relocated by the loader at every
//! start (36 624 pointers here), which writes to 147 pages of its
//! read-only data, so every agent held its own copy of them: 600 KB of
//! private memory per agent, half of what it holds, and a tenth of its
//! start. Linked at a fixed address those pages stay shared with the file:
//! `bench scale --agents 200` went from 1385 to 754 kB of PSS per agent,
//! and `sim-agent --version` from 287 to 136 page faults.
//!
//! What it costs: the agent's own code and data are not placed at a random
//! address (the libraries, heap and stack still are). The orchestrator and
//! the other executables stay position-independent. The Rust code is
//! compiled position-independent as usual; only the final link differs
//! (`-no-pie`, which GCC and Clang both take).

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux") {
        println!("cargo:rustc-link-arg-bins=-no-pie");
    }
}
