//! Triangle Splatting's initialisation from points (`create_from_pcd`,
//! triangle_splatting.md §1.2).
//!
//! Per seed point c with colour rgb:
//! - r = k·sqrt(mean squared distance to its 3 nearest other seeds), the
//!   mean clamped at 1e-7 before the root, k = 2.23 (the code; the
//!   supplement rounds it to 2.2);
//! - the vertices c + r·R·d_i with d_0 = (0, 0, 1), d_1 = (cos θ, sin θ, 0),
//!   θ = π(3 − √5) (the golden angle), d_2 = (0, 0, −1) — the Fibonacci
//!   sphere for n = 3 — and R a uniformly random rotation: an isosceles
//!   right triangle whose hypotenuse (length 2r) passes through c;
//! - opacity 0.28 (raw logit), σ 1.16 (raw ln(1.16 − 0.01)), SH DC
//!   (rgb − 0.5)/C0, higher bands zero, SH degree 3, active degree 0.
//!
//! The dome (outdoor scenes; off with `dome = false`, as on DTU): ⌊0.05·N⌋
//! extra white seeds on a Fibonacci sphere of radius max |coordinate| of the
//! seeds, centred at the origin.
//!
//! Random seeds (data without points, `train --init-points`) are grey:
//! [`crate::train::gaussians::init::grey_seeds`] gives every seed the colour
//! [`crate::train::gaussians::init::RANDOM_SEED_GREY`], for both models. The
//! reference's reader draws its 100,000 random points with SH DC
//! U(0, 1)/255, i.e. colour 0.5 + U(0, 0.0011), which its PLY round trip
//! (`storePly` then `fetchPly`, 8-bit) makes 127/255 on every channel: the
//! random seeds start uncoloured. Uniformly random 8-bit colours (what
//! [`crate::train::gaussians::init::random_points`] draws) let the initial
//! fog of random triangles paint each training view by colour alone: on
//! the generated sphere without points (1,000 iterations, 20,000 seeds)
//! held-out PSNR stopped at 14.3 dB (16.5 at 500) while the training views
//! reached 28.8; grey seeds reach 30.3 dB, rising at every evaluation.

use glam::{DMat3, DQuat, DVec3};

use crate::geom::sampling::knn::mean_sq_dist_3nn;
use crate::model::gaussians::logit;
use crate::model::rng::{Rng, normal};
use crate::model::{PointCloud, TriangleSoup};
use crate::{Error, Result};

/// C0 of the SH basis.
const C0: f32 = 0.282_094_8;

/// Initial values (the reference's defaults).
#[derive(Clone, Debug, serde::Serialize)]
pub struct InitParams {
    /// Size factor k (2.23).
    pub size: f64,
    pub opacity: f32,
    pub sigma: f32,
    /// Add the dome of ⌊0.05·N⌋ white seeds.
    pub dome: bool,
    pub sh_degree: usize,
}

impl Default for InitParams {
    fn default() -> Self {
        InitParams {
            size: 2.23,
            opacity: 0.28,
            sigma: 1.16,
            dome: false,
            sh_degree: 3,
        }
    }
}

/// `n` points of the Fibonacci sphere (unit radius): z = 1 − 2i/(n − 1),
/// azimuth i·θ with θ the golden angle.
pub fn fibonacci_sphere(n: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = if n > 1 {
                1.0 - 2.0 * i as f64 / (n - 1) as f64
            } else {
                0.0
            };
            let rho = (1.0 - z * z).max(0.0).sqrt();
            let a = golden * i as f64;
            DVec3::new(rho * a.cos(), rho * a.sin(), z)
        })
        .collect()
}

/// A uniformly random rotation (a normalised 4-D Gaussian quaternion).
pub fn random_rotation(rng: &mut Rng) -> DMat3 {
    loop {
        let q = DQuat::from_xyzw(normal(rng), normal(rng), normal(rng), normal(rng));
        let l = q.length();
        if l > 1e-9 {
            return DMat3::from_quat(q / l);
        }
    }
}

