//! Forward Gaussian-splat rasteriser with the semantics of the 3DGS CUDA
//! rasteriser, on the CPU.
//!
//! Per Gaussian (preprocess):
//! - camera-space mean t = R·μ + T; culled when t.z ≤ `near` (3DGS: 0.2);
//! - 3-D covariance Σ = R_q S Sᵀ R_qᵀ, S = diag(scales) (activated, world
//!   units), R_q from the quaternion (w, x, y, z), normalised;
//! - EWA projection: J = [[fx/z, 0, −fx·x/z²], [0, fy/z, −fy·y/z²]] with x/z and
//!   y/z clamped to ±1.3·tan(fov/2) as 3DGS does, Σ' = J W Σ Wᵀ Jᵀ + 0.3·I
//!   (the low-pass filter, pixels²);
//! - screen radius = ⌈3·√λ_max(Σ')⌉; Gaussians whose box misses the image are
//!   culled; the tiles are the kernel's `getRect` range of that box
//!   ([`crate::tiles::tile_rect_cuda`]) — it can leave out a row or column
//!   the box reaches, and those pixels do not get the Gaussian;
//! - colour from SH (degree 0–3, 3DGS constants) in the direction from the
//!   camera centre to the mean, + 0.5, clamped at 0.
//!
//! Per pixel (16×16 tiles, Gaussians sorted front to back by view depth per
//! tile; pixel centres at integer + 0.5 in OpenCV pixel coordinates):
//! α = min(0.99, opacity · exp(−½ dᵀ Σ'⁻¹ d)); contributions with α < 1/255
//! or a positive exponent are skipped; a Gaussian whose contribution would
//! take the transmittance T below 1e-4 is not blended and ends the pixel;
//! C = Σ c_i α_i T_i + T·background.
//!
//! Outputs per pixel: RGB, alpha = 1 − T, expected depth Σ w z / Σ w
//! (w = α T; 0 where nothing was blended), median depth (the view depth of the
//! last contribution made while the transmittance before it was above 0.5,
//! as 2DGS's kernel keeps it, so also where the final alpha stays below 0.5;
//! 0 only where nothing was blended),
//! a normal map (Σ w n / |Σ w n| of each Gaussian's shortest axis turned to
//! face the camera, camera axes), the unnormalised accumulated normal Σ w n
//! (2DGS's normal-consistency input) and the number of blended contributions.
//! The expected depth and Σ w n are differentiated by
//! [`crate::gaussian_grad::backward_aux`]; the median depth and the
//! normalised normal map are not.

use rayon::prelude::*;

use crate::Camera;
use crate::dual::{Real, dot3, sh_rgb};
use crate::sh::coeff_count;
pub use crate::splats::Splats;

pub use crate::tiles::TILE;
use crate::tiles::{
    PREFETCH_DISTANCE, TileLists, depth_key, intersect_rects, prefetch_ahead, render_tile_rows,
    tile_pixels, tile_rect, tile_rect_cuda,
};

/// Gaussians as the rasteriser wants them: activated values (three scale
/// axes; see [`Splats`]).
pub type Gaussians3 = Splats<3>;

/// The screen-space (2-D) filter added to each projected covariance Σ'.
///
/// Used by the Gaussian rasteriser only (the triangle and mesh rasterisers
/// ignore it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter2d {
    /// 3DGS's low-pass dilation: Σ' + v·I (pixels², 3DGS: 0.3), opacity
    /// unchanged. The default.
    Dilate(f64),
    /// The 2-D Mip filter of Mip-Splatting and Gaussian Opacity Fields
    /// (their rasterisers' `kernel_size`, pixels²; Mip-Splatting's default
    /// 0.1, GOF's 0.0): Σ' + k·I, and the opacity multiplied by
    /// coef = √(det₀ / (det₁ + 1e-6) + 1e-6), with det₀ = max(1e-6, det Σ')
    /// before and det₁ = max(1e-6, det(Σ' + k·I)) after the dilation;
    /// coef = 0 (the Gaussian is not drawn) where either determinant is at
    /// most 1e-6 before the clamp. These are their CUDA `computeCov2D`'s
    /// rules, evaluated here in f64.
    Mip {
        /// The dilation k, pixels².
        kernel_size: f64,
    },
}

impl Default for Filter2d {
    fn default() -> Self {
        Filter2d::Dilate(0.3)
    }
}

impl Filter2d {
    /// The value added to the diagonal of the projected covariance.
    #[inline]
    pub fn kernel(self) -> f64 {
        match self {
            Filter2d::Dilate(v) => v,
            Filter2d::Mip { kernel_size } => kernel_size,
        }
    }
}

/// Rasteriser settings.
#[derive(Clone, Copy, Debug)]
pub struct RasterSettings {
    /// Background colour.
    pub background: [f32; 3],
    /// Near plane (camera z), Gaussians at or before it are culled.
    pub near: f64,
    /// The screen-space filter of the Gaussian rasteriser (default: 3DGS's
    /// 0.3 dilation).
    pub filter_2d: Filter2d,
    /// Triangles: the smallest inradius r and largest vertex distance R
    /// (pixels) a projected triangle may have and still be drawn. Triangle
    /// Splatting's kernel culls r < 1 or R < 1 (the default, 1.0); a
    /// smaller value also draws sub-pixel triangles (a departure, for
    /// low-resolution training: docs/train.md, "Random initial points").
    pub min_inradius: f64,
}

impl Default for RasterSettings {
    fn default() -> Self {
        RasterSettings {
            background: [0.0; 3],
            near: 0.2,
            filter_2d: Filter2d::default(),
            min_inradius: 1.0,
        }
    }
}

/// The rendered buffers, row-major, `width × height`.
#[derive(Clone, Debug, Default)]
pub struct RenderOutput {
    pub width: usize,
    pub height: usize,
    pub rgb: Vec<[f32; 3]>,
    pub alpha: Vec<f32>,
    /// Σ w z / Σ w with w = α T the blend weights and z each primitive's
    /// view depth (camera z, scene units); 0 where nothing was blended.
    pub expected_depth: Vec<f32>,
    pub median_depth: Vec<f32>,
    /// Camera-space unit normals Σ w n / |Σ w n| (zero where nothing was
    /// blended).
    pub normal: Vec<[f32; 3]>,
    /// The accumulated normal Σ w n, camera space, not normalised (its
    /// length is at most the alpha); zero where nothing was blended. What
    /// 2DGS's normal consistency compares with the depth normal, and what
    /// the backward passes take a normal gradient for.
    pub normal_sum: Vec<[f32; 3]>,
    pub count: Vec<u32>,
}

