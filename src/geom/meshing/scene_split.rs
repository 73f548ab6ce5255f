//! Foreground / background split of a scene and the automatic Poisson depth,
//! as SuGaR's code (`sugar_extractors/coarse_mesh.py`, not its supplement §9)
//! and Frosting (`frosting_extractors/coarse_shell.py`) do them.
//!
//! Camera split: c̄ = mean of the camera centres, R = fg_factor · max‖c_i − c̄‖
//! (fg_factor 1.1, the 3DGS scene radius). Foreground = the axis-aligned
//! cube c̄ ± R; background = points whose L∞ distance to c̄ is below
//! bg_factor · R (4) and that are not foreground; points farther out are
//! dropped. An explicit box replaces the foreground cube (absolute
//! coordinates; unlike SuGaR it is not shifted by c̄), with the background
//! limit still bg_factor · R around c̄ when cameras are given.

use rayon::prelude::*;

use crate::{Error, Result};

/// Which part a point belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    Foreground,
    Background,
    Dropped,
}

/// An axis-aligned box (inclusive).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Aabb {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

impl Aabb {
    /// True when p is inside (boundary included).
    pub fn contains(&self, p: [f64; 3]) -> bool {
        (0..3).all(|k| p[k] >= self.min[k] && p[k] <= self.max[k])
    }

    /// Parses `MINX,MINY,MINZ,MAXX,MAXY,MAXZ`.
    pub fn parse(s: &str) -> Result<Aabb> {
        let v: Vec<f64> = s
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|e| {
                Error::invalid(format!(
                    "--bbox '{s}': {e}; expected MINX,MINY,MINZ,MAXX,MAXY,MAXZ"
                ))
            })?;
        if v.len() != 6 || v.iter().any(|x| !x.is_finite()) {
            return Err(Error::invalid(format!(
                "--bbox '{s}': expected 6 finite numbers MINX,MINY,MINZ,MAXX,MAXY,MAXZ, got {}",
                v.len()
            )));
        }
        let b = Aabb {
            min: [v[0], v[1], v[2]],
            max: [v[3], v[4], v[5]],
        };
        if (0..3).any(|k| b.min[k] >= b.max[k]) {
            return Err(Error::invalid(format!(
                "--bbox '{s}': every min must be below its max"
            )));
        }
        Ok(b)
    }
}

/// The mean of camera centres and the largest distance of a centre from it
/// (3DGS's `getNerfppNorm` radius before its 1.1 factor; SuGaR's extent and
/// its foreground cube use it). (origin, 0) for no centres.
pub fn centre_and_spread(centers: &[[f64; 3]]) -> ([f64; 3], f64) {
    let n = centers.len().max(1) as f64;
    let mut c = [0.0; 3];
    for p in centers {
        for k in 0..3 {
            c[k] += p[k] / n;
        }
    }
    let rmax = centers
        .iter()
        .map(|p| ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt())
        .fold(0.0, f64::max);
    (c, rmax)
}

/// The split rule.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SceneSplit {
    /// Foreground box.
    pub foreground: Aabb,
    /// Centre and half-side of the background cube (L∞), if any.
    pub background: Option<([f64; 3], f64)>,
}

impl SceneSplit {
    /// SuGaR's split from camera centres.
    pub fn from_cameras(centers: &[[f64; 3]], fg_factor: f64, bg_factor: f64) -> Result<Self> {
        if centers.is_empty() {
            return Err(Error::invalid("the camera file holds no cameras"));
        }
        let (c, rmax) = centre_and_spread(centers);
        let r = fg_factor * rmax;
        if r.is_nan() || r <= 0.0 {
            return Err(Error::invalid(
                "all cameras share one centre: the foreground cube would be empty",
            ));
        }
        Ok(SceneSplit {
            foreground: Aabb {
                min: [c[0] - r, c[1] - r, c[2] - r],
                max: [c[0] + r, c[1] + r, c[2] + r],
            },
            background: Some((c, bg_factor * r)),
        })
    }

    /// Classifies a point.
    pub fn part(&self, p: [f64; 3]) -> Part {
        if self.foreground.contains(p) {
            return Part::Foreground;
        }
        match self.background {
            Some((c, h)) if (0..3).all(|k| (p[k] - c[k]).abs() < h) => Part::Background,
            Some(_) => Part::Dropped,
            None => Part::Background,
        }
    }
}

