//! SuGaR's Gaussians bound to mesh triangles (supplement §8; sugar.md §4.1):
//! initialisation, the derived means / rotations / scales, the gradient chain
//! back to vertices and complex rotations ([`grad`]), and rebinding to an
//! edited mesh ([`rebind`]).
//!
//! For Gaussian `i` on face `f = i / n` with vertices v0, v1, v2 (world units)
//! and table barycentrics b (see [`crate::model::bound::barycentrics`]):
//! - mean μ = b0·v0 + b1·v1 + b2·v2;
//! - face frame: R0 = normalize((v1 − v0) × (v2 − v0)) (the face normal, so
//!   its sign follows the winding), B1 = normalize(v0 − v1),
//!   B2 = normalize(R0 × B1);
//! - with (x', y') = (x, y) / ‖(x, y)‖: R1 = x'·B1 + y'·B2,
//!   R2 = −y'·B1 + x'·B2; the rotation has columns [R0 | R1 | R2];
//! - standard deviations (thickness, exp(s0), exp(s1)) along (R0, R1, R2).
//!
//! The rotation is written as a unit quaternion (w, x, y, z) with w ≥ 0.
//!
//! Degenerate faces (zero area or a zero v0 − v1 edge, so no frame) get the
//! identity rotation and pass no gradient to their vertices or rotation; a
//! zero complex number is treated as (1, 0). Both are deliberate: such a
//! Gaussian still renders (at its mean, axis-aligned) instead of producing
//! NaNs that would poison the whole image.

pub mod colors;
pub mod grad;
pub mod rebind;

use splatkit_render::dual::{Real, cross3, dot3};
use splatkit_render::gaussian::Gaussians3;
use splatkit_render::sh::rgb_to_sh;

use crate::Error;
use crate::model::bound::{BoundGaussians, barycentrics, circle_radius};
use crate::model::{Gaussians, Mesh};

/// SuGaR's initial opacity (α = 0.1).
pub const INIT_OPACITY: f32 = 0.1;

/// SuGaR's thickness factor: the third scale is this × the cameras' extent.
pub const THICKNESS_FACTOR: f64 = 1e-6;

/// Initial per-vertex colour when the mesh has none (mid grey).
const GREY: [f32; 3] = [0.5; 3];

