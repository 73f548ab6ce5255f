//! Forward rasteriser for 2D Gaussian surfels with the semantics of 2DGS's
//! CUDA rasteriser (Huang et al. 2024, `hbb1/diff-surfel-rasterization`,
//! commit e0ed020), on the CPU.
//!
//! A surfel is a flat Gaussian disc: centre μ, rotation R (quaternion
//! (w, x, y, z), normalised here), two activated scales (s_u, s_v). Its
//! tangent axes are R's first two columns, its normal the third.
//!
//! Per surfel (CUDA `preprocessCUDA` in `forward.cu`):
//! - camera-space centre c = R_cam·μ + t; culled when c.z ≤ `near`
//!   (`in_frustum` in `auxiliary.h`: 0.2; compared in f32 as there);
//! - the splat-to-pixel homography `T` (`compute_transmat`): the 3×3 matrix
//!   whose rows (T_u, T_v, T_w) map the tangent-plane point (u, v, 1) to
//!   homogeneous pixel coordinates (x·w, y·w, w), w = camera z:
//!   columns K·R_cam·(m s_u R₀), K·R_cam·(m s_v R₁), K·c, with K the
//!   intrinsics and m `scale_modifier`;
//! - the normal n = R_cam·R₂, turned to face the camera: flipped when
//!   n·c > 0, and the surfel culled when n·c = 0 exactly
//!   (`DUAL_VISIABLE` in `preprocessCUDA`);
//! - the screen box (`compute_aabb`, cutoff 3): with
//!   f = (9, 9, −1)/((9, 9, −1)·(T_w ∘ T_w)) (culled when the denominator
//!   is 0), centre p = (f·(T_u ∘ T_w), f·(T_v ∘ T_w)), half-extent
//!   h = √max(10⁻⁴, p² − (f·(T_u ∘ T_u), f·(T_v ∘ T_v))), radius
//!   ⌈max(h_x, h_y, 3·0.707106)⌉ (`FilterSize`);
//! - tiles: the kernel's `getRect` of (p ± radius) on 16×16 tiles
//!   ([`crate::tiles::tile_rect_cuda`]); an empty range culls the surfel;
//! - colour from SH (degree 0–3, `computeColorFromSH`) in the direction from
//!   the camera centre to μ, + 0.5, clamped at 0 (no upper clamp);
//! - sort key: c.z (the view depth of the centre), ties by index.
//!
//! Per pixel (CUDA `renderCUDA`), surfels of the pixel's tile front to back:
//! - the two planes k = x·T_w − T_u, l = y·T_w − T_v through the pixel's
//!   ray; their intersection in the tangent plane p = k × l, skipped when
//!   p_z = 0; (u, v) = (p_x, p_y)/p_z;
//! - ρ₃ = u² + v², ρ₂ = 2·|p_box − pixel|² (`FilterInvSquare` = 2: the
//!   low-pass filter, centred on the box centre p, not on the projected
//!   μ), ρ = min(ρ₃, ρ₂);
//! - depth of the intersection z = u·T_w,x + v·T_w,y + T_w,z (camera z);
//!   skipped when z < `near` (`near_n` = 0.2);
//! - α = min(0.99, o·exp(−ρ/2)), skipped when α < 1/255; a surfel whose
//!   contribution would take the transmittance T below 10⁻⁴ is not blended
//!   and ends the pixel; weights w = α·T;
//! - C = Σ w c + T·background, alpha = 1 − T, D = Σ w z, N = Σ w n;
//!   median depth: the z of the last contribution made while the
//!   transmittance before it was above 0.5 (0 where none);
//!   distortion (`RENDER_AXUTILITY`): with m = far/(far − near)·(1 − near/z)
//!   (`far_n` = 100), Σ w·(m²·(1 − T) + M₂ − 2m·M₁) with M₁ = Σ w m and
//!   M₂ = Σ w m² of the contributions in front.
//!
//! Outputs ([`RenderOutput`]): `rgb`, `alpha`; `expected_depth` = D / alpha,
//! 0 where alpha = 0 (the Python renderer's `render_depth_expected`, with
//! `nan_to_num`); `median_depth`; `normal_sum` = N, camera axes, not
//! normalised (2DGS's `rend_normal` before its rotation to world axes);
//! `normal` = N/|N|; `count` = the number of blended contributions.
//! [`RenderOutput::surface_depth`] then gives 2DGS's
//! `surf_depth = expected·(1 − ratio) + median·ratio` exactly. The
//! distortion map (`rend_dist`) is in [`SurfelState::distortion`].
//!
//! Departures from the CUDA code, all deliberate:
//! - pixel centres: ours at (i + 0.5, j + 0.5) (OpenCV), the kernel's at
//!   integers with the principal point at ((W − 1)/2, (H − 1)/2) (its
//!   `ndc2pix`); the two give the same k, l and box in exact arithmetic
//!   (T_u, T_v and the box centre shift by ½·T_w and ½, which cancel), so
//!   only f32 rounding differs. The kernel's projection matrix puts the
//!   principal point at the image centre; ours uses the camera's cx, cy;
//! - T, the box, the normal and the colour are computed in f64 and rounded
//!   to f32 (the kernel: f32 throughout, through the NDC matrices); the
//!   per-pixel blending is in f32 with the kernel's operations and order;
//! - a zero or non-finite quaternion gives the identity rotation (the
//!   kernel: NaN), as the Gaussian rasteriser does; surfels with a NaN
//!   opacity or a non-finite centre, T or box are culled;
//! - speed only, same output: each surfel is binned to the kernel's tiles
//!   cut to a box outside which its α < 1/255 for certain, and visits only
//!   the pixels of that box (tested bit-equal to the kernel's plain
//!   per-pixel loop over its own tile lists).
//!
//! Checked against an independent NumPy re-implementation of the kernel's
//! rules (`scripts/compare/surfel_reference.py`, fixture
//! `render/tests/data/surfel_reference.txt`, test
//! `render/tests/surfel_reference.rs`).

