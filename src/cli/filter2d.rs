//! The `--filter-2d` and `--kernel-size` flags of the commands that render
//! Gaussians (`render`, `tsdf-fuse`, `splat2points`): which screen-space
//! filter the Gaussian rasteriser uses. See `model::filter3d` for the
//! `filter_3D` property of Mip-Splatting and Gaussian Opacity Fields.

use clap::{Args, ValueEnum};

use crate::model::filter3d::{Filter2dChoice, MIP_KERNEL_SIZE};

/// `--filter-2d` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Filter2dMode {
    /// `mip` for Gaussians with a `filter_3D` property (Mip-Splatting,
    /// Gaussian Opacity Fields), `dilate` for the rest.
    Auto,
    /// 3DGS's low-pass filter: 0.3 pixels² added to the screen covariance.
    Dilate,
    /// The 2-D Mip filter of Mip-Splatting / GOF: `--kernel-size` added to
    /// the screen covariance and the opacity scaled by the determinant ratio.
    Mip,
}

/// The 2-D filter flags (flattened into a command's arguments).
#[derive(Args, Clone, Debug)]
pub struct Filter2dArgs {
    /// Screen-space filter for Gaussians: `auto` picks `mip` when the input
    /// has Mip-Splatting's `filter_3D` property (whose 3-D filter is then
    /// applied to the scales and opacities as its renderer does), `dilate`
    /// otherwise.
    #[arg(long = "filter-2d", value_enum, default_value = "auto")]
    pub filter_2d: Filter2dMode,
    /// Dilation of the Mip filter, pixels² (Mip-Splatting's default 0.1;
    /// Gaussian Opacity Fields trains with 0.0).
    #[arg(long, value_name = "PX2", default_value_t = MIP_KERNEL_SIZE, value_parser = super::nonneg_f64)]
    pub kernel_size: f64,
}

impl Filter2dArgs {
    /// The choice as the model layer names it.
    pub fn choice(&self) -> Filter2dChoice {
        match self.filter_2d {
            Filter2dMode::Auto => Filter2dChoice::Auto,
            Filter2dMode::Dilate => Filter2dChoice::Dilate,
            Filter2dMode::Mip => Filter2dChoice::Mip,
        }
    }
}