/// The seeds with the dome added when asked (see the module docs).
pub fn seeds_with_dome(points: &PointCloud, dome: bool) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let mut pos = points.positions.clone();
    let mut rgb: Vec<[f32; 3]> = match &points.colors {
        Some(c) => c.iter().map(|c| c.map(|v| v as f32 / 255.0)).collect(),
        None => vec![[0.5; 3]; pos.len()],
    };
    if dome {
        let n = (0.05 * pos.len() as f64) as usize;
        let radius = pos.iter().flatten().fold(0.0f32, |m, v| m.max(v.abs())) as f64;
        for d in fibonacci_sphere(n) {
            pos.push((d * radius).as_vec3().to_array());
            rgb.push([1.0; 3]);
        }
    }
    (pos, rgb)
}

/// The initial soup (see the module docs); errors when there are fewer than
/// 2 seeds or a seed is not finite.
pub fn init_triangles(points: &PointCloud, p: &InitParams, rng: &mut Rng) -> Result<TriangleSoup> {
    let (pos, rgb) = seeds_with_dome(points, p.dome);
    if pos.len() < 2 {
        return Err(Error::invalid(format!(
            "triangle initialisation needs at least 2 seed points, got {}",
            pos.len()
        )));
    }
    if let Some(i) = pos.iter().position(|q| q.iter().any(|v| !v.is_finite())) {
        return Err(Error::invalid(format!(
            "seed point {i} is not finite: {:?}",
            pos[i]
        )));
    }
    let p64: Vec<[f64; 3]> = pos.iter().map(|q| q.map(f64::from)).collect();
    let msd = mean_sq_dist_3nn(&p64)?;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let dirs = [
        DVec3::Z,
        DVec3::new(golden.cos(), golden.sin(), 0.0),
        DVec3::NEG_Z,
    ];
    let n = pos.len();
    let mut soup = TriangleSoup {
        triangles: Vec::with_capacity(n),
        opacity_raw: vec![logit(p.opacity); n],
        sigma_raw: vec![(p.sigma - 0.01).ln(); n],
        sh_degree: p.sh_degree,
        active_sh_degree: 0,
        sh_dc: rgb.iter().map(|c| c.map(|v| (v - 0.5) / C0)).collect(),
        sh_rest: vec![0.0; n * ((p.sh_degree + 1).pow(2) - 1) * 3],
        extras: Default::default(),
    };
    for (q, msd) in p64.iter().zip(msd) {
        let c = DVec3::from_array(*q);
        let r = p.size * msd.sqrt();
        let rot = random_rotation(rng);
        soup.triangles
            .push(dirs.map(|d| (c + r * (rot * d)).as_vec3().to_array()));
    }
    Ok(soup)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::rng::seeded;

    /// Four points on a unit square (3-NN mean squared distance (1+1+2)/3):
    /// each triangle is right isosceles with its hypotenuse 2r through its
    /// seed, r = 2.23·sqrt(4/3); raw values are logit(0.28) and ln(1.15).
    #[test]
    fn init_geometry_and_values() {
        let pc = PointCloud {
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.0],
            ],
            colors: Some(vec![[255, 0, 0]; 4]),
            ..Default::default()
        };
        let soup = init_triangles(&pc, &InitParams::default(), &mut seeded(1)).unwrap();
        let r = 2.23 * (4.0f64 / 3.0).sqrt();
        for (t, s) in soup.triangles.iter().zip(&pc.positions) {
            let v = t.map(|x| DVec3::from_array(x.map(f64::from)));
            let c = DVec3::from_array(s.map(f64::from));
            // hypotenuse v0–v2 of length 2r centred on the seed
            assert!(((v[0] - v[2]).length() - 2.0 * r).abs() < 1e-5);
            assert!(((v[0] + v[2]) / 2.0 - c).length() < 1e-5);
            // legs equal, right angle at v1
            assert!(((v[1] - v[0]).length() - (v[1] - v[2]).length()).abs() < 1e-5);
            assert!((v[1] - v[0]).dot(v[1] - v[2]).abs() < 1e-4);
        }
        assert!((soup.opacity(0) - 0.28).abs() < 1e-6);
        assert!((soup.sigma(0) - 1.16).abs() < 1e-6);
        assert!((soup.sh_dc[0][0] - 0.5 / C0).abs() < 1e-5);
        assert!((soup.sh_dc[0][1] + 0.5 / C0).abs() < 1e-5);
        assert_eq!(soup.sh_rest.len(), 4 * 15 * 3);
        assert!(soup.sh_rest.iter().all(|&v| v == 0.0));
    }

    /// Grey seeds keep the positions; every triangle gets SH DC
    /// (127/255 − 0.5)/C0 on each channel, whatever the points' colours.
    #[test]
    fn random_seeds_are_grey() {
        let pc = PointCloud {
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]],
            colors: Some(vec![[255, 0, 9], [0, 0, 0], [30, 200, 100]]),
            ..Default::default()
        };
        let g = crate::train::gaussians::init::grey_seeds(&pc);
        assert_eq!(g.positions, pc.positions);
        let soup = init_triangles(&g, &InitParams::default(), &mut seeded(2)).unwrap();
        let want = (127.0 / 255.0 - 0.5) / C0;
        for dc in &soup.sh_dc {
            for &v in dc {
                assert!((v - want).abs() < 1e-6, "{v} vs {want}");
            }
        }
    }

    /// Seeds of the same random cloud in a box scaled by s give triangles
    /// scaled by s about the scaled seeds (the size rule is linear in the
    /// 3-NN distance): a random-init soup's sizes follow the box.
    #[test]
    fn random_init_sizes_scale_with_the_box() {
        use crate::train::gaussians::init::random_points;
        let a = random_points(400, [-1.0; 3], [1.0; 3], &mut seeded(4));
        let s = 3.5f32;
        let b = PointCloud {
            positions: a.positions.iter().map(|p| p.map(|v| v * s)).collect(),
            ..a.clone()
        };
        let ta = init_triangles(&a, &InitParams::default(), &mut seeded(5)).unwrap();
        let tb = init_triangles(&b, &InitParams::default(), &mut seeded(5)).unwrap();
        let half_hyp = |t: &[[f32; 3]; 3]| {
            let d: [f32; 3] = std::array::from_fn(|k| t[0][k] - t[2][k]);
            0.5 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
        };
        let mean_a = ta.triangles.iter().map(half_hyp).sum::<f32>() / 400.0;
        // 400 points in a 2-unit cube: mean 3-NN distance ≈ 0.554·(8/400)^(1/3)
        // ≈ 0.15 (nearest) to 0.25 (third), times 2.23
        assert!(mean_a > 0.2 && mean_a < 0.8, "{mean_a}");
        for (x, y) in ta.triangles.iter().zip(&tb.triangles) {
            for k in 0..3 {
                for j in 0..3 {
                    assert!((y[k][j] - s * x[k][j]).abs() < 1e-4 * s, "{x:?} {y:?}");
                }
            }
        }
    }

    /// The dome adds ⌊0.05·N⌋ white seeds at radius max |coordinate|.
    #[test]
    fn dome_count_and_radius() {
        let pc = PointCloud {
            positions: (0..40).map(|i| [i as f32 * 0.1, 0.0, -3.0]).collect(),
            ..Default::default()
        };
        let (pos, rgb) = seeds_with_dome(&pc, true);
        assert_eq!(pos.len(), 42);
        for (q, c) in pos[40..].iter().zip(&rgb[40..]) {
            let l = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
            assert!((l - 3.9).abs() < 1e-4, "{l}");
            assert_eq!(*c, [1.0; 3]);
        }
    }
}