/// Frosting's automatic Poisson depth: bbox_size = 1.1 × the largest side of
/// the points' box; q = 10th percentile of (nearest-neighbour distance² /
/// bbox_size); depth = min(⌊−log2(100 q)⌋, 10), clamped to at least 2 (the
/// smallest depth the solver takes). Squared distances are divided by a
/// length, as in Frosting, whose constant was tuned that way.
pub fn auto_depth(points: &[[f64; 3]]) -> Result<u32> {
    if points.len() < 2 {
        return Err(Error::invalid("--auto-depth needs at least two points"));
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let bbox = 1.1 * (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    if bbox.is_nan() || bbox <= 0.0 {
        return Err(Error::invalid("--auto-depth: all points coincide"));
    }
    let tree = kiddo::ImmutableKdTree::<f64, 3>::new_from_slice(points)
        .map_err(|e| Error::invalid(format!("k-d tree construction failed: {e:?}")))?;
    let two = std::num::NonZero::new(2).expect("2 > 0");
    // Squared distance to the nearest other point (the first hit is the
    // point itself), over bbox_size.
    let mut d2: Vec<f64> = points
        .par_iter()
        .map(|p| {
            let nn = tree
                .query(p)
                .nearest_n::<kiddo::SquaredEuclidean<f64>>(two)
                .execute();
            nn.last().map_or(0.0, |r| r.distance) / bbox
        })
        .collect();
    d2.sort_unstable_by(f64::total_cmp);
    let q = crate::geom::mesh_ops::trim::quantile(
        &d2.iter().map(|&x| x as f32).collect::<Vec<_>>(),
        0.1,
    );
    if q.is_nan() || q <= 0.0 {
        return Ok(10);
    }
    Ok((-(100.0 * q).log2()).floor().clamp(2.0, 10.0) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_split_follows_sugar_code() {
        // Cameras on a circle of radius 2 around (1, 0, 0): R = 2.2.
        let cams: Vec<[f64; 3]> = (0..8)
            .map(|i| {
                let a = i as f64 * std::f64::consts::PI / 4.0;
                [1.0 + 2.0 * a.cos(), 2.0 * a.sin(), 0.0]
            })
            .collect();
        let s = SceneSplit::from_cameras(&cams, 1.1, 4.0).unwrap();
        assert!((s.foreground.max[0] - 3.2).abs() < 1e-12);
        assert_eq!(s.part([1.0, 0.0, 2.19]), Part::Foreground);
        assert_eq!(s.part([1.0, 0.0, 2.21]), Part::Background);
        assert_eq!(s.part([1.0, 8.79, 0.0]), Part::Background);
        assert_eq!(s.part([1.0, 8.81, 0.0]), Part::Dropped);
        assert!(SceneSplit::from_cameras(&[[1.0; 3]; 3], 1.1, 4.0).is_err());
    }

    #[test]
    fn bbox_parsing_errors_name_the_problem() {
        let b = Aabb::parse("0,0,0, 1,2,3").unwrap();
        assert_eq!(b.max, [1.0, 2.0, 3.0]);
        assert!(
            Aabb::parse("0,0,0,1,2")
                .unwrap_err()
                .to_string()
                .contains("6 finite numbers")
        );
        assert!(
            Aabb::parse("0,0,x,1,2,3")
                .unwrap_err()
                .to_string()
                .contains("MINX")
        );
        assert!(
            Aabb::parse("0,0,5,1,2,3")
                .unwrap_err()
                .to_string()
                .contains("below")
        );
    }

    #[test]
    fn auto_depth_of_a_grid() {
        // A 50×50 grid of spacing s on [0, 49 s]²: nn² = s², bbox = 1.1·49 s,
        // q = s / 53.9, depth = ⌊−log2(100 s / 53.9)⌋: s = 0.01 → ⌊0.43⌋… use
        // s = 0.001 → −log2(0.001855) = 9.07 → 9.
        let s = 0.001;
        let pts: Vec<[f64; 3]> = (0..2500)
            .map(|i| [(i % 50) as f64 * s, (i / 50) as f64 * s, 0.0])
            .collect();
        assert_eq!(auto_depth(&pts).unwrap(), 9);
        // Coarser spacing gives shallower depths, never above 10 or below 2.
        let pts: Vec<[f64; 3]> = (0..2500)
            .map(|i| [(i % 50) as f64, (i / 50) as f64, 0.0])
            .collect();
        assert_eq!(auto_depth(&pts).unwrap(), 2);
    }
}
