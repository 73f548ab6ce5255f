//! Backward pass of the surfel rasteriser ([`crate::surfel`]).
//!
//! Input: the forward pass's [`SurfelState`] (or a fresh forward pass, in
//! [`backward`]) and the gradient of a scalar loss L with respect to each
//! output pixel's RGB and, optionally ([`SurfelAuxGrads`]), its alpha, its
//! expected depth, its median depth, its accumulated normal Σ w n
//! ([`RenderOutput::normal_sum`], camera axes) and its distortion
//! ([`SurfelState::distortion`]). Output: the gradient with respect to every
//! parameter of [`Surfels2`] as the rasteriser takes them (means, activated
//! scales, quaternions (w, x, y, z) before normalisation, opacities, SH
//! coefficients), and 2DGS's screen-space statistic
//! ([`SurfelGrads::means2d`]).
//!
//! Two stages, as in 2DGS's CUDA backward (`backward.cu`):
//! 1. per pixel, the blending is walked back to front from the last blended
//!    contribution; with g_w = ∂L/∂w of each weight w = α·T (colour, depth
//!    sum, normal sum and, for the distortion, m²·A − 2m·M₁ + M₂ with the
//!    pixel's final A, M₁, M₂), ∂L/∂α_i = T_i·(g_w,i − R_i) +
//!    (∂L/∂alpha − ∂L/∂C·bg)·T_final/(1 − α_i), where R_i = Σ_{j>i}
//!    g_w,j·α_j·Π_{i<k<j}(1 − α_k) is carried back to front (the kernel's
//!    `last_dL_dT`, generalised). From α the gradient reaches the opacity,
//!    and ρ; from ρ₃ = u² + v² and the intersection depth z, the
//!    intersection (u, v) = (p_x, p_y)/p_z, p = k × l, and from there the
//!    rows of T; from ρ₂ the box centre. Per-tile buffers aligned with the
//!    tile lists keep this deterministic; they are summed in tile order.
//! 2. per surfel, ∂L/∂(T, box centre, normal) is taken back to the mean,
//!    scales and quaternion through the Jacobian of the forward code
//!    (`surfel::project_t` run with [`Dual`] numbers, nine
//!    tangents); the colour's gradient reaches SH and the mean through the
//!    Gaussian rasteriser's SH reverse sweep.
//!
//! The expected depth is D/A (A = 1 − T_final): ∂L/∂D = g/A, ∂L/∂A gets
//! −g·D/A². The median depth passes its gradient to the z of the one
//! contribution it was taken from. The normal's flip towards the camera is
//! a constant.
//!
//! Exact derivative of the forward pass. Where this departs from the CUDA
//! backward (which is not the exact derivative of its own forward there):
//! - a capped α (o·G > 0.99) passes no gradient (CUDA: as if uncapped);
//! - in the low-pass branch (ρ₂ < ρ₃) the intersection depth still depends
//!   on (u, v) and so on T_u, T_v (CUDA keeps only ∂z/∂T_w);
//! - the quaternion's normalisation and `scale_modifier` are differentiated
//!   (CUDA: neither; 2DGS's Python normalises the quaternion in autograd);
//! - skipped contributions (α < 1/255, ...) and culled surfels pass nothing,
//!   as in CUDA.

use rayon::prelude::*;

use crate::Camera;
use crate::dual::Dual;
use crate::gaussian::{RenderOutput, rotation_rows};
use crate::gaussian_grad::AuxGrads;
use crate::gaussian_vjp::colour_vjp;
use crate::sh::coeff_count;
pub use crate::splats::SplatGrads;
use crate::surfel::{
    FILTER_INV_SQUARE, Hit, ProjectedSurfel, SurfelSettings, SurfelState, Surfels2, dist_map, hit,
    pixel_span, project_t, rasterize,
};
use crate::tiles::{PREFETCH_DISTANCE, TILE, prefetch_ahead, tile_pixels};

/// Gradients of a loss with respect to [`Surfels2`]'s fields, plus 2DGS's
/// screen-space statistic (see [`SplatGrads`]).
pub type SurfelGrads = SplatGrads<2>;

