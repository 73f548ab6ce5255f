//! Issue 23 hostile cases: one output transaction per run (see
//! docs/RELIABILITY.md, "Nothing is lost"). Every file and folder a run
//! writes lands together or not at all; staging left by a killed run is
//! cleaned by the next one.

use std::path::{Path, PathBuf};

use super::common::{fails, mesh_file, run, s, snapshot, succeeds};
use splatkit::model::Mesh;

/// A two-triangle mesh with a duplicate vertex (so `clean` changes it).
fn mesh(dir: &Path) -> PathBuf {
    let m = Mesh::new(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
        ],
        vec![[0, 1, 2], [3, 4, 2]],
    );
    mesh_file(dir, "m.ply", m)
}

/// Runs `bin args` (no memory limit) with its `k`-th commit rename made to
/// fail (`SPLATKIT_FAULT_COMMIT`).
fn with_fault(bin: &str, args: &[&str], k: u32) -> std::process::Output {
    std::process::Command::new(assert_cmd::cargo::cargo_bin(bin))
        .args(args)
        .env("SPLATKIT_FAULT_COMMIT", k.to_string())
        .output()
        .unwrap()
}

/// A report that cannot be written leaves the data output as it was: the
/// report path is a folder, a path under a file, or (when not root, who
/// may write anywhere) in a read-only folder. Before issue 23 `out.ply`
/// was replaced first and then the run failed.
#[test]
fn a_report_that_cannot_be_written_keeps_every_output() {
    let dir = tempfile::tempdir().unwrap();
    let m = mesh(dir.path());
    let out = dir.path().join("out.ply");
    std::fs::write(&out, b"previous output").unwrap();
    std::fs::create_dir(dir.path().join("r.json")).unwrap();
    std::fs::write(dir.path().join("afile"), b"x").unwrap();
    let ro = dir.path().join("ro");
    std::fs::create_dir(&ro).unwrap();
    let mut reports = vec![
        dir.path().join("r.json"),
        dir.path().join("afile/r.json"),
        dir.path().join("missing/r.json"),
    ];
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != 0 {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
        reports.push(ro.join("r.json"));
    }
    let before = snapshot(dir.path());
    for r in &reports {
        let json = format!("--json={}", s(r));
        let o = run("clean", &[s(&m), "-o", s(&out), &json], None);
        assert_ne!(o.status.code(), Some(0), "{r:?}");
        fails(&o, o.status.code().unwrap(), &["--json"]);
        assert_eq!(snapshot(dir.path()), before, "{r:?}: files changed");
    }
}

/// A run that writes several files (OBJ + MTL + PNG) and cannot write one
/// of them (the MTL's name is a folder) leaves the others as they were.
#[test]
fn outputs_of_one_run_land_together() {
    let dir = tempfile::tempdir().unwrap();
    let m = mesh(dir.path());
    let out = dir.path().join("t.obj");
    std::fs::write(&out, b"old obj").unwrap();
    std::fs::write(dir.path().join("t.png"), b"old png").unwrap();
    std::fs::create_dir(dir.path().join("t.mtl")).unwrap();
    let before = snapshot(dir.path());
    // The Gaussians and cameras need not be valid: the output set is
    // refused first.
    let o = run(
        "bake-texture",
        &[s(&m), s(&m), "--cameras", s(&m), "-o", s(&out)],
        None,
    );
    fails(&o, 1, &["t.mtl", "folder"]);
    assert_eq!(snapshot(dir.path()), before);
}

/// The commit's undo path, through the real binaries: with the k-th rename
/// made to fail (`SPLATKIT_FAULT_COMMIT`), every target (a replaced file,
/// a new file, a folder merged file by file) is as it was, and no staging
/// or backup file is left; without the fault the same run lands in full.
#[test]
fn a_commit_that_fails_half_way_is_undone() {
    let dir = tempfile::tempdir().unwrap();
    let m = mesh(dir.path());
    let out = dir.path().join("out.ply");
    std::fs::write(&out, b"previous output").unwrap();
    let report = dir.path().join("r.json");
    let before = snapshot(dir.path());
    for k in 1..=2 {
        let json = format!("--json={}", s(&report));
        let o = with_fault("clean", &[s(&m), "-o", s(&out), &json], k);
        fails(&o, 1, &["injected failure"]);
        assert_eq!(snapshot(dir.path()), before, "fault at rename {k}");
    }
    // A folder output merged into an existing folder (render's images).
    let views = dir.path().join("views");
    std::fs::create_dir(&views).unwrap();
    std::fs::write(views.join("keep.txt"), b"kept").unwrap();
    let args = [s(&m), "--orbit", "3", "--size", "16x16", "-o", s(&views)];
    let first = run("render", &args, None);
    succeeds(&first);
    let landed = snapshot(dir.path());
    assert!(landed.len() > before.len() + 3, "render wrote its views");
    // Change the previous views so a replacement would show.
    for (p, _) in landed.iter().filter(|(p, _)| p.starts_with("views")) {
        let full = dir.path().join(p);
        if full.is_file() && !p.ends_with("keep.txt") {
            std::fs::write(&full, b"older view").unwrap();
        }
    }
    let before = snapshot(dir.path());
    for k in [1, 2, 4] {
        let o = with_fault("render", &args, k);
        fails(&o, 1, &["injected failure"]);
        assert_eq!(snapshot(dir.path()), before, "fault at rename {k}");
    }
    succeeds(&run("render", &args, None));
    assert_eq!(snapshot(dir.path()), landed, "the full run lands in full");
}