impl RenderOutput {
    /// 2DGS's surface depth `(1 − ratio)·expected + ratio·median` per pixel
    /// (ratio 1: median, Triangle Splatting's and 2DGS's DTU setting; 0:
    /// expected). Where nothing was blended both are 0.
    pub fn surface_depth(&self, ratio: f32) -> Vec<f32> {
        if ratio == 1.0 {
            return self.median_depth.clone();
        }
        if ratio == 0.0 {
            return self.expected_depth.clone();
        }
        self.expected_depth
            .iter()
            .zip(&self.median_depth)
            .map(|(&e, &m)| (1.0 - ratio) * e + ratio * m)
            .collect()
    }

    /// The median depth only where the pixel's accumulated alpha reaches
    /// 0.5, 0 elsewhere: the depth of the contribution that took the
    /// transmittance across one half, i.e. where the splats form a surface.
    /// Point sampling (`splat2points`) uses this; the kernel's rule in
    /// `median_depth` also gives depth to translucent fringe pixels.
    pub fn opaque_median_depth(&self) -> Vec<f32> {
        self.median_depth
            .iter()
            .zip(&self.alpha)
            .map(|(&d, &a)| if a >= 0.5 { d } else { 0.0 })
            .collect()
    }
}

/// One projected Gaussian.
#[derive(Clone, Copy, Debug)]
pub struct Projected {
    /// Index of the Gaussian.
    pub id: u32,
    /// Pixel-space mean (OpenCV pixel coordinates).
    pub xy: [f32; 2],
    /// Inverse 2-D covariance (a, b, c) of [[a, b], [b, c]].
    pub conic: [f32; 3],
    /// View depth.
    pub depth: f32,
    /// Screen radius in pixels.
    pub radius: f32,
    /// Half-extents (x, y) of the ellipse outside which α < 1/255 (pixels):
    /// the exact bounding box of o·G ≥ 1/255, with a small margin. Pixels
    /// outside it would be skipped anyway, so tiles and pixels outside it are
    /// not visited (same output, less work).
    pub ext: [f32; 2],
    /// ln(1/(255·o)) − 1e-4: below this exponent α < 1/255 for certain, and
    /// the exponential need not be evaluated.
    pub power_cut: f32,
    pub opacity: f32,
    pub rgb: [f32; 3],
    /// Camera-space normal facing the camera.
    pub normal: [f32; 3],
}

/// The differentiable part of a Gaussian's projection, generic so that the
/// backward pass gets its Jacobian from the same code (see [`crate::dual`]).
pub(crate) struct ProjectedT<T> {
    pub xy: [T; 2],
    pub conic: [T; 3],
    /// SH colour + 0.5, before the clamp at 0.
    pub rgb: [T; 3],
    /// View depth: camera z of the mean.
    pub depth: T,
    pub radius: f64,
    /// 2-D covariance diagonal (Σ'_xx, Σ'_yy), pixels².
    pub cov_diag: [f64; 2],
    /// Camera-space normal facing the camera: the shortest axis (the choice
    /// and the flip are made on the values, so they carry no derivative).
    pub normal: [T; 3],
    /// The factor the opacity is multiplied by: 1 for [`Filter2d::Dilate`],
    /// the determinant ratio's coef for [`Filter2d::Mip`].
    pub coef: T,
}

/// The rotation matrix R[row][col] of a unit quaternion (w, x, y, z) (the
/// caller normalises; 3DGS's `build_rotation`): its columns are the
/// Gaussian's local axes in world space. Generic so that the projection,
/// its derivatives and the f64 callers share it.
pub fn quat_matrix<T: Real>([w, x, y, z]: [T; 4]) -> [[T; 3]; 3] {
    let one = T::cst(1.0);
    [
        [
            one - (y * y + z * z) * 2.0,
            (x * y - w * z) * 2.0,
            (x * z + w * y) * 2.0,
        ],
        [
            (x * y + w * z) * 2.0,
            one - (x * x + z * z) * 2.0,
            (y * z - w * x) * 2.0,
        ],
        [
            (x * z - w * y) * 2.0,
            (y * z + w * x) * 2.0,
            one - (x * x + y * y) * 2.0,
        ],
    ]
}

/// World-to-camera rotation as rows.
pub(crate) fn rotation_rows(cam: &Camera) -> [[f64; 3]; 3] {
    let r = cam.rotation;
    std::array::from_fn(|i| [r.x_axis[i], r.y_axis[i], r.z_axis[i]])
}