/// Per-pixel gradients of the loss with respect to the auxiliary outputs,
/// each row-major `width × height`, or `None` for zero.
#[derive(Clone, Copy, Debug, Default)]
pub struct SurfelAuxGrads<'a> {
    /// ∂L/∂alpha (alpha = 1 − T_final).
    pub alpha: Option<&'a [f32]>,
    /// ∂L/∂expected depth (D / alpha; pixels where it is 0 because nothing
    /// was blended get none).
    pub depth: Option<&'a [f32]>,
    /// ∂L/∂median depth.
    pub median_depth: Option<&'a [f32]>,
    /// ∂L/∂normal_sum (Σ w n, camera axes, not normalised).
    pub normal: Option<&'a [[f32; 3]]>,
    /// ∂L/∂distortion ([`SurfelState::distortion`]).
    pub distortion: Option<&'a [f32]>,
}

impl<'a> From<AuxGrads<'a>> for SurfelAuxGrads<'a> {
    fn from(a: AuxGrads<'a>) -> Self {
        SurfelAuxGrads {
            alpha: a.alpha,
            depth: a.depth,
            normal: a.normal,
            ..Default::default()
        }
    }
}

impl SurfelAuxGrads<'_> {
    fn check_lengths(&self, d_rgb: &[[f32; 3]], n: usize) {
        assert_eq!(d_rgb.len(), n, "one RGB gradient per pixel");
        for len in [
            self.alpha.map(<[f32]>::len),
            self.depth.map(<[f32]>::len),
            self.median_depth.map(<[f32]>::len),
            self.normal.map(<[[f32; 3]]>::len),
            self.distortion.map(<[f32]>::len),
        ]
        .into_iter()
        .flatten()
        {
            assert_eq!(len, n, "one auxiliary gradient per pixel");
        }
    }
}

/// Per surfel screen gradient: ∂L/∂(T_u (3), T_v (3), T_w (3), box centre
/// (2), opacity, rgb (3), normal (3)).
const K: usize = 18;
const G_XY: usize = 9;
const G_OP: usize = 11;
const G_RGB: usize = 12;
const G_N: usize = 15;

/// Gradient of the loss with respect to `s`, given ∂L/∂rgb per pixel
/// (row-major, `width × height`) and the auxiliary outputs' gradients.
/// `out` is the forward output for these inputs; only its size is used:
/// the forward pass is run again here to rebuild its state (use
/// [`crate::surfel::rasterize`] and [`backward_state`] to avoid that).
/// Deterministic for any thread count.
pub fn backward(
    s: &Surfels2,
    cam: &Camera,
    settings: &SurfelSettings,
    out: &RenderOutput,
    d_rgb: &[[f32; 3]],
    aux: &SurfelAuxGrads,
) -> SurfelGrads {
    assert_eq!(
        (out.width, out.height),
        (cam.width as usize, cam.height as usize),
        "the forward output belongs to this camera"
    );
    let (_, state) = rasterize(s, cam, settings);
    backward_state(s, cam, settings, &state, d_rgb, aux)
}

/// [`backward`] with the state the forward pass ([`crate::surfel::rasterize`])
/// kept.
pub fn backward_state(
    s: &Surfels2,
    cam: &Camera,
    settings: &SurfelSettings,
    state: &SurfelState,
    d_rgb: &[[f32; 3]],
    aux: &SurfelAuxGrads,
) -> SurfelGrads {
    s.check_lengths();
    let (w, h) = (cam.width as usize, cam.height as usize);
    aux.check_lengths(d_rgb, w * h);
    let screen = screen_grads(settings, state, d_rgb, aux, w, h);
    through_projection(s, cam, settings, state, &screen)
}

/// One pixel's state in the backward walk.
#[derive(Clone, Copy, Default)]
struct PixelBack {
    /// Transmittance in front of the current contribution.
    t: f32,
    /// R: Σ over the contributions behind of g_w·α·Π(1 − α) between.
    r: f32,
    t_final: f32,
    /// 1 − T_final.
    a_f: f32,
    gc: [f32; 3],
    /// ∂L/∂alpha (with the expected depth's dependence on it) − ∂L/∂C·bg.
    ga_bg: f32,
    /// ∂L/∂D (D = Σ w z).
    g_d: f32,
    g_med: f32,
    gn: [f32; 3],
    g_dist: f32,
    m1f: f32,
    m2f: f32,
    med: u32,
    last: u32,
}

