//! SuGaR's density field over a neighbour set, with its backward pass.

use super::geometry::{G_A, G_MU, G_R, G_S, Geo, GeoGrad, geometry};
use super::neighbours::Neighbours;
use crate::model::Gaussians;

/// SuGaR's density at the world point `p`, summed over the neighbours of
/// Gaussian `owner` in `nbrs`:
/// `d(p) = min(1, factor · Σ_g α_g exp(−½ (p−μ_g)ᵀ Σ_g⁻¹ (p−μ_g)))`,
/// Σ_g = R_g diag(s_g²) R_gᵀ. Dimensionless; `factor` is SuGaR's
/// `density_factor` (1 in the density mode and in extraction, 1/16 in the
/// sdf mode). At the centre of an isolated Gaussian it is `factor·α`.
pub fn density_at(g: &Gaussians, nbrs: &Neighbours, owner: usize, p: [f64; 3], factor: f64) -> f64 {
    super::check(g);
    let geo = geometry(g);
    let e = Eval::new(&geo, nbrs.of(owner), p, false);
    (factor * e.sum).min(1.0)
}

/// The per-neighbour terms of the density at one point.
pub(super) struct Eval {
    /// Σ_g w_g (before `factor` and the clamp).
    pub sum: f64,
    /// G = Σ_g w_g Σ_g⁻¹ (p − μ_g) = −∇_p Σ_g w_g (when asked for).
    pub grad_dir: [f64; 3],
    terms: Vec<Term>,
}

struct Term {
    delta: [f64; 3],
    /// a = Rᵀ Δ (local coordinates).
    a: [f64; 3],
    /// b = a / s².
    b: [f64; 3],
    /// w = α exp(−½ aᵀb).
    w: f64,
    /// exp(−½ aᵀb).
    e: f64,
}

impl Eval {
    pub fn new(geo: &[Geo], nb: &[u32], p: [f64; 3], with_dir: bool) -> Self {
        let mut sum = 0.0;
        let mut dir = [0.0; 3];
        let terms = nb
            .iter()
            .map(|&j| {
                let ge = &geo[j as usize];
                let delta: [f64; 3] = std::array::from_fn(|i| p[i] - ge.mu[i]);
                let a: [f64; 3] = std::array::from_fn(|k| {
                    ge.r[0][k] * delta[0] + ge.r[1][k] * delta[1] + ge.r[2][k] * delta[2]
                });
                let b: [f64; 3] = std::array::from_fn(|k| a[k] / (ge.s[k] * ge.s[k]));
                let m = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
                let e = (-0.5 * m).exp();
                let w = ge.alpha * e;
                sum += w;
                if with_dir {
                    for (i, d) in dir.iter_mut().enumerate() {
                        *d += w * (ge.r[i][0] * b[0] + ge.r[i][1] * b[1] + ge.r[i][2] * b[2]);
                    }
                }
                Term { delta, a, b, w, e }
            })
            .collect();
        Eval {
            sum,
            grad_dir: dir,
            terms,
        }
    }

    /// Backward: `sum_bar` is ∂L/∂(Σ w) and `dir_bar` ∂L/∂G. Pushes
    /// (neighbour, gradient w.r.t. its geometry) to `out` in neighbour order
    /// and returns ∂L/∂p.
    pub fn backward(
        &self,
        geo: &[Geo],
        nb: &[u32],
        sum_bar: f64,
        dir_bar: [f64; 3],
        out: &mut Vec<(u32, GeoGrad)>,
    ) -> [f64; 3] {
        let mut p_bar = [0.0; 3];
        for (t, &j) in self.terms.iter().zip(nb) {
            let ge = &geo[j as usize];
            let mut gg = [0.0; 16];
            // v = R b, G += w v
            let v: [f64; 3] = std::array::from_fn(|i| {
                ge.r[i][0] * t.b[0] + ge.r[i][1] * t.b[1] + ge.r[i][2] * t.b[2]
            });
            let w_bar = sum_bar + dir_bar[0] * v[0] + dir_bar[1] * v[1] + dir_bar[2] * v[2];
            let v_bar = dir_bar.map(|x| x * t.w);
            let mut a_bar = [0.0; 3];
            for k in 0..3 {
                let s2 = ge.s[k] * ge.s[k];
                // b_k = a_k / s_k²
                let b_bar = ge.r[0][k] * v_bar[0] + ge.r[1][k] * v_bar[1] + ge.r[2][k] * v_bar[2];
                for i in 0..3 {
                    gg[G_R + 3 * i + k] += v_bar[i] * t.b[k];
                }
                a_bar[k] += b_bar / s2;
                gg[G_S + k] += -2.0 * t.b[k] / ge.s[k] * b_bar;
            }
            // w = α exp(−½ m), m = Σ a_k² / s_k²
            gg[G_A] += w_bar * t.e;
            let m_bar = -0.5 * t.w * w_bar;
            for k in 0..3 {
                a_bar[k] += 2.0 * t.b[k] * m_bar;
                gg[G_S + k] += -2.0 * t.a[k] * t.b[k] / ge.s[k] * m_bar;
            }
            // a = Rᵀ Δ, Δ = p − μ
            for i in 0..3 {
                let mut d_bar = 0.0;
                for k in 0..3 {
                    gg[G_R + 3 * i + k] += a_bar[k] * t.delta[i];
                    d_bar += ge.r[i][k] * a_bar[k];
                }
                gg[G_MU + i] -= d_bar;
                p_bar[i] += d_bar;
            }
            out.push((j, gg));
        }
        p_bar
    }
}

/// The sample point `p = μ + R(1.5·s ⊙ ε)` of a Gaussian.
pub(super) fn sample_point(ge: &Geo, eps: [f64; 3]) -> [f64; 3] {
    let c: [f64; 3] = std::array::from_fn(|k| 1.5 * ge.s[k] * eps[k]);
    std::array::from_fn(|i| ge.mu[i] + ge.r[i][0] * c[0] + ge.r[i][1] * c[1] + ge.r[i][2] * c[2])
}

/// Backward of [`sample_point`]: adds ∂L/∂(μ, R, s) of the owner for `p_bar`.
pub(super) fn sample_point_backward(ge: &Geo, eps: [f64; 3], p_bar: [f64; 3], gg: &mut GeoGrad) {
    for k in 0..3 {
        let c = 1.5 * ge.s[k] * eps[k];
        let mut rp = 0.0;
        for i in 0..3 {
            gg[G_R + 3 * i + k] += p_bar[i] * c;
            rp += ge.r[i][k] * p_bar[i];
        }
        gg[G_S + k] += 1.5 * eps[k] * rp;
    }
    for i in 0..3 {
        gg[G_MU + i] += p_bar[i];
    }
}