use rayon::prelude::*;

use crate::Camera;
use crate::dual::{Real, sh_rgb};
use crate::gaussian::{RenderOutput, quat_matrix, rotation_rows};
use crate::sh::coeff_count;
pub use crate::splats::Splats;
use crate::tiles::{
    PREFETCH_DISTANCE, TILE, TileLists, intersect_rects, prefetch_ahead, render_tiles, tile_pixels,
    tile_rect, tile_rect_cuda,
};

/// `compute_aabb`'s cutoff (the kernel's `cutoff` without `TIGHTBBOX`), in
/// standard deviations.
pub const CUTOFF: f64 = 3.0;
/// The kernel's `FilterSize` (√2/2 as written there): the box radius is at
/// least ⌈`CUTOFF`·`FILTER_SIZE`⌉ = 3 pixels.
#[allow(clippy::approx_constant)] // the kernel's truncated literal, on purpose
pub const FILTER_SIZE: f64 = 0.707106;
/// The kernel's `FilterInvSquare`: the low-pass exponent is
/// 2·|p_box − pixel|² (a Gaussian of variance ½ pixel²).
pub const FILTER_INV_SQUARE: f32 = 2.0;
/// Transmittance at which a pixel stops (`test_T < 0.0001`).
pub const T_STOP: f32 = 1e-4;

/// 2D Gaussian surfels as the rasteriser wants them: activated values (two
/// tangent scale axes; the rotation's columns 0 and 1 are the tangent axes,
/// column 2 the normal; see [`Splats`]).
pub type Surfels2 = Splats<2>;

/// Rasteriser settings; the default is 2DGS's.
#[derive(Clone, Copy, Debug)]
pub struct SurfelSettings {
    /// Background colour (2DGS: black, or white with `--white_background`).
    pub background: [f32; 3],
    /// Near plane, camera z: surfels whose centre is at or before it are
    /// culled and ray–splat intersections before it are skipped (the
    /// kernel's hard-coded 0.2, `near_n`).
    pub near: f64,
    /// Far plane of the distortion map's depth mapping (the kernel's
    /// `far_n`, 100); it culls nothing.
    pub far: f64,
    /// Multiplies both scales (2DGS's `scaling_modifier`, 1).
    pub scale_modifier: f32,
}

impl Default for SurfelSettings {
    fn default() -> Self {
        SurfelSettings {
            background: [0.0; 3],
            near: 0.2,
            far: 100.0,
            scale_modifier: 1.0,
        }
    }
}

/// One projected surfel (the kernel's per-surfel buffers).
#[derive(Clone, Copy, Debug)]
pub struct ProjectedSurfel {
    /// Index of the surfel.
    pub id: u32,
    /// Rows of the splat-to-pixel homography T (OpenCV pixel coordinates):
    /// (x·w, y·w, w) = (T_u, T_v, T_w)·(u, v, 1).
    pub tu: [f32; 3],
    pub tv: [f32; 3],
    pub tw: [f32; 3],
    /// Centre of the screen box (`compute_aabb`'s `point_image`), OpenCV
    /// pixel coordinates; the low-pass filter is centred here.
    pub xy: [f32; 2],
    /// Box radius in pixels (an integer, ≥ 3; the kernel's `radii`).
    pub radius: f32,
    /// A screen box (x0, y0, x1, y1), OpenCV pixel coordinates, outside
    /// which the surfel's α is below 1/255 for certain (see `reach_box`):
    /// pixels and tiles outside it are not visited (same output, less
    /// work). Infinite when the α ≥ 1/255 region is unbounded; empty
    /// (x0 > x1) when the opacity is below 1/255.
    pub reach: [f32; 4],
    /// View depth (camera z) of the centre: the sort key.
    pub depth: f32,
    /// Unit normal in camera axes, facing the camera.
    pub normal: [f32; 3],
    pub opacity: f32,
    /// SH colour + 0.5, clamped at 0.
    pub rgb: [f32; 3],
}

/// The differentiable part of a surfel's projection, generic so that the
/// backward pass gets its Jacobian from the same code (see [`crate::dual`]).
pub(crate) struct SurfelProjT<T> {
    /// Rows T_u, T_v, T_w.
    pub t: [[T; 3]; 3],
    /// Box centre.
    pub xy: [T; 2],
    /// Camera-space normal facing the camera (the flip is decided on the
    /// values and carries no derivative).
    pub normal: [T; 3],
    /// SH colour + 0.5, before the clamp at 0.
    pub rgb: [T; 3],
    /// Camera z of the centre.
    pub depth: f64,
    pub radius: f64,
}

