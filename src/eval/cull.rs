//! 2DGS mask culling of a mesh before the DTU evaluation
//! (2DGS `scripts/eval_dtu/evaluate_single_scene.py::cull_scan`).
//!
//! For every view i (one per mask; the camera file must have at least as
//! many views): project each vertex of the mesh (in the normalised frame)
//! with `K [R | t]` decomposed from `world_mat_i · scale_mat_i`, divide by
//! `z + 1e-6` (no z > 0 test, as the reference), and if the pixel lies
//! strictly inside the image (`0 < x < W−1`, `0 < y < H−1`, the reference's
//! normalised `(−1, 1)` test) read the mask, dilated by a disk of radius 24
//! px, at the pixel nearest to it (ties to even, as `grid_sample(nearest)`).
//! A vertex survives iff no view sees it inside the image on background.
//! Faces survive iff their three vertices do; surviving vertices that no
//! face uses are kept (as trimesh's `update_vertices` + `update_faces` do).
//! Finally vertices are mapped to millimetres with
//! `v·scale_mat[0][0] + scale_mat[:3, 3]`, rounded to f32 as the reference's
//! `culled_mesh.ply` stores them.
//!
//! Masks: channel 0 of OpenCV's BGR read, i.e. the **blue** channel of an
//! RGB(A) PNG (the grey value of a grey PNG); any nonzero value is object
//! (decoded by `io::image::read_mask`; the op pairs cameras and masks).

use glam::{DMat3, DMat4, DVec3};
use rayon::prelude::*;

pub use crate::model::Mask;

/// Dilation radius of the reference (`disk(24)`), pixels.
pub const DILATION_RADIUS: u32 = 24;

/// One view for culling.
#[derive(Clone, Debug)]
pub struct CullView {
    pub k: DMat3,
    pub rotation: DMat3,
    pub translation: DVec3,
    /// The dilated mask.
    pub mask: Mask,
}

