//! Reverse-mode derivative of one Gaussian's projection, written out by
//! hand: given ∂L/∂ of the projected quantities of
//! [`crate::gaussian::project_t`] (pixel mean, conic, view depth, camera
//! normal, SH colour), the gradient with respect to the Gaussian's mean,
//! scales, quaternion (w, x, y, z, before normalisation) and SH
//! coefficients.
//!
//! Same function as running `project_t` with [`crate::dual::Dual`]`<10>`
//! (the tests check the two agree to 1e-9 relative on random Gaussians,
//! clamped ones included), at a fraction of the cost: one backward sweep
//! instead of ten tangents carried through every operation. The rules that
//! make the projection non-smooth are the same: the x/z and y/z clamp of
//! the Jacobian passes no gradient to the clamped coordinate, which axis is
//! shortest and its flip towards the camera are constants, and a colour
//! channel clamped at 0 passes none. Arithmetic in f64.
//!
//! Chain, forward: t = W μ + T (camera space); q̂ = q/|q|, R = R(q̂);
//! J = [[fx/z, 0, −fx·u_x/z], [0, fy/z, −fy·u_y/z]] with u = clamp(t_xy/z);
//! A = J W R S (2×3); Σ' = A Aᵀ + k I = [[a, b], [b, c]] (k the 2-D
//! filter's dilation, 3DGS 0.3); conic = (c, −b, a)/det; pixel mean =
//! (fx t_x/z + cx, fy t_y/z + cy); depth = t_z; normal = ±W R e_k (k the
//! shortest axis); with the 2-D Mip filter the drawn opacity is o·coef(Σ'),
//! coef = √(det₀/(det₁ + 1e-6) + 1e-6) ([`crate::gaussian::Filter2d::Mip`]),
//! whose gradient reaches the covariance (exactly: the CUDA backward's
//! extra 1e-6 terms are not copied).

use crate::Camera;
use crate::dual::sh_basis;
use crate::gaussian::{Filter2d, quat_matrix};

/// ∂L/∂ of the projected geometry of one Gaussian.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct ScreenGrad {
    /// Pixel mean (x, y).
    pub xy: [f64; 2],
    /// Conic (a, b, c) of [[a, b], [b, c]] = Σ'⁻¹.
    pub conic: [f64; 3],
    /// View depth (camera z of the mean).
    pub depth: f64,
    /// Camera-space normal (the shortest axis facing the camera).
    pub normal: [f64; 3],
    /// The opacity the pixels blend (o·coef with the Mip filter, o else).
    pub opacity: f64,
}

