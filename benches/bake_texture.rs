//! `bake-texture` benchmark at SuGaR scale, one process.
//!
//! The scene, generated here: a torus (R = 1, r = 0.4) meshed on a 500 × 200
//! grid (200,000 faces) with 5 flat Gaussians per face, face-major as SuGaR
//! binds them (1,000,000 Gaussians, SH degree 0, colour varying with the
//! torus angles), seen by 20 cameras at 800 × 600 (f = 700) on a ring of
//! radius 3.2 at 30° elevation looking at the origin. The atlas is SuGaR
//! V2's (squares of 8 texels): ⌊√100,001 + 1⌋ = 317 squares, 2,536² texels.
//!
//! Timed: `geom::mesh_ops::texture_bake::bake_texture` (20 mesh z-buffers, 20 DC-only
//! Gaussian renders, the accumulation and the fill), then writing the OBJ,
//! MTL and PNG through `io::any::save_mesh` (what `bake-texture` does after
//! loading its inputs). Reported: each time, peak RSS, seen-face fraction.
//!
//! `cargo bench --bench bake_texture -- --write DIR` keeps the written
//! textured OBJ in DIR (`DIR/torus.obj`, `.mtl`, `.png`), the input of
//! `scripts/compare/textured_obj.py DIR/torus.obj`.
//! Threads: rayon's default (all cores); `RAYON_NUM_THREADS=1` for one.

mod common;
use common::peak_mb;
use std::time::Instant;

use glam::{DMat3, DQuat, DVec3};
use splatkit::geom::mesh_ops::texture_bake::{BakeParams, bake_texture};
use splatkit::geom::scenes::synthetic::Torus;
use splatkit::io::any::{MeshWriteOptions, save_mesh};
use splatkit::io::detect::FileFormat;
use splatkit::model::gaussians::logit;
use splatkit::model::{Camera, Gaussians, Mesh};
use splatkit_render::sh::rgb_to_sh;

const PER_FACE: usize = 5;

fn scene() -> (Mesh, Gaussians) {
    let torus = Torus {
        major: 1.0,
        minor: 0.4,
    };
    let mesh = torus.mesh(500, 200);
    let mut g = Gaussians::default();
    let bary = [
        [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
        [0.6, 0.2, 0.2],
        [0.2, 0.6, 0.2],
        [0.2, 0.2, 0.6],
        [0.45, 0.45, 0.1],
    ];
    for f in &mesh.faces {
        let v = f.map(|i| DVec3::from(mesh.vertices[i as usize].map(f64::from)));
        let e1 = v[1] - v[0];
        let n = e1.cross(v[2] - v[0]);
        let s = 0.35 * (0.5 * n.length()).sqrt();
        let (n, t) = (n.normalize(), e1.normalize());
        let q = DQuat::from_mat3(&DMat3::from_cols(t, n.cross(t), n)).normalize();
        for w in &bary[..PER_FACE] {
            let p = v[0] * w[0] + v[1] * w[1] + v[2] * w[2];
            let (u, a) = (p.z.atan2(p.x), p.y.atan2(p.x.hypot(p.z) - 1.0));
            let rgb = [
                0.5 + 0.4 * (3.0 * u).cos(),
                0.5 + 0.4 * a.sin(),
                0.5 - 0.3 * (2.0 * u + a).sin(),
            ];
            g.means.push(p.as_vec3().to_array());
            g.log_scales
                .push([s.ln() as f32, s.ln() as f32, (1e-3f32).ln()]);
            g.rotations
                .push([q.w as f32, q.x as f32, q.y as f32, q.z as f32]);
            g.opacity_logits.push(logit(0.95));
            g.sh_dc.push(rgb.map(|c| rgb_to_sh(c as f32)));
        }
    }
    (mesh, g)
}

fn cameras() -> Vec<Camera> {
    (0..20)
        .map(|k| {
            let a = k as f64 / 20.0 * std::f64::consts::TAU;
            let el = 30f64.to_radians();
            let pos = DVec3::new(a.cos() * el.cos(), -el.sin(), a.sin() * el.cos()) * 3.2;
            let z = (-pos).normalize();
            let x = DVec3::Y.cross(z).normalize();
            let y = z.cross(x);
            let (r, t) = Camera::pose_from_c2w(DMat3::from_cols(x, y, z), pos);
            Camera::pinhole(
                format!("v{k:02}"),
                800,
                600,
                700.0,
                700.0,
                400.0,
                300.0,
                r,
                t,
            )
        })
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let keep = args
        .iter()
        .position(|a| a == "--write")
        .and_then(|i| args.get(i + 1))
        .map(std::path::PathBuf::from);
    let (mesh, g) = scene();
    let cams = cameras();
    println!(
        "bake-texture bench: {} faces, {} Gaussians, {} views of 800x600, {} threads",
        mesh.faces.len(),
        g.len(),
        cams.len(),
        rayon::current_num_threads()
    );
    let t0 = Instant::now();
    let (textured, stats) =
        bake_texture(&mesh, &g, &cams, &BakeParams::default(), |_| {}).expect("bake");
    let bake = t0.elapsed().as_secs_f64();
    let tmp = tempfile::tempdir().unwrap();
    let dir = keep.clone().unwrap_or_else(|| tmp.path().to_path_buf());
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("torus.obj");
    let t1 = Instant::now();
    save_mesh(
        &out,
        &textured,
        FileFormat::Obj,
        &MeshWriteOptions::default(),
    )
    .expect("write");
    let write = t1.elapsed().as_secs_f64();
    println!(
        "bake {bake:.2} s ({:.2} s per view), write OBJ+MTL+PNG {write:.2} s, total {:.2} s; \
         texture {}x{}, seen faces {:.1} %, peak RSS {:.0} MB",
        bake / cams.len() as f64,
        bake + write,
        stats.texture_size,
        stats.texture_size,
        100.0 * stats.seen_fraction(),
        peak_mb()
    );
    if keep.is_some() {
        println!("wrote {}", out.display());
    }
}
