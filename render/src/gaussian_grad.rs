//! Backward pass of the Gaussian rasteriser.
//!
//! Input: the [`RasterState`] of a forward pass and the gradient of a scalar
//! loss L with respect to each output pixel's RGB and, optionally
//! ([`AuxGrads`]), its alpha, its expected depth
//! ([`crate::gaussian::RenderOutput::expected_depth`], D = Σ w z / Σ w) and
//! its accumulated normal
//! ([`crate::gaussian::RenderOutput::normal_sum`], N = Σ w n, camera space,
//! not normalised), where w = α T are the blend weights, z the view depth
//! (camera z) of each Gaussian's mean and n its shortest axis turned to face
//! the camera. Output: the gradient with respect to every parameter of
//! [`Gaussians3`] as the rasteriser takes them (activated values: means,
//! scales in world units, quaternions (w, x, y, z) before normalisation,
//! opacities, SH coefficients), and ∂L/∂(projected mean) in pixels
//! ([`GaussianGrads::means2d`]).
//!
//! Two stages, as in the 3DGS CUDA backward:
//! 1. per pixel, the blending is walked back to front from the last blended
//!    contribution (the colour, depth and normal behind each Gaussian are
//!    rebuilt as it goes) and the gradient reaches each Gaussian's 2-D mean,
//!    conic, opacity, colour, depth and normal; per-tile buffers aligned with
//!    the tile lists keep this deterministic, and they are summed in tile
//!    order;
//! 2. per Gaussian, the screen gradients are taken back through the
//!    projection by the hand-written reverse sweep of
//!    [`crate::gaussian_vjp`] (tested equal to the Dual-number Jacobian of
//!    the forward code): 2-D mean, conic, view depth, normal and
//!    view-dependent colour to the mean, scales and quaternion; the SH
//!    gradient is the basis times the colour gradient.
//!
//! The depth and normal outputs are blends like the colour: ∂N/∂α_i =
//! T_i (n_i − N_behind) and ∂(Σ w z)/∂α_i likewise with background 0, and
//! D = (Σ w z)/(Σ w) with ∂(Σ w)/∂α_i = T_final/(1 − α_i), as for alpha.
//! The depth z depends on the mean only; the normal on the quaternion only:
//! which axis is shortest and the flip towards the camera are taken as
//! constants, so the scales get no gradient through n (only through the
//! blend weights).
//!
//! Exact derivative of the forward semantics: a clamped α (o·G > 0.99) or a
//! clamped colour (< 0) passes no gradient; skipped contributions
//! (α < 1/255) pass none. The median depth and the normalised normal map are
//! not differentiated.

use rayon::prelude::*;

use crate::Camera;
use crate::gaussian::{Gaussians3, RasterSettings, RasterState, TILE, pixel_span, rotation_rows};
use crate::gaussian_vjp::{ScreenGrad, colour_vjp, geometry_vjp};
use crate::sh::coeff_count;
pub use crate::splats::SplatGrads;
use crate::tiles::{PREFETCH_DISTANCE, prefetch_ahead, tile_pixels};

/// Gradients of a loss with respect to [`Gaussians3`]'s fields, plus the
/// screen-space mean gradient (see [`SplatGrads`]).
pub type GaussianGrads = SplatGrads<3>;
pub use crate::splats::means2d_to_ndc;

/// Per-pixel gradients of the loss with respect to the auxiliary outputs,
/// each row-major `width × height` like the image, or `None` for zero.
#[derive(Clone, Copy, Debug, Default)]
pub struct AuxGrads<'a> {
    /// ∂L/∂alpha (alpha = 1 − T_final).
    pub alpha: Option<&'a [f32]>,
    /// ∂L/∂expected depth ([`crate::gaussian::RenderOutput::expected_depth`],
    /// Σ w z / Σ w, scene units; pixels where nothing was blended get none).
    pub depth: Option<&'a [f32]>,
    /// ∂L/∂normal_sum ([`crate::gaussian::RenderOutput::normal_sum`],
    /// Σ w n, camera axes, not normalised).
    pub normal: Option<&'a [[f32; 3]]>,
}