/// Adds one contribution's gradients to its surfel's screen gradient `e`,
/// given ∂L/∂α and ∂L/∂z (intersection depth) at pixel centre (px, py).
#[inline(always)]
fn contribution_grads(
    p: &ProjectedSurfel,
    hh: &Hit,
    px: f32,
    py: f32,
    d_alpha: f32,
    g_z: f32,
    e: &mut [f32; K],
) {
    // α = min(0.99, o·G), G = exp(−ρ/2)
    let mut d_rho = 0.0f32;
    if hh.raw < 0.99 {
        e[G_OP] += hh.g * d_alpha;
        d_rho = -0.5 * p.opacity * hh.g * d_alpha;
    }
    // z = u·T_w,x + v·T_w,y + T_w,z
    let mut d_s = [g_z * p.tw[0], g_z * p.tw[1]];
    e[6] += g_z * hh.s[0];
    e[7] += g_z * hh.s[1];
    e[8] += g_z;
    if hh.rho3d <= hh.rho2d {
        d_s[0] += 2.0 * hh.s[0] * d_rho;
        d_s[1] += 2.0 * hh.s[1] * d_rho;
    } else {
        let c = 2.0 * FILTER_INV_SQUARE * d_rho;
        e[G_XY] += c * hh.d[0];
        e[G_XY + 1] += c * hh.d[1];
    }
    // (u, v) = (p_x, p_y)/p_z, p = k × l, k = x·T_w − T_u, l = y·T_w − T_v
    let (ax, ay) = (d_s[0] / hh.pz, d_s[1] / hh.pz);
    let d_p = [ax, ay, -(ax * hh.s[0] + ay * hh.s[1])];
    let d_k = cross(hh.l, d_p);
    let d_l = cross(d_p, hh.k);
    for c in 0..3 {
        e[c] -= d_k[c];
        e[3 + c] -= d_l[c];
        e[6 + c] += px * d_k[c] + py * d_l[c];
    }
}