/// Projects one surfel (the CUDA `preprocessCUDA` step up to the tile
/// range), `None` when culled. `sh = None` leaves the colour at 0 (for a
/// caller that differentiates it separately).
#[allow(clippy::too_many_arguments)]
pub(crate) fn project_t<T: Real>(
    mean: [T; 3],
    scale: [T; 2],
    quat: [T; 4],
    sh: Option<&[[f32; 3]]>,
    sh_degree: usize,
    cam: &Camera,
    rows: &[[f64; 3]; 3],
    s: &SurfelSettings,
) -> Option<SurfelProjT<T>> {
    let tr = cam.translation;
    let c: [T; 3] = std::array::from_fn(|i| {
        mean[0] * rows[i][0] + mean[1] * rows[i][1] + mean[2] * rows[i][2] + tr[i]
    });
    let z = c[2].val();
    // the kernel compares its f32 view z with 0.2f
    if (z as f32) <= s.near as f32 || !z.is_finite() {
        return None;
    }
    let qn = (quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2] + quat[3] * quat[3]).sqrt();
    let q = if qn.val() > 0.0 && qn.val().is_finite() {
        quat.map(|v| v / qn)
    } else {
        [T::cst(1.0), T::cst(0.0), T::cst(0.0), T::cst(0.0)]
    };
    let r = quat_matrix(q);
    let m = s.scale_modifier as f64;
    // camera-space tangent axes (scaled) and normal
    let axis = |k: usize, f: T| -> [T; 3] {
        std::array::from_fn(|i| {
            (r[0][k] * rows[i][0] + r[1][k] * rows[i][1] + r[2][k] * rows[i][2]) * f
        })
    };
    let cu = axis(0, scale[0] * m);
    let cv = axis(1, scale[1] * m);
    let n = axis(2, T::cst(1.0));
    // T = K [cu cv c], as rows
    let (fx, fy, cx, cy) = (cam.fx, cam.fy, cam.cx, cam.cy);
    let t = [
        [
            cu[0] * fx + cu[2] * cx,
            cv[0] * fx + cv[2] * cx,
            c[0] * fx + c[2] * cx,
        ],
        [
            cu[1] * fy + cu[2] * cy,
            cv[1] * fy + cv[2] * cy,
            c[1] * fy + c[2] * cy,
        ],
        [cu[2], cv[2], c[2]],
    ];
    if t.iter().flatten().any(|v| !v.val().is_finite()) {
        return None;
    }
    // DUAL_VISIABLE: face the camera; cull when seen exactly edge-on
    let cos = -(n[0].val() * c[0].val() + n[1].val() * c[1].val() + n[2].val() * c[2].val());
    if cos == 0.0 || cos.is_nan() {
        return None;
    }
    let normal = if cos > 0.0 { n } else { n.map(|v| -v) };
    // compute_aabb
    let c2 = CUTOFF * CUTOFF;
    let tw = t[2];
    let d = (tw[0] * tw[0] + tw[1] * tw[1]) * c2 - tw[2] * tw[2];
    if d.val() == 0.0 || !d.val().is_finite() {
        return None;
    }
    let f = [T::cst(c2) / d, T::cst(c2) / d, T::cst(-1.0) / d];
    let fdot = |a: [T; 3], b: [T; 3]| f[0] * a[0] * b[0] + f[1] * a[1] * b[1] + f[2] * a[2] * b[2];
    let xy = [fdot(t[0], tw), fdot(t[1], tw)];
    let h0 = [
        xy[0].val() * xy[0].val() - fdot(t[0], t[0]).val(),
        xy[1].val() * xy[1].val() - fdot(t[1], t[1]).val(),
    ];
    let h = h0.map(|v| v.max(1e-4).sqrt());
    let radius = h[0].max(h[1]).max(CUTOFF * FILTER_SIZE).ceil();
    if !(radius.is_finite() && xy[0].val().is_finite() && xy[1].val().is_finite()) {
        return None;
    }
    let rgb = match sh {
        Some(sh) => sh_rgb(mean, cam.center().to_array(), sh, sh_degree),
        None => [T::cst(0.0); 3],
    };
    Some(SurfelProjT {
        t,
        xy,
        normal,
        rgb,
        depth: z,
        radius,
    })
}

/// The kernel's tile range (`getRect` of the box centre ± radius) of a
/// projected surfel on a `w × h` image.
#[inline]
pub(crate) fn kernel_tiles(p: &ProjectedSurfel, w: usize, h: usize) -> Option<[u32; 4]> {
    let r = p.radius;
    tile_rect_cuda([p.xy[0] - r, p.xy[1] - r, p.xy[0] + r, p.xy[1] + r], w, h)
}

/// The tiles a projected surfel is binned to: the kernel's range
/// ([`kernel_tiles`]) cut to the tiles its [`ProjectedSurfel::reach`]
/// touches (elsewhere it would only be skipped, so the output is the
/// kernel's); `None` when none is left.
#[inline]
pub(crate) fn tiles_of(p: &ProjectedSurfel, w: usize, h: usize) -> Option<[u32; 4]> {
    intersect_rects(kernel_tiles(p, w, h)?, tile_rect(p.reach, w, h)?)
}

/// A screen box outside which a surfel with homography rows `t`, box
/// centre `xy` and opacity `op` has α = min(0.99, o·exp(−ρ/2)) < 1/255,
/// i.e. ρ = min(ρ₃, ρ₂) > ρ_max = 2·ln(255·o): the union of the box of the
/// circle ρ₂ ≤ ρ_max (radius √(ρ_max/2) about `xy`) and the box of the
/// projected disc u² + v² ≤ ρ_max, which is `compute_aabb`'s formula with
/// the cutoff √ρ_max (exact for a disc wholly in front of the camera,
/// c²·(T_w,x² + T_w,y²) < T_w,z²; otherwise the region is unbounded and the
/// box infinite). Widened by 1e-3 relative and 0.05 pixels so that the f32
/// rounding of the per-pixel evaluation cannot reach past it (the fast
/// path is tested equal, bit for bit, to the plain per-pixel loop).
fn reach_box(t: &[[f64; 3]; 3], xy: [f64; 2], op: f32) -> [f32; 4] {
    let op = op as f64;
    if op.is_nan() || op * 255.0 < 1.0 {
        return [
            f32::INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
        ];
    }
    let rho_max = 2.0 * (255.0 * op).ln();
    let r2 = (0.5 * rho_max).sqrt() * (1.0 + 1e-3) + 0.05;
    let circle = [xy[0] - r2, xy[1] - r2, xy[0] + r2, xy[1] + r2];
    let [tu, tv, tw] = *t;
    let d = rho_max * (tw[0] * tw[0] + tw[1] * tw[1]) - tw[2] * tw[2];
    if d.is_nan() || d >= 0.0 {
        return [
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
            f32::INFINITY,
            f32::INFINITY,
        ];
    }
    let f = [rho_max / d, rho_max / d, -1.0 / d];
    let fdot =
        |a: [f64; 3], b: [f64; 3]| f[0] * a[0] * b[0] + f[1] * a[1] * b[1] + f[2] * a[2] * b[2];
    let c = [fdot(tu, tw), fdot(tv, tw)];
    let hx = (c[0] * c[0] - fdot(tu, tu)).max(0.0).sqrt() * (1.0 + 1e-3) + 0.05;
    let hy = (c[1] * c[1] - fdot(tv, tv)).max(0.0).sqrt() * (1.0 + 1e-3) + 0.05;
    let b = [
        (c[0] - hx).min(circle[0]),
        (c[1] - hy).min(circle[1]),
        (c[0] + hx).max(circle[2]),
        (c[1] + hy).max(circle[3]),
    ];
    if b.iter().all(|v| v.is_finite()) {
        b.map(|v| v as f32)
    } else {
        [
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
            f32::INFINITY,
            f32::INFINITY,
        ]
    }
}