pub(crate) fn sub3<T: Real>(a: [T; 3], b: [T; 3]) -> [T; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn normalize3<T: Real>(a: [T; 3]) -> Option<[T; 3]> {
    let n2 = dot3(a, a);
    let v = n2.val();
    if !(v > 1e-300 && v.is_finite()) {
        return None;
    }
    let n = n2.sqrt();
    Some([a[0] / n, a[1] / n, a[2] / n])
}

/// The face frame (R0 = normal, B1 = edge v0 − v1, B2 = R0 × B1), or `None`
/// for a degenerate face.
pub fn face_frame<T: Real>(v: [[T; 3]; 3]) -> Option<[[T; 3]; 3]> {
    let n = normalize3(cross3(sub3(v[1], v[0]), sub3(v[2], v[0])))?;
    let e = normalize3(sub3(v[0], v[1]))?;
    let b2 = normalize3(cross3(n, e))?;
    Some([n, e, b2])
}

/// The rotation columns [R0 | R1 | R2] from a face frame and a complex
/// number (x, y); a zero complex number counts as (1, 0).
pub fn rotation_columns<T: Real>(frame: [[T; 3]; 3], c: [T; 2]) -> [[T; 3]; 3] {
    let n2 = c[0] * c[0] + c[1] * c[1];
    let (x, y) = if n2.val() > 1e-300 && n2.val().is_finite() {
        let n = n2.sqrt();
        (c[0] / n, c[1] / n)
    } else {
        (T::cst(1.0), T::cst(0.0))
    };
    let [r0, b1, b2] = frame;
    let r1 = std::array::from_fn(|k| x * b1[k] + y * b2[k]);
    let r2 = std::array::from_fn(|k| -(y * b1[k]) + x * b2[k]);
    [r0, r1, r2]
}

/// A unit quaternion (w, x, y, z), w ≥ 0, of the rotation with columns
/// `c` (Shepperd's method: the largest of the four candidate square roots,
/// so it is well conditioned everywhere).
pub fn quat_from_columns<T: Real>(c: [[T; 3]; 3]) -> [T; 4] {
    // m[r][k] = column k, row r
    let m = |r: usize, k: usize| c[k][r];
    let (m00, m11, m22) = (m(0, 0), m(1, 1), m(2, 2));
    let tr = (m00 + m11 + m22).val();
    let q = if tr > 0.0 {
        let s = (m00 + m11 + m22 + 1.0).sqrt() * 2.0;
        [
            s * 0.25,
            (m(2, 1) - m(1, 2)) / s,
            (m(0, 2) - m(2, 0)) / s,
            (m(1, 0) - m(0, 1)) / s,
        ]
    } else if m00.val() > m11.val() && m00.val() > m22.val() {
        let s = (m00 - m11 - m22 + 1.0).sqrt() * 2.0;
        [
            (m(2, 1) - m(1, 2)) / s,
            s * 0.25,
            (m(0, 1) + m(1, 0)) / s,
            (m(0, 2) + m(2, 0)) / s,
        ]
    } else if m11.val() > m22.val() {
        let s = (m11 - m00 - m22 + 1.0).sqrt() * 2.0;
        [
            (m(0, 2) - m(2, 0)) / s,
            (m(0, 1) + m(1, 0)) / s,
            s * 0.25,
            (m(1, 2) + m(2, 1)) / s,
        ]
    } else {
        let s = (m22 - m00 - m11 + 1.0).sqrt() * 2.0;
        [
            (m(1, 0) - m(0, 1)) / s,
            (m(0, 2) + m(2, 0)) / s,
            (m(1, 2) + m(2, 1)) / s,
            s * 0.25,
        ]
    };
    if q[0].val() < 0.0 { q.map(|v| -v) } else { q }
}

/// Refuses mesh vertices with a NaN or infinite coordinate, naming the
/// first (0-based vertex, coordinate and value): a Gaussian bound to such a
/// face would get a NaN mean and rotation, and an optimiser would spread the
/// NaN to everything it touches. Binding and rebinding call it; a mesh
/// coming from a file is also refused by its loader
/// (`io::any::load_mesh_finite`), which names the file.
pub fn check_finite_vertices(vertices: &[[f32; 3]]) -> crate::Result<()> {
    for (i, v) in vertices.iter().enumerate() {
        if let Some(k) = v.iter().position(|x| !x.is_finite()) {
            return Err(Error::invalid(format!(
                "vertex {i} has a non-finite coordinate ({} = {})",
                ["x", "y", "z"][k],
                v[k]
            )));
        }
    }
    Ok(())
}

/// The three vertices of face `f` in f64.
pub fn face_vertices(mesh: &Mesh, f: usize) -> [[f64; 3]; 3] {
    mesh.faces[f].map(|v| mesh.vertices[v as usize].map(f64::from))
}

/// Mean of Gaussian `i` (barycentric, f64).
pub fn mean_of(b: &BoundGaussians, i: usize) -> [f64; 3] {
    let v = face_vertices(&b.mesh, b.face_of(i));
    let w = b.bary_of(i).map(f64::from);
    std::array::from_fn(|k| w[0] * v[0][k] + w[1] * v[1][k] + w[2] * v[2][k])
}

/// Rotation quaternion (w, x, y, z) of Gaussian `i`; identity on a
/// degenerate face.
pub fn quat_of(b: &BoundGaussians, i: usize) -> [f64; 4] {
    match face_frame(face_vertices(&b.mesh, b.face_of(i))) {
        Some(fr) => quat_from_columns(rotation_columns(fr, b.complex[i].map(f64::from))),
        None => [1.0, 0.0, 0.0, 0.0],
    }
}

/// Options of [`bind`].
#[derive(Clone, Debug)]
pub struct BindOptions {
    /// Gaussians per face (1, 3, 4 or 6).
    pub per_face: usize,
    /// Standard deviation along the normal, world units.
    pub thickness: f32,
    /// SH degree of the model (SuGaR: 3; higher coefficients start at 0).
    pub sh_degree: usize,
}

/// SuGaR's initial binding of `mesh`: complex (1, 0), both in-plane scales
/// `circle_radius(n) × the face's shortest edge` (at least 1e-7), opacity 0.1,
/// SH DC from `colors` (one linear RGB in [0, 1] per Gaussian, face-major) or,
/// when `None`, from the barycentric interpolation of the mesh's vertex
/// colours (grey without them); higher SH 0. Errors on a bad table choice,
/// an invalid mesh, a vertex that is not finite, a thickness that is not a
/// positive number, no faces, or a colour count that does not match.
pub fn bind(
    mesh: &Mesh,
    opts: &BindOptions,
    colors: Option<&[[f32; 3]]>,
) -> crate::Result<BoundGaussians> {
    let n = opts.per_face;
    let table = barycentrics(n).ok_or_else(|| {
        Error::invalid(format!(
            "--per-triangle {n}: SuGaR defines tables for 1, 3, 4 or 6 Gaussians per triangle"
        ))
    })?;
    let radius = circle_radius(n).expect("same choices as the table");
    mesh.validate()?;
    check_finite_vertices(&mesh.vertices)?;
    if !(opts.thickness > 0.0 && opts.thickness.is_finite()) {
        return Err(Error::invalid(format!(
            "thickness {} is not a positive number",
            opts.thickness
        )));
    }
    if mesh.faces.is_empty() {
        return Err(Error::invalid("the mesh has no faces to bind Gaussians to"));
    }
    let count = mesh.faces.len() * n;
    if let Some(c) = colors
        && c.len() != count
    {
        return Err(Error::invalid(format!(
            "{} colours for {count} Gaussians",
            c.len()
        )));
    }
    let vcol = |v: u32| -> [f32; 3] {
        match &mesh.vertex_colors {
            Some(c) => std::array::from_fn(|k| c[v as usize][k] as f32 / 255.0),
            None => GREY,
        }
    };
    let mut out = BoundGaussians {
        mesh: mesh.clone(),
        per_face: n,
        log_thickness: opts.thickness.ln(),
        sh_degree: opts.sh_degree,
        ..Default::default()
    };
    let k3 = out.rest_per_channel() * 3;
    for (f, face) in mesh.faces.iter().enumerate() {
        let v = face_vertices(mesh, f);
        let edge = |a: usize, b: usize| {
            let d = sub3(v[a], v[b]);
            dot3(d, d).sqrt()
        };
        let shortest = edge(0, 1).min(edge(1, 2)).min(edge(2, 0));
        let s = ((radius * shortest).max(1e-7) as f32).ln();
        for (j, w) in table.iter().enumerate() {
            let rgb = match colors {
                Some(c) => c[f * n + j],
                None => {
                    let c = face.map(vcol);
                    std::array::from_fn(|k| w[0] * c[0][k] + w[1] * c[1][k] + w[2] * c[2][k])
                }
            };
            out.complex.push([1.0, 0.0]);
            out.log_scales.push([s, s]);
            out.opacity_logits
                .push(crate::model::gaussians::logit(INIT_OPACITY));
            out.sh_dc.push(rgb.map(rgb_to_sh));
        }
    }
    out.sh_rest = vec![0.0; count * k3];
    out.validate()?;
    Ok(out)
}

/// The bound Gaussians as standard 3DGS Gaussians (raw values, as a 3DGS PLY
/// stores them): means, w-first unit quaternions, log scales
/// (ln thickness, s0, s1), opacity logits and SH unchanged; no normals, no
/// extras.
pub fn materialize(b: &BoundGaussians) -> Gaussians {
    let (means, rotations) = means_and_rotations(b);
    let lt = b.log_thickness;
    Gaussians {
        means,
        normals: None,
        sh_degree: b.sh_degree,
        sh_dc: b.sh_dc.clone(),
        sh_rest: b.sh_rest.clone(),
        opacity_logits: b.opacity_logits.clone(),
        log_scales: b.log_scales.iter().map(|s| [lt, s[0], s[1]]).collect(),
        rotations,
        extras: Default::default(),
    }
}

/// The derived values of every Gaussian: means and w-first unit quaternions
/// (f32), in parallel.
fn means_and_rotations(b: &BoundGaussians) -> (Vec<[f32; 3]>, Vec<[f32; 4]>) {
    use rayon::prelude::*;
    (0..b.len())
        .into_par_iter()
        .map(|i| {
            (
                mean_of(b, i).map(|x| x as f32),
                quat_of(b, i).map(|x| x as f32),
            )
        })
        .unzip()
}

/// The activated values the rasteriser takes, with SH truncated to
/// `active_degree` (≤ the model's degree): SuGaR's SH warm-up renders with
/// one more degree every 1000 iterations.
pub fn to_raster(b: &BoundGaussians, active_degree: usize) -> Gaussians3 {
    let (means, rotations) = means_and_rotations(b);
    let thickness = b.log_thickness.exp();
    let d = active_degree.min(b.sh_degree);
    let sh = crate::model::sh_rows(&b.sh_dc, &b.sh_rest, b.rest_per_channel(), (d + 1).pow(2));
    Gaussians3 {
        means,
        scales: b
            .log_scales
            .iter()
            .map(|s| [thickness, s[0].exp(), s[1].exp()])
            .collect(),
        rotations,
        opacities: b
            .opacity_logits
            .iter()
            .map(|&o| crate::model::gaussians::sigmoid(o))
            .collect(),
        sh,
        sh_degree: d,
    }
}

/// Half the diagonal of the mesh's bounding box (the fallback extent when no
/// cameras are given).
pub fn mesh_radius(mesh: &Mesh) -> f64 {
    match mesh.bounds() {
        Some((lo, hi)) => {
            let d = sub3(hi.map(f64::from), lo.map(f64::from));
            0.5 * dot3(d, d).sqrt()
        }
        None => 0.0,
    }
}

#[cfg(test)]
mod tests;
