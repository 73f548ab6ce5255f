//! Backward pass of the triangle-splat rasteriser.
//!
//! Input: the [`TriangleState`] of a forward pass and ∂L/∂rgb per pixel,
//! optionally ([`AuxGrads`]) ∂L/∂alpha, ∂L/∂expected depth
//! ([`crate::gaussian::RenderOutput::expected_depth`], D = Σ w z / Σ w) and
//! ∂L/∂accumulated normal ([`crate::gaussian::RenderOutput::normal_sum`],
//! N = Σ w n, camera space, not normalised), with w = α T the blend weights,
//! z the view z of each triangle's 3-D centroid and n its camera-facing unit
//! face normal. Output: ∂L/∂ each parameter of [`Triangles3`] (vertices in
//! world units, activated σ and opacity, SH coefficients).
//!
//! Per pixel the blending is walked back to front (as for Gaussians); the
//! window I = (φ/φ(s))^σ with φ = L_k(p) the largest edge value gives
//! ∂I/∂σ = I·ln(φ/φ(s)), ∂I/∂φ = σI/φ, ∂I/∂φ(s) = −σI/φ(s), and
//! ∂φ/∂(n_k, d_k) = (p, 1). Depth and normal are blended like the colour
//! (background 0); D = (Σ w z)/(Σ w) with ∂(Σ w)/∂α_i = T_final/(1 − α_i).
//! Per triangle, the projection (vertices → edge lines, inradius,
//! view-dependent colour, centroid depth, unit face normal) is re-run with
//! [`Dual`] numbers over the 9 vertex coordinates; the normal's flip towards
//! the camera and its length clamp (1e-4) are constants there. So the depth
//! and normal gradients reach σ and opacity through the blend weights, and
//! the vertices through the weights (edge lines, inradius) and through z
//! and n. Clamped α or colour passes no gradient; the median depth and the
//! normalised normal map are not differentiated.

use rayon::prelude::*;

use crate::Camera;
use crate::dual::Dual;
use crate::gaussian::{RasterSettings, rotation_rows};
pub use crate::gaussian_grad::AuxGrads;
use crate::sh::{basis, coeff_count};
use crate::tiles::tile_pixels;
use crate::triangle::{TriangleState, Triangles3, project_tri_t, window};

/// Gradients, shaped like [`Triangles3`]'s fields.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleGrads {
    pub vertices: Vec<[[f32; 3]; 3]>,
    pub sigmas: Vec<f32>,
    pub opacities: Vec<f32>,
    pub sh: Vec<[f32; 3]>,
}

/// Length of the per-triangle screen gradient ∂L/∂(edges 9, φ(s), σ,
/// opacity, rgb 3), then, with depth or normal gradients, ∂L/∂(z, n 3).
const SCREEN: usize = 15;
const SCREEN_AUX: usize = 19;

/// Index, ∂L/∂vertices, ∂L/∂σ, ∂L/∂opacity, ∂L/∂SH.
type PerTriangle = (usize, [f64; 9], f32, f32, [[f32; 3]; 16]);

/// Gradient of the loss with respect to `t`, given ∂L/∂rgb per pixel and
/// optionally ∂L/∂alpha. Same as [`backward_aux`] with only the alpha
/// gradient.
pub fn backward(
    t: &Triangles3,
    cam: &Camera,
    s: &RasterSettings,
    state: &TriangleState,
    d_rgb: &[[f32; 3]],
    d_alpha: Option<&[f32]>,
) -> TriangleGrads {
    let aux = AuxGrads {
        alpha: d_alpha,
        ..Default::default()
    };
    backward_aux(t, cam, s, state, d_rgb, &aux)
}

