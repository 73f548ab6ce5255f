//! GOF's per-Gaussian preprocessing for one view (`preprocessCUDA` and
//! `computeView2Gaussian` of its `forward.cu`) and the tile binning of
//! `rasterizer_impl.cu`, as the integration kernel sees them.

use rayon::prelude::*;

use crate::Camera;
use crate::dual::sh_rgb;
use crate::gaussian::{Gaussians3, mip_coef, quat_matrix, rotation_rows};
use crate::sh::coeff_count;
use crate::tiles::{TILE, TileLists};

/// GOF's `in_frustum` near test (`auxiliary.h`): Gaussians and points whose
/// view z is at most this (in f32) are culled.
pub const CULL_NEAR: f32 = 0.2;

/// One Gaussian as GOF's integration kernel reads it in one view.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ViewGaussian {
    /// `computeView2Gaussian`'s ten values: the symmetric matrix
    /// Q S⁻² Qᵀ (upper triangle: 00, 01, 02, 11, 12, 22), the vector
    /// B = Q S⁻² t₂ and the scalar C = t₂ᵀ S⁻² t₂, with Q the Gaussian's
    /// axes in camera space (columns), S⁻² = diag(1/(σ² + 1e-7)) and t₂ the
    /// camera centre in the Gaussian's frame. Along the camera ray
    /// r = (x, y, 1) at view depth t the Mahalanobis form is
    /// A t² + 2 (B·r) t + C with A = rᵀ(Q S⁻² Qᵀ)r.
    pub v2g: [f32; 10],
    /// Opacity × the 2-D Mip filter's coef (`conic_opacity.w`).
    pub opacity: f32,
    /// SH colour + 0.5, clamped at 0 (`computeColorFromSH`).
    pub rgb: [f32; 3],
    /// Not a kernel value: a box (u0, v0, u1, v1) in pixel coordinates
    /// outside which every ray has α < 1/255 for this Gaussian (the
    /// projection of the ellipsoid at that level, with margins), so a pixel
    /// whose square misses it can skip the Gaussian with the same result.
    /// Infinite where no bound is found (the ellipsoid reaches z ≤ 0).
    pub reach: [f32; 4],
    /// Not a kernel value: a view depth below which every point has α <
    /// 1/255 for this Gaussian in the point pass (the near end of the same
    /// ellipsoid, rounded down); −∞ where no bound is found.
    pub near: f32,
    /// Not a kernel value: an exponent below which α = min(0.99, o·e^power)
    /// is surely under 1/255 (ln(1/(255·o)) less 1e-4, far more than the
    /// rounding of e^power and the product), so the point pass can skip the
    /// exponential; NaN (never taken) for a NaN opacity.
    pub skip_below: f32,
}

/// The box of [`ViewGaussian::reach`]: the image-plane extent of the
/// ellipsoid (x − t)ᵀ(L·Σ)⁻¹(x − t) ≤ 1 around the camera-space mean `t`,
/// L = 2·ln(255·o) (where o·exp(−m/2) ≥ 1/255) widened for the kernel's f32
/// rounding (m is computed as a difference of terms of size `c_form`, the
/// camera's own Mahalanobis form), plus one pixel. The extent along u is
/// where the planes x − a·z = 0 touch the ellipsoid:
/// a²(t_z² − M_zz) − 2a(t_x t_z − M_xz) + t_x² − M_xx = 0, M = L·Σ.
fn reach(sigma: &[[f64; 3]; 3], t: [f64; 3], o: f64, c_form: f64, cam: &Camera) -> ([f32; 4], f32) {
    const ALL: [f32; 4] = [
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
        f32::INFINITY,
        f32::INFINITY,
    ];
    const NONE: [f32; 4] = [
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    ];
    if o.is_nan() {
        return (ALL, f32::NEG_INFINITY);
    }
    if o * 255.0 < 1.0 - 1e-4 {
        return (NONE, f32::INFINITY);
    }
    let level = (2.0 * (255.0 * o).ln()).max(0.0) * (1.0 + 1e-4) + 1e-5 * c_form.abs() + 1e-3;
    let m = |i: usize, j: usize| level * sigma[i][j];
    // the ellipsoid's view-depth range is t_z ± sqrt(M_zz); one part in
    // 10⁶ below it, then rounded down to f32
    let near = t[2] - m(2, 2).max(0.0).sqrt();
    let near = if near.is_finite() {
        let n = (near - 1e-6 * near.abs() - 1e-9) as f32;
        if n as f64 > near { n.next_down() } else { n }
    } else {
        f32::NEG_INFINITY
    };
    let den = t[2] * t[2] - m(2, 2);
    if !(t[2] > 0.0 && den > 0.0) {
        return (ALL, near);
    }
    let span = |k: usize, f: f64, c: f64| -> Option<(f64, f64)> {
        let b = t[k] * t[2] - m(k, 2);
        let disc = b * b - den * (t[k] * t[k] - m(k, k));
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let r = disc.sqrt();
        Some((f * (b - r) / den + c - 1.0, f * (b + r) / den + c + 1.0))
    };
    match (span(0, cam.fx, cam.cx), span(1, cam.fy, cam.cy)) {
        (Some((u0, u1)), Some((v0, v1)))
            if u0.is_finite() && u1.is_finite() && v0.is_finite() && v1.is_finite() =>
        {
            ([u0 as f32, v0 as f32, u1 as f32, v1 as f32], near)
        }
        _ => (ALL, near),
    }
}

