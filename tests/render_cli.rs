//! `render` as a binary: exact depth of a generated mesh, the 16-bit depth
//! scale, `--compare` numbers, errors that name the file, determinism across
//! thread counts on the real biker scene, and a Triangle Splatting render.

use assert_cmd::Command;
use glam::{DMat3, DVec3};
use splatkit::io::cameras::npz::parse_npy;
use splatkit::io::image::read_png_rgb;
use splatkit::model::{Camera, Mesh};

fn bin() -> Command {
    Command::cargo_bin("render").expect("binary built")
}

/// A camera at the origin looking down +z.
fn camera(name: &str, w: u32, h: u32, f: f64) -> Camera {
    Camera::pinhole(
        name,
        w,
        h,
        f,
        f,
        w as f64 / 2.0,
        h as f64 / 2.0,
        DMat3::IDENTITY,
        DVec3::ZERO,
    )
}

/// A slanted plane z = 3 + 0.5·x seen head-on: the depth of pixel column u
/// is the ray/plane intersection z = 3 / (1 − 0.5·(u + 0.5 − cx)/f), exact
/// in the `.npy` (f32) and within half a step in the 16-bit PNG.
#[test]
fn mesh_depth_is_exact() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = Mesh::new(
        vec![
            [-10.0, -10.0, -2.0],
            [10.0, -10.0, 8.0],
            [10.0, 10.0, 8.0],
            [-10.0, 10.0, -2.0],
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let mpath = dir.path().join("plane.ply");
    let mut b = Vec::new();
    splatkit::io::ply::mesh::write_mesh(
        &mut b,
        &mesh,
        splatkit::io::ply::Format::BinaryLittleEndian,
    )
    .unwrap();
    std::fs::write(&mpath, b).unwrap();
    let cams = [camera("view", 40, 30, 30.0)];
    let cpath = dir.path().join("cameras.json");
    splatkit::io::cameras::write_gs_json(&cpath, &cams).unwrap();
    let out = dir.path().join("out");
    bin()
        .args([
            mpath.to_str().unwrap(),
            "--cameras",
            cpath.to_str().unwrap(),
            "-o",
        ])
        .arg(&out)
        .args(["--depth-scale", "5000", "-q"])
        .assert()
        .success();
    let npy = parse_npy("d", &std::fs::read(out.join("view_depth.npy")).unwrap()).unwrap();
    assert_eq!(npy.shape, vec![30, 40]);
    let png = read_png_rgb(&out.join("view_depth.png")).unwrap();
    for v in 0..30 {
        for u in 0..40 {
            let want = 3.0 / (1.0 - 0.5 * (u as f64 + 0.5 - 20.0) / 30.0);
            let got = npy.data[v * 40 + u];
            // f32 storage: 1e-6 relative
            assert!(
                (got - want).abs() < 1e-5 * want,
                "({u},{v}) {got} vs {want}"
            );
            let d16 = (png.pixels[v * 40 + u][0] as f64 * 65535.0).round();
            assert!(
                (d16 - want * 5000.0).abs() <= 0.5 + 1e-6,
                "({u},{v}) png {d16}"
            );
        }
    }
    // every pixel covered: alpha 255
    let alpha = read_png_rgb(&out.join("view_alpha.png")).unwrap();
    assert!(alpha.pixels.iter().all(|p| p[0] == 1.0));
}

/// `--compare` against the render's own PNG: the only difference is the
/// 8-bit rounding (|e| ≤ 1/510), so PSNR ≥ 20·log10(510) ≈ 54.2 dB and
/// SSIM ≈ 1 (the second render reads the cameras.json the first one wrote
/// for its orbit); a missing ground-truth image is an error naming the file.
#[test]
fn compare_reports_psnr_and_ssim() {
    let Some(scene) =
        splatkit::testing::shared_data("3dgs-playcanvas-guitar/guitar.decoded_sh0.ply")
    else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a");
    bin()
        .arg(&scene)
        .args([
            "--orbit",
            "2",
            "--size",
            "96x72",
            "--outputs",
            "rgb",
            "-q",
            "-o",
        ])
        .arg(&out)
        .assert()
        .success();
    // the orbit run left its views in a/cameras.json: rendering from that
    // file must reproduce the same images
    let res = bin()
        .arg(&scene)
        .arg("--cameras")
        .arg(out.join("cameras.json"))
        .args(["--outputs", "rgb", "-q", "--json", "-o"])
        .arg(dir.path().join("b"))
        .arg("--compare")
        .arg(&out)
        .assert()
        .success();
    let v: serde_json::Value = serde_json::from_slice(&res.get_output().stdout).unwrap();
    let p = v["mean_psnr"].as_f64().unwrap();
    let s = v["mean_ssim"].as_f64().unwrap();
    assert!(p >= 54.0, "PSNR {p}");
    assert!(s > 0.999, "SSIM {s}");
    std::fs::remove_file(out.join("orbit_001.png")).unwrap();
    bin()
        .arg(&scene)
        .args([
            "--orbit",
            "2",
            "--size",
            "96x72",
            "--outputs",
            "rgb",
            "-q",
            "-o",
        ])
        .arg(dir.path().join("c"))
        .arg("--compare")
        .arg(&out)
        .assert()
        .failure()
        .stderr(predicates::str::contains("orbit_001"));
}

/// The real 152k-Gaussian biker renders identically with 1 and 2 threads,
/// and the subject covers a good part of the frame (the orbit frames it).
#[test]
fn biker_is_deterministic_across_threads() {
    let Some(scene) = splatkit::testing::shared_data("3dgs-playcanvas-biker/biker.decoded_sh0.ply")
    else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let run = |threads: &str, sub: &str| {
        bin()
            .arg(&scene)
            .args([
                "--orbit", "3", "--size", "160x120", "-q", "-j", threads, "-o",
            ])
            .arg(dir.path().join(sub))
            .assert()
            .success();
    };
    run("1", "t1");
    run("2", "t2");
    for v in 0..3 {
        for suffix in [
            ".png",
            "_depth.npy",
            "_depth.png",
            "_alpha.png",
            "_normal.png",
        ] {
            let f = format!("orbit_{v:03}{suffix}");
            let a = std::fs::read(dir.path().join("t1").join(&f)).unwrap();
            let b = std::fs::read(dir.path().join("t2").join(&f)).unwrap();
            assert!(a == b, "{f} differs between 1 and 2 threads");
        }
        let alpha = read_png_rgb(
            &dir.path()
                .join("t1")
                .join(format!("orbit_{v:03}_alpha.png")),
        )
        .unwrap();
        let covered =
            alpha.pixels.iter().filter(|p| p[0] > 0.5).count() as f64 / alpha.pixels.len() as f64;
        assert!(
            (0.05..0.8).contains(&covered),
            "view {v}: coverage {covered}"
        );
    }
}

/// Bad arguments fail with a message: unknown output item, bad size.
#[test]
fn bad_arguments_fail_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let mpath = dir.path().join("t.off");
    std::fs::write(&mpath, "OFF\n3 1 0\n0 0 3\n1 0 3\n0 1 3\n3 0 1 2\n").unwrap();
    bin()
        .arg(&mpath)
        .args(["--outputs", "rgb,colour", "-o"])
        .arg(dir.path().join("o"))
        .assert()
        .failure()
        .stderr(predicates::str::contains("colour"));
    bin()
        .arg(&mpath)
        .args(["--size", "12by3", "-o"])
        .arg(dir.path().join("o"))
        .assert()
        .failure()
        .stderr(predicates::str::contains("--size"));
    bin()
        .arg(dir.path().join("missing.ply"))
        .args(["-o"])
        .arg(dir.path().join("o"))
        .assert()
        .failure()
        .stderr(predicates::str::contains("missing.ply"));
}