impl AuxGrads<'_> {
    /// Panics unless `d_rgb` and every given auxiliary gradient hold one
    /// value per pixel of a `w × h` image (a caller's bug, as a wrong
    /// buffer length is in every rasteriser entry point).
    pub(crate) fn check_lengths(&self, d_rgb: &[[f32; 3]], w: usize, h: usize) {
        assert_eq!(d_rgb.len(), w * h, "one RGB gradient per pixel");
        for len in [
            self.alpha.map(<[f32]>::len),
            self.depth.map(<[f32]>::len),
            self.normal.map(<[[f32; 3]]>::len),
        ]
        .into_iter()
        .flatten()
        {
            assert_eq!(len, w * h, "one auxiliary gradient per pixel");
        }
    }

    /// Whether a depth or normal gradient is given (the backward passes then
    /// carry the longer per-primitive screen gradient).
    pub(crate) fn has_geometry(&self) -> bool {
        self.depth.is_some() || self.normal.is_some()
    }
}

/// One pixel's state in the backward walk.
#[derive(Clone, Copy, Default)]
struct PixelBack {
    /// Transmittance in front of the current contribution.
    t: f32,
    t_final: f32,
    /// Colour behind the current contribution (normalised).
    behind: [f32; 3],
    gc: [f32; 3],
    /// ∂L/∂alpha, with the expected depth's dependence on Σ w folded in.
    ga: f32,
    last: u32,
    /// Σ w z and Σ w n behind the current contribution (normalised,
    /// background 0) and ∂L/∂(Σ w z), ∂L/∂(Σ w n).
    behind_z: f32,
    behind_n: [f32; 3],
    gz: f32,
    gn: [f32; 3],
}

/// Length of the per-Gaussian screen gradient: ∂L/∂(x, y, conic a, b, c,
/// opacity, r, g, b), then, with auxiliary gradients, ∂L/∂(z, n_x, n_y, n_z).
const SCREEN: usize = 9;
const SCREEN_AUX: usize = 13;

/// Gradient of the loss with respect to `g`, given ∂L/∂rgb per pixel
/// (row-major, `width × height`) and optionally ∂L/∂alpha. Same as
/// [`backward_aux`] with only the alpha gradient.
pub fn backward(
    g: &Gaussians3,
    cam: &Camera,
    s: &RasterSettings,
    state: &RasterState,
    d_rgb: &[[f32; 3]],
    d_alpha: Option<&[f32]>,
) -> GaussianGrads {
    let aux = AuxGrads {
        alpha: d_alpha,
        ..Default::default()
    };
    backward_aux(g, cam, s, state, d_rgb, &aux)
}

/// Gradient of the loss with respect to `g` (and the projected means),
/// given ∂L/∂rgb per pixel (row-major, `width × height`) and the auxiliary
/// outputs' gradients `aux`. Deterministic for any thread count.
pub fn backward_aux(
    g: &Gaussians3,
    cam: &Camera,
    s: &RasterSettings,
    state: &RasterState,
    d_rgb: &[[f32; 3]],
    aux: &AuxGrads,
) -> GaussianGrads {
    let (w, h) = (cam.width as usize, cam.height as usize);
    aux.check_lengths(d_rgb, w, h);
    if aux.has_geometry() {
        let screen = screen_grads::<SCREEN_AUX>(s, state, d_rgb, aux, w, h);
        through_projection(g, cam, s, state, &screen)
    } else {
        let screen = screen_grads::<SCREEN>(s, state, d_rgb, aux, w, h);
        through_projection(g, cam, s, state, &screen)
    }
}

