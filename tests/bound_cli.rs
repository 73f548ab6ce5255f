//! `bind-gaussians` and `refine` from the command line: the bound PLY's
//! round trip and rendering, rebinding, resume, and bad input.

mod common;

use std::path::Path;

use common::{fails, run, succeeds};
use splatkit::geom::binding::{materialize, to_raster};
use splatkit::io::any::{load_bound, save_mesh};
use splatkit::io::cameras::write_gs_json;
use splatkit::io::detect::FileFormat;
use splatkit::io::image::write_png8;
use splatkit::model::Camera;
use splatkit::testing::{cameras_around, uv_sphere};
use splatkit_render::gaussian::{RasterSettings, render};

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// A coloured sphere mesh written as PLY.
fn sphere(dir: &Path) -> std::path::PathBuf {
    let mut m = uv_sphere(8, 1.0);
    m.vertex_colors = Some(
        m.vertices
            .iter()
            .map(|v| {
                [0, 1, 2, 3].map(|k| {
                    if k == 3 {
                        255
                    } else {
                        (127.0 * (v[k] + 1.0)) as u8
                    }
                })
            })
            .collect(),
    );
    let path = dir.join("sphere.ply");
    save_mesh(&path, &m, FileFormat::Ply, &Default::default()).unwrap();
    path
}

/// Photos of the sphere: its own bound Gaussians rendered from 10 cameras
/// (32×32), written as PNGs with a cameras.json.
fn photos(dir: &Path, bound: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let (b, _) = load_bound(bound, "test").unwrap();
    let cams = cameras_around(10, 3.0, 32, 32.0);
    let imgs = dir.join("images");
    std::fs::create_dir_all(&imgs).unwrap();
    let g = to_raster(&b, 0);
    for c in &cams {
        let out = render(&g, c, &RasterSettings::default());
        let data: Vec<u8> = out
            .rgb
            .iter()
            .flat_map(|px| px.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
            .collect();
        let mut f = std::fs::File::create(imgs.join(format!("{}.png", c.name))).unwrap();
        write_png8(&mut f, &c.name, 32, 32, 3, &data).unwrap();
    }
    let cj = dir.join("cameras.json");
    write_gs_json(&cj, &cams).unwrap();
    (imgs, cj)
}

/// The written PLY round-trips bit for bit (bind → load → write again gives
/// the same bytes) and renders exactly like the in-memory model.
#[test]
fn bound_ply_round_trips_and_renders_like_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let m = sphere(dir.path());
    let b1 = dir.path().join("b1.ply");
    succeeds(&run(
        "bind-gaussians",
        &[p(&m), "--per-triangle", "4", "-o", p(&b1), "-q"],
        None,
    ));
    let (b, g) = load_bound(&b1, "test").unwrap();
    assert_eq!(b.per_face, 4);
    // the file's standard values are the materialised model
    let mat = materialize(&b);
    assert_eq!(g.means, mat.means);
    assert_eq!(g.rotations, mat.rotations);
    assert_eq!(g.log_scales, mat.log_scales);
    // rebinding to the unchanged mesh rewrites identical bytes
    let b2 = dir.path().join("b2.ply");
    succeeds(&run(
        "bind-gaussians",
        &[p(&b1), "--rebind", p(&m), "-o", p(&b2), "-q"],
        None,
    ));
    assert_eq!(std::fs::read(&b1).unwrap(), std::fs::read(&b2).unwrap());
    // `render` of the file equals a render of the in-memory model
    let cam: Camera = cameras_around(1, 3.0, 48, 48.0).remove(0);
    let mut plain = g.clone();
    plain.extras = Default::default();
    let from_file = render(&plain.to_raster(), &cam, &RasterSettings::default());
    let in_memory = render(&to_raster(&b, 3), &cam, &RasterSettings::default());
    assert_eq!(from_file.rgb, in_memory.rgb);
    assert!(from_file.alpha.iter().any(|&a| a > 0.5));
    // 3DGS readers: `vertex` is the first element (graphdeco's load_ply reads
    // elements[0]) and no property is a list (the PlayCanvas engine's reader,
    // which SuperSplat uses, throws on `property list`)
    let bytes = std::fs::read(&b1).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap();
    let header = String::from_utf8_lossy(&bytes[..end]);
    let elements: Vec<&str> = header
        .lines()
        .filter(|l| l.starts_with("element "))
        .collect();
    assert!(elements[0].starts_with("element vertex "), "{header}");
    assert!(!header.contains("property list"), "{header}");
    // graphdeco sorts every property starting with `rot`, `scale_` or
    // `f_rest_` by its numeric suffix: only the standard ones may match
    for line in header.lines().filter(|l| l.starts_with("property ")) {
        let name = line.split_whitespace().last().unwrap();
        for prefix in ["rot", "scale_", "f_rest_", "f_dc_"] {
            if let Some(rest) = name.strip_prefix(prefix) {
                let suffix = rest.rsplit('_').next().unwrap();
                assert!(suffix.parse::<u32>().is_ok(), "{name} would break load_ply");
            }
        }
    }
    // info says it is bound
    let out = run("info", &[p(&b1)], None);
    succeeds(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("bound to:") && text.contains("4 Gaussian(s) per face"),
        "{text}"
    );
}