/// The pixels of tile (tx, ty) inside a projected surfel's reach:
/// inclusive column and row ranges in image coordinates, `None` if empty.
#[inline]
pub(crate) fn pixel_span(
    p: &ProjectedSurfel,
    tx: usize,
    ty: usize,
    w: usize,
    h: usize,
) -> Option<(usize, usize, usize, usize)> {
    let (x0, y0) = (tx * TILE, ty * TILE);
    let (x1, y1) = (((tx + 1) * TILE).min(w) - 1, ((ty + 1) * TILE).min(h) - 1);
    // pixel centres i + 0.5 in [b0, b1]; f32 → usize casts saturate
    let lo = |b: f32, a: usize| ((b - 0.5).ceil().max(a as f32)) as usize;
    let hi = |b: f32, e: usize| {
        let v = (b - 0.5).floor();
        (v >= 0.0).then(|| v.min(e as f32) as usize)
    };
    let (xa, ya) = (lo(p.reach[0], x0), lo(p.reach[1], y0));
    let (xb, yb) = (hi(p.reach[2], x1)?, hi(p.reach[3], y1)?);
    (xa <= xb && ya <= yb).then_some((xa, xb, ya, yb))
}

/// Projects surfel `i`; `None` when culled (also when its tile range on the
/// image is empty, as the kernel's `radii = 0`).
pub fn project(
    sf: &Surfels2,
    i: usize,
    cam: &Camera,
    s: &SurfelSettings,
) -> Option<ProjectedSurfel> {
    project_with(sf, i, cam, &rotation_rows(cam), s)
}

fn project_with(
    sf: &Surfels2,
    i: usize,
    cam: &Camera,
    rows: &[[f64; 3]; 3],
    s: &SurfelSettings,
) -> Option<ProjectedSurfel> {
    let nc = coeff_count(sf.sh_degree);
    let p = project_t::<f64>(
        sf.means[i].map(f64::from),
        sf.scales[i].map(f64::from),
        sf.rotations[i].map(f64::from),
        Some(&sf.sh[i * nc..(i + 1) * nc]),
        sf.sh_degree,
        cam,
        rows,
        s,
    )?;
    let op = sf.opacities[i];
    if op.is_nan() {
        return None;
    }
    let f = |v: [f64; 3]| v.map(|x| x as f32);
    let reach = reach_box(&p.t, p.xy, op);
    let out = ProjectedSurfel {
        id: i as u32,
        tu: f(p.t[0]),
        tv: f(p.t[1]),
        tw: f(p.t[2]),
        xy: p.xy.map(|v| v as f32),
        radius: p.radius as f32,
        reach,
        depth: p.depth as f32,
        normal: f(p.normal),
        opacity: op,
        rgb: p.rgb.map(|v| v.max(0.0) as f32),
    };
    kernel_tiles(&out, cam.width as usize, cam.height as usize)?;
    Some(out)
}

/// One ray–splat evaluation (the kernel's per-pixel intermediate values).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Hit {
    pub k: [f32; 3],
    pub l: [f32; 3],
    /// p_z of p = k × l.
    pub pz: f32,
    /// Intersection (u, v) in the tangent plane, standard deviations.
    pub s: [f32; 2],
    pub rho3d: f32,
    pub rho2d: f32,
    /// Box centre − pixel centre.
    pub d: [f32; 2],
    /// Camera z of the intersection.
    pub depth: f32,
    /// exp(−ρ/2).
    pub g: f32,
    /// o·exp(−ρ/2) before the 0.99 cap.
    pub raw: f32,
    pub alpha: f32,
}

#[inline]
fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Evaluates projected surfel `p` at the pixel centre (px, py) (OpenCV
/// pixel coordinates) with the kernel's operations, or `None` where the
/// kernel skips it (p_z = 0, intersection before `near`, positive
/// exponent, α < 1/255).
#[inline(always)]
pub(crate) fn hit(p: &ProjectedSurfel, px: f32, py: f32, near: f32) -> Option<Hit> {
    let (tu, tv, tw) = (p.tu, p.tv, p.tw);
    let k = [px * tw[0] - tu[0], px * tw[1] - tu[1], px * tw[2] - tu[2]];
    let l = [py * tw[0] - tv[0], py * tw[1] - tv[1], py * tw[2] - tv[2]];
    let pp = cross(k, l);
    if pp[2] == 0.0 {
        return None;
    }
    let s = [pp[0] / pp[2], pp[1] / pp[2]];
    let rho3d = s[0] * s[0] + s[1] * s[1];
    let d = [p.xy[0] - px, p.xy[1] - py];
    let rho2d = FILTER_INV_SQUARE * (d[0] * d[0] + d[1] * d[1]);
    let rho = rho3d.min(rho2d);
    let depth = (s[0] * tw[0] + s[1] * tw[1]) + tw[2];
    // `depth < near` is false for NaN, as in the kernel; a NaN depth comes
    // only with a NaN or infinite (u, v), whose ρ₃ loses the min to ρ₂
    if depth < near || depth.is_nan() {
        return None;
    }
    let power = -0.5 * rho;
    if power > 0.0 {
        return None;
    }
    let g = power.exp();
    let raw = p.opacity * g;
    let alpha = raw.min(0.99);
    if alpha < 1.0 / 255.0 {
        return None;
    }
    Some(Hit {
        k,
        l,
        pz: pp[2],
        s,
        rho3d,
        rho2d,
        d,
        depth,
        g,
        raw,
        alpha,
    })
}

/// The distortion map's depth mapping m(z) = far/(far − near)·(1 − near/z)
/// in f32, in the kernel's order of operations.
#[inline(always)]
pub(crate) fn dist_map(z: f32, near: f32, far: f32) -> f32 {
    far / (far - near) * (1.0 - near / z)
}

/// One pixel's outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct PixelOut {
    rgb: [f32; 3],
    alpha: f32,
    depth_sum: f32,
    median: f32,
    normal_sum: [f32; 3],
    m1: f32,
    m2: f32,
    distortion: f32,
    count: u32,
    final_t: f32,
    last: u32,
    median_pos: u32,
}

