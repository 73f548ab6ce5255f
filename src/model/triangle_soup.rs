//! Triangle-splat soups (Triangle Splatting): independent triangles with a
//! smooth window (sigma), an opacity and SH colour.
//!
//! Stored values are raw: opacity α = sigmoid(`opacity_raw`), window
//! sharpness σ = 0.01 + exp(`sigma_raw`). SH layout as in
//! [`super::gaussians`]: `sh_dc[i]` plus `sh_rest` coefficient-major
//! (`sh_rest[(i*K + k)*3 + c]`, K = (D+1)²−1).

use super::Extras;
use super::gaussians::sigmoid;
use crate::Error;

/// Raw sigma that marks a solid triangle (hard window, σ = 0).
///
/// The paper's game-engine conversion sets σ to 0, which the activation
/// 0.01 + exp(raw) cannot reach. splatkit stores raw −∞ and reads it as
/// σ = 0 ([`TriangleSoup::sigma`]); Triangle Splatting's own code, loading
/// such a checkpoint, gets its smallest σ (0.01), a window that is 1 inside
/// the triangle to within 1% except in a thin band at the edges.
pub const SOLID_SIGMA_RAW: f32 = f32::NEG_INFINITY;

/// Raw opacity that solidified triangles get (sigmoid(+∞) = 1).
pub const SOLID_OPACITY_RAW: f32 = f32::INFINITY;

/// A triangle soup (see module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleSoup {
    /// Three vertices per triangle, world units.
    pub triangles: Vec<[[f32; 3]; 3]>,
    pub opacity_raw: Vec<f32>,
    pub sigma_raw: Vec<f32>,
    /// SH degree of the stored coefficients (0–3).
    pub sh_degree: usize,
    /// The degree training had reached (`active_sh_degree`), ≤ `sh_degree`.
    pub active_sh_degree: usize,
    pub sh_dc: Vec<[f32; 3]>,
    pub sh_rest: Vec<f32>,
    /// Unknown per-triangle properties and other file content.
    pub extras: Extras,
}

impl TriangleSoup {
    /// The DC colour of triangle `i` as 8-bit RGB: `0.5 + C0·dc`, clamped
    /// to [0, 1] (NaN → 0) and truncated toward zero like torch's
    /// float→uint8 cast (the face colours of the soup PLY).
    pub fn dc_rgb8(&self, i: usize) -> [u8; 3] {
        self.sh_dc[i].map(|d| (splatkit_render::sh::sh_to_rgb(d).clamp(0.0, 1.0) * 255.0) as u8)
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Higher-order SH coefficients per channel, (D+1)²−1.
    pub fn rest_per_channel(&self) -> usize {
        (self.sh_degree + 1) * (self.sh_degree + 1) - 1
    }

    /// Activated opacity α = sigmoid(raw) of triangle `i`.
    pub fn opacity(&self, i: usize) -> f32 {
        sigmoid(self.opacity_raw[i])
    }

    /// Activated window sharpness σ = 0.01 + exp(raw) of triangle `i`;
    /// 0 for the solid marker raw = −∞ ([`SOLID_SIGMA_RAW`]).
    pub fn sigma(&self, i: usize) -> f32 {
        let raw = self.sigma_raw[i];
        if raw == f32::NEG_INFINITY {
            0.0
        } else {
            0.01 + raw.exp()
        }
    }

    /// Centroid of triangle `i`.
    pub fn centroid(&self, i: usize) -> [f32; 3] {
        let t = &self.triangles[i];
        [0, 1, 2].map(|k| (t[0][k] + t[1][k] + t[2][k]) / 3.0)
    }

    /// SH coefficients of triangle `i`, coefficient-major with DC at k = 0.
    pub fn sh_coeffs(&self, i: usize) -> Vec<[f32; 3]> {
        super::sh_coeffs_of(&self.sh_dc, &self.sh_rest, self.rest_per_channel(), i)
    }

    /// The activated values the rasteriser takes, with the SH truncated to
    /// the active degree (what the reference renders with). Built in
    /// parallel.
    pub fn to_raster(&self) -> splatkit_render::triangle::Triangles3 {
        use rayon::prelude::*;
        let n = self.len();
        let deg = self.active_sh_degree.min(self.sh_degree);
        splatkit_render::triangle::Triangles3 {
            vertices: self.triangles.clone(),
            sigmas: (0..n).into_par_iter().map(|i| self.sigma(i)).collect(),
            opacities: (0..n).into_par_iter().map(|i| self.opacity(i)).collect(),
            sh: super::sh_rows(
                &self.sh_dc,
                &self.sh_rest,
                self.rest_per_channel(),
                (deg + 1) * (deg + 1),
            ),
            sh_degree: deg,
        }
    }

    /// Keeps the triangles whose `keep` flag is set, in order.
    pub fn filter(&self, keep: &[bool]) -> TriangleSoup {
        let idx: Vec<usize> = (0..self.len()).filter(|&i| keep[i]).collect();
        self.gather(&idx)
    }

    /// The triangles at `idx`, in that order.
    pub fn gather(&self, idx: &[usize]) -> TriangleSoup {
        let k3 = self.rest_per_channel() * 3;
        let mut extras = self.extras.clone();
        extras.gather_items(idx);
        TriangleSoup {
            triangles: idx.iter().map(|&i| self.triangles[i]).collect(),
            opacity_raw: idx.iter().map(|&i| self.opacity_raw[i]).collect(),
            sigma_raw: idx.iter().map(|&i| self.sigma_raw[i]).collect(),
            sh_degree: self.sh_degree,
            active_sh_degree: self.active_sh_degree,
            sh_dc: idx.iter().map(|&i| self.sh_dc[i]).collect(),
            sh_rest: idx
                .iter()
                .flat_map(|&i| self.sh_rest[i * k3..(i + 1) * k3].iter().copied())
                .collect(),
            extras,
        }
    }

    /// Checks that every array has one entry per triangle.
    pub fn validate(&self) -> crate::Result<()> {
        let n = self.len();
        if self.sh_degree > 3 {
            return Err(Error::invalid(format!(
                "SH degree {} is above 3",
                self.sh_degree
            )));
        }
        let checks = [
            ("opacity", self.opacity_raw.len(), n),
            ("sigma", self.sigma_raw.len(), n),
            ("sh_dc", self.sh_dc.len(), n),
            (
                "sh_rest",
                self.sh_rest.len(),
                n * self.rest_per_channel() * 3,
            ),
        ];
        for (name, got, want) in checks {
            if got != want {
                return Err(Error::invalid(format!(
                    "{name} has {got} values, expected {want}"
                )));
            }
        }
        Ok(())
    }
}
