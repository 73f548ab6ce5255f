//! How far one set of Gaussians is from another, attribute by attribute:
//! what `convert` reports after writing a lossy format and reading it back.

use serde::Serialize;

use crate::model::Gaussians;

/// SH DC coefficient ↔ colour: 0.5 + C0·dc.
const C0: f64 = 0.282_094_791_773_878_14;

/// Largest and root-mean-square absolute difference of one attribute.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct MaxRms {
    pub max: f64,
    pub rms: f64,
}

/// Attribute errors of `decoded` against `original` (same order). Every
/// value is an absolute difference, per component, NaN pairs skipped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SplatError {
    /// Position components, scene units.
    pub position: MaxRms,
    /// DC colour 0.5 + C0·f_dc per channel (1 = full range).
    pub colour: MaxRms,
    /// Activated opacity sigmoid(v).
    pub opacity: MaxRms,
    /// Natural-log scales.
    pub log_scale: MaxRms,
    /// Largest rotation between the normalised quaternions, degrees.
    pub rotation_max_deg: f64,
    /// Largest |Δ| of an SH rest coefficient; coefficients the decoded set
    /// lacks (a lower SH degree) count as 0.
    pub sh_rest_max: f64,
}

#[derive(Default)]
struct Acc {
    max: f64,
    sum2: f64,
    n: u64,
}

impl Acc {
    fn add(&mut self, d: f64) {
        if d.is_finite() {
            self.max = self.max.max(d);
            self.sum2 += d * d;
            self.n += 1;
        }
    }
    fn done(&self) -> MaxRms {
        MaxRms {
            max: self.max,
            rms: if self.n == 0 {
                0.0
            } else {
                (self.sum2 / self.n as f64).sqrt()
            },
        }
    }
}

/// Compares `decoded` with `original` Gaussian by Gaussian (they must have
/// the same length; `None` otherwise).
pub fn splat_error(original: &Gaussians, decoded: &Gaussians) -> Option<SplatError> {
    if original.len() != decoded.len() {
        return None;
    }
    let (mut pos, mut col, mut op, mut sc) = (
        Acc::default(),
        Acc::default(),
        Acc::default(),
        Acc::default(),
    );
    let mut rot: f64 = 0.0;
    let mut sh: f64 = 0.0;
    let (ka, kb) = (original.rest_per_channel(), decoded.rest_per_channel());
    for i in 0..original.len() {
        for a in 0..3 {
            pos.add((original.means[i][a] as f64 - decoded.means[i][a] as f64).abs());
            col.add(C0 * (original.sh_dc[i][a] as f64 - decoded.sh_dc[i][a] as f64).abs());
            sc.add((original.log_scales[i][a] as f64 - decoded.log_scales[i][a] as f64).abs());
        }
        op.add((original.opacity(i) as f64 - decoded.opacity(i) as f64).abs());
        let q = |g: &Gaussians| {
            let v = g.rotations[i].map(|x| x as f64);
            let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            if n > 0.0 && n.is_finite() {
                v.map(|x| x / n)
            } else {
                [1.0, 0.0, 0.0, 0.0]
            }
        };
        let (qa, qb) = (q(original), q(decoded));
        let dot: f64 = qa.iter().zip(&qb).map(|(x, y)| x * y).sum();
        let angle = 2.0 * dot.abs().min(1.0).acos().to_degrees();
        if angle.is_finite() {
            rot = rot.max(angle);
        }
        for k in 0..ka.max(kb) {
            for c in 0..3 {
                let get = |g: &Gaussians, kk: usize| {
                    if k < kk {
                        g.sh_rest[(i * kk + k) * 3 + c] as f64
                    } else {
                        0.0
                    }
                };
                let d = (get(original, ka) - get(decoded, kb)).abs();
                if d.is_finite() {
                    sh = sh.max(d);
                }
            }
        }
    }
    Some(SplatError {
        position: pos.done(),
        colour: col.done(),
        opacity: op.done(),
        log_scale: sc.done(),
        rotation_max_deg: rot,
        sh_rest_max: sh,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(pos: [f32; 3], dc: f32, op: f32, rot: [f32; 4], rest: f32) -> Gaussians {
        Gaussians {
            means: vec![pos],
            sh_degree: 1,
            sh_dc: vec![[dc; 3]],
            sh_rest: vec![rest; 9],
            opacity_logits: vec![op],
            log_scales: vec![[0.0; 3]],
            rotations: vec![rot],
            ..Default::default()
        }
    }

    /// Known differences give the closed-form errors.
    #[test]
    fn known_differences() {
        let a = one([0.0; 3], 0.0, 0.0, [1.0, 0.0, 0.0, 0.0], 0.25);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let mut b = one([0.3, 0.0, -0.4], 1.0, 100.0, [h, 0.0, 0.0, h], 0.0);
        b.sh_degree = 0;
        b.sh_rest.clear();
        let e = splat_error(&a, &b).unwrap();
        assert!((e.position.max - 0.4).abs() < 1e-6);
        assert!((e.position.rms - ((0.09 + 0.16) / 3.0f64).sqrt()).abs() < 1e-6);
        assert!((e.colour.max - C0).abs() < 1e-7 && (e.colour.rms - C0).abs() < 1e-7);
        assert!((e.opacity.max - 0.5).abs() < 1e-6);
        assert!(
            (e.rotation_max_deg - 90.0).abs() < 1e-4,
            "{}",
            e.rotation_max_deg
        );
        assert_eq!(e.sh_rest_max, 0.25);
        assert_eq!(e.log_scale.max, 0.0);
        // q and −q are the same rotation
        let c = one([0.0; 3], 0.0, 0.0, [-1.0, 0.0, 0.0, 0.0], 0.25);
        assert_eq!(splat_error(&a, &c).unwrap().rotation_max_deg, 0.0);
        assert!(splat_error(&a, &Gaussians::default()).is_none());
    }
}
