//! The orbit flags shared by the commands that can make up cameras when a
//! scene comes without a camera file (`render`, `splat2points`).

use std::path::Path;

use clap::Args;
use glam::DVec3;

use super::usage;
use crate::io::cameras::MAX_PIXELS;
use crate::model::{Camera, OrbitSpec};

/// The most views one orbit ring may have.
pub const MAX_ORBIT_VIEWS: usize = 1000;
/// The most views an orbit may have over all its rings.
pub const MAX_ORBIT_TOTAL: usize = 10_000;

/// Parses `WIDTHxHEIGHT` (both > 0, at most [`MAX_PIXELS`] pixels); a
/// bad value is a usage error (exit 2).
pub fn parse_size(s: &str) -> anyhow::Result<(u32, u32)> {
    let (w, h) = s
        .split_once('x')
        .and_then(|(a, b)| Some((a.trim().parse::<u32>().ok()?, b.trim().parse::<u32>().ok()?)))
        .ok_or_else(|| {
            usage(format!(
                "--size {s:?}: expected WIDTHxHEIGHT, two whole numbers"
            ))
        })?;
    if w == 0 || h == 0 {
        return Err(usage(format!(
            "--size {s:?}: width and height must be greater than zero"
        )));
    }
    if u64::from(w) * u64::from(h) > MAX_PIXELS {
        return Err(usage(format!(
            "--size {s:?}: {w}x{h} exceeds the limit of {MAX_PIXELS} pixels (2^28, e.g. 16384x16384)"
        )));
    }
    Ok((w, h))
}

/// Orbit cameras made up when a scene comes without a camera file: `N`
/// views per ring evenly spaced in azimuth around the centre of the scene's
/// central 96% box, one ring per elevation, looking at that centre.
#[derive(Args, Debug, Clone)]
pub struct OrbitArgs {
    /// Orbit views per ring when no camera file is given (render: 8), 1 to 1000.
    #[arg(long, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=MAX_ORBIT_VIEWS as u64))]
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
    /// The orbit these flags describe, with `n` views per ring, checked; a
    /// bad flag is a usage error (exit 2). Commands call it before reading
    /// the scene, so a bad flag costs no work.
    pub fn spec(&self, n: usize) -> anyhow::Result<OrbitSpec> {
        let (w, h) = parse_size(&self.size)?;
        if n == 0 || n > MAX_ORBIT_VIEWS {
            return Err(usage(format!(
                "--orbit takes 1 to {MAX_ORBIT_VIEWS} views per ring (got {n})"
            )));
        }
        if n.saturating_mul(self.elevation.len()) > MAX_ORBIT_TOTAL {
            return Err(usage(format!(
                "--orbit {n} with {} elevations makes more than {MAX_ORBIT_TOTAL} views",
                self.elevation.len()
            )));
        }
        if !(self.fov.is_finite() && self.fov > 0.0 && self.fov < 180.0) {
            return Err(usage(format!(
                "--fov must lie in (0, 180) degrees (got {})",
                self.fov
            )));
        }
        if let Some(r) = self.radius
            && !(r.is_finite() && r > 0.0)
        {
            return Err(usage(format!(
                "--radius must be a positive distance (got {r})"
            )));
        }
        if self.up.len() != 3 || self.up.iter().any(|v| !v.is_finite()) {
            return Err(usage("--up takes three finite numbers x,y,z"));
        }
        if self.elevation.is_empty() || self.elevation.iter().any(|e| e.is_nan() || e.abs() >= 90.0)
        {
            return Err(usage("--elevation takes angles in (-90, 90) degrees"));
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

/// Bytes of image buffers for views of the sizes `cams`: the largest view's
/// pixels × `per_view` (the buffers of the one view being worked on at a
/// time) plus the pixels of all views × `held` (the buffers kept for every
/// view, e.g. photos held in memory for training). Saturating, so an
/// overflow is an estimate of `u64::MAX` and is refused.
pub fn image_bytes(cams: &[Camera], per_view: u64, held: u64) -> u64 {
    let pixels = |c: &Camera| u64::from(c.width).saturating_mul(u64::from(c.height));
    let largest = cams.iter().map(pixels).max().unwrap_or(0);
    let all = cams
        .iter()
        .map(pixels)
        .fold(0u64, |a, p| a.saturating_add(p));
    largest
        .saturating_mul(per_view)
        .saturating_add(all.saturating_mul(held))
}

/// Where an image size came from, for [`check_image_budget`].
#[derive(Clone, Copy, Debug)]
pub enum SizeFrom<'a> {
    /// A flag and its value as given (`--size 16384x16384`): a refusal is a
    /// usage error (exit 2).
    Flag(&'a str),
    /// A camera file (or data folder): a refusal is an error (exit 1)
    /// naming it.
    File(&'a Path),
}

/// Refuses `bytes` of image buffers beyond the memory budget
/// ([`crate::io::budget::check`]): the message names where the sizes came
/// from (`from`), `what` the buffers are (e.g. "the render buffers of 8
/// views of 16384x16384"), the estimate and the budget. A size from a flag
/// is a usage error (exit 2), one from a file an error (exit 1).
pub fn check_image_budget(from: SizeFrom, what: &str, bytes: u64) -> anyhow::Result<()> {
    match from {
        SizeFrom::Flag(flag) => crate::io::budget::check(&format!("{flag}: {what}"), bytes)
            .map_err(|e| usage(e.to_string())),
        SizeFrom::File(p) => {
            crate::io::budget::check(&format!("{}: {what}", p.display()), bytes)?;
            Ok(())
        }
    }
}

/// `W`x`H` of the largest of `cams` (by pixel count), for messages.
pub fn largest_size(cams: &[Camera]) -> String {
    cams.iter()
        .max_by_key(|c| u64::from(c.width) * u64::from(c.height))
        .map_or_else(
            || "0x0".to_string(),
            |c| format!("{}x{}", c.width, c.height),
        )
}
