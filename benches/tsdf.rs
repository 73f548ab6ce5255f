//! `tsdf-fuse` benchmark at DTU scale, one process.
//!
//! The scene, generated here in DTU's normalised frame (object inside the
//! unit sphere): a bumpy sphere r(θ, φ) = 0.45·(1 + 0.08·sin 5θ·sin 4φ)
//! (≈ 200k faces) standing on a 1.6 × 1.6 table top at y = 0.4513 (off both Open3D grids: a plane through a layer of
//! voxel centres makes marching cubes emit slivers there), seen by 49
//! cameras on a 7 × 7 grid of azimuths (±45°) and elevations (15°–60°) at
//! distance 2.6 looking at the origin, 800 × 600 pixels, f = 1446 (DTU at
//! `-r 2`). Depth maps are the exact z-buffer of that mesh; colours are a
//! fixed pattern.
//!
//! Timed: integrating the 49 maps and extracting the mesh with the DTU
//! settings (voxel 0.004, sdf_trunc 0.016, depth_trunc 3.0), as
//! `tsdf-fuse --dtu` does, without the cluster filter; the depth maps are
//! made before the clock starts. Reported: wall time, peak RSS, blocks,
//! vertices, faces.
//!
//! `cargo bench --bench tsdf -- --write DIR` also writes the cameras
//! (cameras.json) and the maps (NAME_depth.npy, NAME.png) to DIR, the input
//! of `scripts/compare/tsdf_open3d.py DIR`, which measures Open3D on them.
//!
//! `cargo bench --bench tsdf -- unbounded [RES]`: the unbounded variant at
//! real scale instead: the same object inside a 16 × 6 × 16 room (walls,
//! floor and ceiling), 200 views of 1152 × 864 (1 MP) on two rings around
//! the object looking at it, `--mesh-res` RES (default 1024, 2DGS's), box
//! R = 1.9; wall time and peak RSS.
//! Threads: rayon's default (all cores); `RAYON_NUM_THREADS=1` for one.

mod common;
use common::peak_mb;
use std::f64::consts::PI;
use std::time::Instant;

use glam::{DMat3, DVec3};
use splatkit::geom::meshing::tsdf::{Frame, TsdfParams, TsdfVolume, extract_mesh};
use splatkit::model::Camera;
use splatkit_render::mesh as zbuffer;

