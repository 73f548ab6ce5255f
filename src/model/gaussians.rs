//! 3D Gaussian splats with raw (pre-activation) parameters, as stored in the
//! standard 3DGS PLY.
//!
//! Conventions:
//! - `log_scales`: log of the per-axis standard deviation (s = exp(v));
//! - `rotations`: quaternion **(w, x, y, z)**, unnormalised as stored
//!   (glam's `Quat` is (x, y, z, w): convert with [`Gaussians::quat`]);
//! - `opacity_logits`: α = sigmoid(v);
//! - SH: `sh_dc[i]` = RGB DC coefficients; `sh_rest` holds, per Gaussian,
//!   `K = (D+1)²−1` coefficients × 3 channels, **coefficient-major**
//!   (`sh_rest[(i*K + k)*3 + c]`), the in-memory layout of 3DGS. The PLY
//!   `f_rest_*` properties are channel-major; the PLY reader/writer transposes.

use super::Extras;
use crate::Error;

/// A set of Gaussians (see the module docs for conventions).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Gaussians {
    pub means: Vec<[f32; 3]>,
    /// `nx ny nz` as stored (3DGS writes zeros); `None` when the file had none.
    pub normals: Option<Vec<[f32; 3]>>,
    pub sh_degree: usize,
    pub sh_dc: Vec<[f32; 3]>,
    pub sh_rest: Vec<f32>,
    pub opacity_logits: Vec<f32>,
    pub log_scales: Vec<[f32; 3]>,
    pub rotations: Vec<[f32; 4]>,
    /// Unknown vertex properties (row-aligned), other elements and comments.
    pub extras: Extras,
}

/// Logistic sigmoid.
pub fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

/// A stored (w, x, y, z) quaternion as a normalised glam quaternion
/// (identity if it is zero or not finite); shared by Gaussians and surfels.
pub fn unit_quat([w, x, y, z]: [f32; 4]) -> glam::Quat {
    let q = glam::Quat::from_xyzw(x, y, z, w);
    let n = q.length();
    if n > 0.0 && n.is_finite() {
        q / n
    } else {
        glam::Quat::IDENTITY
    }
}

/// Inverse of [`sigmoid`] for p in (0, 1).
pub fn logit(p: f32) -> f32 {
    (p / (1.0 - p)).ln()
}

impl Gaussians {
    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.means.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.means.is_empty()
    }

    /// Higher-order SH coefficients per channel, (D+1)²−1.
    pub fn rest_per_channel(&self) -> usize {
        (self.sh_degree + 1) * (self.sh_degree + 1) - 1
    }

    /// Activated opacity of Gaussian `i`.
    pub fn opacity(&self, i: usize) -> f32 {
        sigmoid(self.opacity_logits[i])
    }

    /// Standard deviations of Gaussian `i`.
    pub fn scales(&self, i: usize) -> [f32; 3] {
        self.log_scales[i].map(f32::exp)
    }

    /// Normalised rotation of Gaussian `i` as a glam quaternion (identity if
    /// the stored quaternion is zero or not finite).
    pub fn quat(&self, i: usize) -> glam::Quat {
        unit_quat(self.rotations[i])
    }

    /// SH coefficients of Gaussian `i`, coefficient-major `[k] = [r, g, b]`
    /// including the DC term at k = 0.
    pub fn sh_coeffs(&self, i: usize) -> Vec<[f32; 3]> {
        super::sh_coeffs_of(&self.sh_dc, &self.sh_rest, self.rest_per_channel(), i)
    }

    /// The activated values the rasteriser takes: scales exp(v), opacities
    /// sigmoid(v), quaternions as stored (normalised by the rasteriser), SH
    /// coefficient-major with the DC term first.
    pub fn to_raster(&self) -> splatkit_render::gaussian::Gaussians3 {
        self.to_raster_at(self.sh_degree)
    }

    /// [`Gaussians::to_raster`] with the SH truncated to degree `d` (at most
    /// the stored degree): what training renders during its SH warm-up.
    /// Built in parallel.
    pub fn to_raster_at(&self, d: usize) -> splatkit_render::gaussian::Gaussians3 {
        use rayon::prelude::*;
        let n = self.len();
        let d = d.min(self.sh_degree);
        splatkit_render::gaussian::Gaussians3 {
            means: self.means.clone(),
            scales: (0..n).into_par_iter().map(|i| self.scales(i)).collect(),
            rotations: self.rotations.clone(),
            opacities: (0..n).into_par_iter().map(|i| self.opacity(i)).collect(),
            sh: super::sh_rows(
                &self.sh_dc,
                &self.sh_rest,
                self.rest_per_channel(),
                (d + 1).pow(2),
            ),
            sh_degree: d,
        }
    }

    /// The Gaussians at `idx`, in that order (extra per-item properties
    /// follow).
    pub fn gather(&self, idx: &[usize]) -> Gaussians {
        let k3 = self.rest_per_channel() * 3;
        let mut extras = self.extras.clone();
        extras.gather_items(idx);
        Gaussians {
            means: idx.iter().map(|&i| self.means[i]).collect(),
            normals: self
                .normals
                .as_ref()
                .map(|n| idx.iter().map(|&i| n[i]).collect()),
            sh_degree: self.sh_degree,
            sh_dc: idx.iter().map(|&i| self.sh_dc[i]).collect(),
            sh_rest: idx
                .iter()
                .flat_map(|&i| self.sh_rest[i * k3..(i + 1) * k3].iter().copied())
                .collect(),
            opacity_logits: idx.iter().map(|&i| self.opacity_logits[i]).collect(),
            log_scales: idx.iter().map(|&i| self.log_scales[i]).collect(),
            rotations: idx.iter().map(|&i| self.rotations[i]).collect(),
            extras,
        }
    }

    /// Checks that every array has one entry per Gaussian.
    pub fn validate(&self) -> crate::Result<()> {
        let n = self.means.len();
        let k = self.rest_per_channel();
        if self.sh_degree > 3 {
            return Err(Error::invalid(format!(
                "SH degree {} is above 3",
                self.sh_degree
            )));
        }
        let checks = [
            ("sh_dc", self.sh_dc.len(), n),
            ("sh_rest", self.sh_rest.len(), n * k * 3),
            ("opacity", self.opacity_logits.len(), n),
            ("scales", self.log_scales.len(), n),
            ("rotations", self.rotations.len(), n),
            ("normals", self.normals.as_ref().map_or(n, Vec::len), n),
        ];
        for (name, got, want) in checks {
            if got != want {
                return Err(Error::invalid(format!(
                    "{name} has {got} values, expected {want}"
                )));
            }
        }
        for p in &self.extras.item {
            if p.data.rows() != n {
                return Err(Error::invalid(format!(
                    "extra property {} has {} rows, expected {n}",
                    p.name,
                    p.data.rows()
                )));
            }
        }
        Ok(())
    }
}
