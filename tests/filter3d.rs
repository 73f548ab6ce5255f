//! Gaussians with Mip-Splatting's / GOF's `filter_3D` property: the fixture
//! written as their `save_ply` writes it, the baked (effective) values
//! against NumPy's, rendering the filtered model against rendering its
//! baked values, the real Mip-Splatting donut export (no `filter_3D`: plain
//! 3DGS), and the commands `render`, `tsdf-fuse` and `splat2points`
//! applying the filter.

mod common;

use std::path::{Path, PathBuf};

use common::{run, s, succeeds};
use serde_json::Value;
use splatkit::io::any::{load_gaussians, save_gaussians};
use splatkit::model::filter3d::{
    FILTER_3D, bake_filter_3d, baked_for_rendering, filter_3d, has_filter_3d,
};
use splatkit::model::gaussians::logit;
use splatkit::model::{Column, Gaussians, Property, ScalarData};
use splatkit::testing::cameras_around;
use splatkit_render::gaussian::{Filter2d, Gaussians3, RasterSettings, render};

fn testdata(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("testdata")
        .join(rel)
}

fn expected() -> Value {
    let p = testdata("gaussians/mip_splatting.json");
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

fn nums(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// The fixture reads as Gaussians with SH degree 3 and a `filter_3D`
/// column equal to what plyfile stored (exact f32); the baked scales and
/// opacities equal NumPy's `get_scaling_with_3D_filter` /
/// `get_opacity_with_3D_filter` in f64 to 2e-6 relative (the baked values
/// are stored as f32 log-scale and logit, then activated in f32: a few
/// f32 roundings of 6e-8 each, amplified by at most 1/(1 − α) ≤ 10 in the
/// logit).
#[test]
fn fixture_reads_and_bakes_like_the_reference() {
    let exp = expected();
    let g = load_gaussians(&testdata("gaussians/mip_splatting.ply"), "test").unwrap();
    assert_eq!(g.len(), 60);
    assert_eq!(g.sh_degree, 3);
    let f = filter_3d(&g).unwrap().expect("filter_3D read");
    let want_f = nums(&exp["filter_3D"]);
    for (a, b) in f.iter().zip(&want_f) {
        assert_eq!(*a as f64, *b);
    }
    let b = bake_filter_3d(&g).unwrap();
    assert!(!has_filter_3d(&b));
    let eff_s = exp["effective_scales"].as_array().unwrap();
    let eff_a = nums(&exp["effective_opacities"]);
    for i in 0..g.len() {
        let want = nums(&eff_s[i]);
        let got = b.scales(i);
        for k in 0..3 {
            let rel = (got[k] as f64 - want[k]).abs() / want[k];
            assert!(
                rel < 2e-6,
                "Gaussian {i} scale {k}: {} vs {}",
                got[k],
                want[k]
            );
        }
        let rel = (b.opacity(i) as f64 - eff_a[i]).abs() / eff_a[i];
        assert!(rel < 2e-6, "Gaussian {i}: {} vs {}", b.opacity(i), eff_a[i]);
    }
    // the filter lowers every opacity and widens every axis
    assert!((0..g.len()).all(|i| b.opacity(i) < g.opacity(i)));
}

/// A read-modify-write keeps `filter_3D` (it is an extra property), in
/// place after the 3DGS properties.
#[test]
fn filter_survives_a_round_trip() {
    let g = load_gaussians(&testdata("gaussians/mip_splatting.ply"), "test").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("out.ply");
    save_gaussians(&p, &g).unwrap();
    let back = load_gaussians(&p, "test").unwrap();
    assert_eq!(filter_3d(&back).unwrap(), filter_3d(&g).unwrap());
}

/// Rendering with the reference's rules = rendering the baked values: the
/// Gaussians the Mip-Splatting renderer draws (NumPy's effective scales
/// and opacities, straight from the JSON) and our baked model, both under
/// the 2-D Mip filter (0.1), agree to 1e-4 per pixel and channel: the
/// inputs differ by the f32 rounding of the baked log-scale and logit
/// (≈ 1e-6 relative); 1e-4 leaves room for that through the blend and is
/// still far below one contribution at the 1/255 cut. The same baked model
/// under 3DGS's 0.3 dilation (what a plain 3DGS viewer shows of a fused
/// PLY) differs from it visibly: more than 0.01 somewhere, since the
/// dilation grows small splats without lowering their opacity.
#[test]
fn rendering_the_filter_equals_rendering_its_bake() {
    let exp = expected();
    let g = load_gaussians(&testdata("gaussians/mip_splatting.ply"), "test").unwrap();
    let baked = bake_filter_3d(&g).unwrap().to_raster_at(0);
    let eff_s = exp["effective_scales"].as_array().unwrap();
    let reference = Gaussians3 {
        scales: eff_s
            .iter()
            .map(|r| {
                let v = nums(r);
                [v[0] as f32, v[1] as f32, v[2] as f32]
            })
            .collect(),
        opacities: nums(&exp["effective_opacities"])
            .iter()
            .map(|&a| a as f32)
            .collect(),
        ..g.to_raster_at(0)
    };
    let mip = RasterSettings {
        background: [0.2, 0.2, 0.2],
        filter_2d: Filter2d::Mip { kernel_size: 0.1 },
        ..Default::default()
    };
    let mut apart = 0.0f32;
    for cam in cameras_around(4, 6.0, 96, 600.0) {
        let a = render(&reference, &cam, &mip);
        let b = render(&baked, &cam, &mip);
        let worst = a
            .rgb
            .iter()
            .zip(&b.rgb)
            .flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs()))
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-4, "camera {}: {worst}", cam.name);
        let d = render(
            &baked,
            &cam,
            &RasterSettings {
                filter_2d: Filter2d::default(),
                ..mip
            },
        );
        apart = a
            .rgb
            .iter()
            .zip(&d.rgb)
            .flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs()))
            .fold(apart, f32::max);
    }
    assert!(apart > 0.01, "dilation differs by {apart} only");
}