/// Per-pixel accumulators of one tile.
#[derive(Clone, Copy, Default)]
struct Acc {
    o: PixelOut,
    t: f32,
    c: [f32; 3],
    done: bool,
}

/// Blends the sorted list of a tile for each of its pixels (row-major).
///
/// Surfel-major: each surfel visits only the pixels of its reach box;
/// every pixel still sees the contributions in list order with the same
/// f32 operations as the kernel's per-pixel loop, so the result is the
/// same (tested against [`render_tile_plain`]).
fn render_tile(
    proj: &[ProjectedSurfel],
    list: &[u32],
    ti: usize,
    tiles_x: usize,
    w: usize,
    h: usize,
    s: &SurfelSettings,
) -> Vec<PixelOut> {
    let (near, far) = (s.near as f32, s.far as f32);
    let (tx, ty) = (ti % tiles_x, ti / tiles_x);
    let (x0, y0) = (tx * TILE, ty * TILE);
    let mut acc = [Acc {
        t: 1.0,
        ..Default::default()
    }; TILE * TILE];
    let mut active = (((tx + 1) * TILE).min(w) - x0) * (((ty + 1) * TILE).min(h) - y0);
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
            for x in xa..=xb {
                let a = &mut acc[(y - y0) * TILE + (x - x0)];
                if a.done {
                    continue;
                }
                let Some(hh) = hit(p, x as f32 + 0.5, py, near) else {
                    continue;
                };
                let t = a.t;
                let test_t = t * (1.0 - hh.alpha);
                if test_t < T_STOP {
                    a.done = true;
                    active -= 1;
                    continue;
                }
                let o = &mut a.o;
                let wgt = hh.alpha * t;
                let at = 1.0 - t;
                let m = dist_map(hh.depth, near, far);
                o.distortion += (m * m * at + o.m2 - 2.0 * m * o.m1) * wgt;
                o.depth_sum += hh.depth * wgt;
                o.m1 += m * wgt;
                o.m2 += m * m * wgt;
                if t > 0.5 {
                    o.median = hh.depth;
                    o.median_pos = li as u32 + 1;
                }
                for k in 0..3 {
                    o.normal_sum[k] += p.normal[k] * wgt;
                    a.c[k] += p.rgb[k] * wgt;
                }
                a.t = test_t;
                o.count += 1;
                o.last = li as u32 + 1;
            }
        }
    }
    tile_pixels(ti, tiles_x, w, h)
        .map(|(x, y)| {
            let a = &acc[(y - y0) * TILE + (x - x0)];
            let mut o = a.o;
            o.rgb = std::array::from_fn(|k| a.c[k] + a.t * s.background[k]);
            o.alpha = 1.0 - a.t;
            o.final_t = a.t;
            o
        })
        .collect()
}

/// Blends the sorted list of a tile for each of its pixels (row-major),
/// pixel by pixel over the whole list as the kernel does: the reference
/// for [`render_tile`] in the tests.
#[cfg(test)]
fn render_tile_plain(
    proj: &[ProjectedSurfel],
    list: &[u32],
    ti: usize,
    tiles_x: usize,
    w: usize,
    h: usize,
    s: &SurfelSettings,
) -> Vec<PixelOut> {
    let (near, far) = (s.near as f32, s.far as f32);
    tile_pixels(ti, tiles_x, w, h)
        .map(|(x, y)| {
            let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
            let mut o = PixelOut::default();
            let mut t = 1.0f32;
            let mut c = [0.0f32; 3];
            for (li, &pi) in list.iter().enumerate() {
                let p = &proj[pi as usize];
                let Some(hh) = hit(p, px, py, near) else {
                    continue;
                };
                let test_t = t * (1.0 - hh.alpha);
                if test_t < T_STOP {
                    break;
                }
                let wgt = hh.alpha * t;
                let a = 1.0 - t;
                let m = dist_map(hh.depth, near, far);
                o.distortion += (m * m * a + o.m2 - 2.0 * m * o.m1) * wgt;
                o.depth_sum += hh.depth * wgt;
                o.m1 += m * wgt;
                o.m2 += m * m * wgt;
                if t > 0.5 {
                    o.median = hh.depth;
                    o.median_pos = li as u32 + 1;
                }
                for (k, ck) in c.iter_mut().enumerate() {
                    o.normal_sum[k] += p.normal[k] * wgt;
                    *ck += p.rgb[k] * wgt;
                }
                t = test_t;
                o.count += 1;
                o.last = li as u32 + 1;
            }
            o.rgb = std::array::from_fn(|k| c[k] + t * s.background[k]);
            o.alpha = 1.0 - t;
            o.final_t = t;
            o
        })
        .collect()
}

