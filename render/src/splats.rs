//! The splat arrays the Gaussian and surfel rasterisers take, and the
//! gradients their backward passes return, as one type generic over the
//! number of scale axes `D`: [`crate::gaussian::Gaussians3`] (`D` = 3, 3DGS
//! Gaussians) and [`crate::surfel::Surfels2`] (`D` = 2, 2DGS surfels, whose
//! rotation's columns 0 and 1 are the tangent axes and column 2 the normal),
//! with [`crate::gaussian_grad::GaussianGrads`] and
//! [`crate::surfel_grad::SurfelGrads`].

use crate::sh::coeff_count;

/// Splats as the rasterisers want them: activated values, one entry per
/// splat in every array (SH: `(sh_degree+1)²` rows per splat).
#[derive(Clone, Debug, Default)]
pub struct Splats<const D: usize> {
    /// Means (centres), world units.
    pub means: Vec<[f32; 3]>,
    /// Standard deviations along the `D` local axes (exp of the stored
    /// log-scales), world units.
    pub scales: Vec<[f32; D]>,
    /// Rotations as quaternions (w, x, y, z), any length (normalised where used).
    pub rotations: Vec<[f32; 4]>,
    /// Opacities in [0, 1] (sigmoid of the stored logits).
    pub opacities: Vec<f32>,
    /// SH coefficients per splat, coefficient-major, `(sh_degree+1)²` rows each.
    pub sh: Vec<[f32; 3]>,
    /// SH degree, 0–3.
    pub sh_degree: usize,
}

impl<const D: usize> Splats<D> {
    /// Number of splats.
    pub fn len(&self) -> usize {
        self.means.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.means.is_empty()
    }

    /// The same splats with SH degree 0 (the DC term only), as 2DGS renders
    /// them for meshing (`active_sh_degree = 0`).
    pub fn dc_only(&self) -> Self {
        let n = coeff_count(self.sh_degree);
        Splats {
            means: self.means.clone(),
            scales: self.scales.clone(),
            rotations: self.rotations.clone(),
            opacities: self.opacities.clone(),
            sh: self.sh.iter().step_by(n.max(1)).copied().collect(),
            sh_degree: 0,
        }
    }

    /// Panics unless every per-splat array has one entry per splat and `sh`
    /// has `(sh_degree+1)²` rows per splat (a caller's bug, as a wrong
    /// buffer length is in every rasteriser entry point).
    pub(crate) fn check_lengths(&self) {
        let n = self.len();
        assert!(self.sh_degree <= 3, "SH degree {} > 3", self.sh_degree);
        assert_eq!(self.scales.len(), n, "one scale per splat");
        assert_eq!(self.rotations.len(), n, "one rotation per splat");
        assert_eq!(self.opacities.len(), n, "one opacity per splat");
        assert_eq!(
            self.sh.len(),
            n * coeff_count(self.sh_degree),
            "(degree+1)² SH rows per splat"
        );
    }
}

/// Gradients of a loss, shaped like [`Splats`]'s fields, plus the
/// screen-space statistic densification uses.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SplatGrads<const D: usize> {
    pub means: Vec<[f32; 3]>,
    /// With respect to the activated scales (standard deviations).
    pub scales: Vec<[f32; D]>,
    /// With respect to the quaternion (w, x, y, z) as given (normalisation
    /// included).
    pub rotations: Vec<[f32; 4]>,
    pub opacities: Vec<f32>,
    pub sh: Vec<[f32; 3]>,
    /// ∂L/∂(x, y) of each splat's projected centre in OpenCV pixel
    /// coordinates (loss per pixel), zero for splats the view culled. Which
    /// paths it follows is each rasteriser's rule:
    /// - Gaussians (3DGS's `viewspace_points` gradient): through the
    ///   per-pixel blending only, not through the conic, depth or colour;
    /// - surfels (2DGS's `dL_dmean2Ds` "hack"): ∂L/∂T_u,z · T_w,z and
    ///   ∂L/∂T_v,z · T_w,z, through the per-pixel ray–splat intersections
    ///   only, not through the low-pass box centre nor the colour.
    ///
    /// Densification compares the norm of [`SplatGrads::means2d_ndc`].
    pub means2d: Vec<[f32; 2]>,
}

impl<const D: usize> SplatGrads<D> {
    /// [`SplatGrads::means2d`] in the NDC units 3DGS and 2DGS compare with
    /// their densification threshold, for a `width × height` image.
    pub fn means2d_ndc(&self, width: u32, height: u32) -> Vec<[f32; 2]> {
        self.means2d
            .iter()
            .map(|&d| means2d_to_ndc(d, width, height))
            .collect()
    }
}

/// One pixel-space centre gradient ∂L/∂(x, y) converted to the NDC gradient:
/// (x·W/2, y·H/2). 3DGS maps NDC to pixels by px = ((ndc + 1)·W − 1)/2, and
/// its CUDA backward scales the pixel gradient by 0.5·W, 0.5·H; the norm of
/// this is what it compares with `densify_grad_threshold` (0.0002), for a
/// loss that is a mean over pixels as its L1.
#[inline]
pub fn means2d_to_ndc(d: [f32; 2], width: u32, height: u32) -> [f32; 2] {
    [d[0] * 0.5 * width as f32, d[1] * 0.5 * height as f32]
}
