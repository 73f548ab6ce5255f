//! Helpers shared by the CLI tests that run commands as a hostile user
//! would: under an address-space limit, checking the exit code, the
//! message and the absence of panic text.
#![allow(dead_code)]

use std::path::Path;
use std::process::Output;

/// Address-space limit of every run, KiB (2 GB): a command that tried to
/// allocate what a hostile header asks for would abort instead of failing
/// cleanly, and the test would see it.
pub const LIMIT_KIB: u64 = 2 * 1024 * 1024;

/// Runs binary `name` with `args` under the address-space limit.
pub fn run(name: &str, args: &[&str], stdin: Option<&Path>) -> Output {
    let exe = assert_cmd::cargo::cargo_bin(name);
    let mut script = format!("ulimit -v {LIMIT_KIB} && exec \"$0\" \"$@\"");
    if let Some(p) = stdin {
        script = format!(
            "ulimit -v {LIMIT_KIB} && exec \"$0\" \"$@\" < '{}'",
            p.display()
        );
    }
    std::process::Command::new("sh")
        .arg("-c")
        .arg(script)
        .arg(exe)
        .args(args)
        .output()
        .expect("sh runs")
}

/// Asserts the run failed with `code`, mentioned every `needles` in its
/// message, printed no panic or allocation-failure text, and wrote nothing
/// to stdout.
pub fn fails(out: &Output, code: i32, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "exit code; stderr: {err}");
    for n in needles {
        assert!(err.contains(n), "{err:?} lacks {n:?}");
    }
    for bad in [
        "panicked",
        "memory allocation",
        "RUST_BACKTRACE",
        "capacity overflow",
    ] {
        assert!(!err.contains(bad), "{err:?} shows {bad:?}");
    }
    assert!(out.stdout.is_empty(), "wrote to stdout");
}

/// Asserts the run succeeded, showing its stderr otherwise.
pub fn succeeds(out: &Output) {
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
