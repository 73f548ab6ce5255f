//! `bake-texture`: a generated sphere whose Gaussians' colours vary smoothly,
//! baked from 12 cameras all around and rendered back unlit from the same
//! views (against the Gaussians' own DC renders); faces no camera sees take
//! their Gaussians' colour; an atlas above `--max-texture` is refused before
//! any work and leaves no file; the command's files, report and errors.

mod common;

use std::path::Path;

use glam::{DMat3, DQuat, DVec3};
use splatkit::geom::mesh_ops::texture_bake::{BakeParams, bake_texture};
use splatkit::io::ply::{Format, gaussians::write_gaussians, mesh::write_mesh};
use splatkit::model::gaussians::logit;
use splatkit::model::{Camera, Gaussians, Mesh};
use splatkit::ops::render::{Shading, shade_mesh};
use splatkit::testing::{cameras_around, uv_sphere};
use splatkit_render::gaussian::{self, RasterSettings};
use splatkit_render::loss::psnr;
use splatkit_render::mesh as zbuffer;
use splatkit_render::sh::rgb_to_sh;

/// The colour of the sphere at unit direction `p`.
fn colour_at(p: DVec3) -> [f32; 3] {
    [
        (0.5 + 0.35 * p.x) as f32,
        (0.5 + 0.35 * p.y) as f32,
        (0.5 + 0.3 * p.z * p.x.signum()) as f32,
    ]
}

/// A UV sphere of radius 1 and `per_face` flat Gaussians per face,
/// face-major, each coloured by [`colour_at`] its centre, opacity 0.99.
fn scene(rings: usize, per_face: usize) -> (Mesh, Gaussians) {
    let mesh = uv_sphere(rings, 1.0);
    let mut g = Gaussians::default();
    let bary = [
        [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
        [4.0 / 6.0, 1.0 / 6.0, 1.0 / 6.0],
        [1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0],
        [1.0 / 6.0, 1.0 / 6.0, 4.0 / 6.0],
    ];
    for f in &mesh.faces {
        let v = f.map(|i| DVec3::from(mesh.vertices[i as usize].map(f64::from)));
        let e1 = v[1] - v[0];
        let n = e1.cross(v[2] - v[0]);
        let size = (0.5 * n.length()).sqrt();
        let (n, t) = (n.normalize(), e1.normalize());
        let rot = DMat3::from_cols(t, n.cross(t), n);
        let q = DQuat::from_mat3(&rot).normalize();
        for w in bary.iter().take(per_face) {
            let p = v[0] * w[0] + v[1] * w[1] + v[2] * w[2];
            g.means.push(p.as_vec3().to_array());
            let s = 0.45 * size;
            g.log_scales
                .push([s.ln() as f32, s.ln() as f32, (1e-3f32).ln()]);
            g.rotations
                .push([q.w as f32, q.x as f32, q.y as f32, q.z as f32]);
            g.opacity_logits.push(logit(0.99));
            g.sh_dc.push(colour_at(p.normalize()).map(rgb_to_sh));
        }
    }
    (mesh, g)
}

fn cameras() -> Vec<Camera> {
    cameras_around(12, 3.0, 128, 110.0)
}

/// Per view: the Gaussians' DC render, and the textured mesh rendered
/// unlit; PSNR over the pixels the mesh covers (the silhouettes of a
/// polygon and of Gaussian discs differ by design, so they are left out).
fn round_trip_psnr(textured: &Mesh, g: &Gaussians, cams: &[Camera]) -> f64 {
    let g3 = g.to_raster().dc_only();
    let s = RasterSettings::default();
    let mut sum = 0.0;
    for cam in cams {
        let gs = gaussian::render(&g3, cam, &s);
        let z = zbuffer::render(&textured.vertices, &textured.faces, cam, s.near);
        let m = shade_mesh(textured, &z, [0.0; 3], Shading::None);
        let (a, b): (Vec<[f32; 3]>, Vec<[f32; 3]>) = (0..m.rgb.len())
            .filter(|&i| m.alpha[i] > 0.0)
            .map(|i| (m.rgb[i], gs.rgb[i]))
            .unzip();
        sum += psnr(&a, &b);
    }
    sum / cams.len() as f64
}

/// Baked from 12 views all around, written, read back and rendered unlit
/// from the same views: within 30 dB of the Gaussians' DC renders on the
/// mesh's pixels (measured 35.2 dB). The tolerance covers what the method
/// cannot reproduce: a face's texture holds ~10 distinct texels (a
/// triangle of 5-texel legs, its hypotenuse row at the face's mean), so
/// colour variation inside a face is stair-stepped, and the texels are
/// 8-bit. Every face is seen.
#[test]
fn baked_texture_renders_back_like_the_gaussians() {
    let (mesh, g) = scene(24, 4);
    let cams = cameras();
    let (textured, stats) = bake_texture(&mesh, &g, &cams, &BakeParams::default(), |_| {}).unwrap();
    assert_eq!(stats.faces, mesh.faces.len());
    assert_eq!(stats.views, 12);
    assert_eq!(stats.seen_faces, stats.faces);
    // the files, read back through the common loader
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.obj");
    splatkit::io::any::save(
        &out,
        &splatkit::model::Scene::Mesh(textured.clone()),
        splatkit::io::detect::FileFormat::Obj,
    )
    .unwrap();
    let back = splatkit::io::any::load_mesh(&out, "test").unwrap();
    assert_eq!(back.texture, {
        let mut t = textured.texture.clone().unwrap();
        t.name = "t.png".into();
        Some(t)
    });
    let p = round_trip_psnr(&back, &g, &cams);
    eprintln!("bake round trip: {p:.2} dB on the mesh's pixels over 12 views");
    assert!(p >= 30.0, "PSNR {p:.2} dB");
}

/// One camera sees one side: faces facing away were never seen and carry
/// the mean DC colour of their own Gaussians in every texel.
#[test]
fn faces_never_seen_take_their_gaussians_colour() {
    let (mesh, g) = scene(8, 2);
    let cams = &cameras()[..1];
    let (textured, stats) = bake_texture(&mesh, &g, cams, &BakeParams::default(), |_| {}).unwrap();
    assert!(stats.seen_faces > 0 && stats.seen_faces < stats.faces / 2 + 20);
    let atlas = splatkit::geom::mesh_ops::texture_bake::Atlas::new(mesh.faces.len(), 8).unwrap();
    let tex = textured.texture.as_ref().unwrap();
    let centre = cams[0].center();
    let mut checked = 0;
    for (f, face) in mesh.faces.iter().enumerate() {
        let c: DVec3 = face
            .iter()
            .map(|&i| DVec3::from(mesh.vertices[i as usize].map(f64::from)))
            .sum::<DVec3>()
            / 3.0;
        // the far side: the face's centre faces away from the camera
        if c.dot(centre - c) > -0.5 {
            continue;
        }
        let want: [f32; 3] = std::array::from_fn(|k| {
            (0..2)
                .map(|j| splatkit_render::sh::sh_to_rgb(g.sh_dc[2 * f + j][k]))
                .sum::<f32>()
                / 2.0
        });
        let want8 = want.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8);
        for t in atlas.texels(f) {
            assert_eq!(tex.pixels[t], want8, "face {f}");
        }
        checked += 1;
    }
    assert!(checked > 10, "{checked}");
}

