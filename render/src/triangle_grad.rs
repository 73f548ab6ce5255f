//! Backward pass of the triangle-splat rasteriser.
//!
//! Input: the [`TriangleState`] of a forward pass and ∂L/∂rgb (optionally
//! ∂L/∂alpha) per pixel. Output: ∂L/∂ each parameter of [`Triangles3`]
//! (vertices in world units, activated σ and opacity, SH coefficients).
//!
//! Per pixel the blending is walked back to front (as for Gaussians); the
//! window I = (φ/φ(s))^σ with φ = L_k(p) the largest edge value gives
//! ∂I/∂σ = I·ln(φ/φ(s)), ∂I/∂φ = σI/φ, ∂I/∂φ(s) = −σI/φ(s), and
//! ∂φ/∂(n_k, d_k) = (p, 1). Per triangle, the projection (vertices → edge
//! lines, inradius, view-dependent colour) is re-run with [`Dual`] numbers
//! over the 9 vertex coordinates. Clamped α or colour passes no gradient;
//! depth and normal outputs are not differentiated.

use rayon::prelude::*;

use crate::Camera;
use crate::dual::Dual;
use crate::gaussian::{RasterSettings, rotation_rows};
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

/// ∂L/∂(edges 9, φ(s), σ, opacity, rgb 3) per projected triangle.
type Screen = [f32; 15];

/// Index, ∂L/∂vertices, ∂L/∂σ, ∂L/∂opacity, ∂L/∂SH.
type PerTriangle = (usize, [f64; 9], f32, f32, [[f32; 3]; 16]);

/// Gradient of the loss with respect to `t`, given ∂L/∂rgb per pixel and
/// optionally ∂L/∂alpha.
pub fn backward(
    t: &Triangles3,
    cam: &Camera,
    s: &RasterSettings,
    state: &TriangleState,
    d_rgb: &[[f32; 3]],
    d_alpha: Option<&[f32]>,
) -> TriangleGrads {
    let (w, h) = (cam.width as usize, cam.height as usize);
    assert_eq!(d_rgb.len(), w * h, "one RGB gradient per pixel");
    let tw = state.tiles.tiles_x;
    let proj = &state.proj;
    let tile_grads: Vec<Vec<Screen>> = (0..state.tiles.len())
        .into_par_iter()
        .map(|ti| {
            let list = state.tiles.list(ti);
            let mut acc = vec![[0.0f32; 15]; list.len()];
            for (x, y) in tile_pixels(ti, tw, w, h) {
                let o = y * w + x;
                let last = state.last[o] as usize;
                if last == 0 {
                    continue;
                }
                let gc = d_rgb[o];
                let ga = d_alpha.map_or(0.0, |a| a[o]);
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
    let screen = state.tiles.gather(&tile_grads);
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
    let per: Vec<PerTriangle> = proj
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
    use crate::testutil::{Lcg, check_gradient, eval_linear, linear_loss, random_sh, test_camera};
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
            let sig: Vec<f64> = gr.sigmas.iter().map(|&x| x as f64).collect();
            check_gradient("sigmas", &sig, 1e-2, |k, h| {
                let mut t2 = t.clone();
                t2.sigmas[k] += h as f32;
                loss(&t2)
            });
            let op: Vec<f64> = gr.opacities.iter().map(|&x| x as f64).collect();
            check_gradient("opacities", &op, 1e-3, |k, h| {
                let mut t2 = t.clone();
                t2.opacities[k] += h as f32;
                loss(&t2)
            });
            let sh: Vec<f64> = gr.sh.iter().flatten().map(|&x| x as f64).collect();
            check_gradient("sh", &sh, 1e-2, |k, h| {
                let mut t2 = t.clone();
                t2.sh[k / 3][k % 3] += h as f32;
                loss(&t2)
            });
            let verts: Vec<f64> = gr
                .vertices
                .iter()
                .flatten()
                .flatten()
                .map(|&x| x as f64)
                .collect();
            check_gradient("vertices", &verts, 1e-2, |k, h| {
                let mut t2 = t.clone();
                t2.vertices[k / 9][(k / 3) % 3][k % 3] += h as f32;
                loss(&t2)
            });
        }
    }
}