/// `3dgs-donut-mipsplatting/fused.ply` is Mip-Splatting's
/// `create_fused_ply.py` output: `save_fused_ply` has already baked the
/// 3-D filter into the scales and opacities and left `filter_3D` out, so
/// it reads as plain 3DGS Gaussians (the `auto` 2-D filter is 3DGS's
/// dilation for it; `--filter-2d mip` renders it as Mip-Splatting would).
#[test]
fn donut_export_is_plain_3dgs() {
    let Some(p) = splatkit::testing::shared_data("3dgs-donut-mipsplatting/fused.ply") else {
        return;
    };
    let g = load_gaussians(&p, "test").unwrap();
    assert_eq!(g.len(), 45_624);
    assert!(!has_filter_3d(&g));
    assert_eq!(filter_3d(&g).unwrap(), None);
    let (same, filtered) = baked_for_rendering(g.clone()).unwrap();
    assert!(!filtered);
    assert_eq!(same, g);
}

/// A sphere of radius 1 covered by 600 flat Gaussians (discs tangent to
/// it, σ 0.07 × 0.07 × 0.003) with `filter_3D` = 0.005 and opacity 0.9 (0.46 baked);
/// returns the filtered file, its baked copy and a copy with the column
/// dropped (the raw values a tool ignoring the filter would draw).
fn sphere_files(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let n = 600;
    let mut g = Gaussians {
        sh_degree: 0,
        ..Default::default()
    };
    for k in 0..n {
        let y = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
        let a = k as f64 * 2.399_963_229_728_653;
        let r = (1.0 - y * y).sqrt();
        let nrm = glam::DVec3::new(r * a.cos(), y, r * a.sin());
        g.means.push(nrm.as_vec3().to_array());
        // local z along the normal
        let q = glam::DQuat::from_rotation_arc(glam::DVec3::Z, nrm);
        g.rotations
            .push([q.w as f32, q.x as f32, q.y as f32, q.z as f32]);
        g.log_scales
            .push([0.07f32.ln(), 0.07f32.ln(), 0.003f32.ln()]);
        g.opacity_logits.push(logit(0.9));
        g.sh_dc.push([0.5, 0.1, -0.3]);
    }
    let plain_path = dir.join("plain.ply");
    save_gaussians(&plain_path, &g).unwrap();
    g.extras.item.push(Property {
        name: FILTER_3D.into(),
        data: Column::Scalar(ScalarData::F32(vec![0.005; n])),
    });
    let filtered_path = dir.join("filtered.ply");
    save_gaussians(&filtered_path, &g).unwrap();
    let baked_path = dir.join("baked.ply");
    save_gaussians(&baked_path, &bake_filter_3d(&g).unwrap()).unwrap();
    (filtered_path, baked_path, plain_path)
}