/// Stage 1: per projected Gaussian, ∂L/∂ its screen quantities (K =
/// [`SCREEN`], or [`SCREEN_AUX`] to include depth and normal).
fn screen_grads<const K: usize>(
    s: &RasterSettings,
    state: &RasterState,
    d_rgb: &[[f32; 3]],
    aux: &AuxGrads,
    w: usize,
    h: usize,
) -> Vec<[f64; K]> {
    let geo = K > SCREEN;
    let tw = state.tiles.tiles_x;
    let proj = &state.proj;
    let tile_grads: Vec<Vec<[f32; K]>> = (0..state.tiles.len())
        .into_par_iter()
        .map(|ti| {
            let list = state.tiles.list(ti);
            let mut acc = vec![[0.0f32; K]; list.len()];
            let (tx, ty) = (ti % tw, ti / tw);
            let (x0, y0) = (tx * TILE, ty * TILE);
            // per-pixel state of the backward walk
            let mut px_state = [PixelBack::default(); TILE * TILE];
            let mut max_last = 0;
            for (x, y) in tile_pixels(ti, tw, w, h) {
                let o = y * w + x;
                max_last = max_last.max(state.last[o]);
                let mut b = PixelBack {
                    t: state.final_t[o],
                    t_final: state.final_t[o],
                    behind: s.background,
                    gc: d_rgb[o],
                    ga: aux.alpha.map_or(0.0, |a| a[o]),
                    last: state.last[o],
                    ..Default::default()
                };
                if geo {
                    let ws = state.weight_sum[o];
                    if let (Some(dd), true) = (aux.depth, ws > 0.0) {
                        // D = S / W: ∂L/∂S = g/W, ∂L/∂W = −g·D/W
                        b.gz = dd[o] / ws;
                        b.ga -= dd[o] * state.expected_depth[o] / ws;
                    }
                    if let Some(dn) = aux.normal {
                        b.gn = dn[o];
                    }
                }
                px_state[(y - y0) * TILE + (x - x0)] = b;
            }
            // Gaussian-major, back to front: each pixel still walks its own
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
                    let dy = p.xy[1] - py;
                    for x in xa..=xb {
                        let b = &mut px_state[(y - y0) * TILE + (x - x0)];
                        if li as u32 >= b.last {
                            continue;
                        }
                        let dx = p.xy[0] - (x as f32 + 0.5);
                        let power = -0.5 * (p.conic[0] * dx * dx + p.conic[2] * dy * dy)
                            - p.conic[1] * dx * dy;
                        // the forward pass's test and exponential (same bits)
                        if !(power <= 0.0 && power >= p.power_cut) {
                            continue;
                        }
                        let gauss = crate::exp_approx::exp(power);
                        let raw = p.opacity * gauss;
                        let alpha = raw.min(0.99);
                        if alpha < 1.0 / 255.0 {
                            continue;
                        }
                        // transmittance in front of this Gaussian
                        let inv = 1.0 / (1.0 - alpha);
                        b.t *= inv;
                        let wgt = alpha * b.t;
                        let mut d_a = 0.0f32;
                        for k in 0..3 {
                            e[6 + k] += b.gc[k] * wgt;
                            d_a += b.gc[k] * (p.rgb[k] - b.behind[k]) * b.t;
                            b.behind[k] = alpha * p.rgb[k] + (1.0 - alpha) * b.behind[k];
                        }
                        if geo {
                            e[SCREEN] += b.gz * wgt;
                            d_a += b.gz * (p.depth - b.behind_z) * b.t;
                            b.behind_z = alpha * p.depth + (1.0 - alpha) * b.behind_z;
                            for k in 0..3 {
                                e[SCREEN + 1 + k] += b.gn[k] * wgt;
                                d_a += b.gn[k] * (p.normal[k] - b.behind_n[k]) * b.t;
                                b.behind_n[k] = alpha * p.normal[k] + (1.0 - alpha) * b.behind_n[k];
                            }
                        }
                        d_a += b.ga * b.t_final * inv;
                        if raw >= 0.99 {
                            continue;
                        }
                        e[5] += gauss * d_a;
                        let d_power = p.opacity * gauss * d_a;
                        e[0] += -d_power * (p.conic[0] * dx + p.conic[1] * dy);
                        e[1] += -d_power * (p.conic[2] * dy + p.conic[1] * dx);
                        e[2] += -0.5 * d_power * dx * dx;
                        e[3] += -d_power * dx * dy;
                        e[4] += -0.5 * d_power * dy * dy;
                    }
                }
                acc[li] = e;
            }
            acc
        })
        .collect();
    state.tiles.gather(&tile_grads)
}

