//! Test support: locating the shared real-data sets, and generated shapes
//! with known geometry.
//!
//! Tests that read `../shared/data` call [`shared_data`]; when the folder is
//! absent they print why and skip, unless `SPLATKIT_REQUIRE_SHARED=1`, in
//! which case they fail (CI sets it so real-data tests can never silently skip).

use std::path::PathBuf;

use glam::{DMat3, DVec3};

use splatkit_render::mesh::{NO_FACE, render as zbuffer};

use crate::model::{Camera, Mesh, View};

/// The path of `rel` under `../shared/data` next to the repository, or
/// `None` (after printing a skip notice) when it does not exist.
///
/// # Panics
/// When the path is missing and `SPLATKIT_REQUIRE_SHARED=1` is set.
pub fn shared_data(rel: &str) -> Option<PathBuf> {
    let root = std::env::var_os("SPLATKIT_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data"));
    let p = root.join(rel);
    if p.exists() {
        return Some(p);
    }
    if std::env::var("SPLATKIT_REQUIRE_SHARED").as_deref() == Ok("1") {
        panic!(
            "{} is missing and SPLATKIT_REQUIRE_SHARED=1: the shared data sets must be beside the checkout",
            p.display()
        );
    }
    eprintln!(
        "skipped: {} is absent (shared data not checked out)",
        p.display()
    );
    None
}

/// A torus in the xy plane about the origin: `nu` steps around the ring
/// (radius `big`) × `nv` around the tube (radius `small`), two faces per
/// quad, closed, genus 1.
pub fn torus_mesh(nu: usize, nv: usize, big: f64, small: f64) -> Mesh {
    let mut v = Vec::new();
    for i in 0..nu {
        let u = std::f64::consts::TAU * i as f64 / nu as f64;
        for j in 0..nv {
            let w = std::f64::consts::TAU * j as f64 / nv as f64;
            let r = big + small * w.cos();
            v.push([
                (r * u.cos()) as f32,
                (r * u.sin()) as f32,
                (small * w.sin()) as f32,
            ]);
        }
    }
    let id = |i: usize, j: usize| ((i % nu) * nv + j % nv) as u32;
    let mut f = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    Mesh::new(v, f)
}

