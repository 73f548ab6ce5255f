//! 2D Gaussian surfels (2DGS, Huang et al., SIGGRAPH 2024) with raw
//! (pre-activation) parameters, as 2DGS's `GaussianModel.save_ply` stores
//! them.
//!
//! A surfel is a flat elliptical Gaussian disc: centre `means[i]`, two
//! tangent axes (the first two columns of the rotation matrix) with
//! standard deviations `exp(log_scales[i])`, and the disc normal along the
//! rotation's third column.
//!
//! Conventions (the same activations as 3DGS):
//! - `log_scales`: log of the two tangent standard deviations (s = exp(v));
//! - `rotations`: quaternion **(w, x, y, z)**, unnormalised as stored
//!   (2DGS normalises at render time; [`Surfels::quat`] does the same);
//! - `opacity_logits`: α = sigmoid(v);
//! - SH: `sh_dc[i]` the RGB DC coefficients; `sh_rest` coefficient-major
//!   (`sh_rest[(i*K + k)*3 + c]`, K = (D+1)²−1) as for [`super::Gaussians`];
//!   the PLY `f_rest_*` properties are channel-major and the reader/writer
//!   transposes.

use super::Extras;
use super::gaussians::sigmoid;
use crate::Error;

/// A set of 2DGS surfels (see the module docs for conventions).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Surfels {
    pub means: Vec<[f32; 3]>,
    /// `nx ny nz` as stored (2DGS writes zeros); `None` when the file had none.
    pub normals: Option<Vec<[f32; 3]>>,
    pub sh_degree: usize,
    pub sh_dc: Vec<[f32; 3]>,
    pub sh_rest: Vec<f32>,
    pub opacity_logits: Vec<f32>,
    /// Log standard deviations along the two tangent axes.
    pub log_scales: Vec<[f32; 2]>,
    /// (w, x, y, z), as stored.
    pub rotations: Vec<[f32; 4]>,
    /// Unknown vertex properties (row-aligned), other elements and comments.
    pub extras: Extras,
}

impl Surfels {
    /// Number of surfels.
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

    /// Activated opacity of surfel `i`.
    pub fn opacity(&self, i: usize) -> f32 {
        sigmoid(self.opacity_logits[i])
    }

    /// Tangent standard deviations of surfel `i`.
    pub fn scales(&self, i: usize) -> [f32; 2] {
        self.log_scales[i].map(f32::exp)
    }

    /// Normalised rotation of surfel `i` as a glam quaternion (identity if
    /// the stored quaternion is zero or not finite).
    pub fn quat(&self, i: usize) -> glam::Quat {
        super::gaussians::unit_quat(self.rotations[i])
    }

    /// Unit normal of surfel `i`'s disc: the rotation's third column (2DGS's
    /// `R[:, 2]`), unoriented.
    pub fn disc_normal(&self, i: usize) -> [f32; 3] {
        (self.quat(i) * glam::Vec3::Z).to_array()
    }

    /// The activated values the surfel rasteriser takes: scales exp(v),
    /// opacities sigmoid(v), quaternions as stored (normalised by the
    /// rasteriser), SH coefficient-major with the DC term first.
    pub fn to_raster(&self) -> splatkit_render::surfel::Surfels2 {
        self.to_raster_at(self.sh_degree)
    }

    /// [`Surfels::to_raster`] with the SH truncated to degree `d` (at most
    /// the stored degree; 0 gives the DC colour only, what 2DGS's meshing
    /// pass renders). Built in parallel.
    pub fn to_raster_at(&self, d: usize) -> splatkit_render::surfel::Surfels2 {
        use rayon::prelude::*;
        let n = self.len();
        let d = d.min(self.sh_degree);
        splatkit_render::surfel::Surfels2 {
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

    /// Checks that every array has one entry per surfel and the SH degree
    /// is at most 3.
    pub fn validate(&self) -> crate::Result<()> {
        let n = self.means.len();
        if self.sh_degree > 3 {
            return Err(Error::invalid(format!(
                "SH degree {} is above 3",
                self.sh_degree
            )));
        }
        let k = self.rest_per_channel();
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

#[cfg(test)]
mod tests {
    use super::*;

    fn one() -> Surfels {
        Surfels {
            means: vec![[1.0, 2.0, 3.0]],
            normals: None,
            sh_degree: 1,
            sh_dc: vec![[0.1, 0.2, 0.3]],
            sh_rest: (0..9).map(|v| v as f32).collect(),
            opacity_logits: vec![0.0],
            log_scales: vec![[0.0, 2f32.ln()]],
            // 90° about x, unnormalised (×2)
            rotations: vec![[2.0 * 0.5f32.sqrt(), 2.0 * 0.5f32.sqrt(), 0.0, 0.0]],
            extras: Extras::default(),
        }
    }

    #[test]
    fn activations_and_disc_normal() {
        let s = one();
        s.validate().unwrap();
        assert_eq!(s.opacity(0), 0.5);
        let sc = s.scales(0);
        assert!((sc[0] - 1.0).abs() < 1e-6 && (sc[1] - 2.0).abs() < 1e-6);
        // z rotated 90° about x is −y
        let n = s.disc_normal(0);
        assert!((n[0]).abs() < 1e-6 && (n[1] + 1.0).abs() < 1e-6 && n[2].abs() < 1e-6);
    }

    #[test]
    fn raster_values_are_activated_and_truncated() {
        let s = one();
        let r = s.to_raster();
        assert_eq!(r.sh_degree, 1);
        assert_eq!(r.sh.len(), 4);
        assert_eq!(r.sh[0], [0.1, 0.2, 0.3]);
        assert_eq!(r.sh[1], [0.0, 1.0, 2.0]);
        assert_eq!(r.opacities, vec![0.5]);
        assert_eq!(r.rotations, s.rotations);
        let dc = s.to_raster_at(0);
        assert_eq!((dc.sh_degree, dc.sh.len()), (0, 1));
        assert_eq!(s.to_raster_at(7).sh_degree, 1);
    }

    #[test]
    fn validate_names_the_short_array() {
        let mut s = one();
        s.log_scales.clear();
        let e = s.validate().unwrap_err().to_string();
        assert!(e.contains("scales has 0 values, expected 1"), "{e}");
        let mut s = one();
        s.sh_rest.pop();
        assert!(s.validate().unwrap_err().to_string().contains("sh_rest"));
    }
}
