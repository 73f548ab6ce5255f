//! Helpers shared by the CLI tests that run commands as a hostile user
//! would: under an address-space limit, checking the exit code, the
//! message and the absence of panic text.
#![allow(dead_code)]

pub mod dtu;
pub mod examples;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Output;

use splatkit::io::any::save;
use splatkit::io::cameras::write_gs_json;
use splatkit::io::detect::FileFormat;
use splatkit::model::{Camera, Mesh, Scene};

/// Address-space limit of every run, KiB (2 GB): a command that tried to
/// allocate what a hostile header asks for would abort instead of failing
/// cleanly, and the test would see it.
pub const LIMIT_KIB: u64 = 2 * 1024 * 1024;

/// Runs binary `name` with `args` WITHOUT the address-space limit (training
/// and meshing need more than 2 GB of address space with rayon's stacks)
/// and asserts it succeeded, its stderr in the message; for the acceptance
/// runs, which test results rather than hostile input.
pub fn run_ok(name: &str, args: &[&str]) -> Output {
    let exe = assert_cmd::cargo::cargo_bin(name);
    let out = std::process::Command::new(exe).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

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

/// `p` as a command-line argument (the test paths are UTF-8).
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Everything under `dir`, by path relative to it, without following
/// links: a file's bytes, `<dir>` for a folder, `-> TARGET` for a symbolic
/// link and `<special>` for anything else (a FIFO or a device, which a read
/// could block on). Equal snapshots before and after a run mean that it
/// added, removed and changed nothing under `dir`.
pub fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            let kind = std::fs::symlink_metadata(&p).unwrap().file_type();
            let key = p.strip_prefix(dir).unwrap().to_path_buf();
            let value = if kind.is_dir() {
                todo.push(p);
                b"<dir>".to_vec()
            } else if kind.is_symlink() {
                let target = std::fs::read_link(&p).unwrap();
                format!("-> {}", target.display()).into_bytes()
            } else if kind.is_file() {
                std::fs::read(&p).unwrap()
            } else {
                b"<special>".to_vec()
            };
            out.insert(key, value);
        }
    }
    out
}

/// The triangle (−1, −1, 0), (1, −1, 0), (0, 1, 0).
pub fn triangle() -> Mesh {
    Mesh::new(
        vec![[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    )
}

/// A PLY mesh file `name` in `dir` holding `m`.
pub fn mesh_file(dir: &Path, name: &str, m: Mesh) -> PathBuf {
    let p = dir.join(name);
    save(&p, &Scene::Mesh(m), FileFormat::Ply).unwrap();
    p
}

/// `m.ply` in `dir`: the triangle (0, 0, 0), (1, 0, 0), (0, 1, 0).
pub fn unit_triangle_file(dir: &Path) -> PathBuf {
    let m = Mesh::new(
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        vec![[0, 1, 2]],
    );
    mesh_file(dir, "m.ply", m)
}

/// A camera file `name` in `dir` holding `cams`.
pub fn cameras_file(dir: &Path, name: &str, cams: &[Camera]) -> PathBuf {
    let p = dir.join(name);
    write_gs_json(&p, cams).unwrap();
    p
}