/// Stage 2: the screen gradients through each Gaussian's projection
/// ([`crate::gaussian_vjp`]), written straight into the output arrays in
/// parallel (each Gaussian's entries by one task: deterministic).
fn through_projection<const K: usize>(
    g: &Gaussians3,
    cam: &Camera,
    s: &RasterSettings,
    state: &RasterState,
    screen: &[[f64; K]],
) -> GaussianGrads {
    let n = g.len();
    let nc = coeff_count(g.sh_degree);
    let mut out = GaussianGrads {
        means: vec![[0.0; 3]; n],
        scales: vec![[0.0; 3]; n],
        rotations: vec![[0.0; 4]; n],
        opacities: vec![0.0; n],
        sh: vec![[0.0; 3]; n * nc],
        means2d: vec![[0.0; 2]; n],
    };
    if nc == 0 {
        return out;
    }
    // position in the projected list of each Gaussian (culled: none)
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
            let mut sg = ScreenGrad {
                xy: [d[0], d[1]],
                conic: [d[2], d[3], d[4]],
                opacity: d[5],
                ..Default::default()
            };
            if K > SCREEN {
                sg.depth = d[SCREEN];
                sg.normal = [d[SCREEN + 1], d[SCREEN + 2], d[SCREEN + 3]];
            }
            let geo = geometry_vjp(
                g.means[i],
                g.scales[i],
                g.rotations[i],
                g.opacities[i],
                s.filter_2d,
                cam,
                &rows,
                &sg,
            );
            let gc = colour_vjp(
                g.means[i],
                eye,
                &g.sh[i * nc..(i + 1) * nc],
                g.sh_degree,
                [d[6], d[7], d[8]],
                gsh,
            );
            *gm = std::array::from_fn(|k| (geo[k] + gc[k]) as f32);
            *gsc = std::array::from_fn(|k| geo[3 + k] as f32);
            *grot = std::array::from_fn(|k| geo[6 + k] as f32);
            *gop = geo[10] as f32;
            *gxy = [d[0] as f32, d[1] as f32];
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gaussian::rasterize;
    use crate::testutil::{
        Lcg, aux_weights, check_gradient, eval_full, linear_loss, random_sh, test_camera,
    };

    /// A scene whose image is smooth in every parameter: a few large
    /// Gaussians (σ ≥ 40 px on a 48×40 image) that cover every pixel with
    /// α above 1/255 and touch every tile, opacities ≤ 0.85 (no 0.99 clamp),
    /// seven layers at most (T never reaches 1e-4). Then the only
    /// non-smoothness of the forward pass is absent and central differences
    /// are a fair ground truth.
    fn smooth_scene(seed: u64) -> Gaussians3 {
        let mut r = Lcg(seed);
        let mut g = Gaussians3 {
            sh_degree: 3,
            ..Default::default()
        };
        for _ in 0..6 {
            let z = r.range(4.0, 6.0);
            g.means.push([
                r.range(-0.4, 0.4) * z / 2.0,
                r.range(-0.4, 0.4) * z / 2.0,
                z,
            ]);
            g.scales
                .push([r.range(4.0, 7.0), r.range(4.0, 7.0), r.range(1.0, 3.0)]);
            g.rotations.push([
                r.range(0.5, 1.0),
                r.range(-0.5, 0.5),
                r.range(-0.5, 0.5),
                r.range(-0.5, 0.5),
            ]);
            g.opacities.push(r.range(0.3, 0.85));
            g.sh.extend(random_sh(&mut r, 16));
        }
        g
    }

    /// Central-difference checks of ∂L/∂means (step 1e-2), scales (5e-2),
    /// quaternions (1e-2) and opacities (1e-3) of `gr` against `loss` around
    /// `g` ([`check_gradient`] and its tolerance); `label` prefixes the names
    /// in a failure.
    fn check_params(
        label: &str,
        g: &Gaussians3,
        gr: &GaussianGrads,
        loss: impl Fn(&Gaussians3) -> f64,
    ) {
        let flat = |v: &[[f32; 3]]| v.iter().flatten().map(|&x| x as f64).collect::<Vec<_>>();
        check_gradient(&format!("{label} means"), &flat(&gr.means), 1e-2, |k, h| {
            let mut g2 = g.clone();
            g2.means[k / 3][k % 3] += h as f32;
            loss(&g2)
        });
        check_gradient(
            &format!("{label} scales"),
            &flat(&gr.scales),
            5e-2,
            |k, h| {
                let mut g2 = g.clone();
                g2.scales[k / 3][k % 3] += h as f32;
                loss(&g2)
            },
        );
        let rot: Vec<f64> = gr.rotations.iter().flatten().map(|&x| x as f64).collect();
        check_gradient(&format!("{label} rotations"), &rot, 1e-2, |k, h| {
            let mut g2 = g.clone();
            g2.rotations[k / 4][k % 4] += h as f32;
            loss(&g2)
        });
        let op: Vec<f64> = gr.opacities.iter().map(|&x| x as f64).collect();
        check_gradient(&format!("{label} opacities"), &op, 1e-3, |k, h| {
            let mut g2 = g.clone();
            g2.opacities[k] += h as f32;
            loss(&g2)
        });
    }

    /// Every parameter type against central differences of the loss
    /// L = Σ w·rgb + Σ v·alpha with random weights. The rasteriser blends in
    /// f32 (see [`check_gradient`] for the tolerance); steps are small
    /// against each parameter's size so the O(h²) truncation error stays
    /// below the noise.
    #[test]
    fn gradients_match_finite_differences() {
        let cam = test_camera(48, 40, 60.0);
        let s = RasterSettings {
            background: [0.2, 0.3, 0.1],
            ..Default::default()
        };
        for seed in [1u64, 2, 3] {
            let g = smooth_scene(seed);
            let (wr, wa) = linear_loss(48 * 40, seed + 100);
            let loss = |g: &Gaussians3| {
                let img = crate::gaussian::render(g, &cam, &s);
                crate::testutil::eval_linear(&img.rgb, &img.alpha, &wr, &wa)
            };
            let (img, state) = rasterize(&g, &cam, &s);
            assert!(
                img.count.iter().all(|&c| c == 6),
                "every Gaussian covers every pixel"
            );
            let gr = backward(&g, &cam, &s, &state, &wr, Some(&wa));
            check_params("", &g, &gr, loss);
            let flat = |v: &[[f32; 3]]| v.iter().flatten().map(|&x| x as f64).collect::<Vec<_>>();
            check_gradient("sh", &flat(&gr.sh), 1e-2, |k, h| {
                let mut g2 = g.clone();
                g2.sh[k / 3][k % 3] += h as f32;
                loss(&g2)
            });
        }
    }

    /// The 2-D Mip filter's backward (Mip-Splatting / GOF): every
    /// parameter against central differences, as
    /// [`gradients_match_finite_differences`]. The dilation is a large
    /// 3000 px² so that the opacity factor coef (≈ 0.3 to 0.9 here) and its
    /// gradient through the covariance weigh as much as the rest; with the
    /// reference's 0.1 px² on these wide Gaussians it would be ≈ 1 − 1e-5
    /// and its gradient invisible under the f32 noise.
    #[test]
    fn mip_filter_gradients_match_finite_differences() {
        use crate::gaussian::{Filter2d, project};
        let cam = test_camera(48, 40, 60.0);
        let s = RasterSettings {
            background: [0.2, 0.3, 0.1],
            filter_2d: Filter2d::Mip {
                kernel_size: 3000.0,
            },
            ..Default::default()
        };
        for seed in [1u64, 2] {
            let g = smooth_scene(seed);
            for i in 0..g.len() {
                let p = project(&g, i, &cam, &s).expect("in view");
                let coef = p.opacity / g.opacities[i];
                assert!((0.1..0.9).contains(&coef), "coef {coef}");
            }
            let (wr, wa) = linear_loss(48 * 40, seed + 100);
            let loss = |g: &Gaussians3| {
                let img = crate::gaussian::render(g, &cam, &s);
                crate::testutil::eval_linear(&img.rgb, &img.alpha, &wr, &wa)
            };
            let (img, state) = rasterize(&g, &cam, &s);
            assert!(img.count.iter().all(|&c| c == 6));
            let gr = backward(&g, &cam, &s, &state, &wr, Some(&wa));
            check_params("mip", &g, &gr, loss);
        }
    }

    /// Deterministic: the gradient does not depend on the thread count.
    #[test]
    fn backward_is_deterministic_across_threads() {
        let cam = test_camera(48, 40, 60.0);
        let s = RasterSettings::default();
        let g = smooth_scene(9);
        let (wr, wa) = linear_loss(48 * 40, 5);
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool")
                .install(|| {
                    let (_, st) = rasterize(&g, &cam, &s);
                    backward(&g, &cam, &s, &st, &wr, Some(&wa))
                })
        };
        assert_eq!(run(1), run(3));
        // with depth and normal gradients too
        let (wd, wn) = aux_weights(48 * 40, 6);
        let run_aux = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool")
                .install(|| {
                    let (_, st) = rasterize(&g, &cam, &s);
                    let aux = AuxGrads {
                        alpha: Some(&wa),
                        depth: Some(&wd),
                        normal: Some(&wn),
                    };
                    backward_aux(&g, &cam, &s, &st, &wr, &aux)
                })
        };
        assert_eq!(run_aux(1), run_aux(3));
        // zero depth and normal gradients: the same as the plain backward
        let zd = vec![0.0f32; 48 * 40];
        let zn = vec![[0.0f32; 3]; 48 * 40];
        let (_, st) = rasterize(&g, &cam, &s);
        let aux = AuxGrads {
            alpha: Some(&wa),
            depth: Some(&zd),
            normal: Some(&zn),
        };
        assert_eq!(
            backward_aux(&g, &cam, &s, &st, &wr, &aux),
            backward(&g, &cam, &s, &st, &wr, Some(&wa))
        );
    }

    /// The depth and normal gradients, with the colour and alpha ones, on
    /// the smooth scenes of [`gradients_match_finite_differences`] against
    /// central differences of L = Σ w·rgb + Σ v·alpha + Σ u·D + Σ q·N with
    /// random weights (D expected depth, N = Σ w n). Same tolerance as
    /// there ([`check_gradient`]: 2% relative, or 3e-5/h absolute for
    /// entries near zero): the depth term adds values near 5 per pixel,
    /// whose f32 rounding (≈ 3e-7 each, random in sign) sums to about 1e-5
    /// over the 1920 pixels, the noise level the floor is made for. The
    /// scales (4–7, 4–7, 1–3) keep the third axis the shortest under every
    /// step, so the normal's axis choice does not flip. Then ∂L/∂(projected
    /// x, y) ([`GaussianGrads::means2d`]) against central differences in
    /// which the projected means themselves are moved (h = 0.05 px) and the
    /// projected Gaussians re-blended.
    #[test]
    fn aux_gradients_match_finite_differences() {
        use crate::gaussian::{Projected, blend_projected, render};
        let cam = test_camera(48, 40, 60.0);
        let s = RasterSettings {
            background: [0.2, 0.3, 0.1],
            ..Default::default()
        };
        for seed in [1u64, 2, 3] {
            let g = smooth_scene(seed);
            let (wr, wa) = linear_loss(48 * 40, seed + 100);
            let (wd, wn) = aux_weights(48 * 40, seed + 200);
            let weights = ((&wr[..], &wa[..]), (&wd[..], &wn[..]));
            let loss = |g: &Gaussians3| eval_full(&render(g, &cam, &s), weights.0, weights.1);
            let (img, state) = rasterize(&g, &cam, &s);
            assert!(img.count.iter().all(|&c| c == 6));
            let aux = AuxGrads {
                alpha: Some(&wa),
                depth: Some(&wd),
                normal: Some(&wn),
            };
            let gr = backward_aux(&g, &cam, &s, &state, &wr, &aux);
            check_params("aux", &g, &gr, loss);
            // the projected means moved directly
            let m2d: Vec<f64> = gr.means2d.iter().flatten().map(|&x| x as f64).collect();
            check_gradient("means2d", &m2d, 5e-2, |k, h| {
                let mut proj: Vec<Projected> = state.proj.clone();
                let j = proj
                    .iter()
                    .position(|p| p.id as usize == k / 2)
                    .expect("visible");
                proj[j].xy[k % 2] += h as f32;
                let (img, _) = blend_projected(proj, 48, 40, &s);
                eval_full(&img, weights.0, weights.1)
            });
        }
    }

    /// Depth and normal separately (each alone in the loss), so that one
    /// cannot hide an error in the other behind the colour terms.
    #[test]
    fn depth_and_normal_gradients_alone() {
        use crate::gaussian::{RenderOutput, render};
        let cam = test_camera(48, 40, 60.0);
        let s = RasterSettings::default();
        let g = smooth_scene(4);
        let zero_rgb = vec![[0.0f32; 3]; 48 * 40];
        let zero_a = vec![0.0f32; 48 * 40];
        let zero_n = vec![[0.0f32; 3]; 48 * 40];
        let (wd, wn) = aux_weights(48 * 40, 11);
        let (_, state) = rasterize(&g, &cam, &s);
        for (name, depth, normal) in [
            ("depth", &wd[..], &zero_n[..]),
            ("normal", &zero_a[..], &wn[..]),
        ] {
            let loss = |g: &Gaussians3| {
                let img: RenderOutput = render(g, &cam, &s);
                eval_full(&img, (&zero_rgb, &zero_a), (depth, normal))
            };
            let aux = AuxGrads {
                alpha: None,
                depth: Some(depth),
                normal: Some(normal),
            };
            let gr = backward_aux(&g, &cam, &s, &state, &zero_rgb, &aux);
            check_params(name, &g, &gr, loss);
        }
    }

    /// The NDC conversion is 3DGS's: x·W/2, y·H/2.
    #[test]
    fn means2d_ndc_scales_by_half_the_image() {
        let gr = GaussianGrads {
            means2d: vec![[1.0, -2.0], [0.0, 0.5]],
            ..Default::default()
        };
        assert_eq!(gr.means2d_ndc(100, 50), vec![[50.0, -50.0], [0.0, 12.5]]);
    }

    /// Radii: the projection's radius for the visible Gaussians, 0 for one
    /// behind the camera and one far off screen; the mean gradient of the
    /// culled ones is zero.
    #[test]
    fn radii_of_the_visible_set() {
        let cam = test_camera(48, 40, 60.0);
        let s = RasterSettings::default();
        let mut g = smooth_scene(5);
        g.means[1] = [0.0, 0.0, -3.0];
        g.means[4] = [500.0, 0.0, 3.0];
        let (_, st) = rasterize(&g, &cam, &s);
        let radii = st.radii(g.len(), 48, 40);
        for (i, &r) in radii.iter().enumerate() {
            if i == 1 || i == 4 {
                assert_eq!(r, 0.0, "{i}");
            } else {
                let p = st
                    .proj
                    .iter()
                    .find(|p| p.id as usize == i)
                    .expect("projected");
                assert_eq!(r, p.radius);
                assert!(r > 0.0);
            }
        }
        let vis: Vec<usize> = st.visible_radii(48, 40).map(|(i, _)| i).collect();
        assert_eq!(vis.len(), 4);
        let (wr, _) = linear_loss(48 * 40, 1);
        let gr = backward(&g, &cam, &s, &st, &wr, None);
        assert_eq!(gr.means2d[1], [0.0; 2]);
        assert_eq!(gr.means2d[4], [0.0; 2]);
        assert!(gr.means2d[0] != [0.0; 2]);
    }
}