/// Projects one Gaussian given its mean, scales and quaternion (w, x, y, z;
/// normalised here) and its SH coefficients (`None`: colour left at 0, for
/// a caller that differentiates it separately); `None` when culled.
#[allow(clippy::too_many_arguments)]
pub(crate) fn project_t<T: Real>(
    mean: [T; 3],
    scale: [T; 3],
    quat: [T; 4],
    sh: Option<&[[f32; 3]]>,
    sh_degree: usize,
    cam: &Camera,
    rows: &[[f64; 3]; 3],
    s: &RasterSettings,
) -> Option<ProjectedT<T>> {
    let tr = cam.translation;
    let t: [T; 3] = std::array::from_fn(|i| {
        mean[0] * rows[i][0] + mean[1] * rows[i][1] + mean[2] * rows[i][2] + tr[i]
    });
    let z = t[2].val();
    if z <= s.near || !z.is_finite() {
        return None;
    }
    let qn = (quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2] + quat[3] * quat[3]).sqrt();
    let [w, x, y, zq] = if qn.val() > 0.0 {
        quat.map(|v| v / qn)
    } else {
        [T::cst(1.0), T::cst(0.0), T::cst(0.0), T::cst(0.0)]
    };
    let one = T::cst(1.0);
    // rotation matrix of the quaternion, rq[r][c]
    let rq = quat_matrix([w, x, y, zq]);
    let (wd, hd) = (cam.width as f64, cam.height as f64);
    let lim_x = 1.3 * (wd / (2.0 * cam.fx));
    let lim_y = 1.3 * (hd / (2.0 * cam.fy));
    let inv_z = one / t[2];
    let clamp = |v: T, lim: f64| {
        let r = v * inv_z;
        if r.val() > lim {
            T::cst(lim)
        } else if r.val() < -lim {
            T::cst(-lim)
        } else {
            r
        }
    };
    let (ux, uy) = (clamp(t[0], lim_x), clamp(t[1], lim_y));
    // J·W (2×3): J = [[fx/z, 0, −fx·ux/z], [0, fy/z, −fy·uy/z]]
    let j0 = [inv_z * cam.fx, T::cst(0.0), -(ux * inv_z) * cam.fx];
    let j1 = [T::cst(0.0), inv_z * cam.fy, -(uy * inv_z) * cam.fy];
    let jw0: [T; 3] =
        std::array::from_fn(|c| j0[0] * rows[0][c] + j0[1] * rows[1][c] + j0[2] * rows[2][c]);
    let jw1: [T; 3] =
        std::array::from_fn(|c| j1[0] * rows[0][c] + j1[1] * rows[1][c] + j1[2] * rows[2][c]);
    // A = J W R_q S (2×3); Σ' = A Aᵀ + k I (k: the 2-D filter, 3DGS 0.3)
    let a0: [T; 3] = std::array::from_fn(|c| {
        (jw0[0] * rq[0][c] + jw0[1] * rq[1][c] + jw0[2] * rq[2][c]) * scale[c]
    });
    let a1: [T; 3] = std::array::from_fn(|c| {
        (jw1[0] * rq[0][c] + jw1[1] * rq[1][c] + jw1[2] * rq[2][c]) * scale[c]
    });
    let k = s.filter_2d.kernel();
    let (ca0, cb, cc0) = (dot3(a0, a0), dot3(a0, a1), dot3(a1, a1));
    let ca = ca0 + k;
    let cc = cc0 + k;
    let coef = match s.filter_2d {
        Filter2d::Dilate(_) => one,
        Filter2d::Mip { .. } => mip_coef(ca0, cb, cc0, ca, cc),
    };
    let det = ca * cc - cb * cb;
    if det.val().is_nan() || det.val() <= 0.0 {
        return None;
    }
    let conic = [cc / det, -cb / det, ca / det];
    let mid = 0.5 * (ca.val() + cc.val());
    let l1 = mid + (mid * mid - det.val()).max(0.1).sqrt();
    let radius = (3.0 * l1.sqrt()).ceil();
    let px = t[0] * inv_z * cam.fx + cam.cx;
    let py = t[1] * inv_z * cam.fy + cam.cy;
    let (pxv, pyv) = (px.val(), py.val());
    if !(pxv + radius >= 0.0 && pxv - radius <= wd && pyv + radius >= 0.0 && pyv - radius <= hd) {
        return None;
    }
    let rgb = match sh {
        Some(sh) => sh_rgb(mean, cam.center().to_array(), sh, sh_degree),
        None => [T::cst(0.0); 3],
    };
    // shortest axis, in camera space, facing the camera (against the view ray)
    let sv = scale.map(|v| v.val());
    let k = (0..3)
        .min_by(|&p, &q| sv[p].total_cmp(&sv[q]))
        .expect("three axes");
    let axis: [T; 3] = std::array::from_fn(|i| {
        rq[0][k] * rows[i][0] + rq[1][k] * rows[i][1] + rq[2][k] * rows[i][2]
    });
    let (av, tv) = (axis.map(|v| v.val()), t.map(|v| v.val()));
    let facing = av[0] * tv[0] + av[1] * tv[1] + av[2] * tv[2] > 0.0;
    let normal = if facing { axis.map(|v| -v) } else { axis };
    Some(ProjectedT {
        xy: [px, py],
        conic,
        rgb,
        depth: t[2],
        radius,
        cov_diag: [ca.val(), cc.val()],
        normal,
        coef,
    })
}

/// The opacity factor of the 2-D Mip filter (see [`Filter2d::Mip`]) from
/// the projected covariance before (`ca0`, `cb`, `cc0`) and after (`ca`,
/// `cb`, `cc`) the dilation: √(det₀/(det₁ + 1e-6) + 1e-6), 0 where a
/// determinant is at most 1e-6 (the CUDA clamps then give 0 as well).
pub(crate) fn mip_coef<T: Real>(ca0: T, cb: T, cc0: T, ca: T, cc: T) -> T {
    let det0 = ca0 * cc0 - cb * cb;
    let det1 = ca * cc - cb * cb;
    if !(det0.val() > 1e-6 && det1.val() > 1e-6) {
        return T::cst(0.0);
    }
    (det0 / (det1 + 1e-6) + 1e-6).sqrt()
}

/// Projects one Gaussian (the 3DGS preprocess step); `None` when culled.
pub fn project(g: &Gaussians3, i: usize, cam: &Camera, s: &RasterSettings) -> Option<Projected> {
    let rows = rotation_rows(cam);
    project_with(g, i, cam, &rows, s)
}

fn project_with(
    g: &Gaussians3,
    i: usize,
    cam: &Camera,
    rows: &[[f64; 3]; 3],
    s: &RasterSettings,
) -> Option<Projected> {
    let n = coeff_count(g.sh_degree);
    let p = project_t::<f64>(
        g.means[i].map(f64::from),
        g.scales[i].map(f64::from),
        g.rotations[i].map(f64::from),
        Some(&g.sh[i * n..(i + 1) * n]),
        g.sh_degree,
        cam,
        rows,
        s,
    )?;
    let op = match s.filter_2d {
        Filter2d::Dilate(_) => g.opacities[i],
        Filter2d::Mip { .. } => (g.opacities[i] as f64 * p.coef) as f32,
    };
    // o·G ≥ 1/255 ⇔ dᵀΣ'⁻¹d ≤ 2·ln(255·o); nothing is drawn when o < 1/255
    if op.is_nan() || op * 255.0 < 1.0 {
        return None;
    }
    let level = 2.0 * (255.0 * op as f64).ln();
    let ext = p
        .cov_diag
        .map(|c| ((level * c).sqrt() * (1.0 + 1e-4) + 1e-3) as f32);
    let nl = (p.normal[0] * p.normal[0] + p.normal[1] * p.normal[1] + p.normal[2] * p.normal[2])
        .sqrt()
        .max(1e-30);
    Some(Projected {
        id: i as u32,
        xy: p.xy.map(|v| v as f32),
        conic: p.conic.map(|v| v as f32),
        depth: p.depth as f32,
        radius: p.radius as f32,
        ext,
        power_cut: (-(255.0 * op as f64).ln() - 1e-4) as f32,
        opacity: op,
        rgb: p.rgb.map(|v| v.max(0.0) as f32),
        normal: p.normal.map(|v| (v / nl) as f32),
    })
}

/// The tiles a projected Gaussian is binned to on a `w × h` image: those of
/// the 3DGS kernel (`getRect` on the 3σ radius, [`tile_rect_cuda`]), cut to
/// the tiles its α ≥ 1/255 box touches (tiles outside it would only skip the
/// Gaussian, so the output is the kernel's); `None` when none is left.
#[inline]
pub(crate) fn tiles_of(p: &Projected, w: usize, h: usize) -> Option<[u32; 4]> {
    let r = p.radius;
    let kernel = tile_rect_cuda([p.xy[0] - r, p.xy[1] - r, p.xy[0] + r, p.xy[1] + r], w, h)?;
    let (rx, ry) = (r.min(p.ext[0]), r.min(p.ext[1]));
    let reach = tile_rect(
        [p.xy[0] - rx, p.xy[1] - ry, p.xy[0] + rx, p.xy[1] + ry],
        w,
        h,
    )?;
    intersect_rects(kernel, reach)
}

