//! Issue 23, "one memory budget, checked before allocating" (see
//! docs/RELIABILITY.md): sizes that a flag or a file drives are estimated
//! and refused beyond the budget — min(MemTotal, `ulimit -v`) × 3/4, so
//! 1.5 GiB under the 2 GB limit of [`run`] — before anything that large is
//! allocated. A flag's size is a usage error (exit 2), a file's an error
//! (exit 1); the message names the flag or file and says "memory budget".
//! Every refused run leaves no output and its inputs byte-identical.

use std::path::{Path, PathBuf};

use super::common::{cameras_file, fails, mesh_file, run, s, snapshot, succeeds};

use glam::{DMat3, DVec3};
use splatkit::geom::scenes::synthetic::Torus;
use splatkit::io::cameras::write_gs_json;
use splatkit::io::ply::{Format, gaussians::write_gaussians};
use splatkit::model::Camera;
use splatkit::testing::{cameras_around, uv_sphere, write_sphere_dataset};

/// A pinhole camera `w`×`h` at z = −4 looking down +z at the origin.
fn camera(name: &str, w: u32, h: u32) -> Camera {
    Camera::pinhole(
        name,
        w,
        h,
        w as f64,
        w as f64,
        w as f64 / 2.0,
        h as f64 / 2.0,
        DMat3::IDENTITY,
        DVec3::new(0.0, 0.0, 4.0),
    )
}

/// A small Gaussian torus file.
fn gaussians_file(dir: &Path) -> PathBuf {
    let p = dir.join("gaussians.ply");
    let g = Torus {
        major: 1.0,
        minor: 0.35,
    }
    .gaussians(24, 12, 0.004, 0, 0);
    let mut b = Vec::new();
    write_gaussians(&mut b, &g, Format::BinaryLittleEndian).unwrap();
    std::fs::write(&p, b).unwrap();
    p
}

/// Runs `bin` with `args`, expects the refusal (`code`, `needles`, and
/// "memory budget" unless `parse` says clap refused it), and checks that
/// the run took under 5 s and changed nothing under `dir`.
fn refused(dir: &Path, bin: &str, args: &[&str], code: i32, needles: &[&str], parse: bool) {
    let before = snapshot(dir);
    let t = std::time::Instant::now();
    let out = run(bin, args, None);
    let secs = t.elapsed().as_secs_f64();
    let mut all = needles.to_vec();
    if !parse {
        all.push("memory budget");
    }
    fails(&out, code, &all);
    // refused before the work: a few seconds at most, not minutes
    assert!(secs < 5.0, "{bin} {args:?} took {secs:.1} s");
    // no output appeared and every input is byte-identical
    assert!(
        snapshot(dir) == before,
        "{bin} {args:?} changed {}",
        dir.display()
    );
}

/// Image buffers: one camera of 16384×16384 (2^28 pixels, which the camera
/// checks allow) in each command that renders or holds images is refused
/// with the camera file (or data folder) named, exit 1; the same size from
/// `--size` is refused as a usage error naming it, exit 2.
#[test]
fn image_buffers_beyond_the_budget() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("in");
    std::fs::create_dir(&dir).unwrap();
    let mesh = mesh_file(&dir, "mesh.ply", uv_sphere(8, 1.0));
    let gs = gaussians_file(&dir);
    let big = cameras_file(&dir, "big.json", &[camera("a", 16384, 16384)]);
    let out = tmp.path().join("out");
    let out_ply = tmp.path().join("out.ply");
    let out_obj = tmp.path().join("out.obj");
    for (bin, args) in [
        (
            "render",
            vec![s(&mesh), "--cameras", s(&big), "-o", s(&out)],
        ),
        ("render", vec![s(&gs), "--cameras", s(&big), "-o", s(&out)]),
        (
            "splat2points",
            vec![
                s(&gs),
                "--cameras",
                s(&big),
                "--all-views",
                "-o",
                s(&out_ply),
            ],
        ),
        (
            "bake-texture",
            vec![s(&mesh), s(&gs), "--cameras", s(&big), "-o", s(&out_obj)],
        ),
        (
            "tsdf-fuse",
            vec![s(&mesh), "--cameras", s(&big), "-o", s(&out_ply)],
        ),
    ] {
        refused(&dir, bin, &args, 1, &["big.json"], false);
        assert!(!out.exists() && !out_ply.exists() && !out_obj.exists());
    }
    // --size drives the orbit's buffers: a flag, exit 2
    for (bin, args) in [
        (
            "render",
            vec![s(&mesh), "--size", "16384x16384", "-o", s(&out)],
        ),
        (
            "splat2points",
            vec![
                s(&gs),
                "--orbit",
                "1",
                "--size",
                "16384x16384",
                "-o",
                s(&out_ply),
            ],
        ),
    ] {
        refused(&dir, bin, &args, 2, &["--size 16384x16384"], false);
        assert!(!out.exists() && !out_ply.exists());
    }
    // refine: bound Gaussians, photos named like the camera, a huge camera
    let bound = tmp.path().join("bound.ply");
    succeeds(&run(
        "bind-gaussians",
        &[s(&mesh), "-o", s(&bound), "-q"],
        None,
    ));
    std::fs::rename(&bound, dir.join("bound.ply")).unwrap();
    let bound = dir.join("bound.ply");
    let images = dir.join("images");
    std::fs::create_dir(&images).unwrap();
    std::fs::write(images.join("a.png"), tiny_png()).unwrap();
    refused(
        &dir,
        "refine",
        &[
            s(&bound),
            "--images",
            s(&images),
            "--cameras",
            s(&big),
            "-o",
            s(&out),
        ],
        1,
        &["big.json"],
        false,
    );
    assert!(!out.exists());
    // train: a data folder whose cameras.json declares 16384² photos (the
    // photos on disk are small: the estimate comes before any is decoded)
    let data = dir.join("data");
    write_sphere_dataset(&data, 3, 16, 50).unwrap();
    let mut cams = cameras_around(3, 3.5, 16384, 20000.0);
    for (i, c) in cams.iter_mut().enumerate() {
        c.name = format!("v{i:02}");
    }
    write_gs_json(&data.join("cameras.json"), &cams).unwrap();
    for model in ["gaussians", "triangles"] {
        refused(
            &dir,
            "train",
            &[model, s(&data), "-o", s(&out), "--iterations", "1"],
            1,
            &[s(&data), "photos of 3 views"],
            false,
        );
        assert!(!out.exists());
    }
    // within the budget, the same commands run (render's 64² views)
    let small = cameras_file(&dir, "small.json", &[camera("a", 64, 64)]);
    succeeds(&run(
        "render",
        &[s(&mesh), "--cameras", s(&small), "-o", s(&out), "-q"],
        None,
    ));
}