/// A UV sphere of radius `r` about the origin with `n` rings (n ≥ 2) and
/// 2n segments: closed, welded poles on ±z, faces counter-clockwise seen
/// from outside.
pub fn uv_sphere(n: usize, r: f64) -> Mesh {
    let mut v = vec![[0.0f32, 0.0, r as f32]];
    for i in 1..n {
        let th = std::f64::consts::PI * i as f64 / n as f64;
        for j in 0..2 * n {
            let ph = std::f64::consts::PI * j as f64 / n as f64;
            v.push([
                (r * th.sin() * ph.cos()) as f32,
                (r * th.sin() * ph.sin()) as f32,
                (r * th.cos()) as f32,
            ]);
        }
    }
    v.push([0.0, 0.0, -r as f32]);
    let m = 2 * n;
    let id = |i: usize, j: usize| (1 + (i - 1) * m + j % m) as u32;
    let south = (v.len() - 1) as u32;
    let mut f = Vec::new();
    for j in 0..m {
        f.push([0, id(1, j), id(1, j + 1)]);
    }
    for i in 1..n - 1 {
        for j in 0..m {
            f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    for j in 0..m {
        f.push([id(n - 1, j), south, id(n - 1, j + 1)]);
    }
    Mesh::new(v, f)
}

/// `n` pinhole cameras named `v00`, `v01`, … at distance `dist` from the
/// origin on a Fibonacci sphere, each looking at the origin (+z forward,
/// OpenCV axes), `size`² pixels, focal `f` pixels, principal point at the
/// image centre.
pub fn cameras_around(n: usize, dist: f64, size: u32, f: f64) -> Vec<Camera> {
    (0..n)
        .map(|k| {
            let y = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let a = k as f64 * 2.399_963_229_728_653;
            let s = (1.0 - y * y).sqrt();
            let pos = DVec3::new(s * a.cos(), y, s * a.sin()) * dist;
            let z = (-pos).normalize();
            let up = if z.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
            let x = up.cross(z).normalize();
            let yv = z.cross(x);
            let (r, t) = Camera::pose_from_c2w(DMat3::from_cols(x, yv, z), pos);
            let half = size as f64 / 2.0;
            Camera::pinhole(format!("v{k:02}"), size, size, f, f, half, half, r, t)
        })
        .collect()
}

/// A smooth colour pattern on the unit sphere (the "texture" of the ground
/// truth), in [0.15, 0.85].
pub fn sphere_texture(p: DVec3) -> [f32; 3] {
    let q = p.normalize();
    [
        0.5 + 0.35 * (2.0 * q.x + 1.0 * q.z).sin(),
        0.5 + 0.35 * (1.5 * q.y - 0.5).cos() * 0.9,
        0.5 + 0.3 * (2.5 * q.z * q.x + q.y).sin(),
    ]
    .map(|v| v as f32)
}

/// The ground truth: a fine sphere mesh rendered with the mesh rasteriser
/// at 4×4 samples per pixel (anti-aliased, as a photo is), each sample
/// coloured by the texture at its hit point (unlit), black background.
pub fn textured_photos(truth: &Mesh, cams: &[Camera]) -> Vec<View> {
    const SS: u32 = 4;
    cams.iter()
        .map(|c| {
            let mut big = c.clone();
            big.width *= SS;
            big.height *= SS;
            big.fx *= SS as f64;
            big.fy *= SS as f64;
            big.cx *= SS as f64;
            big.cy *= SS as f64;
            let z = zbuffer(&truth.vertices, &truth.faces, &big, 0.01);
            let fine: Vec<[f32; 3]> = (0..z.face.len())
                .map(|i| {
                    if z.face[i] == NO_FACE {
                        return [0.0; 3];
                    }
                    let f = truth.faces[z.face[i] as usize];
                    let [u, v] = z.bary[i].map(f64::from);
                    let w = [1.0 - u - v, u, v];
                    let p = (0..3).fold(DVec3::ZERO, |acc, k| {
                        acc + w[k] * DVec3::from_array(truth.vertices[f[k] as usize].map(f64::from))
                    });
                    sphere_texture(p)
                })
                .collect();
            let (w, h, bw) = (c.width as usize, c.height as usize, big.width as usize);
            let s = SS as usize;
            let image = (0..w * h)
                .map(|i| {
                    let (x, y) = (i % w, i / w);
                    let mut acc = [0.0f32; 3];
                    for dy in 0..s {
                        for dx in 0..s {
                            let p = fine[(y * s + dy) * bw + x * s + dx];
                            for k in 0..3 {
                                acc[k] += p[k] / (s * s) as f32;
                            }
                        }
                    }
                    acc
                })
                .collect();
            View {
                camera: c.clone(),
                image,
                mask: None,
                source: c.name.clone(),
                alpha: None,
            }
        })
        .collect()
}

/// `n` seed points on the unit sphere (uniform directions from `seed`),
/// coloured by [`sphere_texture`]: what SfM would give on the generated
/// sphere scene.
pub fn sphere_points(n: usize, seed: u64) -> crate::model::PointCloud {
    use rand::RngExt;
    let mut r = crate::model::rng::seeded(seed);
    let mut pc = crate::model::PointCloud::default();
    let mut colors = Vec::new();
    for _ in 0..n {
        let p = loop {
            let q = DVec3::new(
                r.random_range(-1.0..1.0),
                r.random_range(-1.0..1.0),
                r.random_range(-1.0..1.0),
            );
            if q.length() > 0.1 && q.length() <= 1.0 {
                break q.normalize();
            }
        };
        pc.positions.push(p.as_vec3().to_array());
        colors.push(sphere_texture(p).map(|v| (v * 255.0).round() as u8));
    }
    pc.colors = Some(colors);
    pc
}

/// Writes the generated sphere scene as a 3DGS-style DATA folder:
/// `images/vNN.png` ([`textured_photos`] of a 48-ring sphere from
/// [`cameras_around`]`(n, 3.5, size, 1.25·size)`), `cameras.json` and,
/// when `points > 0`, `input.ply` with [`sphere_points`]`(points, 3)`.
pub fn write_sphere_dataset(
    dir: &std::path::Path,
    n: usize,
    size: u32,
    points: usize,
) -> crate::Result<()> {
    let truth = uv_sphere(48, 1.0);
    let cams = cameras_around(n, 3.5, size, 1.25 * size as f64);
    write_photos(dir, &truth, &cams)?;
    if points > 0 {
        crate::io::any::save_points(
            &dir.join("input.ply"),
            &sphere_points(points, 3),
            crate::io::ply::header::Format::BinaryLittleEndian,
        )?;
    }
    Ok(())
}

/// Writes `dir/images/<camera>.png` ([`textured_photos`] of `truth`, 8-bit
/// RGB) and `dir/cameras.json` (3DGS layout) for `cams`.
pub fn write_photos(dir: &std::path::Path, truth: &Mesh, cams: &[Camera]) -> crate::Result<()> {
    std::fs::create_dir_all(dir.join("images"))
        .map_err(|e| crate::Error::invalid(format!("{}: {e}", dir.display())))?;
    for v in textured_photos(truth, cams) {
        let bytes: Vec<u8> = v
            .image
            .iter()
            .flatten()
            .map(|&x| crate::io::image::to_u8(x))
            .collect();
        let path = dir.join("images").join(format!("{}.png", v.camera.name));
        let name = path.display().to_string();
        let (w, h) = (v.camera.width as usize, v.camera.height as usize);
        crate::io::write_output(&path, |out| {
            crate::io::image::write_png8(out, &name, w, h, 3, &bytes)
        })?;
    }
    crate::io::cameras::gs_json::write_gs_json(&dir.join("cameras.json"), cams)
}

/// Distance of a mesh to the unit sphere, independent of any reconstruction
/// code: (accuracy, completeness) = (mean | |p| − 1 | over ~200,000 points
/// sampled uniformly by area on the mesh, mean distance from 20,000
/// Fibonacci points on the sphere to the nearest of those samples).
pub fn sphere_mesh_distance(m: &Mesh) -> crate::Result<(f64, f64)> {
    use crate::geom::sampling::knn::NnIndex;
    use crate::geom::sampling::sample::sample_area_uniform;
    let v: Vec<[f64; 3]> = m.vertices.iter().map(|p| p.map(f64::from)).collect();
    let area: f64 = m
        .faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| DVec3::from_array(v[i as usize]));
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    let pts = sample_area_uniform(&v, &m.faces, 200_000.0 / area.max(1e-9), 1)?;
    let accuracy = pts
        .iter()
        .map(|p| (DVec3::from_array(*p).length() - 1.0).abs())
        .sum::<f64>()
        / pts.len().max(1) as f64;
    let n = 20_000;
    let sphere: Vec<[f64; 3]> = (0..n)
        .map(|k| {
            let y = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let a = k as f64 * 2.399_963_229_728_653;
            let s = (1.0 - y * y).sqrt();
            [s * a.cos(), y, s * a.sin()]
        })
        .collect();
    let comp = NnIndex::new(&pts)?.nearest_distances(&sphere);
    Ok((accuracy, comp.iter().sum::<f64>() / n as f64))
}

/// `n` 2DGS surfels tangent to the sphere of radius `r` about the origin:
/// centres on a Fibonacci sphere, each disc's normal (its rotation's third
/// column) the radial direction, a seeded random twist about it, the
/// quaternion scaled by a random factor in [0.5, 2] (stored values need not
/// be unit); standard deviations `sigma` and 0.8·`sigma` along the two
/// tangent axes, opacity 0.9, SH degree 0 with the DC colour of
/// [`sphere_texture`].
pub fn surfel_sphere(n: usize, r: f64, sigma: f64, seed: u64) -> crate::model::Surfels {
    use rand::RngExt;
    let mut rng = crate::model::rng::seeded(seed);
    let mut s = crate::model::Surfels::default();
    for k in 0..n {
        let y = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
        let a = k as f64 * 2.399_963_229_728_653;
        let h = (1.0 - y * y).sqrt();
        let dir = DVec3::new(h * a.cos(), y, h * a.sin());
        let twist = glam::DQuat::from_rotation_z(rng.random_range(0.0..std::f64::consts::TAU));
        let q = glam::DQuat::from_rotation_arc(DVec3::Z, dir) * twist;
        let m = rng.random_range(0.5..2.0);
        s.means.push((dir * r).as_vec3().to_array());
        s.rotations
            .push([q.w * m, q.x * m, q.y * m, q.z * m].map(|v| v as f32));
        s.log_scales
            .push([sigma.ln() as f32, (0.8 * sigma).ln() as f32]);
        s.opacity_logits.push(crate::model::gaussians::logit(0.9));
        s.sh_dc
            .push(sphere_texture(dir).map(splatkit_render::sh::rgb_to_sh));
    }
    s
}

/// Flat 3D Gaussians on a surface given by points and unit normals: each
/// Gaussian's third axis is the normal (σ = `thin`), the other two tangent
/// with σ = `sigma` and a seeded random twist; opacity 0.9, SH degree 0 with
/// the DC colour of [`sphere_texture`] at the point's direction.
pub fn flat_gaussians(
    points: &[(DVec3, DVec3)],
    sigma: f64,
    thin: f64,
    seed: u64,
) -> crate::model::Gaussians {
    use rand::RngExt;
    let mut rng = crate::model::rng::seeded(seed);
    let mut g = crate::model::Gaussians::default();
    for &(p, n) in points {
        let twist = glam::DQuat::from_rotation_z(rng.random_range(0.0..std::f64::consts::TAU));
        let q = glam::DQuat::from_rotation_arc(DVec3::Z, n.normalize()) * twist;
        g.means.push(p.as_vec3().to_array());
        g.rotations.push([q.w, q.x, q.y, q.z].map(|v| v as f32));
        g.log_scales
            .push([sigma.ln() as f32, sigma.ln() as f32, thin.ln() as f32]);
        g.opacity_logits.push(crate::model::gaussians::logit(0.9));
        g.sh_dc
            .push(sphere_texture(p).map(splatkit_render::sh::rgb_to_sh));
    }
    g
}

/// `n` points of the sphere of radius `r` about the origin (Fibonacci
/// lattice) with their outward normals.
pub fn sphere_surface_points(n: usize, r: f64) -> Vec<(DVec3, DVec3)> {
    (0..n)
        .map(|k| {
            let y = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let a = k as f64 * 2.399_963_229_728_653;
            let h = (1.0 - y * y).sqrt();
            let dir = DVec3::new(h * a.cos(), y, h * a.sin());
            (dir * r, dir)
        })
        .collect()
}

/// About `n` points of the torus about the y axis (ring radius `big_r`, tube
/// radius `small_r`), spread evenly by area (each tube circle gets points in
/// proportion to its length), with their outward normals.
pub fn torus_surface_points(n: usize, big_r: f64, small_r: f64) -> Vec<(DVec3, DVec3)> {
    use std::f64::consts::TAU;
    // rings around the tube (angle v) and points per ring ∝ (R + r cos v)
    let area = TAU * TAU * big_r * small_r;
    let spacing = (area / n as f64).sqrt();
    let rings = ((TAU * small_r / spacing).round() as usize).max(3);
    let mut out = Vec::with_capacity(n);
    for i in 0..rings {
        let v = TAU * (i as f64 + 0.5) / rings as f64;
        let ring_r = big_r + small_r * v.cos();
        let m = ((TAU * ring_r / spacing).round() as usize).max(3);
        for j in 0..m {
            let u = TAU * (j as f64 + 0.5 * (i % 2) as f64) / m as f64;
            let radial = DVec3::new(u.cos(), 0.0, u.sin());
            let normal = radial * v.cos() + DVec3::Y * v.sin();
            out.push((radial * big_r + normal * small_r, normal));
        }
    }
    out
}