fn write_inputs(dir: &Path, rings: usize, per_face: usize) -> (String, String, String) {
    let (mesh, g) = scene(rings, per_face);
    let mp = dir.join("mesh.ply");
    let mut b = Vec::new();
    write_mesh(&mut b, &mesh, Format::BinaryLittleEndian).unwrap();
    std::fs::write(&mp, b).unwrap();
    let gp = dir.join("gaussians.ply");
    let mut b = Vec::new();
    write_gaussians(&mut b, &g, Format::BinaryLittleEndian).unwrap();
    std::fs::write(&gp, b).unwrap();
    let cp = dir.join("cameras.json");
    splatkit::io::cameras::write_gs_json(&cp, &cameras()).unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    (s(&mp), s(&gp), s(&cp))
}

fn names_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// The command end to end: three files, a report, and `render --shading
/// none --compare` against the Gaussians' own renders over whole images:
/// measured 22.8 dB, asserted ≥ 20. Lower than on the mesh's pixels alone
/// (35.2 dB above) because the silhouettes differ by design: the Gaussian
/// discs reach past the polygon's outline by up to a few pixels, where one
/// image has the sphere and the other black.
#[test]
fn cli_writes_obj_mtl_png_and_renders_back() {
    let dir = tempfile::tempdir().unwrap();
    let (mp, gp, cp) = write_inputs(dir.path(), 24, 4);
    let out = dir.path().join("baked").join("t.obj");
    std::fs::create_dir(out.parent().unwrap()).unwrap();
    let o = common::run(
        "bake-texture",
        &[
            &mp,
            &gp,
            "--cameras",
            &cp,
            "-o",
            out.to_str().unwrap(),
            "--json",
            "-q",
            "-j",
            "2",
        ],
        None,
    );
    common::succeeds(&o);
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["faces"], 2208);
    assert_eq!(report["views"], 12);
    // ⌊√(1104 + 1) + 1⌋ = 34 squares of 8 texels
    assert_eq!(report["texture_size"], 8 * 34);
    assert_eq!(report["seen_face_fraction"], 1.0);
    assert_eq!(names_in(out.parent().unwrap()), ["t.mtl", "t.obj", "t.png"]);
    let m = splatkit::io::any::load_mesh(&out, "test").unwrap();
    assert_eq!(m.texture.as_ref().map(|t| t.width), Some(272));
    // the Gaussians' renders, then the baked mesh compared with them
    let gs = dir.path().join("gs");
    common::succeeds(&common::run(
        "render",
        &[
            &gp,
            "--cameras",
            &cp,
            "-o",
            gs.to_str().unwrap(),
            "--outputs",
            "rgb",
            "-q",
        ],
        None,
    ));
    let views = dir.path().join("views");
    let o = common::run(
        "render",
        &[
            out.to_str().unwrap(),
            "--cameras",
            &cp,
            "-o",
            views.to_str().unwrap(),
            "--outputs",
            "rgb",
            "--shading",
            "none",
            "--compare",
            gs.to_str().unwrap(),
            "--json",
            "-q",
        ],
        None,
    );
    common::succeeds(&o);
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let p = r["mean_psnr"].as_f64().unwrap();
    eprintln!("render --shading none vs Gaussian renders: {p:.2} dB (whole images)");
    assert!(p >= 20.0, "{p}");
    // help with examples
    let h = common::run("bake-texture", &["--help"], None);
    common::succeeds(&h);
    let help = String::from_utf8_lossy(&h.stdout);
    assert!(
        help.contains("Examples:") && help.contains("--max-texture"),
        "{help}"
    );
}