/// A valid 1×1 RGB PNG.
fn tiny_png() -> Vec<u8> {
    let mut b = Vec::new();
    splatkit::io::image::write_png8(&mut b, "a.png", 1, 1, 3, &[10, 20, 30]).unwrap();
    b
}

/// Counts no check used to look at: initial points and regulariser samples
/// (exit 2: flags, `1e12` notation accepted and refused by the budget, or
/// beyond 2^40 at parse), the demo's image size and torus segments (exit
/// 2), and the texture atlas a 60k-face mesh makes at `--square-size 90`
/// inside the default `--max-texture` (exit 1: the mesh's face count).
#[test]
fn counts_beyond_the_budget() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("in");
    std::fs::create_dir(&dir).unwrap();
    let data = dir.join("data");
    write_sphere_dataset(&data, 3, 16, 0).unwrap();
    let out = tmp.path().join("out");
    for model in ["gaussians", "triangles"] {
        refused(
            &dir,
            "train",
            &[model, s(&data), "-o", s(&out), "--init-points", "1e12"],
            2,
            &["--init-points 1000000000000"],
            false,
        );
        refused(
            &dir,
            "train",
            &[
                model,
                s(&data),
                "-o",
                s(&out),
                "--init-points",
                "1000000000000",
            ],
            2,
            &["--init-points"],
            false,
        );
        // past 2^40, or not a whole number: clap refuses it
        for bad in ["2e12", "1.5", "0", "-3", "NaN"] {
            let flag = format!("--init-points={bad}");
            refused(
                &dir,
                "train",
                &[model, s(&data), "-o", s(&out), &flag],
                2,
                &["--init-points"],
                true,
            );
        }
    }
    refused(
        &dir,
        "train",
        &[
            "gaussians",
            s(&data),
            "-o",
            s(&out),
            "--regularize",
            "density",
            "--samples",
            "1e12",
        ],
        2,
        &["--samples 1000000000000"],
        false,
    );
    assert!(!out.exists());
    for args in [
        vec!["demo", "-o", s(&out), "--size", "1000000"],
        vec!["demo", "-o", s(&out), "--views", "10000", "--size", "4096"],
    ] {
        refused(&dir, "splatkit", &args, 2, &["--size"], false);
    }
    for segments in ["4294967295", "100000"] {
        refused(
            &dir,
            "splatkit",
            &["demo", "-o", s(&out), "--segments", segments],
            2,
            &[&format!("--segments {segments}")],
            false,
        );
    }
    assert!(!out.exists());
    // the atlas: 15660² texels for 60k faces at --square-size 90
    let sphere = uv_sphere(124, 1.0);
    assert!(sphere.faces.len() >= 60_000, "{}", sphere.faces.len());
    let mesh = mesh_file(&dir, "mesh60k.ply", sphere);
    let gs = gaussians_file(&dir);
    let cams = cameras_file(&dir, "cameras.json", &[camera("a", 32, 32)]);
    let obj = tmp.path().join("t.obj");
    refused(
        &dir,
        "bake-texture",
        &[
            s(&mesh),
            s(&gs),
            "--cameras",
            s(&cams),
            "--square-size",
            "90",
            "-o",
            s(&obj),
        ],
        1,
        &["mesh60k.ply", "--square-size 90", "texture atlas"],
        false,
    );
    assert!(!obj.exists() && !obj.with_extension("png").exists());
}