/// Gradient of the loss with respect to `t`, given ∂L/∂rgb per pixel
/// (row-major, `width × height`) and the auxiliary outputs' gradients
/// `aux` (see the module docs for what they are taken with respect to).
/// Deterministic for any thread count.
pub fn backward_aux(
    t: &Triangles3,
    cam: &Camera,
    s: &RasterSettings,
    state: &TriangleState,
    d_rgb: &[[f32; 3]],
    aux: &AuxGrads,
) -> TriangleGrads {
    let (w, h) = (cam.width as usize, cam.height as usize);
    aux.check_lengths(d_rgb, w, h);
    if aux.has_geometry() {
        let screen = screen_grads::<SCREEN_AUX>(s, state, d_rgb, aux, w, h);
        through_projection(t, cam, s, state, &screen)
    } else {
        let screen = screen_grads::<SCREEN>(s, state, d_rgb, aux, w, h);
        through_projection(t, cam, s, state, &screen)
    }
}

/// Stage 1: per projected triangle, ∂L/∂ its screen quantities (K =
/// [`SCREEN`], or [`SCREEN_AUX`] to include depth and normal).
fn screen_grads<const K: usize>(
    s: &RasterSettings,
    state: &TriangleState,
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
            for (x, y) in tile_pixels(ti, tw, w, h) {
                let o = y * w + x;
                let last = state.last[o] as usize;
                if last == 0 {
                    continue;
                }
                let gc = d_rgb[o];
                let mut ga = aux.alpha.map_or(0.0, |a| a[o]);
                // ∂L/∂(Σ w z), ∂L/∂(Σ w n) and what is behind (background 0)
                let (mut gz, mut gn) = (0.0f32, [0.0f32; 3]);
                let (mut behind_z, mut behind_n) = (0.0f32, [0.0f32; 3]);
                if geo {
                    let ws = state.weight_sum[o];
                    if let (Some(dd), true) = (aux.depth, ws > 0.0) {
                        // D = S / W: ∂L/∂S = g/W, ∂L/∂W = −g·D/W
                        gz = dd[o] / ws;
                        ga -= dd[o] * state.expected_depth[o] / ws;
                    }
                    if let Some(dn) = aux.normal {
                        gn = dn[o];
                    }
                }
                let t_final = state.final_t[o];
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let mut tr = t_final;
                let mut behind = s.background;
                for li in (0..last).rev() {
                    let p = &proj[list[li] as usize];
                    let Some((win, arg, phi)) = window(p, px, py) else {
                        continue;
                    };
                    let raw = p.opacity * win;
                    let alpha = raw.min(0.99);
                    if alpha < 1.0 / 255.0 {
                        continue;
                    }
                    tr /= 1.0 - alpha;
                    let wgt = alpha * tr;
                    let e = &mut acc[li];
                    let mut d_a = 0.0f32;
                    for k in 0..3 {
                        e[12 + k] += gc[k] * wgt;
                        d_a += gc[k] * (p.rgb[k] - behind[k]) * tr;
                        behind[k] = alpha * p.rgb[k] + (1.0 - alpha) * behind[k];
                    }
                    if geo {
                        e[SCREEN] += gz * wgt;
                        d_a += gz * (p.depth - behind_z) * tr;
                        behind_z = alpha * p.depth + (1.0 - alpha) * behind_z;
                        for k in 0..3 {
                            e[SCREEN + 1 + k] += gn[k] * wgt;
                            d_a += gn[k] * (p.normal[k] - behind_n[k]) * tr;
                            behind_n[k] = alpha * p.normal[k] + (1.0 - alpha) * behind_n[k];
                        }
                    }
                    d_a += ga * t_final / (1.0 - alpha);
                    if raw >= 0.99 {
                        continue;
                    }
                    e[11] += win * d_a;
                    let d_win = p.opacity * d_a;
                    // win > 0 here (α ≥ 1/255), so φ < 0 and the ratio is > 0
                    let ratio = phi / p.phi_s;
                    e[10] += d_win * win * ratio.ln();
                    let d_phi = d_win * p.sigma * win / phi;
                    e[9] += -d_win * p.sigma * win / p.phi_s;
                    e[3 * arg] += d_phi * px;
                    e[3 * arg + 1] += d_phi * py;
                    e[3 * arg + 2] += d_phi;
                }
            }
            acc
        })
        .collect();
    state.tiles.gather(&tile_grads)
}