/// The bumpy sphere on its table, as one triangle mesh.
fn scene() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let (n, m) = (224usize, 448usize);
    let r = |th: f64, ph: f64| 0.45 * (1.0 + 0.08 * (5.0 * th).sin() * (4.0 * ph).sin());
    let mut v: Vec<[f32; 3]> = Vec::new();
    let mut f: Vec<[u32; 3]> = Vec::new();
    for i in 0..=n {
        let th = PI * i as f64 / n as f64;
        for j in 0..m {
            let ph = 2.0 * PI * j as f64 / m as f64;
            let rr = r(th, ph);
            v.push([
                (rr * th.sin() * ph.cos()) as f32,
                (rr * th.cos()) as f32,
                (rr * th.sin() * ph.sin()) as f32,
            ]);
        }
    }
    let id = |i: usize, j: usize| (i * m + j % m) as u32;
    for i in 0..n {
        for j in 0..m {
            f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    // table top (y down in the camera frame of views above it: y = +0.4513 is below)
    let b = v.len() as u32;
    for [x, z] in [[-0.8f32, -0.8], [0.8, -0.8], [0.8, 0.8], [-0.8, 0.8]] {
        v.push([x, 0.4513, z]);
    }
    f.push([b, b + 1, b + 2]);
    f.push([b, b + 2, b + 3]);
    (v, f)
}

fn cameras() -> Vec<Camera> {
    let mut out = Vec::new();
    for a in 0..7 {
        for e in 0..7 {
            let az = (-45.0 + 15.0 * a as f64).to_radians();
            let el = (15.0 + 7.5 * e as f64).to_radians();
            // above the table: −y is up
            let pos = DVec3::new(el.cos() * az.sin(), -el.sin(), -el.cos() * az.cos()) * 2.6;
            let z = (-pos).normalize();
            let x = DVec3::new(0.0, -1.0, 0.0).cross(z).normalize();
            let y = z.cross(x);
            let (r, t) = Camera::pose_from_c2w(DMat3::from_cols(x, y, z), pos);
            out.push(Camera::pinhole(
                format!("{:03}.png", out.len()),
                800,
                600,
                1446.0,
                1446.0,
                400.0,
                300.0,
                r,
                t,
            ));
        }
    }
    out
}

/// The object inside a room: 16 × 6 × 16 (floor at y = 0.45, ceiling 6
/// above it), faces two triangles each.
fn room_scene() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let (mut v, mut f) = scene();
    let (x0, x1, y0, y1, z0, z1) = (-8.0f32, 8.0, -5.55, 0.45, -8.0, 8.0);
    let quads = [
        [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0]],
        [[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]],
        [[x0, y0, z0], [x0, y0, z1], [x0, y1, z1], [x0, y1, z0]],
        [[x1, y0, z0], [x1, y0, z1], [x1, y1, z1], [x1, y1, z0]],
        [[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]],
        [[x0, y1, z0], [x1, y1, z0], [x1, y1, z1], [x0, y1, z1]],
    ];
    for q in quads {
        let b = v.len() as u32;
        v.extend(q);
        f.push([b, b + 1, b + 2]);
        f.push([b, b + 2, b + 3]);
    }
    (v, f)
}

/// 200 cameras on two rings (radius 2.2 and 3.4, heights −0.6 and −1.4)
/// looking at the origin, 1152 × 864.
fn ring_cameras() -> Vec<Camera> {
    let mut out = Vec::new();
    for (ring, (rad, y)) in [(2.2f64, -0.6f64), (3.4, -1.4)].iter().enumerate() {
        for k in 0..100 {
            let a = 2.0 * PI * (k as f64 + 0.5 * ring as f64) / 100.0;
            let pos = DVec3::new(rad * a.cos(), *y, rad * a.sin());
            let z = (-pos).normalize();
            let x = DVec3::new(0.0, -1.0, 0.0).cross(z).normalize();
            let yv = z.cross(x);
            let (r, t) = Camera::pose_from_c2w(DMat3::from_cols(x, yv, z), pos);
            out.push(Camera::pinhole(
                format!("u{:03}.png", out.len()),
                1152,
                864,
                900.0,
                900.0,
                576.0,
                432.0,
                r,
                t,
            ));
        }
    }
    out
}

