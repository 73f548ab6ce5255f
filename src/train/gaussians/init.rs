//! 3DGS's initialisation of Gaussians from points
//! (gaussian_training.md "Initialisation").
//!
//! Per point: mean = the point; SH DC = (rgb − 0.5)/C0, higher bands 0;
//! all three log scales = ln sqrt(max(mean squared distance to the 3
//! nearest other points, 1e-7)); rotation identity (w = 1); opacity
//! logit(0.1). Without points (synthetic scenes), [`random_points`] draws
//! them uniformly in a box, seeded, and [`grey_seeds`] makes them grey as
//! the references' readers do (for both models).

use rand::RngExt;

use crate::geom::sampling::knn::mean_sq_dist_3nn;
use crate::model::gaussians::logit;
use crate::model::rng::Rng;
use crate::model::{Gaussians, PointCloud};
use crate::{Error, Result};

const C0: f32 = 0.282_094_8;

/// `n` points uniform in the box `[lo, hi]` with uniformly random 8-bit
/// colours.
pub fn random_points(n: usize, lo: [f64; 3], hi: [f64; 3], rng: &mut Rng) -> PointCloud {
    let mut pc = PointCloud::default();
    let mut colors = Vec::with_capacity(n);
    for _ in 0..n {
        let p: [f32; 3] =
            std::array::from_fn(|k| (lo[k] + (hi[k] - lo[k]) * rng.random::<f64>()) as f32);
        pc.positions.push(p);
        colors.push(std::array::from_fn(|_| rng.random_range(0..=255u32) as u8));
    }
    pc.colors = Some(colors);
    pc
}

/// The 8-bit colour of random seeds on every channel: the references'
/// readers (3DGS's and Triangle Splatting's) draw random points' colour as
/// 0.5 + U(0, 0.0011) and store it as 8 bits, i.e. 127 (docs/train.md,
/// "Random initial points"; `crate::train::triangles::init` tells why it
/// matters).
pub const RANDOM_SEED_GREY: u8 = 127;

/// `points` with every colour set to [`RANDOM_SEED_GREY`] (positions and
/// normals kept): the seeds of a run from random points.
pub fn grey_seeds(points: &PointCloud) -> PointCloud {
    PointCloud {
        colors: Some(vec![[RANDOM_SEED_GREY; 3]; points.len()]),
        ..points.clone()
    }
}

/// 3DGS's Gaussians for `points` at SH degree `sh_degree` (see the module
/// docs); errors when there are fewer than 2 points or one is not finite.
pub fn init_gaussians(points: &PointCloud, sh_degree: usize) -> Result<Gaussians> {
    let n = points.len();
    if n < 2 {
        return Err(Error::invalid(format!(
            "Gaussian initialisation needs at least 2 points, got {n}"
        )));
    }
    let p64: Vec<[f64; 3]> = points.positions.iter().map(|q| q.map(f64::from)).collect();
    let log_scales = mean_sq_dist_3nn(&p64)?
        .into_iter()
        .map(|msd| [(msd.sqrt().ln()) as f32; 3])
        .collect();
    let rgb: Vec<[f32; 3]> = match &points.colors {
        Some(c) => c.iter().map(|c| c.map(|v| v as f32 / 255.0)).collect(),
        None => vec![[0.5; 3]; n],
    };
    Ok(Gaussians {
        means: points.positions.clone(),
        normals: None,
        sh_degree,
        sh_dc: rgb.iter().map(|c| c.map(|v| (v - 0.5) / C0)).collect(),
        sh_rest: vec![0.0; n * ((sh_degree + 1).pow(2) - 1) * 3],
        opacity_logits: vec![logit(0.1); n],
        log_scales,
        rotations: vec![[1.0, 0.0, 0.0, 0.0]; n],
        extras: Default::default(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::rng::seeded;

    /// Unit square corners: 3-NN mean squared distance 4/3, so every log
    /// scale is ln sqrt(4/3); opacity 0.1; identity rotations; DC from the
    /// colour.
    #[test]
    fn init_values() {
        let pc = PointCloud {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.0],
            ],
            colors: Some(vec![[255, 128, 0]; 4]),
            ..Default::default()
        };
        let g = init_gaussians(&pc, 3).unwrap();
        let want = (4.0f64 / 3.0).sqrt().ln() as f32;
        assert!(
            g.log_scales
                .iter()
                .flatten()
                .all(|&s| (s - want).abs() < 1e-6)
        );
        assert!((g.opacity(0) - 0.1).abs() < 1e-6);
        assert_eq!(g.rotations[2], [1.0, 0.0, 0.0, 0.0]);
        assert!((g.sh_dc[0][0] - 0.5 / C0).abs() < 1e-5);
        assert_eq!(g.sh_rest.len(), 4 * 45);
        g.validate().unwrap();
    }

    /// Random points stay in their box and depend only on the seed.
    #[test]
    fn random_points_in_box() {
        let a = random_points(500, [-1.0, 0.0, 2.0], [1.0, 0.5, 3.0], &mut seeded(9));
        let b = random_points(500, [-1.0, 0.0, 2.0], [1.0, 0.5, 3.0], &mut seeded(9));
        assert_eq!(a, b);
        assert!(a.positions.iter().all(|p| p[0].abs() <= 1.0
            && (0.0..=0.5).contains(&p[1])
            && (2.0..=3.0).contains(&p[2])));
    }
}
