//! Gaussians bound to the triangles of a mesh (SuGaR's refinement model).
//!
//! Each face carries `per_face` ∈ {1, 3, 4, 6} flat Gaussians at fixed
//! barycentric coordinates (the tables of [`barycentrics`]), in **face-major**
//! order: Gaussian `i` belongs to face `i / per_face` and uses table row
//! `i % per_face`. The learned values are raw, as SuGaR stores them:
//! - `complex[i] = (x, y)`: an in-plane rotation as an unnormalised complex
//!   number, relative to the face frame (normal, edge v0 − v1, normal × edge);
//! - `log_scales[i]`: log of the two in-plane standard deviations (world
//!   units), matched to the rotated in-plane axes;
//! - `opacity_logits[i]`: α = sigmoid(v);
//! - SH as in [`super::Gaussians`]: `sh_dc[i]` and coefficient-major
//!   `sh_rest`.
//!
//! The third scale (along the face normal) is exp(`log_thickness`), a
//! constant in world units (SuGaR: the cameras' spatial extent / 10⁶), kept
//! as its log like the other scales so files round-trip bit for bit. The mesh itself (its
//! vertices move during refinement) is part of the model; means and
//! rotations are derived from it by [`crate::geom::binding`].

use super::Mesh;
use crate::Error;

/// The Gaussian counts per triangle SuGaR defines tables for.
pub const PER_FACE_CHOICES: [usize; 4] = [1, 3, 4, 6];

/// Barycentric coordinates (weights of vertices 0, 1, 2) of the Gaussians of
/// one face, SuGaR's tables for `n` ∈ {1, 3, 4, 6}; `None` for any other n.
pub fn barycentrics(n: usize) -> Option<&'static [[f32; 3]]> {
    const T: f32 = 1.0 / 3.0;
    const S: f32 = 1.0 / 6.0;
    const F: f32 = 5.0 / 12.0;
    match n {
        1 => Some(&[[T, T, T]]),
        3 => Some(&[[0.5, 0.25, 0.25], [0.25, 0.5, 0.25], [0.25, 0.25, 0.5]]),
        4 => Some(&[[T, T, T], [2.0 * T, S, S], [S, 2.0 * T, S], [S, S, 2.0 * T]]),
        6 => Some(&[
            [2.0 * T, S, S],
            [S, 2.0 * T, S],
            [S, S, 2.0 * T],
            [S, F, F],
            [F, S, F],
            [F, F, S],
        ]),
        _ => None,
    }
}

/// SuGaR's `circle_radius` factor for `n` Gaussians per face: the initial
/// in-plane scale is this × the face's shortest edge.
pub fn circle_radius(n: usize) -> Option<f64> {
    let r3 = 3f64.sqrt();
    match n {
        1 => Some(1.0 / (2.0 * r3)),
        3 => Some(1.0 / (2.0 * (r3 + 1.0))),
        4 => Some(1.0 / (4.0 * r3)),
        6 => Some(1.0 / (4.0 + 2.0 * r3)),
        _ => None,
    }
}

/// Gaussians bound to a mesh (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BoundGaussians {
    /// The mesh the Gaussians are bound to (vertices, faces, optional colours).
    pub mesh: Mesh,
    /// Gaussians per face, one of [`PER_FACE_CHOICES`].
    pub per_face: usize,
    /// Log of the standard deviation along the face normal (world units; not
    /// learned).
    pub log_thickness: f32,
    /// In-plane rotation (x, y) per Gaussian, unnormalised.
    pub complex: Vec<[f32; 2]>,
    /// Log in-plane standard deviations per Gaussian.
    pub log_scales: Vec<[f32; 2]>,
    /// Opacity logits per Gaussian.
    pub opacity_logits: Vec<f32>,
    /// SH degree, 0–3.
    pub sh_degree: usize,
    /// DC SH coefficients per Gaussian.
    pub sh_dc: Vec<[f32; 3]>,
    /// Higher-order SH, coefficient-major, `(D+1)²−1` × 3 per Gaussian.
    pub sh_rest: Vec<f32>,
}

impl BoundGaussians {
    /// Number of Gaussians (faces × per_face).
    pub fn len(&self) -> usize {
        self.complex.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.complex.is_empty()
    }

    /// Higher-order SH coefficients per channel.
    pub fn rest_per_channel(&self) -> usize {
        (self.sh_degree + 1).pow(2) - 1
    }

    /// Face of Gaussian `i`.
    pub fn face_of(&self, i: usize) -> usize {
        i / self.per_face
    }

    /// Barycentrics of Gaussian `i`.
    pub fn bary_of(&self, i: usize) -> [f32; 3] {
        barycentrics(self.per_face).expect("validated per_face")[i % self.per_face]
    }

    /// Checks the counts, the table and the arrays; the message names the
    /// first problem.
    pub fn validate(&self) -> crate::Result<()> {
        if barycentrics(self.per_face).is_none() {
            return Err(Error::invalid(format!(
                "{} Gaussians per triangle: SuGaR defines 1, 3, 4 or 6",
                self.per_face
            )));
        }
        self.mesh.validate()?;
        let n = self.mesh.faces.len() * self.per_face;
        if self.sh_degree > 3 {
            return Err(Error::invalid(format!(
                "SH degree {} is above 3",
                self.sh_degree
            )));
        }
        let k3 = self.rest_per_channel() * 3;
        let checks = [
            ("complex rotations", self.complex.len(), n),
            ("in-plane scales", self.log_scales.len(), n),
            ("opacities", self.opacity_logits.len(), n),
            ("sh_dc", self.sh_dc.len(), n),
            ("sh_rest", self.sh_rest.len(), n * k3),
        ];
        for (name, got, want) in checks {
            if got != want {
                return Err(Error::invalid(format!(
                    "{name}: {got} values, expected {want} ({} faces × {} per face)",
                    self.mesh.faces.len(),
                    self.per_face
                )));
            }
        }
        if !self.log_thickness.is_finite() {
            return Err(Error::invalid(format!(
                "log thickness {} is not a finite number",
                self.log_thickness
            )));
        }
        Ok(())
    }
}