/// ∂L/∂(mean, scale, quaternion, opacity) as 11 numbers (mean 0–2, scales
/// 3–5, quaternion 6–9, opacity 10) for the Gaussian (`mean`, `scale` in
/// world units, `quat` (w, x, y, z) any length, `opacity` activated), seen
/// by `cam` whose world-to-camera rotation rows are `rows`, under the 2-D
/// filter `filter`. The Gaussian is assumed not culled (it is in the
/// forward pass's projected list).
#[allow(clippy::too_many_arguments)]
pub(crate) fn geometry_vjp(
    mean: [f32; 3],
    scale: [f32; 3],
    quat: [f32; 4],
    opacity: f32,
    filter: Filter2d,
    cam: &Camera,
    rows: &[[f64; 3]; 3],
    gs: &ScreenGrad,
) -> [f64; 11] {
    let m = mean.map(f64::from);
    let sc = scale.map(f64::from);
    let q = quat.map(f64::from);
    let tr = cam.translation;
    let t: [f64; 3] =
        std::array::from_fn(|i| m[0] * rows[i][0] + m[1] * rows[i][1] + m[2] * rows[i][2] + tr[i]);
    let qn = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let unit = qn > 0.0;
    let inv_qn = 1.0 / qn;
    let [w, x, y, z] = if unit {
        q.map(|v| v * inv_qn)
    } else {
        [1.0, 0.0, 0.0, 0.0]
    };
    let rq = quat_matrix([w, x, y, z]);
    let (fx, fy) = (cam.fx, cam.fy);
    let lim_x = 1.3 * (cam.width as f64 / (2.0 * fx));
    let lim_y = 1.3 * (cam.height as f64 / (2.0 * fy));
    let iz = 1.0 / t[2];
    // u = t_xy/z unless clamped (then a constant)
    let clamp = |v: f64, lim: f64| {
        let r = v * iz;
        if r > lim {
            (lim, false)
        } else if r < -lim {
            (-lim, false)
        } else {
            (r, true)
        }
    };
    let ((ux, free_x), (uy, free_y)) = (clamp(t[0], lim_x), clamp(t[1], lim_y));
    let j0 = [fx * iz, 0.0, -ux * iz * fx];
    let j1 = [0.0, fy * iz, -uy * iz * fy];
    let jw0: [f64; 3] =
        std::array::from_fn(|c| j0[0] * rows[0][c] + j0[1] * rows[1][c] + j0[2] * rows[2][c]);
    let jw1: [f64; 3] =
        std::array::from_fn(|c| j1[0] * rows[0][c] + j1[1] * rows[1][c] + j1[2] * rows[2][c]);
    // B = J W R (2×3), A = B S
    let b0: [f64; 3] =
        std::array::from_fn(|c| jw0[0] * rq[0][c] + jw0[1] * rq[1][c] + jw0[2] * rq[2][c]);
    let b1: [f64; 3] =
        std::array::from_fn(|c| jw1[0] * rq[0][c] + jw1[1] * rq[1][c] + jw1[2] * rq[2][c]);
    let a0: [f64; 3] = std::array::from_fn(|c| b0[c] * sc[c]);
    let a1: [f64; 3] = std::array::from_fn(|c| b1[c] * sc[c]);
    let dot = |u: [f64; 3], v: [f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let k = filter.kernel();
    let (ca0, cb, cc0) = (dot(a0, a0), dot(a0, a1), dot(a1, a1));
    let ca = ca0 + k;
    let cc = cc0 + k;
    let det = ca * cc - cb * cb;

    // conic = (cc, −cb, ca)/det
    let [g0, g1, g2] = gs.conic;
    let inv_det = 1.0 / det;
    let g_det = -(g0 * cc - g1 * cb + g2 * ca) * inv_det * inv_det;
    let mut g_ca = g2 * inv_det + g_det * cc;
    let mut g_cc = g0 * inv_det + g_det * ca;
    let mut g_cb = -g1 * inv_det - 2.0 * g_det * cb;
    // drawn opacity o·coef: ∂/∂o, and ∂/∂coef through det₀ and det₁
    let mut g_opacity = gs.opacity;
    if let Filter2d::Mip { .. } = filter {
        let det0 = ca0 * cc0 - cb * cb;
        if det0 > 1e-6 && det > 1e-6 {
            let d1 = det + 1e-6;
            let coef = (det0 / d1 + 1e-6).sqrt();
            g_opacity = gs.opacity * coef;
            let g_r = gs.opacity * f64::from(opacity) * 0.5 / coef;
            let (g_det0, g_det1) = (g_r / d1, -g_r * det0 / (d1 * d1));
            // ∂/∂ca0 = ∂/∂ca (ca = ca0 + k), likewise cc
            g_ca += g_det0 * cc0 + g_det1 * cc;
            g_cc += g_det0 * ca0 + g_det1 * ca;
            g_cb -= 2.0 * cb * (g_det0 + g_det1);
        } else {
            g_opacity = 0.0;
        }
    }
    let g_a0: [f64; 3] = std::array::from_fn(|c| 2.0 * g_ca * a0[c] + g_cb * a1[c]);
    let g_a1: [f64; 3] = std::array::from_fn(|c| 2.0 * g_cc * a1[c] + g_cb * a0[c]);
    let g_sc: [f64; 3] = std::array::from_fn(|c| g_a0[c] * b0[c] + g_a1[c] * b1[c]);
    let g_b0: [f64; 3] = std::array::from_fn(|c| g_a0[c] * sc[c]);
    let g_b1: [f64; 3] = std::array::from_fn(|c| g_a1[c] * sc[c]);
    let mut g_rq: [[f64; 3]; 3] =
        std::array::from_fn(|r| std::array::from_fn(|c| jw0[r] * g_b0[c] + jw1[r] * g_b1[c]));
    let g_jw0: [f64; 3] = std::array::from_fn(|r| dot(rq[r], g_b0));
    let g_jw1: [f64; 3] = std::array::from_fn(|r| dot(rq[r], g_b1));
    let g_j0: [f64; 3] = std::array::from_fn(|r| dot(rows[r], g_jw0));
    let g_j1: [f64; 3] = std::array::from_fn(|r| dot(rows[r], g_jw1));
    let mut g_iz = fx * g_j0[0] - fx * ux * g_j0[2] + fy * g_j1[1] - fy * uy * g_j1[2];
    let mut g_t = [0.0f64; 3];
    if free_x {
        let g_ux = -fx * iz * g_j0[2];
        g_t[0] += g_ux * iz;
        g_iz += g_ux * t[0];
    }
    if free_y {
        let g_uy = -fy * iz * g_j1[2];
        g_t[1] += g_uy * iz;
        g_iz += g_uy * t[1];
    }
    // pixel mean (fx t_x/z + cx, fy t_y/z + cy), not clamped
    g_t[0] += gs.xy[0] * fx * iz;
    g_t[1] += gs.xy[1] * fy * iz;
    g_iz += gs.xy[0] * fx * t[0] + gs.xy[1] * fy * t[1];
    g_t[2] += gs.depth - g_iz * iz * iz;

    // normal: ±(W R)[·][k], the choice and sign constant
    let k = (0..3)
        .min_by(|&p, &q| sc[p].total_cmp(&sc[q]))
        .expect("three axes");
    let axis: [f64; 3] = std::array::from_fn(|i| dot(rows[i], [rq[0][k], rq[1][k], rq[2][k]]));
    let sign = if dot(axis, t) > 0.0 { -1.0 } else { 1.0 };
    for (r, g_row) in g_rq.iter_mut().enumerate() {
        g_row[k] += sign * (0..3).map(|i| rows[i][r] * gs.normal[i]).sum::<f64>();
    }

    let mut out = [0.0f64; 11];
    out[10] = g_opacity;
    for c in 0..3 {
        out[c] = rows[0][c] * g_t[0] + rows[1][c] * g_t[1] + rows[2][c] * g_t[2];
        out[3 + c] = g_sc[c];
    }
    if unit {
        let g = &g_rq;
        let gq = [
            2.0 * (-z * g[0][1] + y * g[0][2] + z * g[1][0] - x * g[1][2] - y * g[2][0]
                + x * g[2][1]),
            2.0 * (y * g[0][1] + z * g[0][2] + y * g[1][0] - 2.0 * x * g[1][1] - w * g[1][2]
                + z * g[2][0]
                + w * g[2][1]
                - 2.0 * x * g[2][2]),
            2.0 * (-2.0 * y * g[0][0] + x * g[0][1] + w * g[0][2] + x * g[1][0] + z * g[1][2]
                - w * g[2][0]
                + z * g[2][1]
                - 2.0 * y * g[2][2]),
            2.0 * (-2.0 * z * g[0][0] - w * g[0][1] + x * g[0][2] + w * g[1][0]
                - 2.0 * z * g[1][1]
                + y * g[1][2]
                + x * g[2][0]
                + y * g[2][1]),
        ];
        // through q̂ = q/|q|: (g − q̂ (q̂·g))/|q|
        let n = [w, x, y, z];
        let along = n[0] * gq[0] + n[1] * gq[1] + n[2] * gq[2] + n[3] * gq[3];
        for j in 0..4 {
            out[6 + j] = (gq[j] - n[j] * along) * inv_qn;
        }
    }
    out
}

/// The SH colour's gradients for one Gaussian: writes ∂L/∂SH into `dsh`
/// (`(degree+1)²` entries, zero for a channel clamped at 0) and returns
/// ∂L/∂mean through the view direction v = mean − `eye` (normalised in the
/// basis), given ∂L/∂rgb `g_rgb` of the clamped colour.
///
/// With w_k = Σ_ch g_ch·sh[k][ch] (unclamped channels), the mean gradient
/// is (I − d d ᵀ)/|v| · ∇f(d) for f(d) = Σ_k w_k Y_k(d), d = v/|v|, where
/// ∇f is the gradient of the basis polynomials of [`crate::sh::basis`]
/// (3DGS's constants), written out term by term below.
pub(crate) fn colour_vjp(
    mean: [f32; 3],
    eye: [f64; 3],
    sh: &[[f32; 3]],
    degree: usize,
    g_rgb: [f64; 3],
    dsh: &mut [[f32; 3]],
) -> [f64; 3] {
    use crate::sh::{C1, C2, C3};
    let v = [
        mean[0] as f64 - eye[0],
        mean[1] as f64 - eye[1],
        mean[2] as f64 - eye[2],
    ];
    // the forward pass's basis values (same generic code)
    let basis = sh_basis(degree, v);
    let n = crate::sh::coeff_count(degree).min(sh.len()).min(dsh.len());
    // the forward colour, to tell the clamped channels (same sums as sh_rgb)
    let gw: [f64; 3] = std::array::from_fn(|ch| {
        let mut acc = basis[0] * sh[0][ch] as f64;
        for k in 1..n {
            acc += basis[k] * sh[k][ch] as f64;
        }
        if acc + 0.5 < 0.0 { 0.0 } else { g_rgb[ch] }
    });
    let mut w = [0.0f64; 16];
    for k in 0..n {
        dsh[k] = std::array::from_fn(|ch| (basis[k] * gw[ch]) as f32);
        w[k] = gw[0] * sh[k][0] as f64 + gw[1] * sh[k][1] as f64 + gw[2] * sh[k][2] as f64;
    }
    let len2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    if degree == 0 || n < 4 || !(len2 > 0.0 && len2.is_finite()) {
        return [0.0; 3];
    }
    let len = len2.sqrt();
    let (x, y, z) = (v[0] / len, v[1] / len, v[2] / len);
    let (c1, c2, c3) = (C1 as f64, C2.map(|c| c as f64), C3.map(|c| c as f64));
    // ∇f, band 1
    let mut gx = -c1 * w[3];
    let mut gy = -c1 * w[1];
    let mut gz = c1 * w[2];
    if n >= 9 {
        gx += c2[0] * y * w[4] - 2.0 * c2[2] * x * w[6] + c2[3] * z * w[7] + 2.0 * c2[4] * x * w[8];
        gy += c2[0] * x * w[4] + c2[1] * z * w[5] - 2.0 * c2[2] * y * w[6] - 2.0 * c2[4] * y * w[8];
        gz += c2[1] * y * w[5] + 4.0 * c2[2] * z * w[6] + c2[3] * x * w[7];
    }
    if n >= 16 {
        let (xx, yy, zz) = (x * x, y * y, z * z);
        gx += 6.0 * c3[0] * x * y * w[9] + c3[1] * y * z * w[10]
            - 2.0 * c3[2] * x * y * w[11]
            - 6.0 * c3[3] * x * z * w[12]
            + c3[4] * (4.0 * zz - 3.0 * xx - yy) * w[13]
            + 2.0 * c3[5] * x * z * w[14]
            + c3[6] * (3.0 * xx - 3.0 * yy) * w[15];
        gy += c3[0] * (3.0 * xx - 3.0 * yy) * w[9]
            + c3[1] * x * z * w[10]
            + c3[2] * (4.0 * zz - xx - 3.0 * yy) * w[11]
            - 6.0 * c3[3] * y * z * w[12]
            - 2.0 * c3[4] * x * y * w[13]
            - 2.0 * c3[5] * y * z * w[14]
            - 6.0 * c3[6] * x * y * w[15];
        gz += c3[1] * x * y * w[10]
            + 8.0 * c3[2] * y * z * w[11]
            + c3[3] * (6.0 * zz - 3.0 * xx - 3.0 * yy) * w[12]
            + 8.0 * c3[4] * x * z * w[13]
            + c3[5] * (xx - yy) * w[14];
    }
    // through d = v/|v|
    let along = x * gx + y * gy + z * gz;
    [
        (gx - x * along) / len,
        (gy - y * along) / len,
        (gz - z * along) / len,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dual::{Dual, sh_rgb};
    use crate::gaussian::{RasterSettings, project_t, rotation_rows};

    const N: usize = 11;
    use crate::testutil::{Lcg, random_sh, test_camera};

    /// The Dual<11> Jacobian of `project_t` (and of the drawn opacity
    /// o·coef) contracted with `gs`: the oracle the hand-written sweep must
    /// equal.
    #[allow(clippy::too_many_arguments)]
    fn dual_vjp(
        mean: [f32; 3],
        scale: [f32; 3],
        quat: [f32; 4],
        opacity: f32,
        filter: Filter2d,
        cam: &Camera,
        gs: &ScreenGrad,
    ) -> Option<[f64; N]> {
        let rows = rotation_rows(cam);
        let mean_d: [Dual<N>; 3] = std::array::from_fn(|k| Dual::var(mean[k] as f64, k));
        let scale_d: [Dual<N>; 3] = std::array::from_fn(|k| Dual::var(scale[k] as f64, 3 + k));
        let quat_d: [Dual<N>; 4] = std::array::from_fn(|k| Dual::var(quat[k] as f64, 6 + k));
        let op_d: Dual<N> = Dual::var(opacity as f64, 10);
        let s = RasterSettings {
            filter_2d: filter,
            ..Default::default()
        };
        let p = project_t(mean_d, scale_d, quat_d, None, 0, cam, &rows, &s)?;
        let mut g = [0.0f64; N];
        let mut add = |v: &Dual<N>, w: f64| {
            for (gk, dk) in g.iter_mut().zip(v.d) {
                *gk += dk * w;
            }
        };
        add(&p.xy[0], gs.xy[0]);
        add(&p.xy[1], gs.xy[1]);
        for k in 0..3 {
            add(&p.conic[k], gs.conic[k]);
            add(&p.normal[k], gs.normal[k]);
        }
        add(&p.depth, gs.depth);
        add(&(op_d * p.coef), gs.opacity);
        Some(g)
    }

    fn close(a: f64, b: f64, scale: f64) -> bool {
        (a - b).abs() <= 1e-9 * scale.max(1e-300)
    }

    /// 2,000 random Gaussians (some far to the side, so the x/z or y/z
    /// clamp is active; some with unnormalised quaternions; random screen
    /// gradients), under 3DGS's dilation and under the 2-D Mip filter
    /// (Mip-Splatting's 0.1, GOF's 0.0): the hand-written sweep equals the
    /// Dual<11> Jacobian to 1e-9 of the largest entry (both are f64; only
    /// rounding differs).
    #[test]
    fn geometry_matches_dual_numbers() {
        for filter in [
            Filter2d::default(),
            Filter2d::Mip { kernel_size: 0.1 },
            Filter2d::Mip { kernel_size: 0.0 },
        ] {
            geometry_matches_dual_numbers_with(filter);
        }
    }

    fn geometry_matches_dual_numbers_with(filter: Filter2d) {
        let cam = test_camera(64, 48, 60.0);
        let rows = rotation_rows(&cam);
        let mut r = Lcg(77);
        let (mut tested, mut clamped) = (0, 0);
        for i in 0..2000 {
            let zc = r.range(1.0, 6.0);
            let (spread, big) = if i % 4 == 0 { (1.2, 1.5) } else { (0.5, 0.5) };
            let mean = [
                r.range(-spread, spread) * zc,
                r.range(-spread, spread) * zc,
                zc,
            ];
            let scale = [r.range(0.01, big), r.range(0.01, big), r.range(0.01, big)];
            let qs = r.range(0.3, 2.0);
            let quat = [
                r.range(-1.0, 1.0) * qs,
                r.range(-1.0, 1.0) * qs,
                r.range(-1.0, 1.0) * qs,
                r.range(-1.0, 1.0) * qs,
            ];
            let gs = ScreenGrad {
                xy: [r.range(-1.0, 1.0) as f64, r.range(-1.0, 1.0) as f64],
                conic: [
                    r.range(-50.0, 50.0) as f64,
                    r.range(-50.0, 50.0) as f64,
                    r.range(-50.0, 50.0) as f64,
                ],
                depth: r.range(-1.0, 1.0) as f64,
                normal: [
                    r.range(-1.0, 1.0) as f64,
                    r.range(-1.0, 1.0) as f64,
                    r.range(-1.0, 1.0) as f64,
                ],
                opacity: r.range(-1.0, 1.0) as f64,
            };
            let opacity = r.range(0.05, 1.0);
            let Some(want) = dual_vjp(mean, scale, quat, opacity, filter, &cam, &gs) else {
                continue;
            };
            tested += 1;
            let (lx, ly) = (1.3 * 32.0 / cam.fx, 1.3 * 24.0 / cam.fy);
            if (mean[0] / zc).abs() as f64 > lx || (mean[1] / zc).abs() as f64 > ly {
                clamped += 1;
            }
            let got = geometry_vjp(mean, scale, quat, opacity, filter, &cam, &rows, &gs);
            let big = want.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            for k in 0..N {
                assert!(
                    close(got[k], want[k], big),
                    "{filter:?}: Gaussian {i}, entry {k}: {} vs Dual {}",
                    got[k],
                    want[k]
                );
            }
        }
        assert!(
            tested > 1000 && clamped > 100,
            "{tested} tested, {clamped} clamped"
        );
    }

    /// The colour sweep against sh_rgb run with Dual<3> (mean gradient) and
    /// the basis values (SH gradient), with channels clamped at 0 passing
    /// nothing.
    #[test]
    fn colour_matches_dual_numbers() {
        let mut r = Lcg(5);
        let eye = [0.3, -0.2, -2.0];
        for deg in 0..=3usize {
            let n = crate::sh::coeff_count(deg);
            for _ in 0..200 {
                let mean = [r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0)];
                let mut sh = random_sh(&mut r, n);
                // a strongly negative DC sometimes: clamped channels
                if r.range(0.0, 1.0) < 0.3 {
                    sh[0][1] = -3.0;
                }
                let g_rgb = [
                    r.range(-1.0, 1.0) as f64,
                    r.range(-1.0, 1.0) as f64,
                    r.range(-1.0, 1.0) as f64,
                ];
                let mut dsh = [[0.0f32; 3]; 16];
                let got = colour_vjp(mean, eye, &sh, deg, g_rgb, &mut dsh);
                let m3: [Dual<3>; 3] = std::array::from_fn(|k| Dual::var(mean[k] as f64, k));
                let rgb = sh_rgb(m3, eye, &sh, deg);
                let mut want = [0.0f64; 3];
                for ch in 0..3 {
                    if rgb[ch].v < 0.0 {
                        assert!(dsh[..n].iter().all(|d| d[ch] == 0.0));
                        continue;
                    }
                    for (w, d) in want.iter_mut().zip(rgb[ch].d) {
                        *w += d * g_rgb[ch];
                    }
                }
                let big = want.iter().fold(1e-12f64, |a, v| a.max(v.abs()));
                for k in 0..3 {
                    assert!(close(got[k], want[k], big), "{deg}: {got:?} vs {want:?}");
                }
                // ∂L/∂sh[k][ch] = Y_k · g_ch: a unit SH change moves the
                // channel by the basis value
                let dir = [
                    mean[0] as f64 - eye[0],
                    mean[1] as f64 - eye[1],
                    mean[2] as f64 - eye[2],
                ];
                let b = sh_basis(deg, dir);
                for k in 0..n {
                    for ch in 0..3 {
                        if rgb[ch].v >= 0.0 {
                            let want = (b[k] * g_rgb[ch]) as f32;
                            assert!((dsh[k][ch] - want).abs() <= 1e-6 * want.abs().max(1e-6));
                        }
                    }
                }
            }
        }
    }
}