/// Stage 2: the screen gradients through each triangle's projection.
fn through_projection<const K: usize>(
    t: &Triangles3,
    cam: &Camera,
    s: &RasterSettings,
    state: &TriangleState,
    screen: &[[f64; K]],
) -> TriangleGrads {
    let n = t.len();
    let nc = coeff_count(t.sh_degree);
    let mut out = TriangleGrads {
        vertices: vec![[[0.0; 3]; 3]; n],
        sigmas: vec![0.0; n],
        opacities: vec![0.0; n],
        sh: vec![[0.0; 3]; n * nc],
    };
    let rows = rotation_rows(cam);
    let center = cam.center();
    let per: Vec<PerTriangle> = state
        .proj
        .par_iter()
        .zip(screen.par_iter())
        .map(|(p, d)| {
            let i = p.id as usize;
            let verts: [[Dual<9>; 3]; 3] = std::array::from_fn(|v| {
                std::array::from_fn(|k| Dual::var(t.vertices[i][v][k] as f64, 3 * v + k))
            });
            let sh = &t.sh[i * nc..(i + 1) * nc];
            let mut grad = [0.0f64; 9];
            let mut dsh = [[0.0f32; 3]; 16];
            if let Some(pt) = project_tri_t(
                verts,
                t.sigmas[i],
                t.opacities[i],
                sh,
                t.sh_degree,
                cam,
                &rows,
                s,
            ) {
                let mut add = |v: &Dual<9>, gv: f64| {
                    for (gk, dk) in grad.iter_mut().zip(v.d) {
                        *gk += dk * gv;
                    }
                };
                for e in 0..3 {
                    for k in 0..3 {
                        add(&pt.edges[e][k], d[3 * e + k]);
                    }
                }
                add(&pt.phi_s, d[9]);
                if K > SCREEN {
                    add(&pt.depth, d[SCREEN]);
                    for k in 0..3 {
                        add(&pt.normal[k], d[SCREEN + 1 + k]);
                    }
                }
                let c: [f32; 3] = std::array::from_fn(|k| {
                    ((t.vertices[i][0][k] as f64
                        + t.vertices[i][1][k] as f64
                        + t.vertices[i][2][k] as f64)
                        / 3.0
                        - center[k]) as f32
                });
                let mut b = [0.0f32; 16];
                basis(t.sh_degree, c, &mut b);
                for ch in 0..3 {
                    if pt.rgb[ch].v < 0.0 {
                        continue;
                    }
                    add(&pt.rgb[ch], d[12 + ch]);
                    for k in 0..nc {
                        dsh[k][ch] = b[k] * d[12 + ch] as f32;
                    }
                }
            }
            (i, grad, d[10] as f32, d[11] as f32, dsh)
        })
        .collect();
    for (i, grad, dsig, dop, dsh) in per {
        out.vertices[i] = std::array::from_fn(|v| std::array::from_fn(|k| grad[3 * v + k] as f32));
        out.sigmas[i] = dsig;
        out.opacities[i] = dop;
        out.sh[i * nc..(i + 1) * nc].copy_from_slice(&dsh[..nc]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::{
        Lcg, aux_weights, check_gradient, eval_full, eval_linear, linear_loss, random_sh,
        test_camera,
    };
    use crate::triangle::{rasterize, render};

    /// Large triangles (inradius 210–300 px) placed so that the whole 48×40
    /// image lies 29–91 px inside one of their edges and far from the other
    /// two: over the image φ is that one edge's value (no kink where the
    /// arg-max edge changes), the window stays above the 1/255 cut and inside
    /// the tightened tile box. Then the image is smooth in every parameter
    /// and central differences are a fair ground truth. The vertex order is
    /// rotated so that each edge index is the active one in some triangle.
    fn smooth_scene(seed: u64) -> Triangles3 {
        let mut r = Lcg(seed);
        let mut t = Triangles3 {
            sh_degree: 2,
            ..Default::default()
        };
        let (f, cx, cy) = (60.0f32, 24.0f32, 20.0f32);
        for i in 0..5 {
            let th = r.range(0.0, std::f64::consts::TAU);
            let (ux, uy) = (th.cos(), th.sin());
            let d = r.range(150.0, 240.0);
            let rin = d + 60.0;
            let (ix, iy) = (cx + d * ux, cy + d * uy);
            let mut px = [[0.0f32; 2]; 3];
            for (k, p) in px.iter_mut().enumerate() {
                let a = th + k as f32 * 2.0 * std::f32::consts::FRAC_PI_3;
                let jitter: f64 = if k == 0 { 30.0 } else { 4.0 };
                *p = [
                    ix + 2.0 * rin * a.cos() + r.range(-jitter, jitter),
                    iy + 2.0 * rin * a.sin() + r.range(-jitter, jitter),
                ];
            }
            let mut v = [[0.0f32; 3]; 3];
            for k in 0..3 {
                let z = r.range(4.0, 6.0);
                let p = px[(k + i) % 3];
                v[k] = [(p[0] - cx) * z / f, (p[1] - cy) * z / f, z];
            }
            t.vertices.push(v);
            t.sigmas.push(r.range(0.5, 1.2));
            t.opacities.push(r.range(0.4, 0.8));
            t.sh.extend(random_sh(&mut r, 9));
        }
        t
    }

    /// Every parameter type against central differences (tolerance in
    /// [`check_gradient`]).
    #[test]
    fn gradients_match_finite_differences() {
        let cam = test_camera(48, 40, 60.0);
        let s = RasterSettings {
            background: [0.1, 0.2, 0.3],
            ..Default::default()
        };
        for seed in [1u64, 2, 3] {
            let t = smooth_scene(seed);
            let (wr, wa) = linear_loss(48 * 40, seed + 50);
            let loss = |t: &Triangles3| {
                let img = render(t, &cam, &s);
                eval_linear(&img.rgb, &img.alpha, &wr, &wa)
            };
            let (img, state) = rasterize(&t, &cam, &s);
            assert!(
                img.count.iter().all(|&c| c == 5),
                "every triangle covers every pixel"
            );
            let gr = backward(&t, &cam, &s, &state, &wr, Some(&wa));
            check_geometry("colour + alpha", &t, &gr, loss);
            let sh: Vec<f64> = gr.sh.iter().flatten().map(|&x| x as f64).collect();
            check_gradient("sh", &sh, 1e-2, |k, h| {
                let mut t2 = t.clone();
                t2.sh[k / 3][k % 3] += h as f32;
                loss(&t2)
            });
        }
    }

    /// Checks vertices, σ and opacity against central differences of `loss`
    /// (steps and tolerance as in [`gradients_match_finite_differences`]).
    fn check_geometry(
        name: &str,
        t: &Triangles3,
        gr: &TriangleGrads,
        loss: impl Fn(&Triangles3) -> f64,
    ) {
        let sig: Vec<f64> = gr.sigmas.iter().map(|&x| x as f64).collect();
        check_gradient(&format!("{name}: sigmas"), &sig, 1e-2, |k, h| {
            let mut t2 = t.clone();
            t2.sigmas[k] += h as f32;
            loss(&t2)
        });
        let op: Vec<f64> = gr.opacities.iter().map(|&x| x as f64).collect();
        check_gradient(&format!("{name}: opacities"), &op, 1e-3, |k, h| {
            let mut t2 = t.clone();
            t2.opacities[k] += h as f32;
            loss(&t2)
        });
        let verts: Vec<f64> = gr
            .vertices
            .iter()
            .flatten()
            .flatten()
            .map(|&x| x as f64)
            .collect();
        check_gradient(&format!("{name}: vertices"), &verts, 1e-2, |k, h| {
            let mut t2 = t.clone();
            t2.vertices[k / 9][(k / 3) % 3][k % 3] += h as f32;
            loss(&t2)
        });
    }

    /// Depth and normal gradients on the smooth scenes, against central
    /// differences of L = Σ w·rgb + Σ v·alpha + Σ u·D + Σ q·N (random
    /// weights; D expected depth, N = Σ w n), and of the depth term alone
    /// and the normal term alone. Tolerance of [`check_gradient`] (2%
    /// relative, or 3e-5/h absolute near zero): the depth term adds values
    /// near 5 per pixel whose f32 rounding sums to about 1e-5 over the 1920
    /// pixels, the noise the floor is made for.
    #[test]
    fn aux_gradients_match_finite_differences() {
        let cam = test_camera(48, 40, 60.0);
        let s = RasterSettings {
            background: [0.1, 0.2, 0.3],
            ..Default::default()
        };
        let zero_rgb = vec![[0.0f32; 3]; 48 * 40];
        let zero_a = vec![0.0f32; 48 * 40];
        let zero_n = vec![[0.0f32; 3]; 48 * 40];
        for seed in [1u64, 2, 3] {
            let t = smooth_scene(seed);
            let (wr, wa) = linear_loss(48 * 40, seed + 50);
            let (wd, wn) = aux_weights(48 * 40, seed + 70);
            let (img, state) = rasterize(&t, &cam, &s);
            assert!(img.count.iter().all(|&c| c == 5));
            // (name, ∂L/∂rgb, ∂L/∂alpha, ∂L/∂depth, ∂L/∂normal_sum)
            type Case<'a> = (
                &'a str,
                &'a [[f32; 3]],
                &'a [f32],
                &'a [f32],
                &'a [[f32; 3]],
            );
            let cases: [Case; 3] = [
                ("all", &wr, &wa, &wd, &wn),
                ("depth", &zero_rgb, &zero_a, &wd, &zero_n),
                ("normal", &zero_rgb, &zero_a, &zero_a, &wn),
            ];
            for (name, cr, ca, cd, cn) in cases {
                let aux = AuxGrads {
                    alpha: Some(ca),
                    depth: Some(cd),
                    normal: Some(cn),
                };
                let gr = backward_aux(&t, &cam, &s, &state, cr, &aux);
                check_geometry(name, &t, &gr, |t2| {
                    eval_full(&render(t2, &cam, &s), (cr, ca), (cd, cn))
                });
            }
        }
    }

    /// Deterministic for any thread count, with and without the auxiliary
    /// gradients; zero depth and normal gradients give the plain backward.
    #[test]
    fn backward_is_deterministic_across_threads() {
        let cam = test_camera(48, 40, 60.0);
        let s = RasterSettings::default();
        let t = smooth_scene(7);
        let (wr, wa) = linear_loss(48 * 40, 3);
        let (wd, wn) = aux_weights(48 * 40, 4);
        let run = |threads: usize, geo: bool| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool")
                .install(|| {
                    let (_, st) = rasterize(&t, &cam, &s);
                    let aux = AuxGrads {
                        alpha: Some(&wa),
                        depth: geo.then_some(&wd[..]),
                        normal: geo.then_some(&wn[..]),
                    };
                    backward_aux(&t, &cam, &s, &st, &wr, &aux)
                })
        };
        assert_eq!(run(1, false), run(3, false));
        assert_eq!(run(1, true), run(3, true));
        let zd = vec![0.0f32; 48 * 40];
        let zn = vec![[0.0f32; 3]; 48 * 40];
        let (_, st) = rasterize(&t, &cam, &s);
        let aux = AuxGrads {
            alpha: Some(&wa),
            depth: Some(&zd),
            normal: Some(&zn),
        };
        assert_eq!(
            backward_aux(&t, &cam, &s, &st, &wr, &aux),
            backward(&t, &cam, &s, &st, &wr, Some(&wa))
        );
    }
}
