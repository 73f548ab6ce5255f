//! 2DGS's depth–normal consistency: normals from a rendered depth map and the
//! loss that ties the rendered normal map to them (Triangle Splatting's
//! normal loss, SuGaR V2's `dn_consistency`).
//!
//! Conventions (those of [`crate::gaussian::RenderOutput`]):
//! - buffers are row-major `width × height`, pixel `(x, y)` at index
//!   `y·width + x`; pixel centres at `(x + 0.5, y + 0.5)` in OpenCV pixel
//!   coordinates (the camera's `cx, cy` use the same convention);
//! - depth is the view-space z in scene units, 0 where nothing was rendered;
//! - points and normals are in **camera space** (x right, y down, z
//!   forward); normals face the camera (negative camera z for a plane seen
//!   from the front), like the rasterisers' normal output, which turns each
//!   primitive's normal against the view ray.
//!
//! Only the pinhole intrinsics `fx, fy, cx, cy` are used; distortion
//! parameters of the camera model are ignored.

use crate::Camera;

/// Back-projects every pixel of `depth` (view-space z, scene units) to camera
/// space: `p = z · K⁻¹ [x + 0.5, y + 0.5, 1]ᵀ`, i.e.
/// `((x + 0.5 − cx)/fx · z, (y + 0.5 − cy)/fy · z, z)`. A pixel with depth 0
/// maps to the camera centre (0, 0, 0). Row-major, `width × height` entries.
///
/// Panics when `depth.len() != width·height`.
pub fn depth_to_points(depth: &[f32], cam: &Camera) -> Vec<[f32; 3]> {
    let (w, h) = dims(depth, cam);
    (0..w * h)
        .map(|i| point(cam, i % w, i / w, depth[i] as f64).map(|v| v as f32))
        .collect()
}

/// Normals of the surface seen in `depth`, as 2DGS computes them: with `P`
/// the back-projected points ([`depth_to_points`]), `a = P(x+1, y) − P(x−1, y)`
/// and `b = P(x, y+1) − P(x, y−1)` (central differences along the image x and
/// y axes), `n = normalize(b × a)`. This orientation gives a plane facing the
/// camera a normal with negative camera z. Unit length in camera space; zero
/// on the 1-pixel image border and where `b × a` vanishes (length below
/// 1e-20, e.g. a 3×3 block of zero depths).
///
/// Panics when `depth.len() != width·height`.
pub fn depth_to_normal(depth: &[f32], cam: &Camera) -> Vec<[f32; 3]> {
    let (w, h) = dims(depth, cam);
    let mut out = vec![[0.0f32; 3]; w * h];
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let (_, _, c) = cross_at(depth, cam, w, x, y);
            let l = len3(c);
            if l > MIN_CROSS {
                out[y * w + x] = c.map(|v| (v / l) as f32);
            }
        }
    }
    out
}

/// 2DGS's depth–normal consistency loss and its gradients.
///
/// Inputs (row-major, `width × height` each):
/// - `normal_sum`: the rendered, **unnormalised** accumulated normal
///   `Σ_i w_i n_i` per pixel (camera space, facing the camera);
/// - `depth`: the rendered surface depth (view-space z, scene units);
/// - `alpha`: the rendered opacity, treated as a constant (2DGS detaches it).
///
/// With `n_surf = depth_to_normal(depth)`, the loss is
/// `L = (1/P) Σ_pixels (1 − ⟨normal_sum, alpha · n_surf⟩)`, the mean over all
/// `P` pixels (the border, where `n_surf = 0`, contributes 1 and no gradient).
///
/// Returns `(L, ∂L/∂normal_sum, ∂L/∂depth)`. The depth gradient flows through
/// the central differences of the back-projected points into the depths of
/// the four neighbours of each interior pixel. Where `b × a` is shorter than
/// 1e-20 the surface normal is zero and that pixel sends no gradient to the
/// depth (the normalisation has no derivative there). Accumulation in f64.
///
/// Panics when the three buffers and the camera disagree in size.
pub fn normal_consistency(
    normal_sum: &[[f32; 3]],
    depth: &[f32],
    alpha: &[f32],
    cam: &Camera,
) -> (f64, Vec<[f32; 3]>, Vec<f32>) {
    let (w, h) = dims(depth, cam);
    let n = w * h;
    assert_eq!(normal_sum.len(), n, "normal_sum size");
    assert_eq!(alpha.len(), n, "alpha size");
    let inv_p = 1.0 / n.max(1) as f64;
    let mut loss = 0.0f64;
    let mut g_normal = vec![[0.0f32; 3]; n];
    let mut g_depth = vec![0.0f64; n];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            loss += 1.0;
            if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
                continue;
            }
            let (a, b, c) = cross_at(depth, cam, w, x, y);
            let l = len3(c);
            if l <= MIN_CROSS {
                continue;
            }
            let ns = c.map(|v| v / l);
            let al = alpha[i] as f64;
            let nr = normal_sum[i].map(|v| v as f64);
            loss -= al * dot(nr, ns);
            g_normal[i] = ns.map(|v| (-al * v * inv_p) as f32);
            // ∂L/∂n_surf, then through n = c/|c|, c = b × a
            let gn = nr.map(|v| -al * v * inv_p);
            let ng = dot(ns, gn);
            let gc: [f64; 3] = std::array::from_fn(|k| (gn[k] - ns[k] * ng) / l);
            let gb = cross(a, gc);
            let ga = cross(gc, b);
            // a = P(x+1,y) − P(x−1,y), b = P(x,y+1) − P(x,y−1), P = z·r
            let mut add = |xx: usize, yy: usize, g: [f64; 3], s: f64| {
                let r = ray(cam, xx, yy);
                g_depth[yy * w + xx] += s * dot(g, r);
            };
            add(x + 1, y, ga, 1.0);
            add(x - 1, y, ga, -1.0);
            add(x, y + 1, gb, 1.0);
            add(x, y - 1, gb, -1.0);
        }
    }
    (
        loss * inv_p,
        g_normal,
        g_depth.into_iter().map(|v| v as f32).collect(),
    )
}

