//! Z-buffer of the camera-facing ±2σ diamonds of a Gaussian scene (SuGaR's
//! depth for level-set sampling), without binning: each diamond is tested
//! at the pixel centres inside its screen box, and every pixel keeps the
//! nearest hit through an atomic minimum on a packed 64-bit key
//! (f32 depth bits, Gaussian index). Positive f32 values order like their
//! bit patterns, so the minimum is the nearest hit with ties to the lower
//! index — the same rule as the mesh z-buffer, and independent of the
//! order the threads run in, so the result is deterministic.
//!
//! Each diamond is the two triangles (+a1, +a2, −a1) and (+a1, −a1, −a2)
//! of [`diamond_corners`], intersected exactly as the mesh rasteriser does
//! (Möller–Trumbore in camera space, f64). Depth is camera z.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use rayon::prelude::*;
use splatkit_render::Camera;
use splatkit_render::gaussian::{Gaussians3, quat_matrix};
use splatkit_render::mesh::RayTriangle;

/// Per pixel (row-major `width × height`): camera z of the nearest diamond
/// hit beyond `near` and the index of its Gaussian, `None` where nothing is
/// hit.
pub fn diamond_zbuffer(g: &Gaussians3, cam: &Camera, near: f64) -> Vec<Option<(f32, u32)>> {
    let (w, h) = (cam.width as usize, cam.height as usize);
    let buf: Vec<AtomicU64> = (0..w * h).map(|_| AtomicU64::new(u64::MAX)).collect();
    if w == 0 || h == 0 {
        return Vec::new();
    }
    let c = cam.center();
    let c = [c.x, c.y, c.z];
    (0..g.len())
        .into_par_iter()
        .with_min_len(256)
        .for_each(|i| {
            let q = diamond_corners(g, i, c);
            let v: [DVec3; 4] = q.map(|p| cam.to_camera(DVec3::from_array(p.map(f64::from))));
            let finite = v.map(|p| p.is_finite());
            let tris = [[0usize, 1, 2], [0, 2, 3]].map(|t| {
                (t.iter().all(|&k| finite[k]) && t.iter().any(|&k| v[k].z > near)).then_some(t)
            });
            if tris.iter().all(|t| t.is_none()) {
                return;
            }
            // screen box of the usable corners; a triangle reaching behind
            // the near plane may cover any pixel, so it gets the whole image
            let used = |k: usize| tris.iter().flatten().any(|t| t.contains(&k));
            let (mut x0, mut y0, mut x1, mut y1) = (0.0f64, 0.0f64, w as f64, h as f64);
            if (0..4).all(|k| !used(k) || v[k].z > near) {
                (x0, y0, x1, y1) = (
                    f64::INFINITY,
                    f64::INFINITY,
                    f64::NEG_INFINITY,
                    f64::NEG_INFINITY,
                );
                for k in (0..4).filter(|&k| used(k)) {
                    let (px, py) = (
                        cam.fx * v[k].x / v[k].z + cam.cx,
                        cam.fy * v[k].y / v[k].z + cam.cy,
                    );
                    (x0, y0, x1, y1) = (x0.min(px), y0.min(py), x1.max(px), y1.max(py));
                }
            }
            // pixel centres (x + 0.5) in the box, widened by 0.01 px
            let span = |lo: f64, hi: f64, n: usize| -> (usize, usize) {
                let a = (lo - 0.51).ceil().max(0.0);
                let b = (hi - 0.49).floor();
                if b < 0.0 || a >= n as f64 || a > b {
                    return (0, 0);
                }
                // `as usize` saturates for huge boxes: add without overflowing
                (a as usize, (b as usize).saturating_add(1).min(n))
            };
            let prepared = tris.map(|t| t.map(|t| RayTriangle::new(&t.map(|k| v[k]))));
            let (px0, px1) = span(x0, x1, w);
            let (py0, py1) = span(y0, y1, h);
            for y in py0..py1 {
                let dy = (y as f64 + 0.5 - cam.cy) / cam.fy;
                for x in px0..px1 {
                    let d = DVec3::new((x as f64 + 0.5 - cam.cx) / cam.fx, dy, 1.0);
                    let mut best = f64::INFINITY;
                    for t in prepared.iter().flatten() {
                        if let Some((z, _, _)) = t.hit(d)
                            && z > near
                            && z < best
                        {
                            best = z;
                        }
                    }
                    if best < f64::INFINITY {
                        let key = ((best as f32).to_bits() as u64) << 32 | i as u64;
                        let slot = &buf[y * w + x];
                        // a plain load first: most hits lie behind what the
                        // pixel already has, and need no atomic update
                        if key < slot.load(Ordering::Relaxed) {
                            slot.fetch_min(key, Ordering::Relaxed);
                        }
                    }
                }
            }
        });
    buf.into_iter()
        .map(|a| {
            let k = a.into_inner();
            (k != u64::MAX).then(|| (f32::from_bits((k >> 32) as u32), k as u32))
        })
        .collect()
}

fn quat_rows(q: [f32; 4]) -> [[f64; 3]; 3] {
    let n = q.iter().map(|v| (*v as f64).powi(2)).sum::<f64>().sqrt();
    let unit = if n > 0.0 && n.is_finite() {
        q.map(|v| v as f64 / n)
    } else {
        [1.0, 0.0, 0.0, 0.0]
    };
    quat_matrix(unit)
}