/// One pixel's outputs.
#[derive(Clone, Copy, Debug, Default)]
struct PixelOut {
    rgb: [f32; 3],
    alpha: f32,
    expected_depth: f32,
    median_depth: f32,
    normal: [f32; 3],
    normal_sum: [f32; 3],
    weight_sum: f32,
    count: u32,
    /// Transmittance left after the last blended contribution.
    final_t: f32,
    /// List position one past the last blended contribution.
    last: u32,
}

/// The rows of one tile row in each output array of [`blend_projected`],
/// so the tile rows land in parallel.
struct Band<'a> {
    rgb: &'a mut [[f32; 3]],
    alpha: &'a mut [f32],
    expected_depth: &'a mut [f32],
    median_depth: &'a mut [f32],
    normal: &'a mut [[f32; 3]],
    normal_sum: &'a mut [[f32; 3]],
    count: &'a mut [u32],
    final_t: &'a mut [f32],
    last: &'a mut [u32],
    weight_sum: &'a mut [f32],
}

/// The pixels of tile (tx, ty) that a projected Gaussian can reach:
/// inclusive column and row ranges in image coordinates, `None` if empty.
#[inline]
pub(crate) fn pixel_span(
    p: &Projected,
    tx: usize,
    ty: usize,
    w: usize,
    h: usize,
) -> Option<(usize, usize, usize, usize)> {
    let (x0, y0) = (tx * TILE, ty * TILE);
    let (x1, y1) = (((tx + 1) * TILE).min(w) - 1, ((ty + 1) * TILE).min(h) - 1);
    // pixel centres c = i + 0.5 with |c − μ| ≤ ext
    let lo = |m: f32, e: f32, a: usize| (m - e - 0.5).ceil().max(a as f32) as usize;
    let hi = |m: f32, e: f32, b: usize| {
        let v = (m + e - 0.5).floor();
        if v < 0.0 {
            None
        } else {
            Some((v as usize).min(b))
        }
    };
    let xa = lo(p.xy[0], p.ext[0], x0);
    let ya = lo(p.xy[1], p.ext[1], y0);
    let xb = hi(p.xy[0], p.ext[0], x1)?;
    let yb = hi(p.xy[1], p.ext[1], y1)?;
    (xa <= xb && ya <= yb).then_some((xa, xb, ya, yb))
}

/// The alpha of projected Gaussian `p` at offset (dx, dy) = μ − pixel
/// centre: min(0.99, o·exp(power)), or `None` where it is skipped (power
/// above 0, below the cut where α < 1/255 for sure, or α < 1/255).
#[inline]
fn alpha_at(p: &Projected, dx: f32, dy: f32) -> Option<f32> {
    let power = -0.5 * (p.conic[0] * dx * dx + p.conic[2] * dy * dy) - p.conic[1] * dx * dy;
    // also skips a NaN power (a degenerate conic), as the 8-lane blend does
    if !(power <= 0.0 && power >= p.power_cut) {
        return None;
    }
    let alpha = (p.opacity * crate::exp_approx::exp(power)).min(0.99);
    if alpha < 1.0 / 255.0 {
        None
    } else {
        Some(alpha)
    }
}

/// Per-pixel accumulators of one tile.
#[derive(Clone, Copy)]
struct Acc {
    t: f32,
    c: [f32; 3],
    nsum: [f32; 3],
    dsum: f32,
    wsum: f32,
    median: f32,
    n: u32,
    last: u32,
    done: bool,
}

/// Blends the sorted list of a tile for each of its pixels (row-major): 8
/// pixels at a time where the CPU has AVX2 (`gaussian_tile_avx2.rs`, the same
/// bits), else [`render_tile_scalar`].
fn render_tile(
    proj: &[Projected],
    list: &[u32],
    tx: usize,
    ty: usize,
    w: usize,
    h: usize,
    s: &RasterSettings,
) -> Vec<PixelOut> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 is present (checked just above).
        return unsafe { tile_avx2::render_tile(proj, list, tx, ty, w, h, s) };
    }
    render_tile_scalar(proj, list, tx, ty, w, h, s)
}

#[cfg(target_arch = "x86_64")]
#[path = "gaussian_tile_avx2.rs"]
mod tile_avx2;

/// The output of one pixel from its accumulators: final transmittance `t`,
/// Σ w·colour `c`, Σ w·normal `nsum`, Σ w·depth `dsum`, Σ w `wsum`, the median
/// depth, the number of contributions and one past the last one's position.
#[allow(clippy::too_many_arguments)]
#[inline]
fn pixel_out(
    t: f32,
    c: [f32; 3],
    nsum: [f32; 3],
    dsum: f32,
    wsum: f32,
    median: f32,
    n: u32,
    last: u32,
    s: &RasterSettings,
) -> PixelOut {
    let mut o = PixelOut {
        rgb: std::array::from_fn(|k| c[k] + t * s.background[k]),
        alpha: 1.0 - t,
        median_depth: median,
        count: n,
        final_t: t,
        last,
        normal_sum: nsum,
        weight_sum: wsum,
        ..Default::default()
    };
    if wsum > 0.0 {
        o.expected_depth = dsum / wsum;
        let l = (nsum[0] * nsum[0] + nsum[1] * nsum[1] + nsum[2] * nsum[2]).sqrt();
        if l > 0.0 {
            o.normal = nsum.map(|v| v / l);
        }
    }
    o
}

/// [`render_tile`] one pixel at a time.
///
/// Gaussian-major: each Gaussian visits only the pixels of its ellipse box;
/// every pixel still sees the contributions in list order with the same f32
/// operations as a per-pixel loop, so the result is the same.
fn render_tile_scalar(
    proj: &[Projected],
    list: &[u32],
    tx: usize,
    ty: usize,
    w: usize,
    h: usize,
    s: &RasterSettings,
) -> Vec<PixelOut> {
    let (x0, y0) = (tx * TILE, ty * TILE);
    let mut acc = [Acc {
        t: 1.0,
        c: [0.0; 3],
        nsum: [0.0; 3],
        dsum: 0.0,
        wsum: 0.0,
        median: 0.0,
        n: 0,
        last: 0,
        done: false,
    }; TILE * TILE];
    let pixels = (((tx + 1) * TILE).min(w) - x0) * (((ty + 1) * TILE).min(h) - y0);
    let mut active = pixels;
    for (li, &pi) in list.iter().enumerate() {
        if active == 0 {
            break;
        }
        prefetch_ahead(proj, list, li + PREFETCH_DISTANCE);
        let p = &proj[pi as usize];
        let Some((xa, xb, ya, yb)) = pixel_span(p, tx, ty, w, h) else {
            continue;
        };
        for y in ya..=yb {
            let py = y as f32 + 0.5;
            let dy = p.xy[1] - py;
            for x in xa..=xb {
                let a = &mut acc[(y - y0) * TILE + (x - x0)];
                if a.done {
                    continue;
                }
                let dx = p.xy[0] - (x as f32 + 0.5);
                let Some(alpha) = alpha_at(p, dx, dy) else {
                    continue;
                };
                let next = a.t * (1.0 - alpha);
                if next < 1e-4 {
                    a.done = true;
                    active -= 1;
                    continue;
                }
                let wgt = alpha * a.t;
                for k in 0..3 {
                    a.c[k] += p.rgb[k] * wgt;
                    a.nsum[k] += p.normal[k] * wgt;
                }
                a.dsum += p.depth * wgt;
                a.wsum += wgt;
                // 2DGS: the last contribution made while T before it > 0.5
                if a.t > 0.5 {
                    a.median = p.depth;
                }
                a.t = next;
                a.n += 1;
                a.last = li as u32 + 1;
            }
        }
    }
    let mut res = Vec::with_capacity(pixels);
    for (x, y) in tile_pixels(ty * w.div_ceil(TILE) + tx, w.div_ceil(TILE), w, h) {
        let a = &acc[(y - y0) * TILE + (x - x0)];
        res.push(pixel_out(
            a.t, a.c, a.nsum, a.dsum, a.wsum, a.median, a.n, a.last, s,
        ));
    }
    res
}