/// Stage 1: per projected surfel, ∂L/∂ its screen quantities.
fn screen_grads(
    s: &SurfelSettings,
    state: &SurfelState,
    d_rgb: &[[f32; 3]],
    aux: &SurfelAuxGrads,
    w: usize,
    h: usize,
) -> Vec<[f64; K]> {
    if state.tiles.is_empty() {
        return vec![[0.0; K]; state.proj.len()];
    }
    let (near, far) = (s.near as f32, s.far as f32);
    let dm_scale = far * near / (far - near);
    let tw = state.tiles.tiles_x;
    let proj = &state.proj;
    let tile_grads: Vec<Vec<[f32; K]>> = (0..state.tiles.len())
        .into_par_iter()
        .map(|ti| {
            let list = state.tiles.list(ti);
            let mut acc = vec![[0.0f32; K]; list.len()];
            let (tx, ty) = (ti % tw, ti / tw);
            let (x0, y0) = (tx * TILE, ty * TILE);
            let mut px_state = [PixelBack::default(); TILE * TILE];
            let mut max_last = 0;
            for (x, y) in tile_pixels(ti, tw, w, h) {
                let o = y * w + x;
                let t_final = state.final_t[o];
                let a_f = 1.0 - t_final;
                let gc = d_rgb[o];
                let mut ga = aux.alpha.map_or(0.0, |a| a[o]);
                let mut g_d = 0.0f32;
                if let Some(dd) = aux.depth {
                    // E = D / A where the forward's quotient was finite
                    let e = state.depth_sum[o] / a_f;
                    if e.is_finite() {
                        g_d = dd[o] / a_f;
                        ga -= dd[o] * e / a_f;
                    }
                }
                let bg = s.background;
                max_last = max_last.max(state.last[o]);
                px_state[(y - y0) * TILE + (x - x0)] = PixelBack {
                    t: t_final,
                    r: 0.0,
                    t_final,
                    a_f,
                    gc,
                    ga_bg: ga - (gc[0] * bg[0] + gc[1] * bg[1] + gc[2] * bg[2]),
                    g_d,
                    g_med: aux.median_depth.map_or(0.0, |a| a[o]),
                    gn: aux.normal.map_or([0.0; 3], |a| a[o]),
                    g_dist: aux.distortion.map_or(0.0, |a| a[o]),
                    m1f: state.m1[o],
                    m2f: state.m2[o],
                    med: state.median_pos[o],
                    last: state.last[o],
                };
            }
            // surfel-major, back to front: each pixel still walks its own
            // contributions in reverse list order
            for li in (0..max_last as usize).rev() {
                if li >= PREFETCH_DISTANCE {
                    prefetch_ahead(proj, list, li - PREFETCH_DISTANCE);
                }
                let p = &proj[list[li] as usize];
                let Some((xa, xb, ya, yb)) = pixel_span(p, tx, ty, w, h) else {
                    continue;
                };
                let mut e = [0.0f32; K];
                for y in ya..=yb {
                    let py = y as f32 + 0.5;
                    for x in xa..=xb {
                        let b = &mut px_state[(y - y0) * TILE + (x - x0)];
                        if li as u32 >= b.last {
                            continue;
                        }
                        let px = x as f32 + 0.5;
                        let Some(hh) = hit(p, px, py, near) else {
                            continue;
                        };
                        let alpha = hh.alpha;
                        let inv = 1.0 / (1.0 - alpha);
                        b.t *= inv;
                        let t = b.t;
                        let wgt = alpha * t;
                        let z = hh.depth;
                        // ∂L/∂w of this contribution, and the direct gradients
                        let mut g_w = b.g_d * z;
                        for k in 0..3 {
                            g_w += b.gc[k] * p.rgb[k] + b.gn[k] * p.normal[k];
                            e[G_RGB + k] += b.gc[k] * wgt;
                            e[G_N + k] += b.gn[k] * wgt;
                        }
                        let mut g_z = b.g_d * wgt;
                        if b.g_dist != 0.0 {
                            let m = dist_map(z, near, far);
                            g_w += b.g_dist * (m * m * b.a_f - 2.0 * m * b.m1f + b.m2f);
                            let g_m = b.g_dist * 2.0 * wgt * (m * b.a_f - b.m1f);
                            g_z += g_m * dm_scale / (z * z);
                        }
                        if li as u32 + 1 == b.med {
                            g_z += b.g_med;
                        }
                        let d_alpha = t * (g_w - b.r) + b.ga_bg * b.t_final * inv;
                        b.r = g_w * alpha + (1.0 - alpha) * b.r;
                        contribution_grads(p, &hh, px, py, d_alpha, g_z, &mut e);
                    }
                }
                acc[li] = e;
            }
            acc
        })
        .collect();
    state.tiles.gather(&tile_grads)
}

