//! Shared helpers for the CLI tests.
#![allow(dead_code)]
use std::path::Path;
use std::process::{Command, Output};

/// A `feedscope` command running in `dir`.
pub fn feedscope(dir: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_feedscope"));
    c.current_dir(dir);
    c
}

/// Run and return the output, with stdout/stderr printed on failure of the expectation.
pub fn run(mut cmd: Command) -> Output {
    cmd.output().expect("failed to start feedscope")
}

/// Stderr as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Stdout as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Run `feedscope ARGS` in `dir` and expect a refusal of bad input: exit code 2, no panic, and
/// every one of `needles` in stderr.
pub fn expect_bad_input(dir: &Path, args: &[&str], needles: &[&str]) {
    let mut c = feedscope(dir);
    c.args(args);
    let o = run(c);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "feedscope {args:?}: {err}");
    assert!(!err.contains("panicked"), "feedscope {args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "feedscope {args:?}: `{n}` not in: {err}");
    }
}