/// The colour (with the background blended in) of only the given pixels
/// (row-major offsets `y·width + x`), equal bit for bit to what [`render`]
/// gives at them. Instead of binning the whole scene into tiles, each
/// projected Gaussian is matched against the wanted pixels of the tiles its
/// box touches (the same tiles and the same pixel box test as the tile
/// lists); each pixel then sorts its own few Gaussians by the tile lists'
/// key (depth, then index) and blends them front to back with the same f32
/// operations and the same early stop. Cheap when few pixels are wanted.
pub fn render_pixels(
    g: &Gaussians3,
    cam: &Camera,
    s: &RasterSettings,
    pixels: &[u32],
) -> Vec<[f32; 3]> {
    let (w, h) = (cam.width as usize, cam.height as usize);
    let (tw, th) = (w.div_ceil(TILE), h.div_ceil(TILE));
    if tw == 0 || th == 0 || pixels.is_empty() {
        return vec![s.background; pixels.len()];
    }
    let rows = rotation_rows(cam);
    let proj: Vec<Projected> = (0..g.len())
        .into_par_iter()
        .filter_map(|i| project_with(g, i, cam, &rows, s))
        .collect();
    // the wanted pixels of each tile, as indices into `pixels` (CSR)
    let nt = tw * th;
    let tile_of = |o: usize| (o / w < h).then(|| (o / w / TILE) * tw + (o % w) / TILE);
    let mut start = vec![0usize; nt + 1];
    for &o in pixels {
        if let Some(t) = tile_of(o as usize) {
            start[t + 1] += 1;
        }
    }
    for t in 0..nt {
        start[t + 1] += start[t];
    }
    let mut at = start.clone();
    let mut slots = vec![0u32; start[nt]];
    for (k, &o) in pixels.iter().enumerate() {
        if let Some(t) = tile_of(o as usize) {
            slots[at[t]] = k as u32;
            at[t] += 1;
        }
    }
    // (wanted pixel, sort key) for every Gaussian that reaches it
    let pairs: Vec<(u32, u64)> = proj
        .par_iter()
        .enumerate()
        .fold(Vec::new, |mut acc, (pi, p)| {
            let Some([tx0, ty0, tx1, ty1]) = tiles_of(p, w, h) else {
                return acc;
            };
            let key = ((depth_key(p.depth) as u64) << 32) | pi as u64;
            for ty in ty0 as usize..=ty1 as usize {
                for tx in tx0 as usize..=tx1 as usize {
                    let t = ty * tw + tx;
                    for &k in &slots[start[t]..start[t + 1]] {
                        let o = pixels[k as usize] as usize;
                        if in_ext_box(p, o % w, o / w) {
                            acc.push((k, key));
                        }
                    }
                }
            }
            acc
        })
        .reduce(Vec::new, |mut a, mut b| {
            if a.len() < b.len() {
                std::mem::swap(&mut a, &mut b);
            }
            a.extend(b);
            a
        });
    // group by pixel (counting sort), then sort each pixel's keys
    let mut off = vec![0usize; pixels.len() + 1];
    for &(k, _) in &pairs {
        off[k as usize + 1] += 1;
    }
    for k in 0..pixels.len() {
        off[k + 1] += off[k];
    }
    let mut fill = off.clone();
    let mut keys = vec![0u64; pairs.len()];
    for &(k, key) in &pairs {
        keys[fill[k as usize]] = key;
        fill[k as usize] += 1;
    }
    drop(pairs);
    let mut lists: Vec<&mut [u64]> = Vec::with_capacity(pixels.len());
    let mut rest = &mut keys[..];
    for k in 0..pixels.len() {
        let (head, tail) = rest.split_at_mut(off[k + 1] - off[k]);
        lists.push(head);
        rest = tail;
    }
    lists
        .into_par_iter()
        .enumerate()
        .map(|(k, list)| {
            list.sort_unstable();
            let o = pixels[k] as usize;
            let (px, py) = ((o % w) as f32 + 0.5, (o / w) as f32 + 0.5);
            let (mut t, mut c) = (1.0f32, [0.0f32; 3]);
            for &key in list.iter() {
                let p = &proj[(key & 0xffff_ffff) as usize];
                let Some(alpha) = alpha_at(p, p.xy[0] - px, p.xy[1] - py) else {
                    continue;
                };
                let next = t * (1.0 - alpha);
                if next < 1e-4 {
                    break;
                }
                let wgt = alpha * t;
                for (ck, rk) in c.iter_mut().zip(p.rgb) {
                    *ck += rk * wgt;
                }
                t = next;
            }
            std::array::from_fn(|k| c[k] + t * s.background[k])
        })
        .collect()
}

/// Whether pixel (x, y) lies in the box [`pixel_span`] gives for `p`: for
/// an integer x, x ≥ ceil(v) ⟺ x ≥ v and x ≤ floor(v) ⟺ x ≤ v, with v the
/// same f32 expressions.
#[inline]
fn in_ext_box(p: &Projected, x: usize, y: usize) -> bool {
    let (fx, fy) = (x as f32, y as f32);
    fx >= p.xy[0] - p.ext[0] - 0.5
        && fx <= p.xy[0] + p.ext[0] - 0.5
        && fy >= p.xy[1] - p.ext[1] - 0.5
        && fy <= p.xy[1] + p.ext[1] - 0.5
}