/// TSDF grids through other flags: a `--sdf-trunc` so wide that one depth
/// sample alone touches more blocks than fit (`1e30`; `--voxel 0.001
/// --sdf-trunc 10`), and `--unbounded` at the default `--mesh-res 1024`,
/// are refused up front as usage errors naming the flags; a tiny voxel that
/// only the surfaces seen make too large stops at the block limit with the
/// flags and the budget named, never past the memory limit; a small
/// unbounded grid still fuses.
#[test]
fn tsdf_grids_beyond_the_budget() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("in");
    std::fs::create_dir(&dir).unwrap();
    let mesh = mesh_file(&dir, "sphere.ply", uv_sphere(24, 1.0));
    let cams = cameras_file(&dir, "cameras.json", &cameras_around(4, 3.5, 48, 40.0));
    let out = tmp.path().join("fused.ply");
    let base = [s(&mesh), "--cameras", s(&cams), "-o", s(&out)];
    for (extra, needles) in [
        (
            vec!["--sdf-trunc", "1e30"],
            vec!["--sdf-trunc 1000000000000000"],
        ),
        (
            vec!["--voxel", "0.001", "--sdf-trunc", "10"],
            vec!["--voxel 0.001 --sdf-trunc 10"],
        ),
        (vec!["--unbounded"], vec!["--mesh-res 1024"]),
        (
            vec!["--unbounded", "--mesh-res", "65536"],
            vec!["--mesh-res 65536"],
        ),
    ] {
        let args: Vec<&str> = base.iter().copied().chain(extra).collect();
        refused(&dir, "tsdf-fuse", &args, 2, &needles, false);
        assert!(!out.exists());
    }
    // tiny voxels: the blocks the surface needs (10,000 samples a view at
    // 400², each touching 1 to 8 blocks of 8 mm) pass the limit mid-fusion;
    // the run stops before allocating them (no abort, no output)
    let fine = cameras_file(&dir, "fine.json", &cameras_around(4, 3.5, 400, 330.0));
    let args = [
        s(&mesh),
        "--cameras",
        s(&fine),
        "-o",
        s(&out),
        "--voxel",
        "0.0005",
        "--depth-trunc",
        "10",
    ];
    refused(
        &dir,
        "tsdf-fuse",
        &args,
        1,
        &["--voxel 0.0005", "blocks"],
        false,
    );
    assert!(!out.exists());
    // within the budget both fusions run
    succeeds(&run(
        "tsdf-fuse",
        &[s(&mesh), "--cameras", s(&cams), "-o", s(&out), "-q"],
        None,
    ));
    std::fs::remove_file(&out).unwrap();
    succeeds(&run(
        "tsdf-fuse",
        &[
            s(&mesh),
            "--cameras",
            s(&cams),
            "--unbounded",
            "--mesh-res",
            "128",
            "-o",
            s(&out),
            "-q",
        ],
        None,
    ));
}

/// `poisson --full-depth` allocates the complete levels whatever the
/// points (8^12 nodes at 12): refused as a usage error naming the flag and
/// the budget before the points are read; the default still runs.
#[test]
fn poisson_full_depth_beyond_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.ply");
    // The points file need not exist: the flag is refused first.
    let pts = dir.path().join("missing.ply");
    let o = super::common::run(
        "poisson",
        &[
            pts.to_str().unwrap(),
            "--depth",
            "12",
            "--full-depth",
            "12",
            "-o",
            out.to_str().unwrap(),
        ],
        None,
    );
    super::common::fails(&o, 2, &["--full-depth 12", "memory budget"]);
    assert!(!out.exists());
}

/// `tsdf-fuse --voxel 1e-30` (sdf_trunc 5 voxels): each sample touches one
/// block, but the block indices of a surface at distance ~3 are ~10^29,
/// beyond the `i32` voxel indices. Refused naming the voxel size, where it
/// used to overflow (a panic in debug builds, wrapped indices in release).
#[test]
fn tsdf_indices_beyond_their_range() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("in");
    std::fs::create_dir(&dir).unwrap();
    let mesh = mesh_file(&dir, "sphere.ply", uv_sphere(12, 1.0));
    let cams = cameras_file(&dir, "cameras.json", &cameras_around(2, 3.5, 24, 20.0));
    let out = tmp.path().join("fused.ply");
    let args = [
        s(&mesh),
        "--cameras",
        s(&cams),
        "-o",
        s(&out),
        "--voxel",
        "1e-30",
    ];
    // (`parse = true`: the message is not a budget one)
    refused(
        &dir,
        "tsdf-fuse",
        &args,
        1,
        &["voxel size", "address"],
        true,
    );
    assert!(!out.exists());
}