/// Bad input: counts outside the tables, a rebind mesh with other faces,
/// plain Gaussians where a bound file is needed, an inconsistent binding —
/// each a clear error, nothing written.
#[test]
fn bad_binding_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = sphere(dir.path());
    let out = dir.path().join("out.ply");
    fails(
        &run(
            "bind-gaussians",
            &[p(&m), "--per-triangle", "5", "-o", p(&out)],
            None,
        ),
        2,
        &["--per-triangle 5", "1, 3, 4 and 6"],
    );
    let b = dir.path().join("b.ply");
    succeeds(&run("bind-gaussians", &[p(&m), "-o", p(&b), "-q"], None));
    // a mesh with other faces
    let mut other = uv_sphere(6, 1.0);
    other.vertex_colors = None;
    let om = dir.path().join("other.ply");
    save_mesh(&om, &other, FileFormat::Ply, &Default::default()).unwrap();
    fails(
        &run(
            "bind-gaussians",
            &[p(&b), "--rebind", p(&om), "-o", p(&out)],
            None,
        ),
        1,
        &["other.ply", "faces", "bound to 224"],
    );
    // plain Gaussians (the bound file without its binding)
    let (_, g) = load_bound(&b, "test").unwrap();
    let mut plain = g.clone();
    plain.extras = Default::default();
    let pg = dir.path().join("plain.ply");
    splatkit::io::any::save_gaussians(&pg, &plain).unwrap();
    fails(
        &run(
            "bind-gaussians",
            &[p(&pg), "--rebind", p(&m), "-o", p(&out)],
            None,
        ),
        1,
        &["plain.ply", "face_index is missing"],
    );
    // an inconsistent binding: face indices out of face-major order
    let mut bad = g.clone();
    for prop in &mut bad.extras.item {
        if prop.name == "face_index"
            && let splatkit::model::Column::Scalar(splatkit::model::ScalarData::I32(v)) =
                &mut prop.data
        {
            v.swap(0, 5);
        }
    }
    let bp = dir.path().join("bad.ply");
    splatkit::io::any::save_gaussians(&bp, &bad).unwrap();
    fails(
        &run(
            "bind-gaussians",
            &[p(&bp), "--rebind", p(&m), "-o", p(&out)],
            None,
        ),
        1,
        &["bad.ply", "Gaussian 0 has face_index 5"],
    );
    assert!(!out.exists(), "nothing written");
}

/// `refine` for 6 iterations equals 3 iterations + `--resume` for 3 more
/// (the refined PLY and the optimiser state byte for byte); metrics.json
/// holds the evaluations.
#[test]
fn refine_resume_equals_an_uninterrupted_run() {
    let dir = tempfile::tempdir().unwrap();
    let m = sphere(dir.path());
    let b = dir.path().join("b.ply");
    succeeds(&run("bind-gaussians", &[p(&m), "-o", p(&b), "-q"], None));
    let (imgs, cj) = photos(dir.path(), &b);
    let common = [
        "--images",
        p(&imgs),
        "--cameras",
        p(&cj),
        "--eval-every",
        "2",
        "-q",
    ];
    let whole = dir.path().join("whole");
    let mut a = vec![p(&b), "--iterations", "6", "-o", p(&whole)];
    a.extend(common);
    succeeds(&run("refine", &a, None));
    let half = dir.path().join("half");
    let mut a = vec![p(&b), "--iterations", "3", "-o", p(&half)];
    a.extend(common);
    succeeds(&run("refine", &a, None));
    let mut a = vec![
        p(&b),
        "--iterations",
        "6",
        "--resume",
        p(&half),
        "-o",
        p(&half),
    ];
    a.extend(common);
    succeeds(&run("refine", &a, None));
    for f in [
        "refined_bound.ply",
        "checkpoint/optimizer.bin",
        "refined_mesh.ply",
    ] {
        assert_eq!(
            std::fs::read(whole.join(f)).unwrap(),
            std::fs::read(half.join(f)).unwrap(),
            "{f}"
        );
    }
    let metrics: serde_json::Value =
        serde_json::from_slice(&std::fs::read(whole.join("metrics.json")).unwrap()).unwrap();
    let evals = metrics["evals"].as_array().unwrap();
    let its: Vec<u64> = evals
        .iter()
        .map(|e| e["iteration"].as_u64().unwrap())
        .collect();
    assert_eq!(its, vec![0, 2, 4, 6]);
    // resuming with other settings is refused
    let mut a = vec![
        p(&b),
        "--iterations",
        "8",
        "--resume",
        p(&half),
        "-o",
        p(&half),
    ];
    a.extend(common);
    a.push("--white-background");
    fails(&run("refine", &a, None), 1, &["other settings"]);
}

/// Missing or mis-sized photos are errors naming the camera or the file.
#[test]
fn refine_names_missing_and_mis_sized_images() {
    let dir = tempfile::tempdir().unwrap();
    let m = sphere(dir.path());
    let b = dir.path().join("b.ply");
    succeeds(&run("bind-gaussians", &[p(&m), "-o", p(&b), "-q"], None));
    let (imgs, cj) = photos(dir.path(), &b);
    let out = dir.path().join("out");
    let refine = |input: &Path| {
        run(
            "refine",
            &[
                p(input),
                "--images",
                p(&imgs),
                "--cameras",
                p(&cj),
                "-o",
                p(&out),
            ],
            None,
        )
    };
    std::fs::remove_file(imgs.join("v03.png")).unwrap();
    fails(&refine(&b), 1, &["camera \"v03\"", "no image"]);
    let mut f = std::fs::File::create(imgs.join("v03.png")).unwrap();
    write_png8(&mut f, "v03", 20, 16, 3, &[100u8; 20 * 16 * 3]).unwrap();
    drop(f);
    fails(&refine(&b), 1, &["v03.png", "20x16", "32x32"]);
    // a plain mesh is not a bound file
    fails(&refine(&m), 1, &["sphere.ply"]);
    assert!(!out.exists(), "no output folder left behind");
}