/// What the forward pass keeps for the backward pass: the projected
/// Gaussians, the per-tile front-to-back lists and, per pixel, the final
/// transmittance, the list position past its last blended contribution, the
/// expected depth and the weight sum Σ w it was divided by.
#[derive(Clone, Debug, Default)]
pub struct RasterState {
    pub proj: Vec<Projected>,
    pub tiles: TileLists,
    pub final_t: Vec<f32>,
    pub last: Vec<u32>,
    /// Per pixel, [`RenderOutput::expected_depth`].
    pub expected_depth: Vec<f32>,
    /// Per pixel, Σ w (= 1 − T up to rounding), 0 where nothing was blended.
    pub weight_sum: Vec<f32>,
}

impl RasterState {
    /// Screen radius (pixels, ⌈3·√λ_max(Σ')⌉ as 3DGS's `radii`) of each of
    /// `count` Gaussians, 0 for those this view culled. Like 3DGS, a
    /// Gaussian counts as visible (radius > 0, its `visibility_filter`)
    /// when it passed the projection and the kernel's tile range of its
    /// 3σ box ([`crate::tiles::tile_rect_cuda`]) on the `width × height`
    /// image is not empty, even where no pixel blends it.
    pub fn radii(&self, count: usize, width: usize, height: usize) -> Vec<f32> {
        let mut out = vec![0.0f32; count];
        for p in &self.proj {
            let (x, y, r) = (p.xy[0], p.xy[1], p.radius);
            if tile_rect_cuda([x - r, y - r, x + r, y + r], width, height).is_some() {
                out[p.id as usize] = r;
            }
        }
        out
    }

    /// The visible Gaussians (as [`RasterState::radii`] counts them) with
    /// their screen radius in pixels, in projection order.
    pub fn visible_radii(
        &self,
        width: usize,
        height: usize,
    ) -> impl Iterator<Item = (usize, f32)> + '_ {
        self.proj.iter().filter_map(move |p| {
            let (x, y, r) = (p.xy[0], p.xy[1], p.radius);
            tile_rect_cuda([x - r, y - r, x + r, y + r], width, height).map(|_| (p.id as usize, r))
        })
    }
}

/// Renders `g` from `cam`.
pub fn render(g: &Gaussians3, cam: &Camera, s: &RasterSettings) -> RenderOutput {
    rasterize(g, cam, s).0
}

/// Renders `g` from `cam` and keeps what [`crate::gaussian_grad::backward`] needs.
pub fn rasterize(g: &Gaussians3, cam: &Camera, s: &RasterSettings) -> (RenderOutput, RasterState) {
    let (w, h) = (cam.width as usize, cam.height as usize);
    let rows = rotation_rows(cam);
    let proj: Vec<Projected> = (0..g.len())
        .into_par_iter()
        .filter_map(|i| project_with(g, i, cam, &rows, s))
        .collect();
    blend_projected(proj, w, h, s)
}