/// Staging left by a killed run (a process that no longer runs) is
/// recognised by its name and cleaned by the next run on that target: a
/// staging file and folder are removed; a backup whose target is missing
/// (the run died between its two renames) is restored before the new run
/// replaces it. Each is reported on stderr.
#[test]
fn staging_left_by_a_killed_run_is_cleaned() {
    let dir = tempfile::tempdir().unwrap();
    let m = mesh(dir.path());
    let out = dir.path().join("out.ply");
    // PID 4194304 is above Linux's pid_max limit, so no process has it.
    let dead = 4_194_304u32;
    let tmp = dir.path().join(format!(".out.ply.splatkit-{dead}-0.tmp"));
    let old = dir.path().join(format!(".out.ply.splatkit-{dead}-1.old"));
    let stage_dir = dir.path().join(format!(".out.ply.splatkit-{dead}-2"));
    let other = dir.path().join(format!(".other.ply.splatkit-{dead}-0.tmp"));
    std::fs::write(&tmp, b"half written").unwrap();
    std::fs::write(&old, b"the previous output").unwrap();
    std::fs::create_dir(&stage_dir).unwrap();
    std::fs::write(&other, b"another target's").unwrap();
    // The run fails (bad flag value at run time? no: a bad input): the
    // backup is still restored and the leftovers removed.
    let bad = dir.path().join("bad.ply");
    std::fs::write(
        &bad,
        b"ply\nformat ascii 1.0\nelement vertex 1\nend_header\n",
    )
    .unwrap();
    let o = run("clean", &[s(&bad), "-o", s(&out)], None);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("restored") && err.contains("interrupted run"),
        "{err}"
    );
    assert_eq!(std::fs::read(&out).unwrap(), b"the previous output");
    assert!(!tmp.exists() && !old.exists() && !stage_dir.exists());
    assert!(other.exists(), "another target's staging is not touched");
    // A staging file next to an existing target is simply removed.
    std::fs::write(&tmp, b"half written").unwrap();
    let o = run("clean", &[s(&m), "-o", s(&out)], None);
    succeeds(&o);
    assert!(String::from_utf8_lossy(&o.stderr).contains("removed"));
    assert!(!tmp.exists());
    assert_ne!(std::fs::read(&out).unwrap(), b"the previous output");
}

/// `--json` on stdout is printed only after the files landed: a run whose
/// commit fails prints no report claiming success.
#[test]
fn the_stdout_report_waits_for_the_commit() {
    let dir = tempfile::tempdir().unwrap();
    let m = mesh(dir.path());
    let out = dir.path().join("out.ply");
    let args = [s(&m), "-o", s(&out), "--json"];
    fails(&with_fault("clean", &args, 1), 1, &["injected failure"]);
    assert!(!out.exists());
    let o = std::process::Command::new(assert_cmd::cargo::cargo_bin("clean"))
        .args(args)
        .output()
        .unwrap();
    succeeds(&o);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v.get("report").is_some(), "{v}");
    assert!(out.exists());
}

/// An output that is a device or a pipe (`-o /dev/null` for a dry run,
/// `-o fifo`) is written in place: renaming a staged file over it would
/// replace the device or pipe itself with a regular file. Here a FIFO
/// with a reader: the reader gets the PLY and the FIFO stays a FIFO.
#[test]
fn special_outputs_are_written_in_place() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let m = mesh(dir.path());
    let fifo = dir.path().join("out.ply");
    let c = std::ffi::CString::new(s(&fifo)).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(fifo).unwrap())
    };
    let o = run("clean", &[s(&m), "-o", s(&fifo)], None);
    if o.status.code() != Some(0) {
        // Unblock the reader so a failure is reported, not a hang.
        let _ = std::fs::OpenOptions::new().write(true).open(&fifo);
    }
    succeeds(&o);
    let got = reader.join().unwrap();
    assert!(got.starts_with(b"ply\n"), "the reader got the mesh");
    let meta = std::fs::symlink_metadata(&fifo).unwrap();
    assert!(meta.file_type().is_fifo(), "the FIFO was replaced");
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.contains(".splatkit-"))
        .collect();
    assert!(left.is_empty(), "staging left: {left:?}");
}

/// A reader that goes away (`--json | head`) is not a crash: the report,
/// printed after the outputs are committed, meets a closed pipe and the
/// run still ends with 0, the output in place and no panic on stderr.
/// Before, `println!` panicked ("failed printing to stdout: Broken pipe")
/// with a backtrace. The writer starts 0.3 s after `true` has exited, so
/// the pipe is closed when it writes.
#[test]
fn a_closed_stdout_after_commit_is_not_a_crash() {
    let dir = tempfile::tempdir().unwrap();
    let m = mesh(dir.path());
    let out = dir.path().join("c.ply");
    for (bin, args) in [
        ("clean", vec![s(&m), "-o", s(&out), "--json"]),
        ("info", vec![s(&m)]),
    ] {
        let cmd = format!(
            "(sleep 0.3; '{}' {} 2>'{}'; echo $? > '{}') | true",
            assert_cmd::cargo::cargo_bin(bin).display(),
            args.iter()
                .map(|a| format!("'{a}'"))
                .collect::<Vec<_>>()
                .join(" "),
            dir.path().join("err").display(),
            dir.path().join("rc").display()
        );
        let st = std::process::Command::new("sh")
            .args(["-c", &cmd])
            .status()
            .unwrap();
        assert!(st.success());
        let rc = std::fs::read_to_string(dir.path().join("rc")).unwrap();
        let err = std::fs::read_to_string(dir.path().join("err")).unwrap();
        assert_eq!(rc.trim(), "0", "{bin}: {err}");
        assert!(!err.contains("panicked"), "{bin}: {err}");
    }
    assert!(out.is_file());
}