/// 1-D squared Euclidean distance transform (Felzenszwalb & Huttenlocher)
/// of `f` (0 at sites, a large finite value elsewhere) into `d`; `v`, `z` are
/// scratch buffers of length n and n + 1.
fn edt_1d(f: &[f64], d: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let n = f.len();
    let mut k = 0usize;
    v[0] = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    for q in 1..n {
        let fq = f[q] + (q * q) as f64;
        // z[0] = −∞ and every value is finite, so this loop ends.
        let mut s;
        loop {
            let p = v[k];
            s = (fq - (f[p] + (p * p) as f64)) / (2.0 * (q - p) as f64);
            if s > z[k] {
                break;
            }
            k -= 1;
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
    k = 0;
    for (q, out) in d.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let p = v[k];
        *out = (q as f64 - p as f64).powi(2) + f[p];
    }
}

/// Dilates `m` by a disk of radius `r` (pixels with x² + y² ≤ r², as
/// scikit-image's `disk(r)`), exactly, through the squared distance
/// transform: a pixel is set iff some set pixel lies within distance r.
pub fn dilate_disk(m: &Mask, r: u32) -> Mask {
    let (w, h) = (m.width, m.height);
    if w == 0 || h == 0 {
        return m.clone();
    }
    // "No site": farther than any distance in the image, but finite so the
    // parabola arithmetic stays exact.
    let far = ((w + h) as f64).powi(2) * 4.0;
    // Columns then rows.
    let mut g = vec![0f64; w * h];
    let cols: Vec<Vec<f64>> = (0..w)
        .into_par_iter()
        .map(|x| {
            let f: Vec<f64> = (0..h)
                .map(|y| if m.bits[y * w + x] { 0.0 } else { far })
                .collect();
            let mut d = vec![0f64; h];
            let (mut v, mut z) = (vec![0usize; h], vec![0f64; h + 1]);
            edt_1d(&f, &mut d, &mut v, &mut z);
            d
        })
        .collect();
    for (x, col) in cols.iter().enumerate() {
        for (y, &val) in col.iter().enumerate() {
            g[y * w + x] = val;
        }
    }
    let r2 = (r as f64) * (r as f64);
    let bits: Vec<bool> = g
        .par_chunks(w)
        .flat_map_iter(|row| {
            let mut d = vec![0f64; w];
            let (mut v, mut z) = (vec![0usize; w], vec![0f64; w + 1]);
            edt_1d(row, &mut d, &mut v, &mut z);
            d.into_iter().map(move |x| x <= r2)
        })
        .collect();
    Mask {
        width: w,
        height: h,
        bits,
    }
}

/// Which vertices survive the culling (see module docs).
pub fn cull_vertices(vertices: &[[f64; 3]], views: &[CullView]) -> Vec<bool> {
    vertices
        .par_iter()
        .with_min_len(1024)
        .map(|v| {
            let x = DVec3::from_array(*v);
            views.iter().all(|view| {
                let cam = view.k * (view.rotation * x + view.translation);
                let px = cam.x / (cam.z + 1e-6);
                let py = cam.y / (cam.z + 1e-6);
                let (w, h) = (view.mask.width as f64, view.mask.height as f64);
                let gx = (px / (w - 1.0) - 0.5) * 2.0;
                let gy = (py / (h - 1.0) - 0.5) * 2.0;
                let valid = gx > -1.0 && gx < 1.0 && gy > -1.0 && gy < 1.0;
                if !valid {
                    return true;
                }
                let (c, r) = (px.round_ties_even() as usize, py.round_ties_even() as usize);
                view.mask.bits
                    [r.min(view.mask.height - 1) * view.mask.width + c.min(view.mask.width - 1)]
            })
        })
        .collect()
}

/// Culls a mesh in the normalised frame and maps it to millimetres.
/// Returns (vertices in mm, kept faces re-indexed, number of vertices removed).
pub fn cull_mesh(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
    views: &[CullView],
    scale_mat: &DMat4,
) -> (Vec<[f64; 3]>, Vec<[u32; 3]>, usize) {
    let keep = cull_vertices(vertices, views);
    let mut remap = vec![u32::MAX; vertices.len()];
    let mut out = Vec::with_capacity(vertices.len());
    let s = scale_mat.x_axis.x;
    let c = scale_mat.w_axis.truncate();
    for (i, v) in vertices.iter().enumerate() {
        if keep[i] {
            remap[i] = out.len() as u32;
            out.push([0, 1, 2].map(|k| (v[k] * s + c[k]) as f32 as f64));
        }
    }
    let kept_faces = faces
        .iter()
        .filter(|f| f.iter().all(|&i| keep[i as usize]))
        .map(|f| f.map(|i| remap[i as usize]))
        .collect();
    let removed = vertices.len() - out.len();
    (out, kept_faces, removed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disk_dilation_matches_brute_force() {
        let (w, h) = (37, 29);
        let mut bits = vec![false; w * h];
        for &(x, y) in &[(3usize, 4usize), (20, 20), (36, 0), (10, 28)] {
            bits[y * w + x] = true;
        }
        let m = Mask {
            width: w,
            height: h,
            bits,
        };
        for r in [0u32, 1, 3, 7, 24] {
            let d = dilate_disk(&m, r);
            for y in 0..h {
                for x in 0..w {
                    let want = (0..h).any(|yy| {
                        (0..w).any(|xx| {
                            m.bits[yy * w + xx] && {
                                let (dx, dy) = (x as i64 - xx as i64, y as i64 - yy as i64);
                                dx * dx + dy * dy <= (r * r) as i64
                            }
                        })
                    });
                    assert_eq!(d.bits[y * w + x], want, "r={r} at ({x},{y})");
                }
            }
        }
        // An empty mask stays empty.
        let e = Mask {
            width: 5,
            height: 5,
            bits: vec![false; 25],
        };
        assert!(dilate_disk(&e, 3).bits.iter().all(|b| !b));
    }
}
