//! `orchestrator completions SHELL` prints a completion script that knows
//! the real subcommands and flags; the bash one is valid bash and completes.

use std::process::{Command, Output};

fn completions(shell: &str) -> Output {
    Command::new(env!("CARGO_BIN_EXE_orchestrator"))
        .args(["completions", shell])
        .env_remove("BYCOMS_LOG_FORMAT")
        .output()
        .expect("run orchestrator")
}

#[test]
fn every_shell_gets_a_script_naming_the_subcommands_and_flags() {
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let o = completions(shell);
        assert!(o.status.success(), "{shell}: {}", String::from_utf8_lossy(&o.stderr));
        let script = String::from_utf8(o.stdout).expect("utf-8 script");
        for word in ["launch", "sweep", "simulate", "completions", "log-format", "time-limit"] {
            assert!(script.contains(word), "{shell} script lacks {word}");
        }
    }
}

#[test]
fn an_unknown_shell_is_a_usage_error() {
    let o = completions("tcsh");
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("tcsh"));
}

/// Sources the bash script and asks it to complete `orchestrator la`.
#[test]
fn the_bash_script_completes_a_subcommand() {
    let o = completions("bash");
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("orchestrator.bash");
    std::fs::write(&path, &o.stdout).expect("write script");
    let probe = format!(
        "source {}; COMP_WORDS=(orchestrator la); COMP_CWORD=1; _orchestrator orchestrator la orchestrator; \
         printf '%s\\n' \"${{COMPREPLY[@]}}\"",
        path.display()
    );
    // bash is everywhere this project is built (`.ci/run` is a bash script): without it the
    // test fails, saying so, rather than passing without having run the script.
    let out = Command::new("bash").args(["--norc", "-c", &probe]).output().unwrap_or_else(|e| {
        panic!("this test runs the bash completion script in bash, but bash cannot start: {e}")
    });
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let words = String::from_utf8_lossy(&out.stdout);
    assert_eq!(words.trim(), "launch", "completions of `la`");
}