/// Bins and blends already projected Gaussians on a `w × h` image: the
/// second half of [`rasterize`] (tests perturb the projection through it).
pub(crate) fn blend_projected(
    proj: Vec<Projected>,
    w: usize,
    h: usize,
    s: &RasterSettings,
) -> (RenderOutput, RasterState) {
    let (tw, th) = (w.div_ceil(TILE), h.div_ceil(TILE));
    if tw == 0 || th == 0 {
        return (
            RenderOutput {
                width: w,
                height: h,
                ..Default::default()
            },
            RasterState::default(),
        );
    }
    // Gaussians whose 3σ box touches the tile, front to back
    let tiles = TileLists::build(&proj, |p| tiles_of(p, w, h), |p| p.depth, w, h);
    let mut out = RenderOutput {
        width: w,
        height: h,
        rgb: vec![[0.0; 3]; w * h],
        alpha: vec![0.0; w * h],
        expected_depth: vec![0.0; w * h],
        median_depth: vec![0.0; w * h],
        normal: vec![[0.0; 3]; w * h],
        normal_sum: vec![[0.0; 3]; w * h],
        count: vec![0; w * h],
    };
    let mut final_t = vec![1.0f32; w * h];
    let mut last = vec![0u32; w * h];
    let mut weight_sum = vec![0.0f32; w * h];
    let band = w * TILE;
    let mut rgb = out.rgb.chunks_mut(band);
    let mut alpha = out.alpha.chunks_mut(band);
    let mut expected_depth = out.expected_depth.chunks_mut(band);
    let mut median_depth = out.median_depth.chunks_mut(band);
    let mut normal = out.normal.chunks_mut(band);
    let mut normal_sum = out.normal_sum.chunks_mut(band);
    let mut count = out.count.chunks_mut(band);
    let mut final_t_rows = final_t.chunks_mut(band);
    let mut last_rows = last.chunks_mut(band);
    let mut weight_sum_rows = weight_sum.chunks_mut(band);
    let bands: Vec<Band> = (0..th)
        .map(|_| Band {
            rgb: rgb.next().expect("one band per tile row"),
            alpha: alpha.next().expect("one band per tile row"),
            expected_depth: expected_depth.next().expect("one band per tile row"),
            median_depth: median_depth.next().expect("one band per tile row"),
            normal: normal.next().expect("one band per tile row"),
            normal_sum: normal_sum.next().expect("one band per tile row"),
            count: count.next().expect("one band per tile row"),
            final_t: final_t_rows.next().expect("one band per tile row"),
            last: last_rows.next().expect("one band per tile row"),
            weight_sum: weight_sum_rows.next().expect("one band per tile row"),
        })
        .collect();
    render_tile_rows(
        tw,
        w,
        h,
        bands,
        |ti| render_tile(&proj, tiles.list(ti), ti % tw, ti / tw, w, h, s),
        |b, o, p| {
            b.rgb[o] = p.rgb;
            b.alpha[o] = p.alpha;
            b.expected_depth[o] = p.expected_depth;
            b.median_depth[o] = p.median_depth;
            b.normal[o] = p.normal;
            b.normal_sum[o] = p.normal_sum;
            b.count[o] = p.count;
            b.final_t[o] = p.final_t;
            b.last[o] = p.last;
            b.weight_sum[o] = p.weight_sum;
        },
    );
    let state = RasterState {
        proj,
        tiles,
        final_t,
        last,
        expected_depth: out.expected_depth.clone(),
        weight_sum,
    };
    (out, state)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::rgb_to_sh;
    use crate::testutil::test_camera as camera;

    fn one(mean: [f32; 3], scale: [f32; 3], opacity: f32, rgb: [f32; 3]) -> Gaussians3 {
        Gaussians3 {
            means: vec![mean],
            scales: vec![scale],
            rotations: vec![[1.0, 0.0, 0.0, 0.0]],
            opacities: vec![opacity],
            sh: vec![rgb.map(rgb_to_sh)],
            sh_degree: 0,
        }
    }

    /// One Gaussian on the optical axis, isotropic across the view (σ, σ)
    /// and thinner along it: the Jacobian's depth column vanishes on the axis,
    /// so the image is the closed-form 2-D Gaussian with variance
    /// (f σ / z)² + 0.3 pixels², weighted by the opacity, cut where α < 1/255;
    /// its normal is the view axis turned to the camera.
    #[test]
    fn isotropic_gaussian_is_the_closed_form() {
        let cam = camera(64, 48, 100.0);
        let (z, sigma, op) = (5.0f32, 0.2f32, 0.8f32);
        let g = one(
            [0.0, 0.0, z],
            [sigma, sigma, 0.5 * sigma],
            op,
            [1.0, 0.5, 0.25],
        );
        let img = render(&g, &cam, &RasterSettings::default());
        let var = (100.0 * sigma / z).powi(2) as f64 + 0.3;
        for y in 0..48 {
            for x in 0..64 {
                let (dx, dy) = (32.0 - (x as f64 + 0.5), 24.0 - (y as f64 + 0.5));
                let a = (op as f64 * (-0.5 * (dx * dx + dy * dy) / var).exp()).min(0.99);
                let want = if a < 1.0 / 255.0 { 0.0 } else { a };
                let got = img.alpha[y * 64 + x] as f64;
                // f32 arithmetic in the rasteriser: agreement to 1e-5
                assert!((got - want).abs() < 1e-5, "({x},{y}) {got} vs {want}");
                assert!((img.rgb[y * 64 + x][1] as f64 - 0.5 * want).abs() < 1e-5);
            }
        }
        // expected and median depth of a single splat are its depth
        let c = 24 * 64 + 32;
        assert!((img.expected_depth[c] - z).abs() < 1e-5);
        assert_eq!(img.median_depth[c], z, "α = 0.8 takes T below 0.5");
        assert_eq!(img.count[c], 1);
        assert_eq!(img.normal[c], [0.0, 0.0, -1.0]);
    }

    /// Two overlapping layers: C = c1 α1 + c2 α2 (1 − α1) + bg (1−α1)(1−α2),
    /// whatever the order they are given in.
    #[test]
    fn two_layers_composite_front_to_back() {
        let cam = camera(32, 32, 50.0);
        let mut g = one([0.0, 0.0, 4.0], [10.0, 10.0, 0.01], 0.6, [1.0, 0.0, 0.0]);
        let back = one([0.0, 0.0, 2.0], [10.0, 10.0, 0.01], 0.55, [0.0, 0.0, 1.0]);
        g.means.extend(back.means);
        g.scales.extend(back.scales);
        g.rotations.extend(back.rotations);
        g.opacities.extend(back.opacities);
        g.sh.extend(back.sh);
        let s = RasterSettings {
            background: [0.0, 1.0, 0.0],
            ..Default::default()
        };
        let img = render(&g, &cam, &s);
        // wide, flat splats: α ≈ opacity at the centre (exp(−tiny))
        let c = 16 * 32 + 16;
        let (a1, a2) = (0.55f32, 0.6f32); // front (z 2, blue), back (z 4, red)
        let want = [a2 * (1.0 - a1), (1.0 - a1) * (1.0 - a2), a1];
        for k in 0..3 {
            assert!(
                (img.rgb[c][k] - want[k]).abs() < 1e-3,
                "{:?} vs {want:?}",
                img.rgb[c]
            );
        }
        // T falls from 1 to 0.45 at the front layer: the median depth is 2
        assert_eq!(img.median_depth[c], 2.0);
        let ed = (a1 * 2.0 + a2 * (1.0 - a1) * 4.0) / (a1 + a2 * (1.0 - a1));
        assert!((img.expected_depth[c] - ed).abs() < 1e-3);
        assert_eq!(img.count[c], 2);
    }

    /// Median depth as the 2DGS kernel keeps it: the depth of the last
    /// contribution made while the transmittance before it is above 0.5.
    /// Three wide layers of opacity 0.3 at z = 2, 3, 4: T before each is 1,
    /// 0.7, 0.49, so the median is 3 (not 0: T never crosses 0.5 at a
    /// contribution's end before the third); one layer alone (final alpha
    /// 0.3 < 0.5) has its own depth; an uncovered pixel has 0.
    #[test]
    fn median_depth_follows_the_kernel_rule() {
        let cam = camera(32, 32, 50.0);
        let layer = |z: f32| one([0.0, 0.0, z], [10.0, 10.0, 0.01], 0.3, [1.0; 3]);
        let mut g = layer(4.0);
        for z in [2.0, 3.0] {
            let l = layer(z);
            g.means.extend(l.means);
            g.scales.extend(l.scales);
            g.rotations.extend(l.rotations);
            g.opacities.extend(l.opacities);
            g.sh.extend(l.sh);
        }
        let c = 16 * 32 + 16;
        let img = render(&g, &cam, &RasterSettings::default());
        assert_eq!(img.count[c], 3);
        assert_eq!(img.median_depth[c], 3.0);
        let single = render(&layer(2.5), &cam, &RasterSettings::default());
        assert!(single.alpha[c] < 0.31);
        assert_eq!(single.median_depth[c], 2.5);
        let small = one([0.0, 0.0, 4.0], [0.05, 0.05, 0.01], 0.9, [1.0; 3]);
        let img = render(&small, &cam, &RasterSettings::default());
        assert_eq!(img.count[0], 0);
        assert_eq!(img.median_depth[0], 0.0);
    }

    /// A plane of flat splats at depth z: median and expected depth equal z
    /// wherever the plane covers the pixel.
    #[test]
    fn plane_of_splats_has_its_depth() {
        let cam = camera(40, 40, 40.0);
        let mut g = Gaussians3 {
            sh_degree: 0,
            ..Default::default()
        };
        let z = 3.0f32;
        for j in -12..=12 {
            for i in -12..=12 {
                g.means.push([i as f32 * 0.1, j as f32 * 0.1, z]);
                g.scales.push([0.08, 0.08, 0.001]);
                g.rotations.push([1.0, 0.0, 0.0, 0.0]);
                g.opacities.push(0.9);
                g.sh.push([0.0; 3]);
            }
        }
        let img = render(&g, &cam, &RasterSettings::default());
        for y in 10..30 {
            for x in 10..30 {
                let o = y * 40 + x;
                assert!(img.alpha[o] > 0.99);
                assert_eq!(img.median_depth[o], z);
                assert!((img.expected_depth[o] - z).abs() < 1e-5);
            }
        }
    }

    /// `n` random Gaussians in front of [`camera`] (seeded [`crate::testutil::Lcg`]):
    /// anisotropic, randomly rotated, 30 % fully opaque and the rest of any
    /// opacity, random SH of degree `sh_degree`.
    fn random_gaussians(seed: u64, n: usize, sh_degree: usize) -> Gaussians3 {
        let mut r = crate::testutil::Lcg(seed);
        let mut g = Gaussians3 {
            sh_degree,
            ..Default::default()
        };
        for _ in 0..n {
            g.means
                .push([r.range(-3.0, 3.0), r.range(-2.0, 2.0), r.range(2.0, 6.0)]);
            g.scales
                .push([r.range(0.01, 0.4), r.range(0.005, 0.1), r.range(0.001, 0.3)]);
            g.rotations.push([
                r.range(-1.0, 1.0),
                r.range(-1.0, 1.0),
                r.range(-1.0, 1.0),
                r.range(-1.0, 1.0),
            ]);
            g.opacities.push(if r.next_f64() < 0.3 {
                1.0
            } else {
                r.range(0.0, 1.0)
            });
            for _ in 0..coeff_count(sh_degree) {
                g.sh.push([r.range(-0.5, 0.5), r.range(-0.5, 0.5), r.range(-0.5, 0.5)]);
            }
        }
        g
    }

    /// The 8-lane tile blend gives every output of every pixel bit for bit
    /// as the scalar one: 4 random scenes of 300–1,200 Gaussians (opaque and
    /// faint, thin and wide, so pixels stop early, boxes cut groups of 8 and
    /// tiles saturate) on an image whose last tile column and row are partial.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_tile_equals_the_scalar_tile() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("skipped: no AVX2 on this CPU");
            return;
        }
        let bits = |o: &PixelOut| {
            let f = [
                o.rgb[0],
                o.rgb[1],
                o.rgb[2],
                o.alpha,
                o.expected_depth,
                o.median_depth,
                o.normal[0],
                o.normal[1],
                o.normal[2],
                o.normal_sum[0],
                o.normal_sum[1],
                o.normal_sum[2],
                o.weight_sum,
                o.final_t,
            ];
            (f.map(f32::to_bits), o.count, o.last)
        };
        let (w, h) = (83, 61);
        let cam = camera(w as u32, h as u32, 70.0);
        let s = RasterSettings {
            background: [0.1, 0.3, 0.7],
            ..Default::default()
        };
        let mut compared = 0usize;
        for seed in 0..4 {
            let g = random_gaussians(10 + seed, 300 * (seed as usize + 1), 0);
            let rows = rotation_rows(&cam);
            let proj: Vec<Projected> = (0..g.len())
                .filter_map(|i| project_with(&g, i, &cam, &rows, &s))
                .collect();
            let tiles = TileLists::build(&proj, |p| tiles_of(p, w, h), |p| p.depth, w, h);
            for t in 0..tiles.len() {
                let (tx, ty) = (t % tiles.tiles_x, t / tiles.tiles_x);
                let a = render_tile_scalar(&proj, tiles.list(t), tx, ty, w, h, &s);
                // SAFETY: AVX2 checked above.
                let b = unsafe { tile_avx2::render_tile(&proj, tiles.list(t), tx, ty, w, h, &s) };
                assert_eq!(a.len(), b.len());
                for (i, (pa, pb)) in a.iter().zip(&b).enumerate() {
                    assert_eq!(bits(pa), bits(pb), "seed {seed}, tile {t}, pixel {i}");
                }
                compared += a.len();
            }
        }
        assert_eq!(compared, 4 * w * h);
    }

    /// The tile-and-span machinery (opacity-aware tile boxes, per-Gaussian
    /// pixel spans, the exponent cut, the global depth sort) is a speed-up
    /// only: the image equals, bit for bit, a plain per-pixel loop over the
    /// reference's tile lists (3DGS `getRect` of the 3σ radius) on a random scene with thin,
    /// elongated, opaque and faint Gaussians.
    #[test]
    fn fast_path_equals_the_plain_loop() {
        let cam = camera(80, 56, 70.0);
        let g = random_gaussians(4, 400, 1);
        let s = RasterSettings::default();
        let img = render(&g, &cam, &s);
        // the per-pixel colour path equals the full render, bit for bit, in
        // any pixel order and with a background blended in
        let s2 = RasterSettings {
            background: [0.2, 0.5, 0.9],
            ..s
        };
        let full = render(&g, &cam, &s2).rgb;
        let mut order: Vec<u32> = (0..80 * 56).rev().step_by(3).collect();
        order.extend([order[7], order[7], 80 * 56 + 3]); // repeats, one past the image
        let part = render_pixels(&g, &cam, &s2, &order);
        for (k, &o) in order.iter().enumerate() {
            let want = full.get(o as usize).copied().unwrap_or(s2.background);
            assert_eq!(part[k], want, "pixel {o}");
        }
        let rows = rotation_rows(&cam);
        let mut proj: Vec<Projected> = (0..g.len())
            .filter_map(|i| project_with(&g, i, &cam, &rows, &s))
            .collect();
        proj.sort_by(|a, b| a.depth.total_cmp(&b.depth).then(a.id.cmp(&b.id)));
        // 3DGS getRect, in its pixel coordinates (centres at integers, ours
        // − 0.5): tiles [(int)((x − r)/16), (int)((x + r + 15)/16)), ≥ 0
        let tile_of = |p: &Projected, tx: usize, ty: usize| {
            let r = p.radius;
            let lo = |v: f32| ((v - 0.5 - r) / 16.0).max(0.0) as usize;
            let hi = |v: f32| ((v - 0.5 + r + 15.0) / 16.0).max(0.0) as usize;
            (lo(p.xy[0])..hi(p.xy[0])).contains(&tx) && (lo(p.xy[1])..hi(p.xy[1])).contains(&ty)
        };
        for y in 0..56 {
            for x in 0..80 {
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let (mut t, mut c) = (1.0f32, [0.0f32; 3]);
                for p in proj.iter().filter(|p| tile_of(p, x / TILE, y / TILE)) {
                    let (dx, dy) = (p.xy[0] - px, p.xy[1] - py);
                    let power =
                        -0.5 * (p.conic[0] * dx * dx + p.conic[2] * dy * dy) - p.conic[1] * dx * dy;
                    if power > 0.0 {
                        continue;
                    }
                    let alpha = (p.opacity * crate::exp_approx::exp(power)).min(0.99);
                    if alpha < 1.0 / 255.0 {
                        continue;
                    }
                    let next = t * (1.0 - alpha);
                    if next < 1e-4 {
                        break;
                    }
                    let wgt = alpha * t;
                    for (ck, rk) in c.iter_mut().zip(p.rgb) {
                        *ck += rk * wgt;
                    }
                    t = next;
                }
                let o = y * 80 + x;
                assert_eq!(img.alpha[o], 1.0 - t, "({x},{y})");
                assert_eq!(img.rgb[o], c, "({x},{y})");
            }
        }
    }
}