fn json_of(out: &std::process::Output) -> Value {
    serde_json::from_slice(&out.stdout).unwrap()
}

fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

/// Runs `CMD SCENE --cameras CAMS -o DIR/OUT --json ARGS…`, which must
/// succeed; returns its JSON report and the output path.
fn run_with_cameras(
    cmd: &str,
    scene: &Path,
    cams: &Path,
    out: PathBuf,
    args: &[&str],
) -> (Value, PathBuf) {
    let mut all = vec![s(scene), "--cameras", s(cams), "-o", s(&out), "--json"];
    all.extend_from_slice(args);
    let o = run(cmd, &all, None);
    succeeds(&o);
    (json_of(&o), out)
}

/// `render` of the filtered file picks the Mip filter (its report says
/// "mip 0.1") and gives the same bytes as the baked file with
/// `--filter-2d mip`; the raw values with the same filter (the 3-D filter
/// left out) give other images, and so does `--filter-2d dilate`.
#[test]
fn render_applies_the_filter() {
    let dir = tempfile::tempdir().unwrap();
    let (filtered, baked, plain) = sphere_files(dir.path());
    let cams = dir.path().join("cameras.json");
    splatkit::io::cameras::write_gs_json(&cams, &cameras_around(3, 3.5, 64, 80.0)).unwrap();
    let go = |scene: &Path, name: &str, extra: &[&str]| {
        let (j, o) = run_with_cameras("render", scene, &cams, dir.path().join(name), extra);
        (j, files(&o))
    };
    let (j, a) = go(&filtered, "a", &[]);
    assert_eq!(j["filter_2d"], "mip 0.1");
    let (j2, b) = go(&baked, "b", &["--filter-2d", "mip"]);
    assert_eq!(j2["filter_2d"], "mip 0.1");
    assert_eq!(a, b, "filtered (auto) and baked (mip) renders differ");
    let (_, c) = go(&plain, "c", &["--filter-2d", "mip"]);
    assert_ne!(a, c, "the 3-D filter changed nothing");
    let (j4, d) = go(&filtered, "d", &["--filter-2d", "dilate"]);
    assert_eq!(j4["filter_2d"], "dilate 0.3");
    assert_ne!(a, d, "the 2-D filter changed nothing");
    let (j5, _) = go(&baked, "e", &[]);
    assert_eq!(j5["filter_2d"], "dilate 0.3", "auto on a plain file");
}

/// `tsdf-fuse` likewise: the filtered file (auto) and the baked file with
/// `--filter-2d mip` fuse to the same mesh bytes; the raw values give
/// another mesh.
#[test]
fn tsdf_fuse_applies_the_filter() {
    let dir = tempfile::tempdir().unwrap();
    let (filtered, baked, plain) = sphere_files(dir.path());
    let cams = dir.path().join("cameras.json");
    splatkit::io::cameras::write_gs_json(&cams, &cameras_around(10, 3.5, 64, 80.0)).unwrap();
    let go = |scene: &Path, name: &str, extra: &[&str]| {
        let mut args = vec![
            "--voxel",
            "0.04",
            "--sdf-trunc",
            "0.16",
            "--depth-trunc",
            "10",
        ];
        args.extend_from_slice(extra);
        let (j, o) = run_with_cameras("tsdf-fuse", scene, &cams, dir.path().join(name), &args);
        (j, std::fs::read(&o).unwrap())
    };
    let (j, a) = go(&filtered, "a.ply", &[]);
    assert_eq!(j["filter_2d"], "mip 0.1");
    let (_, b) = go(&baked, "b.ply", &["--filter-2d", "mip"]);
    assert_eq!(a, b, "filtered (auto) and baked (mip) meshes differ");
    let (_, c) = go(&plain, "c.ply", &["--filter-2d", "mip"]);
    assert_ne!(a, c, "the 3-D filter changed nothing");
}