/// The rotation (columns = local axes) and scales of Gaussian `i`, with the
/// scales floored at 1e-9 so the inverse covariance stays finite.
pub(crate) fn frame(g: &Gaussians3, i: usize) -> ([[f64; 3]; 3], [f64; 3]) {
    (
        quat_rows(g.rotations[i]),
        g.scales[i].map(|s| (s as f64).abs().max(1e-9)),
    )
}

/// The four corners of Gaussian `i`'s camera-facing diamond seen from the
/// camera centre `c`: ±2σ along its two largest axes, each slid along its
/// camera ray onto the plane through μ perpendicular to the view direction,
/// in the order (+a1, +a2, −a1, −a2). All corners are NaN when μ is at the
/// camera, and a corner that falls behind it is NaN (its faces never hit).
pub fn diamond_corners(g: &Gaussians3, i: usize, c: [f64; 3]) -> [[f32; 3]; 4] {
    let (r, s) = frame(g, i);
    let mu = g.means[i].map(f64::from);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| s[b].total_cmp(&s[a]));
    let (k1, k2) = (order[0], order[1]);
    let axis = |k: usize| [r[0][k], r[1][k], r[2][k]];
    let (a1, a2) = (axis(k1), axis(k2));
    let to = [mu[0] - c[0], mu[1] - c[1], mu[2] - c[2]];
    let dist = (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
    if dist.is_nan() || dist == 0.0 {
        return [[f32::NAN; 3]; 4];
    }
    let dh = to.map(|v| v / dist);
    let corner = |a: [f64; 3], t: f64| -> [f32; 3] {
        let v = [mu[0] + t * a[0], mu[1] + t * a[1], mu[2] + t * a[2]];
        // slide along the camera ray onto the plane through μ ⟂ dh
        let rel = [v[0] - c[0], v[1] - c[1], v[2] - c[2]];
        let along = rel[0] * dh[0] + rel[1] * dh[1] + rel[2] * dh[2];
        if along <= 0.0 {
            return [f32::NAN; 3];
        }
        let f = dist / along;
        [0, 1, 2].map(|k| (c[k] + rel[k] * f) as f32)
    };
    [
        corner(a1, 2.0 * s[k1]),
        corner(a2, 2.0 * s[k2]),
        corner(a1, -2.0 * s[k1]),
        corner(a2, -2.0 * s[k2]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use splatkit_render::mesh as zbuffer;

    /// The diamonds as a mesh for the mesh rasteriser: 4 vertices and 2
    /// faces per Gaussian (faces 2i and 2i+1 belong to Gaussian i), split
    /// along the +a1/−a1 diagonal as [`diamond_zbuffer`] splits them.
    fn diamonds(g: &Gaussians3, cam: &Camera) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let c = cam.center();
        let mut pos = Vec::with_capacity(4 * g.len());
        let mut faces = Vec::with_capacity(2 * g.len());
        for i in 0..g.len() {
            let b = 4 * i as u32;
            pos.extend_from_slice(&diamond_corners(g, i, [c.x, c.y, c.z]));
            faces.push([b, b + 1, b + 2]);
            faces.push([b, b + 2, b + 3]);
        }
        (pos, faces)
    }

    /// Same depths and Gaussians as the mesh z-buffer of [`diamonds`] on a
    /// random scene of 3,000 overlapping Gaussians (some straddling the near
    /// plane, some behind the camera), except where two hits tie in f32
    /// but not in f64 (allowed for under 0.1% of the pixels).
    #[test]
    fn equals_the_mesh_zbuffer_of_the_diamonds() {
        let mut state = 11u64;
        let mut r = |a: f64, b: f64| -> f32 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (a + (b - a) * ((state >> 11) as f64 / (1u64 << 53) as f64)) as f32
        };
        let mut g = Gaussians3 {
            sh_degree: 0,
            ..Default::default()
        };
        for i in 0..3000 {
            let z = if i % 300 == 0 {
                r(-1.0, 0.5)
            } else {
                r(1.0, 4.0)
            };
            g.means.push([r(-1.5, 1.5), r(-1.0, 1.0), z]);
            g.scales
                .push([r(0.01, 0.15), r(0.01, 0.15), r(0.001, 0.01)]);
            g.rotations
                .push([r(-1.0, 1.0), r(-1.0, 1.0), r(-1.0, 1.0), r(-1.0, 1.0)]);
            g.opacities.push(0.9);
            g.sh.push([0.1, 0.2, 0.3]);
        }
        let cam = Camera::pinhole(
            "test",
            90,
            70,
            70.0,
            70.0,
            45.0,
            35.0,
            glam::DMat3::IDENTITY,
            glam::DVec3::ZERO,
        );
        let near = 0.2;
        let got = diamond_zbuffer(&g, &cam, near);
        let (pos, faces) = diamonds(&g, &cam);
        let want = zbuffer::render(&pos, &faces, &cam, near);
        let mut differ = 0;
        let mut hit = 0;
        assert_eq!(got.len(), 90 * 70);
        for (o, &g) in got.iter().enumerate() {
            let w = (want.face[o] != zbuffer::NO_FACE).then(|| (want.depth[o], want.face[o] / 2));
            if w.is_some() {
                hit += 1;
            }
            if g != w {
                // only an f32 tie may differ: same depth, other Gaussian
                let (a, b) = (g.expect("hit"), w.expect("hit"));
                assert_eq!(a.0, b.0, "pixel {o}: {a:?} vs {b:?}");
                differ += 1;
            }
        }
        assert!(hit > 4000, "{hit} pixels hit");
        assert!(differ * 1000 <= 90 * 70, "{differ} pixels differ");
    }
}