/// What the forward pass keeps for the backward pass, and the maps that
/// [`RenderOutput`] has no field for.
#[derive(Clone, Debug, Default)]
pub struct SurfelState {
    pub proj: Vec<ProjectedSurfel>,
    pub tiles: TileLists,
    /// Per pixel, the transmittance left after the last blended contribution.
    pub final_t: Vec<f32>,
    /// Per pixel, the list position one past the last blended contribution.
    pub last: Vec<u32>,
    /// Per pixel, the list position one past the contribution whose depth is
    /// the median depth (0: none).
    pub median_pos: Vec<u32>,
    /// Per pixel, D = Σ w z (the kernel's raw depth output).
    pub depth_sum: Vec<f32>,
    /// Per pixel, M₁ = Σ w m and M₂ = Σ w m² of the distortion mapping.
    pub m1: Vec<f32>,
    pub m2: Vec<f32>,
    /// Per pixel, 2DGS's depth distortion map (`rend_dist`).
    pub distortion: Vec<f32>,
}

impl SurfelState {
    /// Screen radius (pixels, the kernel's `radii`) of each of `count`
    /// surfels, 0 for those this view culled: 2DGS's `visibility_filter`
    /// is radius > 0.
    pub fn radii(&self, count: usize) -> Vec<f32> {
        let mut out = vec![0.0f32; count];
        for p in &self.proj {
            out[p.id as usize] = p.radius;
        }
        out
    }
}

/// Renders `sf` from `cam` (see the module docs for what each output holds).
pub fn render(sf: &Surfels2, cam: &Camera, settings: &SurfelSettings) -> RenderOutput {
    rasterize(sf, cam, settings).0
}