/// `splat2points --method depth`: the same points from the filtered file
/// (auto) as from the baked file with `--filter-2d mip`.
#[test]
fn splat2points_applies_the_filter() {
    let dir = tempfile::tempdir().unwrap();
    let (filtered, baked, _) = sphere_files(dir.path());
    let cams = dir.path().join("cameras.json");
    splatkit::io::cameras::write_gs_json(&cams, &cameras_around(6, 3.5, 64, 80.0)).unwrap();
    let go = |scene: &Path, name: &str, extra: &[&str]| {
        // the baked opacity of these thin discs is ≈ 0.46
        let mut args = vec!["--all-views", "--method", "depth", "--min-opacity", "0.05"];
        args.extend_from_slice(extra);
        let (j, o) = run_with_cameras("splat2points", scene, &cams, dir.path().join(name), &args);
        (j, std::fs::read(&o).unwrap())
    };
    let (j, a) = go(&filtered, "a.ply", &[]);
    assert_eq!(j["filter_2d"], "mip 0.1");
    let (_, b) = go(&baked, "b.ply", &["--filter-2d", "mip"]);
    assert_eq!(a, b);
}

/// A bad `filter_3D` value is an error naming the file and the Gaussian.
#[test]
fn negative_filter_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let (filtered, _, _) = sphere_files(dir.path());
    let mut g = load_gaussians(&filtered, "test").unwrap();
    let p = g
        .extras
        .item
        .iter_mut()
        .find(|p| p.name == FILTER_3D)
        .unwrap();
    p.data = Column::Scalar(ScalarData::F32({
        let mut v = vec![0.02f32; 600];
        v[17] = -1.0;
        v
    }));
    let bad = dir.path().join("bad.ply");
    save_gaussians(&bad, &g).unwrap();
    let out = run(
        "render",
        &[s(&bad), "--orbit", "2", "-o", s(&dir.path().join("o"))],
        None,
    );
    common::fails(&out, 1, &["bad.ply", "Gaussian 17", "filter_3D"]);
}

/// Bound Gaussians carrying `filter_3D`: `bind-gaussians --rebind` would
/// carry them on without the filter, so it refuses them with a message
/// naming the file and the property, and writes nothing (`refine` and
/// `train --resume` call the same check, `refuse_filter_3d`).
#[test]
fn binding_commands_refuse_filtered_gaussians() {
    let dir = tempfile::tempdir().unwrap();
    let m = common::unit_triangle_file(dir.path());
    let b = dir.path().join("bound.ply");
    succeeds(&run("bind-gaussians", &[s(&m), "-o", s(&b), "-q"], None));
    let mut g = load_gaussians(&b, "test").unwrap();
    let n = g.len();
    g.extras.item.push(Property {
        name: FILTER_3D.into(),
        data: Column::Scalar(ScalarData::F32(vec![0.01; n])),
    });
    let bf = dir.path().join("bound_filtered.ply");
    save_gaussians(&bf, &g).unwrap();
    let out = dir.path().join("out.ply");
    let res = run(
        "bind-gaussians",
        &[s(&bf), "--rebind", s(&m), "-o", s(&out)],
        None,
    );
    common::fails(&res, 1, &["bound_filtered.ply", FILTER_3D]);
    assert!(!out.exists());
}

/// `convert` refuses to drop `filter_3D` into a format that cannot hold it
/// (exit 1, no output), and `--bake-filter-3d` writes the baked values:
/// read back, they equal `bake_filter_3d` of the input bit for bit (a PLY
/// keeps f32 exactly) and carry no `filter_3D` column.
#[test]
fn convert_bakes_the_filter_on_request() {
    let dir = tempfile::tempdir().unwrap();
    let input = testdata("gaussians/mip_splatting.ply");
    let spz = dir.path().join("x.spz");
    let o = run("convert", &[s(&input), "-o", s(&spz)], None);
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    assert!(!spz.exists());
    let out = dir.path().join("baked.ply");
    succeeds(&run(
        "convert",
        &[s(&input), "-o", s(&out), "--bake-filter-3d"],
        None,
    ));
    let got = load_gaussians(&out, "test").unwrap();
    let want = bake_filter_3d(&load_gaussians(&input, "test").unwrap()).unwrap();
    assert!(!has_filter_3d(&got));
    assert_eq!(got.log_scales, want.log_scales);
    assert_eq!(got.opacity_logits, want.opacity_logits);
    assert_eq!(got.means, want.means);
}