/// Refusals: an atlas above --max-texture (exit 1, naming the size and the
/// flag, no file written, an existing output untouched); Gaussians that
/// cannot be bound; an output that is not an OBJ (usage, exit 2).
#[test]
fn cli_refusals_leave_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let (mp, gp, cp) = write_inputs(dir.path(), 8, 2);
    let out = dir.path().join("t.obj");
    let before = names_in(dir.path());
    let o = common::run(
        "bake-texture",
        &[
            &mp,
            &gp,
            "--cameras",
            &cp,
            "-o",
            out.to_str().unwrap(),
            "--max-texture",
            "64",
        ],
        None,
    );
    // 224 faces: ⌊√113 + 1⌋ = 11 squares of 8 texels
    common::fails(
        &o,
        1,
        &["88x88 texels", "--max-texture 64", "--square-size 8"],
    );
    assert_eq!(names_in(dir.path()), before);
    std::fs::write(&out, "keep").unwrap();
    let (_, g_other, _) = {
        let d2 = dir.path().join("other");
        std::fs::create_dir(&d2).unwrap();
        write_inputs(&d2, 6, 1)
    };
    let o = common::run(
        "bake-texture",
        &[&mp, &g_other, "--cameras", &cp, "-o", out.to_str().unwrap()],
        None,
    );
    common::fails(
        &o,
        1,
        &["120 Gaussians cannot be bound to 224 faces", "face_index"],
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "keep");
    assert!(!dir.path().join("t.png").exists() && !dir.path().join("t.mtl").exists());
    let o = common::run(
        "bake-texture",
        &[
            &mp,
            &gp,
            "--cameras",
            &cp,
            "-o",
            dir.path().join("t.ply").to_str().unwrap(),
        ],
        None,
    );
    common::fails(&o, 2, &["name it NAME.obj"]);
}

/// `info` on the textured OBJ that `bake-texture` writes: texture
/// coordinates, the MTL file, material `material_0` with its `map_Kd` and
/// the PNG, which exists; with the PNG removed, `info` says it is missing.
#[test]
fn info_lists_uvs_material_and_texture_of_the_baked_obj() {
    let dir = tempfile::tempdir().unwrap();
    let (mp, gp, cp) = write_inputs(dir.path(), 8, 1);
    let out = dir.path().join("t.obj");
    common::succeeds(&common::run(
        "bake-texture",
        &[
            &mp,
            &gp,
            "--cameras",
            &cp,
            "-o",
            out.to_str().unwrap(),
            "-q",
        ],
        None,
    ));
    let info = |json: bool| {
        let mut args = vec![out.to_str().unwrap()];
        if json {
            args.push("--json");
        }
        let o = common::run("info", &args, None);
        common::succeeds(&o);
        o.stdout
    };
    let r: serde_json::Value = serde_json::from_slice(&info(true)).unwrap();
    let i = &r[0];
    let attrs: Vec<&str> = i["attributes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a.as_str().unwrap())
        .collect();
    assert!(attrs.contains(&"uvs"), "{attrs:?}");
    let png = dir.path().join("t.png");
    let mtl = dir.path().join("t.mtl");
    assert_eq!(i["material_libraries"][0], mtl.display().to_string());
    let m = &i["materials"][0];
    assert_eq!(m["name"], "material_0");
    assert_eq!(m["used_by"], i["faces"]);
    assert_eq!(m["defined"], true);
    assert_eq!(m["textures"][0]["slot"], "map_Kd");
    assert_eq!(m["textures"][0]["file"], png.display().to_string());
    assert_eq!(i["textures"][0]["file"], png.display().to_string());
    assert_eq!(i["textures"][0]["exists"], true);
    let text = String::from_utf8(info(false)).unwrap();
    assert!(
        text.contains("uvs") && text.contains("material:   material_0") && text.contains("map_Kd"),
        "{text}"
    );
    std::fs::remove_file(&png).unwrap();
    let r: serde_json::Value = serde_json::from_slice(&info(true)).unwrap();
    assert_eq!(r[0]["textures"][0]["exists"], false);
    let text = String::from_utf8(info(false)).unwrap();
    assert!(text.contains("(missing)"), "{text}");
}