/// A Triangle Splatting checkpoint: one solid (σ raw = −∞), opaque
/// (logit 10) red triangle at z = 4 fills exactly the pixels whose centres
/// its projection contains (α = 0.99 there: the reference's cap), with the
/// centroid depth.
#[test]
fn triangle_checkpoint_renders_hard_triangle() {
    use splatkit::model::TriangleSoup;
    let dir = tempfile::tempdir().unwrap();
    let soup = TriangleSoup {
        triangles: vec![[[-1.02, -0.97, 4.0], [1.23, -0.83, 4.0], [0.13, 1.07, 4.0]]],
        opacity_raw: vec![10.0],
        sigma_raw: vec![f32::NEG_INFINITY],
        sh_degree: 0,
        active_sh_degree: 0,
        sh_dc: vec![[
            splatkit_render::sh::rgb_to_sh(1.0),
            splatkit_render::sh::rgb_to_sh(0.0),
            splatkit_render::sh::rgb_to_sh(0.0),
        ]],
        sh_rest: vec![],
        ..Default::default()
    };
    let p = dir.path().join("point_cloud_state_dict.pt");
    let mut f = std::fs::File::create(&p).unwrap();
    splatkit::io::torch_pt::write_triangle_checkpoint(&mut f, &soup).unwrap();
    drop(f);
    let cpath = dir.path().join("cameras.json");
    splatkit::io::cameras::write_gs_json(&cpath, &[camera("v", 40, 40, 40.0)]).unwrap();
    bin()
        .arg(&p)
        .args(["--cameras", cpath.to_str().unwrap(), "-q", "-o"])
        .arg(dir.path().join("o"))
        .assert()
        .success();
    let rgb = read_png_rgb(&dir.path().join("o/v.png")).unwrap();
    let depth = parse_npy(
        "d",
        &std::fs::read(dir.path().join("o/v_depth.npy")).unwrap(),
    )
    .unwrap();
    let px = |v: [f64; 2]| [40.0 * v[0] / 4.0 + 20.0, 40.0 * v[1] / 4.0 + 20.0];
    let t = [px([-1.02, -0.97]), px([1.23, -0.83]), px([0.13, 1.07])];
    let edge = |a: [f64; 2], b: [f64; 2], x: f64, y: f64| {
        (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])
    };
    for y in 0..40 {
        for x in 0..40 {
            let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
            let e = [
                edge(t[0], t[1], cx, cy),
                edge(t[1], t[2], cx, cy),
                edge(t[2], t[0], cx, cy),
            ];
            let inside = e.iter().all(|&v| v > 0.0) || e.iter().all(|&v| v < 0.0);
            let r = rgb.pixels[y * 40 + x][0];
            let d = depth.data[y * 40 + x];
            if inside {
                assert!((r - 0.99).abs() < 0.5 / 255.0 + 1e-6, "({x},{y}) {r}");
                assert!((d - 4.0).abs() < 1e-6);
            } else {
                assert_eq!(r, 0.0, "({x},{y})");
                assert_eq!(d, 0.0);
            }
        }
    }
}