#[inline]
fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Stage 2: the screen gradients through each surfel's projection (the
/// Jacobian of [`project_t`] by dual numbers), written straight into the
/// output arrays in parallel (each surfel's entries by one task).
fn through_projection(
    sf: &Surfels2,
    cam: &Camera,
    settings: &SurfelSettings,
    state: &SurfelState,
    screen: &[[f64; K]],
) -> SurfelGrads {
    let n = sf.len();
    let nc = coeff_count(sf.sh_degree);
    let mut out = SurfelGrads {
        means: vec![[0.0; 3]; n],
        scales: vec![[0.0; 2]; n],
        rotations: vec![[0.0; 4]; n],
        opacities: vec![0.0; n],
        sh: vec![[0.0; 3]; n * nc],
        means2d: vec![[0.0; 2]; n],
    };
    let mut slot = vec![u32::MAX; n];
    for (j, p) in state.proj.iter().enumerate() {
        slot[p.id as usize] = j as u32;
    }
    let rows = rotation_rows(cam);
    let eye = cam.center().to_array();
    out.means
        .par_iter_mut()
        .zip(out.scales.par_iter_mut())
        .zip(out.rotations.par_iter_mut())
        .zip(out.opacities.par_iter_mut())
        .zip(out.sh.par_chunks_mut(nc))
        .zip(out.means2d.par_iter_mut())
        .enumerate()
        .for_each(|(i, (((((gm, gsc), grot), gop), gsh), gxy))| {
            let j = slot[i];
            if j == u32::MAX {
                return;
            }
            let d = &screen[j as usize];
            let (m, sc, q) = (sf.means[i], sf.scales[i], sf.rotations[i]);
            let mean: [Dual<9>; 3] = std::array::from_fn(|k| Dual::var(m[k] as f64, k));
            let scale: [Dual<9>; 2] = std::array::from_fn(|k| Dual::var(sc[k] as f64, 3 + k));
            let quat: [Dual<9>; 4] = std::array::from_fn(|k| Dual::var(q[k] as f64, 5 + k));
            let Some(p) = project_t(mean, scale, quat, None, 0, cam, &rows, settings) else {
                return; // cannot happen: the f64 projection passed
            };
            let mut g = [0.0f64; 9];
            let mut add = |v: &Dual<9>, gv: f64| {
                for (gk, dk) in g.iter_mut().zip(v.d) {
                    *gk += gv * dk;
                }
            };
            for r in 0..3 {
                for c in 0..3 {
                    add(&p.t[r][c], d[3 * r + c]);
                }
                add(&p.normal[r], d[G_N + r]);
            }
            add(&p.xy[0], d[G_XY]);
            add(&p.xy[1], d[G_XY + 1]);
            let gc = colour_vjp(
                m,
                eye,
                &sf.sh[i * nc..(i + 1) * nc],
                sf.sh_degree,
                [d[G_RGB], d[G_RGB + 1], d[G_RGB + 2]],
                gsh,
            );
            *gm = std::array::from_fn(|k| (g[k] + gc[k]) as f32);
            *gsc = [g[3] as f32, g[4] as f32];
            *grot = std::array::from_fn(|k| g[5 + k] as f32);
            *gop = d[G_OP] as f32;
            let depth = p.t[2][2].v;
            *gxy = [(d[2] * depth) as f32, (d[5] * depth) as f32];
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surfel::tests::{look_at, random_scene};
    use crate::testutil::{Lcg, check_gradient, random_sh};
    use glam::{DQuat, DVec3};

    /// The test camera: 16×16, rotated, fx ≠ fy, off-centre principal point.
    fn camera() -> Camera {
        look_at(16, 16, 20.0, DVec3::new(0.4, -0.3, -4.0), DVec3::ZERO)
    }

    /// A scene whose image is smooth in every parameter at the chosen steps:
    /// four large surfels (≥ 8 px standard deviation, facing the camera
    /// within 0.5 rad) that cover every pixel with α well above 1/255, at
    /// depths from 2 to 6 (so the distortion map is not tiny), opacities
    /// 0.3–0.7 (no 0.99 cap, T never near 10⁻⁴) except the front one, wide
    /// and with opacity 0.8, which takes T from 1 to below 0.45 on every
    /// pixel (so the median contributor never changes), and one sub-pixel surfel
    /// (drawn by the low-pass filter, the other branch of the min) whose
    /// centre projects to a pixel centre and whose opacity puts its
    /// 1/255 level between the pixel rings (|Δ|² = 4.5). Margins from every
    /// threshold are asserted by [`assert_margins`].
    fn smooth_scene(seed: u64) -> Surfels2 {
        let cam = camera();
        let mut r = Lcg(seed);
        let mut sf = Surfels2 {
            sh_degree: 1,
            ..Default::default()
        };
        let c2w = cam.c2w_rotation();
        let eye = cam.center();
        let back = |px: f64, py: f64, z: f64| {
            let ray = DVec3::new((px - cam.cx) / cam.fx, (py - cam.cy) / cam.fy, 1.0);
            eye + c2w * (ray * z)
        };
        for k in 0..4 {
            let z = [2.0, 5.5, 3.0, 6.0][k] + r.range(-0.3, 0.3) as f64;
            let c = back(
                8.0 + r.range(-3.0, 3.0) as f64,
                8.0 + r.range(-3.0, 3.0) as f64,
                z,
            );
            sf.means.push(c.as_vec3().to_array());
            // the front one wide and dense enough that T falls below 0.45
            // at it on every pixel: the median depth is always its depth
            let (lo, hi) = if k == 0 { (18.0, 20.0) } else { (10.0, 13.0) };
            let sigma = |r: &mut Lcg| (r.range(lo, hi) as f64 * z / 20.0) as f32;
            sf.scales.push([sigma(&mut r), sigma(&mut r)]);
            let axis = DVec3::new(r.range(-1.0, 1.0) as f64, r.range(-1.0, 1.0) as f64, 0.3);
            let tilt = DQuat::from_axis_angle(axis.normalize(), r.range(0.0, 0.25) as f64);
            let q = tilt * DQuat::from_mat3(&c2w);
            sf.rotations
                .push([q.w as f32, q.x as f32, q.y as f32, q.z as f32]);
            sf.opacities.push(if k == 0 {
                r.range(0.84, 0.86)
            } else {
                r.range(0.3, 0.7)
            });
            sf.sh.extend(random_sh(&mut r, 4));
        }
        // the sub-pixel surfel at pixel centre (6.5, 9.5), depth 2.5, in
        // front of most: o·exp(−|Δ|²) = 1/255 at |Δ|² = 4.5
        sf.means.push(back(6.5, 9.5, 2.5).as_vec3().to_array());
        sf.scales.push([0.004, 0.006]);
        let q = DQuat::from_mat3(&c2w) * DQuat::from_rotation_x(0.4);
        sf.rotations
            .push([q.w as f32, q.x as f32, q.y as f32, q.z as f32]);
        sf.opacities.push((4.5f32.exp() / 255.0).min(0.9));
        sf.sh.extend(random_sh(&mut r, 4));
        sf
    }

    /// o·exp(−ρ/2) of a projected surfel at a pixel centre, before the
    /// 1/255 test (the forward's formulas).
    fn raw_alpha(p: &ProjectedSurfel, px: f32, py: f32) -> f32 {
        let k: [f32; 3] = std::array::from_fn(|i| px * p.tw[i] - p.tu[i]);
        let l: [f32; 3] = std::array::from_fn(|i| py * p.tw[i] - p.tv[i]);
        let pp = cross(k, l);
        let (u, v) = (pp[0] / pp[2], pp[1] / pp[2]);
        let (dx, dy) = (p.xy[0] - px, p.xy[1] - py);
        let rho = (u * u + v * v).min(2.0 * (dx * dx + dy * dy));
        p.opacity * (-0.5 * rho).exp()
    }

    /// Every pixel × surfel: α at least 20% away from 1/255 and the
    /// transmittance after each contribution at least 0.02 away from 0.5
    /// (the median rule), so steps that move α by under 1% (and T by under
    /// 0.002) cross no threshold; all five surfels drawn at the sub-pixel one's centre.
    fn assert_margins(sf: &Surfels2, cam: &Camera) {
        let (img, st) = rasterize(sf, cam, &SurfelSettings::default());
        assert_eq!(st.proj.len(), 5);
        for y in 0..16 {
            for x in 0..16 {
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let mut t = 1.0f32;
                for &pi in st.tiles.list(0) {
                    let a = raw_alpha(&st.proj[pi as usize], px, py);
                    let ratio = a * 255.0;
                    assert!(!(0.8..1.25).contains(&ratio), "({x},{y}) α·255 = {ratio}");
                    if ratio >= 1.0 {
                        t *= 1.0 - a;
                        assert!((t - 0.5).abs() > 0.02, "({x},{y}) T = {t}");
                    }
                }
            }
        }
        assert_eq!(img.count[9 * 16 + 6], 5);
    }

    /// Random weights in [−1, 1] per pixel (three per pixel for RGB and the
    /// normal).
    fn weights(seed: u64, scale: f32) -> (Vec<f32>, Vec<[f32; 3]>) {
        let mut r = Lcg(seed);
        let one = (0..256).map(|_| r.range(-1.0, 1.0) * scale).collect();
        let three = (0..256)
            .map(|_| std::array::from_fn(|_| r.range(-1.0, 1.0) * scale))
            .collect();
        (one, three)
    }

    /// Test (b): every parameter group against f64 central differences of a
    /// linear loss on each output map in turn (RGB with a background,
    /// alpha, expected depth, median depth, accumulated normal, distortion
    /// ×100), on the smooth scene. Tolerance: [`check_gradient`]'s (2%
    /// relative, or 3e-5/h absolute for entries near zero: the blending is
    /// f32); steps 1e-3 (means, scales, quaternions, opacities) and 1e-2
    /// (SH, where the loss is linear). Three seeds. (Dropping the low-pass
    /// branch's centre gradient, or the intersection depth's dependence on
    /// (u, v) in that branch as the CUDA backward does, fails it.)
    #[test]
    fn gradients_match_finite_differences() {
        let cam = camera();
        let s = SurfelSettings {
            background: [0.3, 0.1, 0.6],
            ..Default::default()
        };
        let maps = [
            "rgb",
            "alpha",
            "expected depth",
            "median depth",
            "normal",
            "distortion",
        ];
        for seed in [1, 2, 3] {
            let sf = smooth_scene(seed);
            assert_margins(&sf, &cam);
            check_maps(&sf, &cam, &s, &maps);
        }
    }

    /// The checks of [`gradients_match_finite_differences`] on one scene.
    fn check_maps(sf: &Surfels2, cam: &Camera, s: &SurfelSettings, maps: &[&str; 6]) {
        let (cam, s) = (cam.clone(), *s);
        for (mi, &map) in maps.iter().enumerate() {
            let scale = if map == "distortion" { 100.0 } else { 1.0 };
            let (w1, w3) = weights(40 + mi as u64, scale);
            let loss = |sf: &Surfels2| -> f64 {
                let (img, st) = rasterize(sf, &cam, &s);
                let one = |v: &[f32]| v.iter().zip(&w1).map(|(a, b)| *a as f64 * *b as f64).sum();
                let three = |v: &[[f32; 3]]| -> f64 {
                    v.iter()
                        .zip(&w3)
                        .map(|(a, b)| (0..3).map(|k| a[k] as f64 * b[k] as f64).sum::<f64>())
                        .sum()
                };
                match mi {
                    0 => three(&img.rgb),
                    1 => one(&img.alpha),
                    2 => one(&img.expected_depth),
                    3 => one(&img.median_depth),
                    4 => three(&img.normal_sum),
                    _ => one(&st.distortion),
                }
            };
            let zero3 = vec![[0.0f32; 3]; 256];
            let mut aux = SurfelAuxGrads::default();
            let d_rgb = if mi == 0 { &w3 } else { &zero3 };
            match mi {
                1 => aux.alpha = Some(&w1),
                2 => aux.depth = Some(&w1),
                3 => aux.median_depth = Some(&w1),
                4 => aux.normal = Some(&w3),
                5 => aux.distortion = Some(&w1),
                _ => {}
            }
            let (img, _) = rasterize(sf, &cam, &s);
            let gr = backward(sf, &cam, &s, &img, d_rgb, &aux);
            let f3 = |v: &[[f32; 3]]| v.iter().flatten().map(|&x| x as f64).collect::<Vec<_>>();
            check_gradient(&format!("{map}: means"), &f3(&gr.means), 1e-3, |k, h| {
                let mut s2 = sf.clone();
                s2.means[k / 3][k % 3] += h as f32;
                loss(&s2)
            });
            let sc: Vec<f64> = gr.scales.iter().flatten().map(|&x| x as f64).collect();
            check_gradient(&format!("{map}: scales"), &sc, 1e-3, |k, h| {
                let mut s2 = sf.clone();
                s2.scales[k / 2][k % 2] += h as f32;
                loss(&s2)
            });
            let rot: Vec<f64> = gr.rotations.iter().flatten().map(|&x| x as f64).collect();
            check_gradient(&format!("{map}: rotations"), &rot, 1e-3, |k, h| {
                let mut s2 = sf.clone();
                s2.rotations[k / 4][k % 4] += h as f32;
                loss(&s2)
            });
            let op: Vec<f64> = gr.opacities.iter().map(|&x| x as f64).collect();
            let op_loss = |k: usize, h: f64| {
                let mut s2 = sf.clone();
                s2.opacities[k] += h as f32;
                loss(&s2)
            };
            if mi == 3 {
                // the median depth does not depend on opacities while the
                // median contributor stays: zero, and so are the differences
                assert!(op.iter().all(|&v| v == 0.0), "{map}: opacities {op:?}");
                for k in 0..op.len() {
                    let fd = (op_loss(k, 1e-3) - op_loss(k, -1e-3)) / 2e-3;
                    assert!(fd.abs() < 1e-3, "{map}: opacity {k}: {fd}");
                }
            } else {
                check_gradient(&format!("{map}: opacities"), &op, 1e-3, op_loss);
            }
            if mi == 0 {
                check_gradient(&format!("{map}: sh"), &f3(&gr.sh), 1e-2, |k, h| {
                    let mut s2 = sf.clone();
                    s2.sh[k / 3][k % 3] += h as f32;
                    loss(&s2)
                });
            } else {
                assert!(gr.sh.iter().flatten().all(|&v| v == 0.0), "{map}: SH");
            }
        }
    }

    /// `means2d` is ∂L/∂(T_u,z, T_v,z)·T_w,z: the gradient with respect to
    /// the centre's pixel position at fixed depth. With the box-centre
    /// (low-pass) branch unused and SH degree 0, that is the mean's
    /// gradient in camera axes, (R_cam·∂L/∂μ)_x·z/fx and _y·z/fy, since
    /// T_u,z = fx·c_x + cx·c_z and T_v,z = fy·c_y + cy·c_z.
    #[test]
    fn means2d_is_the_centre_gradient_at_fixed_depth() {
        let cam = camera();
        let s = SurfelSettings::default();
        let mut sf = smooth_scene(2);
        // the four large surfels only, DC colour only
        sf.means.truncate(4);
        sf.scales.truncate(4);
        sf.rotations.truncate(4);
        sf.opacities.truncate(4);
        sf.sh = (0..4).map(|i| sf.sh[i * 4]).collect();
        sf.sh_degree = 0;
        let (img, st) = rasterize(&sf, &cam, &s);
        for y in 0..16 {
            for x in 0..16 {
                for p in &st.proj {
                    if let Some(hh) = hit(p, x as f32 + 0.5, y as f32 + 0.5, 0.2) {
                        assert!(hh.rho3d <= hh.rho2d, "low-pass branch at ({x},{y})");
                    }
                }
            }
        }
        let (w1, w3) = weights(7, 1.0);
        let aux = SurfelAuxGrads {
            alpha: Some(&w1),
            depth: Some(&w1),
            normal: Some(&w3),
            ..Default::default()
        };
        let gr = backward(&sf, &cam, &s, &img, &w3, &aux);
        for p in &st.proj {
            let i = p.id as usize;
            let g = DVec3::from_array(gr.means[i].map(f64::from));
            let gc = cam.rotation * g;
            let z = p.tw[2] as f64;
            let want = [gc.x * z / cam.fx, gc.y * z / cam.fy];
            for k in 0..2 {
                let got = gr.means2d[i][k] as f64;
                let tol = 1e-4 * want[k].abs().max(1e-2);
                assert!(
                    (got - want[k]).abs() < tol,
                    "{i}: {:?} vs {want:?}",
                    gr.means2d[i]
                );
            }
        }
        let ndc = gr.means2d_ndc(16, 16);
        assert_eq!(ndc[0], [gr.means2d[0][0] * 8.0, gr.means2d[0][1] * 8.0]);
    }

    /// Test (d), backward part: a random scene with layers, thin and faint
    /// surfels gives the same gradient bytes on one thread and on four,
    /// with every auxiliary gradient given.
    #[test]
    fn backward_is_the_same_for_any_thread_count() {
        let sf = random_scene(5, 60, 2);
        let cam = look_at(70, 50, 60.0, DVec3::new(0.5, -0.3, -5.0), DVec3::ZERO);
        let s = SurfelSettings::default();
        let mut r = Lcg(9);
        let n = 70 * 50;
        let d_rgb: Vec<[f32; 3]> = (0..n)
            .map(|_| std::array::from_fn(|_| r.range(-1.0, 1.0)))
            .collect();
        let one: Vec<f32> = (0..n).map(|_| r.range(-1.0, 1.0)).collect();
        let aux = SurfelAuxGrads {
            alpha: Some(&one),
            depth: Some(&one),
            median_depth: Some(&one),
            normal: Some(&d_rgb),
            distortion: Some(&one),
        };
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    let (img, _) = rasterize(&sf, &cam, &s);
                    backward(&sf, &cam, &s, &img, &d_rgb, &aux)
                })
        };
        let a = run(1);
        assert_eq!(a, run(4));
        assert!(a.means.iter().flatten().any(|&v| v != 0.0));
    }
}