/// The Gaussians of one view: the kept ones in index order and their
/// per-tile lists (indices into `gaussians`), front to back.
pub(crate) struct Binned {
    pub gaussians: Vec<ViewGaussian>,
    pub lists: TileLists,
}

/// GOF's `getRect` on its pixel coordinates (pixel centres at integers):
/// tile columns `(int)((x − r)/16)` up to, excluding, `(int)((x + r + 15)/16)`,
/// clamped to `[0, grid]` (f32 arithmetic, truncation toward zero).
/// Returns the inclusive rectangle, `None` when it is empty.
fn get_rect(p: [f32; 2], r: i32, grid: [u32; 2]) -> Option<[u32; 4]> {
    let r = r as f32;
    let b = TILE as f32;
    let lo = |v: f32, n: u32| ((((v - r) / b) as i32).max(0) as u32).min(n);
    let hi = |v: f32, n: u32| ((((v + r + b - 1.0) / b) as i32).max(0) as u32).min(n);
    let (x0, x1) = (lo(p[0], grid[0]), hi(p[0], grid[0]));
    let (y0, y1) = (lo(p[1], grid[1]), hi(p[1], grid[1]));
    (x0 < x1 && y0 < y1).then(|| [x0, y0, x1 - 1, y1 - 1])
}

/// Preprocesses Gaussian `i` as `preprocessCUDA` does; `None` when the
/// kernel drops it (view z ≤ 0.2, a zero 2-D determinant, an empty tile
/// rectangle; here also a non-finite depth, determinant or radius).
/// Returns the Gaussian, its inclusive tile rectangle and its view depth.
pub(crate) fn preprocess(
    g: &Gaussians3,
    i: usize,
    cam: &Camera,
    rows: &[[f64; 3]; 3],
    kernel_size: f64,
) -> Option<(ViewGaussian, [u32; 4], f32)> {
    let mean = g.means[i].map(f64::from);
    let tr = cam.translation;
    let t: [f64; 3] = std::array::from_fn(|r| {
        rows[r][0] * mean[0] + rows[r][1] * mean[1] + rows[r][2] * mean[2] + tr[r]
    });
    let depth = t[2] as f32;
    if !depth.is_finite() || depth <= CULL_NEAR {
        return None;
    }
    let s = g.scales[i].map(f64::from);
    let q = g.rotations[i].map(f64::from);
    let qn = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    // GOF passes `get_rotation` (F.normalize: a zero quaternion stays zero,
    // whose matrix is the identity)
    let m = quat_matrix(if qn > 0.0 {
        q.map(|v| v / qn)
    } else {
        [0.0; 4]
    });
    // Q = R_view · M: the Gaussian's axes in camera space (columns)
    let qm: [[f64; 3]; 3] = std::array::from_fn(|r| {
        std::array::from_fn(|c| rows[r][0] * m[0][c] + rows[r][1] * m[1][c] + rows[r][2] * m[2][c])
    });
    // computeCov2D: EWA with the view-ray clamp at 1.3·tan(fov/2)
    let (wd, hd) = (cam.width as f64, cam.height as f64);
    let lim_x = 1.3 * (wd / (2.0 * cam.fx));
    let lim_y = 1.3 * (hd / (2.0 * cam.fy));
    let z = t[2];
    let ux = (t[0] / z).clamp(-lim_x, lim_x);
    let uy = (t[1] / z).clamp(-lim_y, lim_y);
    let j0 = [cam.fx / z, 0.0, -cam.fx * ux / z];
    let j1 = [0.0, cam.fy / z, -cam.fy * uy / z];
    // A = J Q S (2×3), Σ' = A Aᵀ
    let a0: [f64; 3] =
        std::array::from_fn(|c| (j0[0] * qm[0][c] + j0[1] * qm[1][c] + j0[2] * qm[2][c]) * s[c]);
    let a1: [f64; 3] =
        std::array::from_fn(|c| (j1[0] * qm[0][c] + j1[1] * qm[1][c] + j1[2] * qm[2][c]) * s[c]);
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let (ca0, cb, cc0) = (dot(a0, a0), dot(a0, a1), dot(a1, a1));
    let (ca, cc) = (ca0 + kernel_size, cc0 + kernel_size);
    let coef = mip_coef::<f64>(ca0, cb, cc0, ca, cc);
    let det = ca * cc - cb * cb;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let mid = 0.5 * (ca + cc);
    let l1 = mid + (mid * mid - det).max(0.1).sqrt();
    let radius = (3.0 * l1.sqrt()).ceil();
    if !radius.is_finite() || radius > i32::MAX as f64 {
        return None;
    }
    // ndc2Pix of the projected mean: GOF's pixel coordinates (centres at
    // integers), with the principal point (cx, cy) where GOF has (W/2, H/2)
    let p_w = 1.0 / (z + 1e-7);
    let point_image = [
        (cam.fx * t[0] * p_w + cam.cx - 0.5) as f32,
        (cam.fy * t[1] * p_w + cam.cy - 0.5) as f32,
    ];
    let grid = [
        (cam.width as usize).div_ceil(TILE) as u32,
        (cam.height as usize).div_ceil(TILE) as u32,
    ];
    let rect = get_rect(point_image, radius as i32, grid)?;
    let n = coeff_count(g.sh_degree);
    let rgb = sh_rgb::<f64>(
        mean,
        cam.center().to_array(),
        &g.sh[i * n..(i + 1) * n],
        g.sh_degree,
    )
    .map(|v| v.max(0.0) as f32);
    let opacity = g.opacities[i] * coef as f32;
    let v2g = view2gaussian(&qm, t, s);
    // camera-space covariance with the kernel's σ² + 1e-7
    let var = s.map(|v| v * v + 1e-7);
    let sigma: [[f64; 3]; 3] = std::array::from_fn(|a| {
        std::array::from_fn(|b| (0..3).map(|c| qm[a][c] * var[c] * qm[b][c]).sum())
    });
    let (reach, near) = reach(&sigma, t, opacity as f64, v2g[9] as f64, cam);
    Some((
        ViewGaussian {
            v2g,
            opacity,
            rgb,
            reach,
            near,
            skip_below: skip_below(opacity),
        },
        rect,
        depth,
    ))
}

