//! Issue 23 hostile cases: bounded reads (see docs/RELIABILITY.md). Inputs
//! that never end (`/dev/zero` as a file, through a symlink or on stdin; a
//! glTF buffer or a resume checkpoint pointing at it; a PLY on stdin that
//! goes on past what its header declares) are refused after a bounded
//! read, naming the file, under the 2 GB limit.

use std::path::Path;
use std::process::Output;

use super::common::{LIMIT_KIB, fails, run, s, succeeds, unit_triangle_file};
use splatkit::io::any::save;
use splatkit::io::detect::FileFormat;
use splatkit::model::{Mesh, Scene};
use splatkit::testing::write_sphere_dataset;

/// Runs `cmd args` under the 2 GB limit with stdin from a shell pipeline.
fn run_piped(pipeline: &str, cmd: &str, args: &[&str]) -> Output {
    let exe = assert_cmd::cargo::cargo_bin(cmd);
    let script = format!("ulimit -v {LIMIT_KIB} && {pipeline} | \"$0\" \"$@\"");
    std::process::Command::new("sh")
        .arg("-c")
        .arg(script)
        .arg(exe)
        .args(args)
        .output()
        .unwrap()
}

/// `/dev/zero` as the input file, through a symlink, and on stdin: a
/// clear error naming it, no output, for the readers of several commands.
#[test]
fn inputs_that_never_end_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let zero = dir.path().join("zero.ply");
    std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
    let out = dir.path().join("out.ply");
    let m = unit_triangle_file(dir.path());
    for input in [Path::new("/dev/zero"), zero.as_path()] {
        let o = run("clean", &[s(input), "-o", s(&out)], None);
        fails(&o, 1, &[s(input), "all zero"]);
        let o = run("info", &[s(input)], None);
        fails(&o, 1, &[s(input), "all zero"]);
        let o = run("chamfer", &[s(input), s(&m)], None);
        fails(&o, 1, &["prediction", "all zero"]);
    }
    let o = run("clean", &["-", "-o", s(&out)], Some(Path::new("/dev/zero")));
    fails(&o, 1, &["<stdin>", "all zero"]);
    assert!(!out.exists());
}

/// A binary PLY on stdin followed by an endless stream: read up to what
/// its header declares (plus 1 MiB), then refused; the same PLY alone on
/// stdin is read as usual.
#[test]
fn a_stream_is_capped_by_its_declared_size() {
    let dir = tempfile::tempdir().unwrap();
    let m = unit_triangle_file(dir.path());
    let out = dir.path().join("out.ply");
    // A mesh large enough that its header and body exceed the 64 KiB sniff.
    let n = 6000;
    let verts: Vec<[f32; 3]> = (0..n).map(|i| [i as f32, (i % 7) as f32, 0.0]).collect();
    let faces: Vec<[u32; 3]> = (0..n as u32 - 2).map(|i| [i, i + 1, i + 2]).collect();
    let big = dir.path().join("big.ply");
    save(&big, &Scene::Mesh(Mesh::new(verts, faces)), FileFormat::Ply).unwrap();
    assert!(std::fs::metadata(&big).unwrap().len() > 64 << 10);
    let o = run_piped(
        &format!("cat '{}' /dev/urandom", s(&big)),
        "clean",
        &["-", "-o", s(&out)],
    );
    fails(&o, 1, &["<stdin>", "goes on past"]);
    assert!(!out.exists());
    let o = run_piped(
        &format!("cat '{}'", s(&big)),
        "clean",
        &["-", "-o", s(&out)],
    );
    succeeds(&o);
    // A small file on stdin is read whole as before.
    let o = run_piped(&format!("cat '{}'", s(&m)), "info", &["-"]);
    succeeds(&o);
}

/// A glTF whose external buffer is `/dev/zero`: the declared byteLength is
/// checked before reading and only that many bytes are read; a byteLength
/// beyond the budget is refused before opening; errors name the `.gltf`.
#[test]
fn gltf_external_buffers_are_read_to_their_declared_length() {
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.bin")).unwrap();
    let out = dir.path().join("out.ply");
    // byteLength within reason: 36 zero bytes make three vertices at the
    // origin and the file reads (a degenerate triangle, but no hang).
    let ok = r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":36,"uri":"zero.bin"}],
      "bufferViews":[{"buffer":0,"byteLength":36}],
      "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
        "min":[0,0,0],"max":[0,0,0]}],
      "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
      "nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]}"#;
    let g1 = dir.path().join("a.gltf");
    std::fs::write(&g1, ok).unwrap();
    let o = run("info", &[s(&g1)], None);
    succeeds(&o);
    // A byteLength of 2^52 bytes: refused naming the glTF and the budget.
    let huge = ok.replace(
        r#""byteLength":36,"uri""#,
        r#""byteLength":4503599627370496,"uri""#,
    );
    let g2 = dir.path().join("b.gltf");
    std::fs::write(&g2, huge).unwrap();
    let o = run("clean", &[s(&g2), "-o", s(&out)], None);
    fails(&o, 1, &["b.gltf", "zero.bin"]);
    assert!(!out.exists());
}

/// `--resume` whose `optimizer.bin` is `/dev/zero`: refused after a
/// bounded read, naming the file; the output folder is as it was.
#[test]
fn a_resume_checkpoint_that_never_ends_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    write_sphere_dataset(&data, 4, 16, 50).unwrap();
    let out = dir.path().join("out");
    let args = [
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
    let mut first = args.to_vec();
    first.extend(["--stop-at", "2"]);
    succeeds(&run("train", &first, None));
    let opt = out.join("checkpoint/optimizer.bin");
    std::fs::remove_file(&opt).unwrap();
    std::os::unix::fs::symlink("/dev/zero", &opt).unwrap();
    let model = std::fs::read(out.join("checkpoint/model.ply")).unwrap();
    let mut resume = args.to_vec();
    resume.extend(["--resume", s(&out)]);
    let o = run("train", &resume, None);
    fails(&o, 1, &["optimizer.bin"]);
    assert_eq!(
        std::fs::read(out.join("checkpoint/model.ply")).unwrap(),
        model
    );
    assert!(
        std::fs::symlink_metadata(&opt)
            .unwrap()
            .file_type()
            .is_symlink()
    );
}
