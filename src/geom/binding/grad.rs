//! The gradient chain from the rasteriser's Gaussian parameters back to the
//! bound model's raw parameters.
//!
//! Input: [`GaussianGrads`] of a render of [`super::to_raster`] (∂L/∂ means,
//! activated scales, quaternions, opacities, SH at the active degree).
//! Output: ∂L/∂ mesh vertices, complex rotations, in-plane log scales,
//! opacity logits and SH (DC and rest, zero beyond the active degree).
//!
//! - means are linear in the vertices: ∂μ/∂v_k = b_k·I;
//! - the quaternion depends on the 9 face coordinates and the complex number
//!   through the face frame, the complex normalisation and Shepperd's
//!   conversion: its 4×11 Jacobian is computed exactly with forward-mode dual
//!   numbers running the same generic code as the forward pass
//!   ([`super::quat_from_columns`] etc.), so the two cannot drift apart;
//! - log scales: ∂s/∂ln s = s; the thickness is constant and gets none;
//! - opacity: ∂α/∂logit = α(1 − α).
//!
//! Per-Gaussian terms are computed in parallel and summed onto the vertices
//! in Gaussian order, so the result does not depend on the thread count.

use rayon::prelude::*;
use splatkit_render::dual::{Dual, Real};
use splatkit_render::gaussian_grad::GaussianGrads;

use super::{face_frame, face_vertices, quat_from_columns, rotation_columns};
use crate::model::bound::BoundGaussians;
use crate::model::gaussians::sigmoid;

/// Gradients shaped like [`BoundGaussians`]' learned arrays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BoundGrads {
    /// ∂L/∂ vertex positions.
    pub vertices: Vec<[f64; 3]>,
    pub complex: Vec<[f32; 2]>,
    pub log_scales: Vec<[f32; 2]>,
    pub opacity_logits: Vec<f32>,
    pub sh_dc: Vec<[f32; 3]>,
    /// Coefficient-major like `BoundGaussians::sh_rest`.
    pub sh_rest: Vec<f32>,
}

/// ∂(quaternion)/∂(9 face coordinates, complex x, y): `jac[q][p]`; `None`
/// for a degenerate face.
pub fn quat_jacobian(v: [[f64; 3]; 3], c: [f32; 2]) -> Option<[[f64; 11]; 4]> {
    let vd: [[Dual<11>; 3]; 3] =
        std::array::from_fn(|a| std::array::from_fn(|k| Dual::var(v[a][k], 3 * a + k)));
    let cd = [Dual::var(c[0] as f64, 9), Dual::var(c[1] as f64, 10)];
    let fr = face_frame(vd)?;
    let q = quat_from_columns(rotation_columns(fr, cd));
    Some(q.map(|x| x.d))
}

/// Chains `g` (from rendering `to_raster(b, active_degree)`) back to `b`'s
/// parameters.
pub fn backward(b: &BoundGaussians, g: &GaussianGrads, active_degree: usize) -> BoundGrads {
    let n = b.len();
    let d = active_degree.min(b.sh_degree);
    let per = (d + 1).pow(2);
    let k = b.rest_per_channel();
    assert_eq!(g.means.len(), n, "one gradient per bound Gaussian");
    assert_eq!(g.sh.len(), n * per, "SH gradients at the active degree");
    // per Gaussian: ∂ face coordinates (9), ∂ complex (2)
    let per_gauss: Vec<([f64; 9], [f32; 2])> = (0..n)
        .into_par_iter()
        .map(|i| {
            let f = b.face_of(i);
            let v = face_vertices(&b.mesh, f);
            let w = b.bary_of(i);
            let mut dv = [0.0f64; 9];
            for a in 0..3 {
                for kk in 0..3 {
                    dv[3 * a + kk] = w[a] as f64 * g.means[i][kk] as f64;
                }
            }
            let mut dc = [0.0f32; 2];
            if let Some(j) = quat_jacobian(v, b.complex[i]) {
                let gq = g.rotations[i];
                for p in 0..11 {
                    let s: f64 = (0..4).map(|q| gq[q] as f64 * j[q][p]).sum();
                    if p < 9 {
                        dv[p] += s;
                    } else {
                        dc[p - 9] = s as f32;
                    }
                }
            }
            (dv, dc)
        })
        .collect();
    let mut vertices = vec![[0.0f64; 3]; b.mesh.vertices.len()];
    for (i, (dv, _)) in per_gauss.iter().enumerate() {
        let face = b.mesh.faces[b.face_of(i)];
        for a in 0..3 {
            let t = &mut vertices[face[a] as usize];
            for kk in 0..3 {
                t[kk] += dv[3 * a + kk];
            }
        }
    }
    // the element-wise parts in parallel (each output depends on one
    // Gaussian only, so the bits do not depend on the thread count)
    let mut sh_rest = vec![0.0f32; n * k * 3];
    if k > 0 {
        sh_rest
            .par_chunks_mut(k * 3)
            .enumerate()
            .for_each(|(i, dst)| {
                for kk in 0..per - 1 {
                    dst[kk * 3..kk * 3 + 3].copy_from_slice(&g.sh[i * per + 1 + kk]);
                }
            });
    }
    BoundGrads {
        vertices,
        complex: per_gauss.par_iter().map(|p| p.1).collect(),
        log_scales: (0..n)
            .into_par_iter()
            .map(|i| {
                let s = b.log_scales[i];
                [g.scales[i][1] * s[0].exp(), g.scales[i][2] * s[1].exp()]
            })
            .collect(),
        opacity_logits: (0..n)
            .into_par_iter()
            .map(|i| {
                let a = sigmoid(b.opacity_logits[i]);
                g.opacities[i] * a * (1.0 - a)
            })
            .collect(),
        sh_dc: (0..n).into_par_iter().map(|i| g.sh[i * per]).collect(),
        sh_rest,
    }
}