/// [`ViewGaussian::skip_below`] of opacity `o`, rounded down to f32.
fn skip_below(o: f32) -> f32 {
    let e = -(255.0 * o as f64).ln() - 1e-4;
    let f = e as f32;
    if f as f64 > e { f.next_down() } else { f }
}

/// `computeView2Gaussian` from the camera-space axes `qm` (columns), the
/// camera-space mean `t` and the scales `s` (see [`ViewGaussian::v2g`]).
fn view2gaussian(qm: &[[f64; 3]; 3], t: [f64; 3], s: [f64; 3]) -> [f32; 10] {
    // t₂ = −Qᵀ t: the camera centre in the Gaussian's frame
    let t2: [f64; 3] =
        std::array::from_fn(|c| -(qm[0][c] * t[0] + qm[1][c] * t[1] + qm[2][c] * t[2]));
    let sinv = s.map(|v| 1.0 / (v * v + 1e-7));
    let cst = t2[0] * t2[0] * sinv[0] + t2[1] * t2[1] * sinv[1] + t2[2] * t2[2] * sinv[2];
    let sig = |i: usize, j: usize| (0..3).map(|c| qm[i][c] * sinv[c] * qm[j][c]).sum::<f64>();
    let b = |i: usize| (0..3).map(|c| qm[i][c] * sinv[c] * t2[c]).sum::<f64>();
    [
        sig(0, 0),
        sig(0, 1),
        sig(0, 2),
        sig(1, 1),
        sig(1, 2),
        sig(2, 2),
        b(0),
        b(1),
        b(2),
        cst,
    ]
    .map(|v| v as f32)
}

/// Preprocesses every Gaussian for `cam` and bins the kept ones to GOF's
/// tile rectangles, each tile's list sorted by (view depth, index) as the
/// kernel's stable radix sort of `tile | depth` keys leaves it.
pub(crate) fn bin(g: &Gaussians3, cam: &Camera, kernel_size: f64) -> Binned {
    g.check_lengths();
    let rows = rotation_rows(cam);
    let kept: Vec<(ViewGaussian, [u32; 4], f32)> = (0..g.len())
        .into_par_iter()
        .filter_map(|i| preprocess(g, i, cam, &rows, kernel_size))
        .collect();
    let lists = TileLists::build(
        &kept,
        |k| Some(k.1),
        |k| k.2,
        cam.width as usize,
        cam.height as usize,
    );
    Binned {
        gaussians: kept.into_iter().map(|k| k.0).collect(),
        lists,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// getRect truncates toward zero and clamps: a box reaching left of the
    /// image starts at tile 0, a right edge in [16k − 15, 16k + 1) ends
    /// before tile k, and a box left of the image is empty.
    #[test]
    fn get_rect_rules() {
        let grid = [4, 3];
        // x − r = 10 → tile 0; x + r + 15 = 45 → (int)(2.8) = 2: tiles 0 and 1
        assert_eq!(get_rect([20.0, 5.0], 10, grid), Some([0, 0, 1, 0]));
        // x + r + 15 = 31.9 → (int)(1.99) = 1: only tile 0
        assert_eq!(get_rect([10.9, 5.0], 6, grid), Some([0, 0, 0, 0]));
        // x − r = −20 → (int)(−1.25) = −1 → 0; x + r + 15 = 14 → 0: empty
        assert_eq!(get_rect([-10.0, 5.0], 10, grid), None);
        // far right: clamped to the grid, keeps the last tile column
        assert_eq!(get_rect([63.5, 5.0], 2, grid), Some([3, 0, 3, 0]));
        assert_eq!(get_rect([80.0, 5.0], 2, grid), None);
    }
}