fn unbounded(res: usize) {
    use splatkit::geom::meshing::tsdf::{
        UnboundedParams, UnboundedView, camera_sphere, fuse_unbounded,
    };
    let (v, f) = room_scene();
    let cams = ring_cameras();
    let t = Instant::now();
    let maps: Vec<(Vec<f32>, Vec<[u8; 3]>)> = cams
        .iter()
        .map(|c| {
            let z = zbuffer::render(&v, &f, c, 0.2);
            let rgb = z
                .face
                .iter()
                .map(|&fc| {
                    if fc.is_multiple_of(2) {
                        [200, 120, 40]
                    } else {
                        [40, 90, 200]
                    }
                })
                .collect();
            (z.depth, rgb)
        })
        .collect();
    println!(
        "unbounded scene: {} faces, {} views 1152x864, depth maps in {:.2} s",
        f.len(),
        cams.len(),
        t.elapsed().as_secs_f64()
    );
    let base = peak_mb();
    let s = camera_sphere(&cams).expect("cameras");
    let views: Vec<UnboundedView> = cams
        .iter()
        .zip(&maps)
        .map(|(c, (d, rgb))| UnboundedView {
            camera: c,
            depth: d,
            rgb: Some(rgb),
        })
        .collect();
    let t = Instant::now();
    let mesh = fuse_unbounded(
        &views,
        &UnboundedParams {
            center: s.center,
            radius: s.radius,
            resolution: res,
            bound: 1.9,
            max_range: 32.0,
        },
    )
    .expect("fuse");
    println!(
        "tsdf unbounded: resolution {res}, {:.2} s, {} vertices, {} faces, peak RSS {:.0} MB \
         (depth maps alone {:.0} MB), {} threads",
        t.elapsed().as_secs_f64(),
        mesh.vertices.len(),
        mesh.faces.len(),
        peak_mb(),
        base,
        rayon::current_num_threads()
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if let Some(i) = args.iter().position(|a| a == "unbounded") {
        let res = args
            .get(i + 1)
            .and_then(|r| r.parse().ok())
            .unwrap_or(1024usize);
        unbounded(res);
        return;
    }
    let write = args
        .iter()
        .position(|a| a == "--write")
        .and_then(|i| args.get(i + 1))
        .map(std::path::PathBuf::from);
    let (v, f) = scene();
    let cams = cameras();
    let t = Instant::now();
    let maps: Vec<(Vec<f32>, Vec<[u8; 3]>)> = cams
        .iter()
        .map(|c| {
            let z = zbuffer::render(&v, &f, c, 0.2);
            let rgb = (0..z.depth.len())
                .map(|i| {
                    let (x, y) = (i % 800, i / 800);
                    [
                        (x % 256) as u8,
                        (y % 256) as u8,
                        if z.face[i].is_multiple_of(2) { 200 } else { 60 },
                    ]
                })
                .collect();
            (z.depth, rgb)
        })
        .collect();
    println!(
        "scene: {} faces, {} views 800x600, depth maps in {:.2} s",
        f.len(),
        cams.len(),
        t.elapsed().as_secs_f64()
    );
    if let Some(dir) = &write {
        std::fs::create_dir_all(dir).expect("output folder");
        splatkit::io::cameras::write_gs_json(&dir.join("cameras.json"), &cams).expect("cameras");
        for (c, (d, rgb)) in cams.iter().zip(&maps) {
            let stem = c.name.trim_end_matches(".png");
            std::fs::write(
                dir.join(format!("{stem}_depth.npy")),
                splatkit::io::cameras::npz::encode_npy_f32(&[600, 800], d),
            )
            .expect("depth");
            let flat: Vec<u8> = rgb.iter().flatten().copied().collect();
            let mut file = std::fs::File::create(dir.join(format!("{stem}.png"))).expect("png");
            splatkit::io::image::write_png8(&mut file, stem, 800, 600, 3, &flat).expect("png");
        }
        println!("wrote {}", dir.display());
    }
    let base = peak_mb();
    let t = Instant::now();
    let mut vol = TsdfVolume::new(TsdfParams::new(0.004, 0.016, 3.0), true).expect("params");
    let frames: Vec<Frame> = cams
        .iter()
        .zip(&maps)
        .map(|(c, (d, rgb))| Frame {
            camera: c,
            depth: d,
            color: Some(rgb),
        })
        .collect();
    for batch in frames.chunks(splatkit::geom::meshing::tsdf::BATCH) {
        vol.integrate_batch(batch).expect("integrate");
    }
    let ti = t.elapsed().as_secs_f64();
    let blocks = vol.len();
    let mesh = extract_mesh(&vol);
    let total = t.elapsed().as_secs_f64();
    println!(
        "tsdf dtu: integrate {ti:.2} s + extract {:.2} s = {total:.2} s, {} blocks ({:.0} MB), \
         {} vertices, {} faces, peak RSS {:.0} MB (depth maps alone {:.0} MB), {} threads",
        total - ti,
        blocks,
        vol.memory_bytes() as f64 / 1e6,
        mesh.vertices.len(),
        mesh.faces.len(),
        peak_mb(),
        base,
        rayon::current_num_threads()
    );
}
