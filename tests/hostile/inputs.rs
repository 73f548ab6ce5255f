//! Issue 23 hostile cases: inputs are read-only (see docs/RELIABILITY.md).
//! An output path that resolves to an input file (directly, through a
//! symlink, or as a hard link), or that is or lies in an input folder, is
//! refused with exit 2 naming both, before any work; every file is as it
//! was afterwards.

use super::common::{fails, run, s, snapshot, succeeds, unit_triangle_file};
use splatkit::testing::write_sphere_dataset;

/// `-o` or `--json=` naming the input, a symlink to it, a hard link to it,
/// or the same file by another spelling (`./sub/../m.ply`): exit 2, the
/// message names the flag and the input; nothing changes.
#[test]
fn an_output_that_is_an_input_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = unit_triangle_file(dir.path());
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    let link = dir.path().join("link.ply");
    std::os::unix::fs::symlink(&m, &link).unwrap();
    let hard = dir.path().join("hard.ply");
    std::fs::hard_link(&m, &hard).unwrap();
    let other = dir.path().join("sub/../m.ply");
    let before = snapshot(dir.path());
    for out in [&m, &link, &hard, &other] {
        for cmd in ["clean", "decimate"] {
            let mut args = vec![s(&m), "-o", s(out)];
            if cmd == "decimate" {
                args.extend(["--faces", "1"]);
            }
            let o = run(cmd, &args, None);
            fails(&o, 2, &["-o", "m.ply", "input"]);
            assert_eq!(snapshot(dir.path()), before, "{cmd} -o {out:?}");
        }
        let json = format!("--json={}", s(out));
        let o = run(
            "clean",
            &[s(&m), "-o", s(&dir.path().join("c.ply")), &json],
            None,
        );
        fails(&o, 2, &["--json", "input"]);
        assert_eq!(snapshot(dir.path()), before, "--json={out:?}");
    }
    // Reading through the symlink and writing the file itself, too.
    let o = run("clean", &[s(&link), "-o", s(&m)], None);
    fails(&o, 2, &["input"]);
    assert_eq!(snapshot(dir.path()), before);
}

/// The examples: bake-texture whose Gaussians file is named like
/// the texture it would write (`t.png` beside `-o t.obj`); `train DATA -o
/// DATA` (which replaced DATA/cameras.json with downscaled cameras) and an
/// output folder inside DATA; tsdf-fuse writing into its depth folder.
#[test]
fn outputs_in_or_over_input_folders_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = unit_triangle_file(dir.path());
    let t_png = dir.path().join("t.png");
    std::fs::copy(&m, &t_png).unwrap();
    let cams = dir.path().join("c.json");
    std::fs::write(&cams, b"[]").unwrap();
    let data = dir.path().join("data");
    write_sphere_dataset(&data, 4, 16, 50).unwrap();
    let depth = dir.path().join("depth");
    std::fs::create_dir(&depth).unwrap();
    std::fs::write(depth.join("a.npy"), b"not read").unwrap();
    let before = snapshot(dir.path());

    let o = run(
        "bake-texture",
        &[
            s(&m),
            s(&t_png),
            "--cameras",
            s(&cams),
            "-o",
            s(&dir.path().join("t.obj")),
        ],
        None,
    );
    fails(&o, 2, &["t.png", "input"]);
    assert_eq!(snapshot(dir.path()), before, "bake-texture");

    for out in [data.clone(), data.join("out"), data.join(".")] {
        for model in ["triangles", "gaussians"] {
            let o = run(
                "train",
                &[
                    model,
                    s(&data),
                    "-o",
                    s(&out),
                    "--downscale",
                    "2",
                    "--iterations",
                    "1",
                    "-q",
                ],
                None,
            );
            fails(&o, 2, &["data", "input folder"]);
            assert_eq!(snapshot(dir.path()), before, "train {model} -o {out:?}");
        }
    }

    let o = run(
        "tsdf-fuse",
        &[
            "--depth",
            s(&depth),
            "--cameras",
            s(&data.join("cameras.json")),
            "-o",
            s(&depth.join("mesh.ply")),
        ],
        None,
    );
    fails(&o, 2, &["depth", "input folder"]);
    assert_eq!(snapshot(dir.path()), before, "tsdf-fuse");
}

/// Resuming into the run's own output folder stays possible: the
/// checkpoint read by `--resume` is the run's state, which it advances.
#[test]
fn resume_into_the_same_folder_still_works() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    write_sphere_dataset(&data, 4, 16, 50).unwrap();
    let out = dir.path().join("out");
    let common = [
        "triangles",
        s(&data),
        "-o",
        s(&out),
        "--iterations",
        "4",
        "--max-shapes",
        "200",
        "-q",
    ];
    let mut first = common.to_vec();
    first.extend(["--stop-at", "2"]);
    succeeds(&run("train", &first, None));
    let mut resume = common.to_vec();
    resume.extend(["--resume", s(&out)]);
    succeeds(&run("train", &resume, None));
    assert!(out.join("point_cloud/iteration_4").is_dir());
}

/// The file on stdin is an input too (`clean - -o m.ply < m.ply`, `info -
/// --json=m.ply < m.ply`): compared by device and inode. A path named as
/// an input but left unread (bind-gaussians' `--cameras` when
/// `--thickness` is given) is protected as well.
#[test]
fn stdin_and_unread_inputs_are_protected() {
    let dir = tempfile::tempdir().unwrap();
    let m = unit_triangle_file(dir.path());
    let cams = dir.path().join("cams.json");
    std::fs::write(&cams, b"[]").unwrap();
    let before = snapshot(dir.path());
    let o = run("clean", &["-", "-o", s(&m)], Some(&m));
    fails(&o, 2, &["m.ply", "stdin"]);
    let json = format!("--json={}", s(&m));
    let o = run("info", &["-", &json], Some(&m));
    fails(&o, 2, &["m.ply", "stdin"]);
    let o = run(
        "bind-gaussians",
        &[
            s(&m),
            "--cameras",
            s(&cams),
            "--thickness",
            "0.1",
            "-o",
            s(&cams),
        ],
        None,
    );
    fails(&o, 2, &["cams.json", "input"]);
    assert_eq!(snapshot(dir.path()), before);
    // The same stdin to another output works.
    let out = dir.path().join("out.ply");
    succeeds(&run("clean", &["-", "-o", s(&out)], Some(&m)));
}