/// Below this length `b × a` counts as zero (no normal, no gradient).
const MIN_CROSS: f64 = 1e-20;

fn dims(depth: &[f32], cam: &Camera) -> (usize, usize) {
    let (w, h) = (cam.width as usize, cam.height as usize);
    assert_eq!(depth.len(), w * h, "depth size must be width × height");
    (w, h)
}

/// `K⁻¹ [x + 0.5, y + 0.5, 1]ᵀ`: the camera-space point at depth 1.
fn ray(cam: &Camera, x: usize, y: usize) -> [f64; 3] {
    [
        (x as f64 + 0.5 - cam.cx) / cam.fx,
        (y as f64 + 0.5 - cam.cy) / cam.fy,
        1.0,
    ]
}

fn point(cam: &Camera, x: usize, y: usize, z: f64) -> [f64; 3] {
    ray(cam, x, y).map(|v| v * z)
}

/// (a, b, b × a) at interior pixel (x, y).
fn cross_at(
    depth: &[f32],
    cam: &Camera,
    w: usize,
    x: usize,
    y: usize,
) -> ([f64; 3], [f64; 3], [f64; 3]) {
    let p = |xx: usize, yy: usize| point(cam, xx, yy, depth[yy * w + xx] as f64);
    let (px1, px0, py1, py0) = (p(x + 1, y), p(x - 1, y), p(x, y + 1), p(x, y - 1));
    let a: [f64; 3] = std::array::from_fn(|k| px1[k] - px0[k]);
    let b: [f64; 3] = std::array::from_fn(|k| py1[k] - py0[k]);
    (a, b, cross(b, a))
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn len3(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{Lcg, test_camera};

    /// A smooth random depth map on `cam`: 2 + low-frequency sines.
    fn smooth_depth(cam: &Camera, seed: u64) -> Vec<f32> {
        let mut r = Lcg(seed);
        let (a, b, c, d) = (
            r.range(0.1, 0.4) as f64,
            r.range(0.1, 0.4) as f64,
            r.range(0.0, 6.0) as f64,
            r.range(-0.03, 0.03) as f64,
        );
        let w = cam.width as usize;
        (0..w * cam.height as usize)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                (2.0 + 0.3 * (a * x + c).sin() * (b * y).cos() + d * x) as f32
            })
            .collect()
    }

    /// Central difference with the perturbation actually stored in f32, so
    /// the only error left is the O(h²) truncation (relative ~1e-6 here).
    /// Tolerance: 1e-3 relative, 1e-9 absolute (everything is computed in
    /// f64 from f32 inputs; the gradients are returned as f32, ~6e-8 relative).
    fn fd_check(name: &str, analytic: &[f64], base: &[f32], h: f32, f: impl Fn(&[f32]) -> f64) {
        let mut worst = 0.0f64;
        for k in 0..base.len() {
            let mut p = base.to_vec();
            p[k] = base[k] + h;
            let hp = (p[k] - base[k]) as f64;
            let lp = f(&p);
            p[k] = base[k] - h;
            let hm = (p[k] - base[k]) as f64;
            let lm = f(&p);
            let fd = (lp - lm) / (hp - hm);
            let err = (fd - analytic[k]).abs();
            let tol = 1e-3 * fd.abs().max(analytic[k].abs()) + 1e-9;
            assert!(
                err <= tol,
                "{name}[{k}]: analytic {} vs fd {fd}",
                analytic[k]
            );
            worst = worst.max(analytic[k].abs());
        }
        assert!(worst > 0.0, "{name}: all-zero gradient");
    }

    #[test]
    fn points_use_pixel_centres() {
        let cam = test_camera(4, 2, 10.0); // cx = 2, cy = 1
        let depth = vec![2.0f32; 8];
        let p = depth_to_points(&depth, &cam);
        // pixel (1, 0): u = 1.5, v = 0.5
        assert_eq!(
            p[1],
            [2.0 * (1.5 - 2.0) / 10.0, 2.0 * (0.5 - 1.0) / 10.0, 2.0]
        );
    }

    #[test]
    fn tilted_plane_gives_its_normal() {
        let cam = test_camera(16, 12, 20.0);
        // plane n·X = c in camera space, n facing the camera (n_z < 0)
        let n = {
            let v = [0.3f64, -0.2, -1.0];
            let l = len3(v);
            v.map(|c| c / l)
        };
        let c = dot(n, [0.0, 0.0, 3.0]);
        let w = 16;
        let depth: Vec<f32> = (0..16 * 12)
            .map(|i| (c / dot(n, ray(&cam, i % w, i / w))) as f32)
            .collect();
        let normals = depth_to_normal(&depth, &cam);
        for y in 0..12 {
            for x in 0..16 {
                let got = normals[y * w + x];
                if x == 0 || y == 0 || x == 15 || y == 11 {
                    assert_eq!(got, [0.0; 3]);
                } else {
                    for k in 0..3 {
                        assert!(
                            (got[k] as f64 - n[k]).abs() < 1e-5,
                            "{x},{y}: {got:?} vs {n:?}"
                        );
                    }
                }
            }
        }
        // a fronto-parallel plane faces the camera: (0, 0, −1)
        let flat = depth_to_normal(&[1.5f32; 16 * 12], &cam);
        assert_eq!(flat[5 * w + 5], [0.0, 0.0, -1.0]);
    }

    #[test]
    fn loss_value_on_a_plane() {
        // rendered normal = alpha · n_surf exactly: loss = (border + Σ(1 − α²))/P
        let cam = test_camera(6, 5, 8.0);
        let depth = vec![2.0f32; 30];
        let alpha: Vec<f32> = (0..30).map(|i| 0.1 + 0.02 * i as f32).collect();
        let ns: Vec<[f32; 3]> = alpha.iter().map(|&a| [0.0, 0.0, -a]).collect();
        let (l, _, _) = normal_consistency(&ns, &depth, &alpha, &cam);
        let mut want = 0.0;
        for (i, &al) in alpha.iter().enumerate() {
            let (x, y) = (i % 6, i / 6);
            let interior = x > 0 && y > 0 && x < 5 && y < 4;
            let a = al as f64;
            want += if interior { 1.0 - a * a } else { 1.0 };
        }
        assert!((l - want / 30.0).abs() < 1e-7, "{l} vs {}", want / 30.0);
    }

    #[test]
    fn gradients_match_finite_differences() {
        for seed in [1u64, 2, 3] {
            let cam = test_camera(9, 7, 12.0);
            let n = 63;
            let depth = smooth_depth(&cam, seed);
            let mut r = Lcg(seed + 100);
            let alpha: Vec<f32> = (0..n).map(|_| r.range(0.0, 1.0)).collect();
            let nsum: Vec<[f32; 3]> = (0..n)
                .map(|_| [r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.2, 0.2)])
                .collect();
            let (_, gn, gd) = normal_consistency(&nsum, &depth, &alpha, &cam);
            let gd: Vec<f64> = gd.iter().map(|&v| v as f64).collect();
            fd_check("depth", &gd, &depth, 1e-3, |d| {
                normal_consistency(&nsum, d, &alpha, &cam).0
            });
            let flat: Vec<f32> = nsum.iter().flatten().copied().collect();
            let gnf: Vec<f64> = gn.iter().flatten().map(|&v| v as f64).collect();
            fd_check("normal_sum", &gnf, &flat, 1e-2, |v| {
                let ns: Vec<[f32; 3]> = v.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
                normal_consistency(&ns, &depth, &alpha, &cam).0
            });
        }
    }

    #[test]
    fn zero_depth_block_has_no_normal_and_no_gradient() {
        let cam = test_camera(5, 5, 8.0);
        let depth = vec![0.0f32; 25];
        assert!(depth_to_normal(&depth, &cam).iter().all(|n| *n == [0.0; 3]));
        let (l, gn, gd) = normal_consistency(&[[0.0, 0.0, -1.0]; 25], &depth, &[1.0; 25], &cam);
        assert_eq!(l, 1.0);
        assert!(gn.iter().all(|n| *n == [0.0; 3]) && gd.iter().all(|&v| v == 0.0));
    }
}