/// PyTorch3D's `mesh_normal_consistency` of one mesh and its gradient with
/// respect to the vertices.
///
/// For every edge (a, b) and every pair of faces sharing it, with c0, c1 the
/// faces' vertices opposite the edge: n0 = (v_b − v_a) × (v_c0 − v_a),
/// n1 = −(v_b − v_a) × (v_c1 − v_a) (so the pair counts as consistently
/// oriented whatever the faces' winding), term = 1 − n0·n1 / max(‖n0‖‖n1‖,
/// 1e-8); the loss is the mean of the terms over all pairs (0 when there are
/// none).
pub struct NormalConsistency {
    /// (a, b, c0, c1) vertex indices of each face pair.
    pairs: Vec<[u32; 4]>,
}

impl NormalConsistency {
    /// The face pairs of `faces` (computed once: the topology is fixed during
    /// refinement).
    pub fn new(faces: &[[u32; 3]]) -> Self {
        let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(faces.len() * 3);
        for f in faces {
            for e in 0..3 {
                let (a, b, c) = (f[e], f[(e + 1) % 3], f[(e + 2) % 3]);
                if a == b {
                    continue;
                }
                edges.push((a.min(b), a.max(b), c));
            }
        }
        edges.sort_unstable();
        let mut pairs = Vec::new();
        let mut s = 0;
        while s < edges.len() {
            let mut e = s + 1;
            while e < edges.len() && edges[e].0 == edges[s].0 && edges[e].1 == edges[s].1 {
                e += 1;
            }
            for i in s..e {
                for j in i + 1..e {
                    pairs.push([edges[s].0, edges[s].1, edges[i].2, edges[j].2]);
                }
            }
            s = e;
        }
        NormalConsistency { pairs }
    }

    /// Number of face pairs.
    pub fn pairs(&self) -> usize {
        self.pairs.len()
    }

    /// The loss, and (if `grad` is given, shaped like `vertices`) adds
    /// `weight × ∂loss/∂vertices` to it.
    pub fn eval(&self, vertices: &[[f32; 3]], weight: f64, grad: Option<&mut [[f64; 3]]>) -> f64 {
        if self.pairs.is_empty() {
            return 0.0;
        }
        let m = self.pairs.len() as f64;
        let terms: Vec<(f64, [f64; 12])> = self
            .pairs
            .par_iter()
            .map(|p| {
                let x: [[Dual<12>; 3]; 4] = std::array::from_fn(|a| {
                    std::array::from_fn(|k| Dual::var(vertices[p[a] as usize][k] as f64, 3 * a + k))
                });
                let t = pair_term(x);
                (t.v, t.d)
            })
            .collect();
        let loss = terms.iter().map(|t| t.0).sum::<f64>() / m;
        if let Some(gr) = grad {
            let s = weight / m;
            for (p, (_, d)) in self.pairs.iter().zip(&terms) {
                for a in 0..4 {
                    for k in 0..3 {
                        gr[p[a] as usize][k] += s * d[3 * a + k];
                    }
                }
            }
        }
        loss
    }
}

/// 1 − cos between the two normals of one face pair.
fn pair_term<T: Real>(x: [[T; 3]; 4]) -> T {
    use splatkit_render::dual::{cross3, dot3};
    let e = super::sub3(x[1], x[0]);
    let n0 = cross3(e, super::sub3(x[2], x[0]));
    let n1 = cross3(e, super::sub3(x[3], x[0])).map(|v| -v);
    let den = (dot3(n0, n0) * dot3(n1, n1)).sqrt();
    let den = if den.val() > 1e-8 { den } else { T::cst(1e-8) };
    T::cst(1.0) - dot3(n0, n1) / den
}
