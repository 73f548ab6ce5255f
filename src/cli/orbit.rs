//! The orbit flags shared by the commands that can make up cameras when a
//! scene comes without a camera file (`render`, `splat2points`).

use anyhow::{Context, bail};
use clap::Args;
use glam::DVec3;

use crate::model::OrbitSpec;

/// Orbit cameras made up when a scene comes without a camera file: `N`
/// views per ring evenly spaced in azimuth around the centre of the scene's
/// central 96% box, one ring per elevation, looking at that centre.
#[derive(Args, Debug, Clone)]
pub struct OrbitArgs {
    /// Orbit views per ring when no camera file is given (render: 8).
    #[arg(long)]
    pub orbit: Option<usize>,
    /// Orbit image size WIDTHxHEIGHT.
    #[arg(long, default_value = "800x600")]
    pub size: String,
    /// Orbit horizontal field of view, degrees.
    #[arg(long, default_value_t = 50.0)]
    pub fov: f64,
    /// Orbit elevations above the horizon, degrees, comma-separated: one
    /// ring of `--orbit` views each.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "15",
        allow_hyphen_values = true
    )]
    pub elevation: Vec<f64>,
    /// Orbit distance from the scene centre (default: the scene's central
    /// 96% box fills the view).
    #[arg(long)]
    pub radius: Option<f64>,
    /// World up direction for the orbit (COLMAP-trained scenes: 0,-1,0).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0,-1,0",
        allow_hyphen_values = true
    )]
    pub up: Vec<f64>,
}

impl OrbitArgs {
    /// The orbit these flags describe, with `n` views per ring, checked.
    pub fn spec(&self, n: usize) -> anyhow::Result<OrbitSpec> {
        let (w, h) = self
            .size
            .split_once('x')
            .and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?)))
            .filter(|&(w, h)| w > 0 && h > 0 && (w as u64) * (h as u64) <= 1 << 28)
            .with_context(|| format!("--size {:?}: expected WIDTHxHEIGHT", self.size))?;
        if n == 0 {
            bail!("--orbit must be at least 1 (or give --cameras)");
        }
        if self.up.len() != 3 {
            bail!("--up takes three numbers x,y,z");
        }
        if self.elevation.is_empty() || self.elevation.iter().any(|e| e.is_nan() || e.abs() >= 90.0)
        {
            bail!("--elevation takes angles in (-90, 90) degrees");
        }
        Ok(OrbitSpec {
            views_per_ring: n,
            width: w,
            height: h,
            fov_deg: self.fov,
            elevations_deg: self.elevation.clone(),
            radius: self.radius,
            up: DVec3::new(self.up[0], self.up[1], self.up[2]),
        })
    }
}
