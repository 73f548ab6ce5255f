//! Rebinding Gaussians to an edited or animated copy of their mesh (same
//! faces, moved vertices): SuGaR supplement §8 and its current code.
//!
//! Means follow from the barycentrics and rotations from the face frame, so
//! the only values that need updating are the in-plane scales (and, for the
//! anisotropic rule, the complex rotations):
//! - [`ScaleRule::MeanSide`] (the supplement's rule, the default): both
//!   in-plane scales × (mean side length of the edited face / of the
//!   original face); rotations unchanged, since the complex number is
//!   relative to the face frame.
//! - [`ScaleRule::Anisotropic`] (SuGaR's `get_edited_quaternions_and_scales`,
//!   the code's default "new method"), as the code computes it:
//!   (a) per face vertex k, the unsigned angle (arccos) between the unit
//!   direction centroid → v_k (reversed for k = 2) and the unit edge
//!   v0 − v1 is taken in both meshes; the change, interpolated with the
//!   Gaussian's barycentrics, turns the complex number;
//!   (b) with the turned rotation's in-plane axes R in the edited face, the
//!   edited face's unit directions â_k (vertex → centroid), ô_k = â_k × its
//!   normal and the length ratios ρ_k = ‖a_k‖ edited / ‖a_k‖ original, each
//!   in-plane scale is multiplied by Σ_k b_k·√((⟨R, â_k⟩·ρ_k)² + ⟨R, ô_k⟩²).
//!   The stored complex number is the turned one (unnormalised as given).
//!
//! Faces that are degenerate in either mesh keep their scales and rotations.
//! The thickness is not changed (SuGaR keeps it constant).

use super::{face_frame, face_vertices, rotation_columns, sub3};
use crate::Error;
use crate::model::Mesh;
use crate::model::bound::BoundGaussians;
use splatkit_render::dual::dot3;

/// How in-plane scales follow an edit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScaleRule {
    /// × ratio of mean side lengths (supplement §8).
    MeanSide,
    /// SuGaR's anisotropic per-axis rule with the rotation adjustment.
    Anisotropic,
}

fn mean_side(v: &[[f64; 3]; 3]) -> f64 {
    (0..3)
        .map(|k| {
            let d = sub3(v[k], v[(k + 1) % 3]);
            dot3(d, d).sqrt()
        })
        .sum::<f64>()
        / 3.0
}

/// `b` bound to `edited` instead of its own mesh. The result carries
/// `edited` as its mesh (so rebinding can be chained). Errors when the
/// topology differs or an edited vertex is not finite.
pub fn rebind(b: &BoundGaussians, edited: &Mesh, rule: ScaleRule) -> crate::Result<BoundGaussians> {
    edited.validate()?;
    super::check_finite_vertices(&edited.vertices)?;
    let (fr, fe) = (b.mesh.faces.len(), edited.faces.len());
    if fr != fe {
        return Err(Error::invalid(format!(
            "the edited mesh has {fe} faces but the Gaussians are bound to {fr}: rebinding needs \
             the same faces (only vertices may move)"
        )));
    }
    if let Some(f) = (0..fr).find(|&f| b.mesh.faces[f] != edited.faces[f]) {
        return Err(Error::invalid(format!(
            "face {f} is {:?} in the edited mesh but {:?} in the bound mesh: rebinding needs the \
             same faces in the same order",
            edited.faces[f], b.mesh.faces[f]
        )));
    }
    let mut out = b.clone();
    out.mesh = edited.clone();
    if out.mesh.vertex_colors.is_none() && b.mesh.vertices.len() == edited.vertices.len() {
        out.mesh.vertex_colors = b.mesh.vertex_colors.clone();
    }
    let n = b.per_face;
    for f in 0..fr {
        let vr = face_vertices(&b.mesh, f);
        let vc = face_vertices(edited, f);
        match rule {
            ScaleRule::MeanSide => {
                let (sr, sc) = (mean_side(&vr), mean_side(&vc));
                if !(sr > 0.0 && sc > 0.0 && sr.is_finite() && sc.is_finite()) {
                    continue;
                }
                let l = (sc / sr).ln();
                for i in f * n..(f + 1) * n {
                    out.log_scales[i] = b.log_scales[i].map(|s| (s as f64 + l) as f32);
                }
            }
            ScaleRule::Anisotropic => {
                let (Some(_), Some(frc)) = (face_frame(vr), face_frame(vc)) else {
                    continue;
                };
                let len = |a: [f64; 3]| dot3(a, a).sqrt();
                let unit = |a: [f64; 3]| {
                    let l = len(a).max(1e-300);
                    a.map(|x| x / l)
                };
                let cen = |v: &[[f64; 3]; 3]| -> [f64; 3] {
                    std::array::from_fn(|k| (v[0][k] + v[1][k] + v[2][k]) / 3.0)
                };
                let (cr, cc) = (cen(&vr), cen(&vc));
                // (a) unsigned angles of the centroid-to-vertex directions
                // (the third one reversed, as SuGaR does) against v0 − v1
                let angles = |v: &[[f64; 3]; 3], c: [f64; 3]| -> [f64; 3] {
                    let base = unit(sub3(v[0], v[1]));
                    std::array::from_fn(|k| {
                        let mut a = unit(sub3(v[k], c));
                        if k == 2 {
                            a = a.map(|x| -x);
                        }
                        dot3(a, base).clamp(-1.0, 1.0).acos()
                    })
                };
                let (ar, ac) = (angles(&vr, cr), angles(&vc, cc));
                // (b) vertex directions and their in-plane orthogonals in the
                // edited face, and the length ratios
                let dirs: [[f64; 3]; 3] = std::array::from_fn(|k| sub3(cc, vc[k]));
                let ratio: [f64; 3] = std::array::from_fn(|k| {
                    let (l0, l1) = (len(sub3(cr, vr[k])), len(dirs[k]));
                    if l0 > 0.0 { l1 / l0 } else { 1.0 }
                });
                let axis: [[f64; 3]; 3] = std::array::from_fn(|k| unit(dirs[k]));
                let orth: [[f64; 3]; 3] =
                    std::array::from_fn(|k| splatkit_render::dual::cross3(axis[k], frc[0]));
                for i in f * n..(f + 1) * n {
                    let w = b.bary_of(i).map(f64::from);
                    let d: f64 = (0..3).map(|k| w[k] * (ac[k] - ar[k])).sum();
                    let c = b.complex[i].map(f64::from);
                    let (sn, cs) = d.sin_cos();
                    let adj = [c[0] * cs - c[1] * sn, c[0] * sn + c[1] * cs];
                    out.complex[i] = adj.map(|x| x as f32);
                    let cols = rotation_columns(frc, adj);
                    let stretch = |r: [f64; 3]| -> f64 {
                        (0..3)
                            .map(|k| {
                                let p = dot3(r, axis[k]) * ratio[k];
                                let o = dot3(r, orth[k]);
                                w[k] * (p * p + o * o).sqrt()
                            })
                            .sum()
                    };
                    let (f1, f2) = (stretch(cols[1]), stretch(cols[2]));
                    if f1 > 0.0 && f2 > 0.0 {
                        out.log_scales[i] = [
                            (b.log_scales[i][0] as f64 + f1.ln()) as f32,
                            (b.log_scales[i][1] as f64 + f2.ln()) as f32,
                        ];
                    }
                }
            }
        }
    }
    Ok(out)
}