/// Renders `sf` from `cam` and keeps what
/// [`crate::surfel_grad::backward_state`] needs, with the distortion map.
/// Deterministic for any thread count.
pub fn rasterize(
    sf: &Surfels2,
    cam: &Camera,
    settings: &SurfelSettings,
) -> (RenderOutput, SurfelState) {
    sf.check_lengths();
    let (w, h) = (cam.width as usize, cam.height as usize);
    let rows = rotation_rows(cam);
    let proj: Vec<ProjectedSurfel> = (0..sf.len())
        .into_par_iter()
        .filter_map(|i| project_with(sf, i, cam, &rows, settings))
        .collect();
    let (tw, th) = (w.div_ceil(TILE), h.div_ceil(TILE));
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
    let mut st = SurfelState {
        final_t: vec![1.0; w * h],
        last: vec![0; w * h],
        median_pos: vec![0; w * h],
        depth_sum: vec![0.0; w * h],
        m1: vec![0.0; w * h],
        m2: vec![0.0; w * h],
        distortion: vec![0.0; w * h],
        ..Default::default()
    };
    if tw == 0 || th == 0 {
        return (out, st);
    }
    let tiles = TileLists::build(&proj, |p| tiles_of(p, w, h), |p| p.depth, w, h);
    render_tiles(
        tw,
        th,
        w,
        h,
        |ti| render_tile(&proj, tiles.list(ti), ti, tw, w, h, settings),
        |o, p| {
            out.rgb[o] = p.rgb;
            out.alpha[o] = p.alpha;
            // the Python renderer: D / alpha, nan_to_num(·, 0, 0)
            let e = p.depth_sum / p.alpha;
            out.expected_depth[o] = if e.is_finite() { e } else { 0.0 };
            out.median_depth[o] = p.median;
            out.normal_sum[o] = p.normal_sum;
            let [a, b, c] = p.normal_sum;
            let l = (a * a + b * b + c * c).sqrt();
            if l > 0.0 {
                out.normal[o] = p.normal_sum.map(|v| v / l);
            }
            out.count[o] = p.count;
            st.final_t[o] = p.final_t;
            st.last[o] = p.last;
            st.median_pos[o] = p.median_pos;
            st.depth_sum[o] = p.depth_sum;
            st.m1[o] = p.m1;
            st.m2[o] = p.m2;
            st.distortion[o] = p.distortion;
        },
    );
    st.proj = proj;
    st.tiles = tiles;
    (out, st)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::testutil::{Lcg, random_sh, test_camera};
    use glam::{DMat3, DQuat, DVec3};

    /// A camera at `eye` looking at `target` (OpenCV axes, world up −y).
    pub(crate) fn look_at(w: u32, h: u32, f: f64, eye: DVec3, target: DVec3) -> Camera {
        let z = (target - eye).normalize();
        let x = DVec3::new(0.0, -1.0, 0.0).cross(z).normalize();
        let y = z.cross(x);
        let (r, t) = Camera::pose_from_c2w(DMat3::from_cols(x, y, z), eye);
        Camera::pinhole(
            "look",
            w,
            h,
            f,
            f * 1.1,
            w as f64 * 0.52,
            h as f64 * 0.47,
            r,
            t,
        )
    }

    /// (w, x, y, z) of a glam quaternion, as f32.
    fn wxyz(q: DQuat) -> [f32; 4] {
        [q.w as f32, q.x as f32, q.y as f32, q.z as f32]
    }

    /// A grid of overlapping surfels lying in the plane through `p0` with
    /// unit normal `n` (their third rotation axis is `n` or −`n`, at
    /// random, with random in-plane spins), opacity 0.9.
    fn plane_grid(p0: DVec3, n: DVec3, half: i32, step: f64, scale: f32, seed: u64) -> Surfels2 {
        let mut r = Lcg(seed);
        let base = DQuat::from_rotation_arc(DVec3::Z, n);
        let (e0, e1) = (base * DVec3::X, base * DVec3::Y);
        let mut sf = Surfels2::default();
        for j in -half..=half {
            for i in -half..=half {
                let c = p0 + e0 * (i as f64 * step) + e1 * (j as f64 * step);
                sf.means.push(c.as_vec3().to_array());
                sf.scales
                    .push([scale * r.range(0.8, 1.2), scale * r.range(0.8, 1.2)]);
                let spin = DQuat::from_rotation_z(r.range(0.0, std::f64::consts::TAU) as f64);
                let flip = if r.next_f64() < 0.5 {
                    DQuat::IDENTITY
                } else {
                    DQuat::from_rotation_x(std::f64::consts::PI)
                };
                sf.rotations.push(wxyz(base * flip * spin));
                sf.opacities.push(0.9);
                sf.sh.push([0.3, -0.2, 0.1]);
            }
        }
        sf
    }

    /// Test (a): a plane tiled with surfels, seen obliquely by a rotated
    /// camera with an off-centre principal point and fx ≠ fy. Where the
    /// tiling is opaque (α > 0.99), both depths equal the camera z of the
    /// pixel ray's intersection with the plane (closed form, f64) to 1e-4
    /// relative — the depth is that of the ray–splat intersection, not of
    /// the surfel centres — and the blended normal is the plane's normal in
    /// camera axes turned to the camera, to 1e-4, although half the surfels
    /// have their normal axis the other way.
    #[test]
    fn plane_of_surfels_has_the_plane_depth_and_normal() {
        let cam = look_at(64, 48, 60.0, DVec3::new(1.0, -0.5, -4.0), DVec3::ZERO);
        let n = DVec3::new(0.3, -0.2, -1.0).normalize();
        let sf = plane_grid(DVec3::ZERO, n, 10, 0.15, 0.15, 7);
        let (img, st) = rasterize(&sf, &cam, &SurfelSettings::default());
        let (rc, tc) = (cam.rotation, cam.translation);
        let (nc, pc) = (rc * n, tc); // plane through the world origin
        let want_n = if nc.dot(pc) > 0.0 { -nc } else { nc };
        let mut checked = 0;
        for y in 0..48 {
            for x in 0..64 {
                let o = y * 64 + x;
                if img.alpha[o] < 0.99 {
                    continue;
                }
                let ray = DVec3::new(
                    (x as f64 + 0.5 - cam.cx) / cam.fx,
                    (y as f64 + 0.5 - cam.cy) / cam.fy,
                    1.0,
                );
                let z = nc.dot(pc) / nc.dot(ray);
                for (name, d) in [
                    ("expected", img.expected_depth[o]),
                    ("median", img.median_depth[o]),
                ] {
                    let rel = (d as f64 - z).abs() / z;
                    assert!(rel < 1e-4, "{name} ({x},{y}): {d} vs {z}");
                }
                let got = DVec3::from_array(img.normal[o].map(f64::from));
                assert!((got - want_n).length() < 1e-4, "({x},{y}) {got} {want_n}");
                let sum = DVec3::from_array(img.normal_sum[o].map(f64::from));
                assert!((sum.length() - img.alpha[o] as f64).abs() < 1e-4);
                // one layer of surfaces: no distortion to speak of
                assert!(st.distortion[o].abs() < 1e-6, "{}", st.distortion[o]);
                checked += 1;
            }
        }
        assert!(checked > 1000, "only {checked} opaque pixels");
        // surface_depth mixes the two as 2DGS's surf_depth
        let sd = img.surface_depth(0.3);
        let o = 24 * 64 + 32;
        let want = img.expected_depth[o] * 0.7 + img.median_depth[o] * 0.3;
        assert!((sd[o] - want).abs() <= 1e-6 * want);
    }

    /// One surfel facing the camera on the optical axis at depth z, scales
    /// (σ_u, σ_v) in pixels much larger than the filter: its α is
    /// o·exp(−½((Δx/σ_u)² + (Δy/σ_v)²)) (the 3-D branch of the min) in
    /// closed form, its depth z everywhere, and pixels where α < 1/255 are
    /// untouched. A tiny surfel (σ = 0.05 px) is drawn by the low-pass
    /// filter alone: α = o·exp(−|Δ|²), centred on the box centre.
    #[test]
    fn single_surfel_closed_forms() {
        let cam = test_camera(48, 40, 100.0);
        let (z, su, sv, op) = (4.0f32, 0.2f32, 0.12f32, 0.7f32);
        let sf = Surfels2 {
            means: vec![[0.0, 0.0, z]],
            scales: vec![[su, sv]],
            rotations: vec![[1.0, 0.0, 0.0, 0.0]],
            opacities: vec![op],
            sh: vec![[0.0; 3]],
            sh_degree: 0,
        };
        let img = render(&sf, &cam, &SurfelSettings::default());
        let (pu, pv) = (100.0 * su as f64 / z as f64, 100.0 * sv as f64 / z as f64);
        for y in 0..40 {
            for x in 0..48 {
                let (dx, dy) = (x as f64 + 0.5 - 24.0, y as f64 + 0.5 - 20.0);
                let r3 = (dx / pu).powi(2) + (dy / pv).powi(2);
                let r2 = 2.0 * (dx * dx + dy * dy);
                let a = op as f64 * (-0.5 * r3.min(r2)).exp();
                let want = if a < 1.0 / 255.0 { 0.0 } else { a };
                let o = y * 48 + x;
                assert!((img.alpha[o] as f64 - want).abs() < 2e-6, "({x},{y})");
                if want > 0.0 {
                    // D / (1 − T): 1 − (1 − α) in f32 costs ~6e-8/α relative
                    let tol = z * (1e-6 + 1e-7 / img.alpha[o]);
                    assert!((img.expected_depth[o] - z).abs() < tol, "({x},{y})");
                    assert_eq!(img.normal[o], [0.0, 0.0, -1.0], "faces the camera");
                }
            }
        }
        let mut tiny = sf.clone();
        tiny.means[0] = [0.013, -0.007, z];
        tiny.scales[0] = [0.002, 0.002];
        let img = render(&tiny, &cam, &SurfelSettings::default());
        let (cx, cy) = (24.0 + 100.0 * 0.013 / 4.0, 20.0 - 100.0 * 0.007 / 4.0);
        for y in 15..25 {
            for x in 19..29 {
                let (dx, dy) = (x as f64 + 0.5 - cx, y as f64 + 0.5 - cy);
                let a = op as f64 * (-(dx * dx + dy * dy)).exp();
                let want = if a < 1.0 / 255.0 { 0.0 } else { a };
                let got = img.alpha[y * 48 + x] as f64;
                assert!((got - want).abs() < 1e-5, "({x},{y}) {got} {want}");
            }
        }
    }

    /// Seen exactly edge-on (normal ⟂ the centre's view ray) a surfel is
    /// culled, as the kernel's `cos == 0` test; one whose centre is at the
    /// near plane too.
    #[test]
    fn edge_on_and_near_surfels_are_culled() {
        let cam = test_camera(32, 32, 40.0);
        let q = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2);
        let sf = Surfels2 {
            means: vec![[0.0, 0.0, 3.0], [0.0, 0.0, 0.2]],
            scales: vec![[0.5, 0.5], [0.5, 0.5]],
            rotations: vec![wxyz(q), [1.0, 0.0, 0.0, 0.0]],
            opacities: vec![0.9, 0.9],
            sh: vec![[0.0; 3]; 2],
            sh_degree: 0,
        };
        // rotation_y(π/2) maps z to x: n = (1, 0, 0)·(0, 0, 3) = 0 exactly
        // up to the f64 rounding of the quaternion; accept either a cull or
        // nothing drawn
        let (img, st) = rasterize(&sf, &cam, &SurfelSettings::default());
        assert!(st.proj.iter().all(|p| p.id != 1), "near-plane centre");
        assert!(img.alpha.iter().all(|&a| a < 0.05));
    }

    /// A random scene with several layers at all angles renders to the
    /// same bytes on one thread and on four (test (d), forward part).
    #[test]
    fn forward_is_the_same_for_any_thread_count() {
        let sf = random_scene(11, 60, 2);
        let cam = look_at(70, 50, 60.0, DVec3::new(0.5, -0.3, -5.0), DVec3::ZERO);
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| rasterize(&sf, &cam, &SurfelSettings::default()))
        };
        let (a, sa) = run(1);
        let (b, sb) = run(4);
        assert_eq!(a.rgb, b.rgb);
        assert_eq!(a.alpha, b.alpha);
        assert_eq!(a.expected_depth, b.expected_depth);
        assert_eq!(a.median_depth, b.median_depth);
        assert_eq!(a.normal_sum, b.normal_sum);
        assert_eq!(sa.distortion, sb.distortion);
        assert!(a.count.iter().any(|&c| c >= 3), "layers overlap");
    }

    /// The reach boxes and surfel-major tile loop are a speed-up only: on
    /// random scenes (thin, tiny, faint, opaque, large surfels seen at all
    /// angles, some whose 3σ disc reaches behind the camera) every pixel's
    /// outputs equal, bit for bit, the kernel's plain per-pixel loop over
    /// its own tile lists (`getRect` of the 3σ box, uncut).
    #[test]
    fn fast_path_equals_the_plain_loop() {
        for (seed, eye) in [(21u64, -5.0), (22, -2.5), (23, -1.2)] {
            let mut sf = random_scene(seed, 150, 1);
            // a few huge and a few faint ones
            for i in 0..10 {
                sf.scales[i] = [3.0, 2.0];
                sf.opacities[i + 10] = 0.006;
            }
            let cam = look_at(70, 50, 50.0, DVec3::new(0.4, -0.3, eye), DVec3::ZERO);
            let s = SurfelSettings::default();
            let (w, h) = (70, 50);
            let (_, st) = rasterize(&sf, &cam, &s);
            let full = TileLists::build(&st.proj, |p| kernel_tiles(p, w, h), |p| p.depth, w, h);
            let mut cut = 0;
            for ti in 0..full.len() {
                let fast = render_tile(&st.proj, st.tiles.list(ti), ti, full.tiles_x, w, h, &s);
                let plain = render_tile_plain(&st.proj, full.list(ti), ti, full.tiles_x, w, h, &s);
                cut += full.list(ti).len() - st.tiles.list(ti).len();
                for (a, b) in fast.iter().zip(&plain) {
                    let key = |o: &PixelOut| (o.rgb, o.alpha, o.depth_sum, o.median, o.normal_sum);
                    assert_eq!(key(a), key(b), "seed {seed} tile {ti}");
                    assert_eq!((a.m1, a.m2, a.distortion), (b.m1, b.m2, b.distortion));
                    assert_eq!((a.count, a.final_t), (b.count, b.final_t));
                }
            }
            assert!(cut > 0, "seed {seed}: the reach boxes cut nothing");
        }
    }

    /// `n` random surfels around the origin, SH degree `deg`.
    pub(crate) fn random_scene(seed: u64, n: usize, deg: usize) -> Surfels2 {
        let mut r = Lcg(seed);
        let mut sf = Surfels2 {
            sh_degree: deg,
            ..Default::default()
        };
        for _ in 0..n {
            sf.means
                .push([r.range(-1.5, 1.5), r.range(-1.0, 1.0), r.range(-1.0, 1.0)]);
            sf.scales.push([r.range(0.02, 0.5), r.range(0.02, 0.5)]);
            sf.rotations.push([
                r.range(-1.0, 1.0),
                r.range(-1.0, 1.0),
                r.range(-1.0, 1.0),
                r.range(-1.0, 1.0),
            ]);
            sf.opacities.push(r.range(0.05, 1.0));
            sf.sh.extend(random_sh(&mut r, coeff_count(deg)));
        }
        sf
    }
}
