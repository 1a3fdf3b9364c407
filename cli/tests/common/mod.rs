//! Helpers the CLI's test binaries share: run the real `throng`, a scratch folder per test
//! process, the output as text.

#![allow(dead_code)]

use std::path::PathBuf;
use std::process::{Command, Output};

/// Runs the `throng` binary with `args` and waits for it.
pub fn throng(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_throng"))
        .args(args)
        .output()
        .expect("run throng")
}

/// `name` in this test process's scratch folder (created on first use), under the target
/// directory's `tmp` (which `cargo clean` removes) rather than the system's temporary folder.
pub fn tmp(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("throng-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Standard output as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `throng` with `args`, which must fail with one line on standard error that contains
/// `needle` and no panic; returns the output.
pub fn assert_one_line_failure(args: &[&str], needle: &str) -> Output {
    let o = throng(args);
    assert!(!o.status.success(), "{args:?} succeeded");
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{args:?}: one line wanted, got:\n{err}");
    assert!(
        lines[0].contains(needle),
        "{args:?}: {:?} lacks {needle:?}",
        lines[0]
    );
    assert!(
        !err.contains("panicked") && !err.contains("backtrace"),
        "{err}"
    );
    o
}
