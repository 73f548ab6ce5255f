//! Pruning a triangle-splat soup to its solid, opaque triangles (the core of
//! `prune-triangles`).
//!
//! Criteria, applied in this order (Triangle Splatting's pruning rules):
//! 1. invalid triangles are always removed: a non-finite vertex coordinate,
//!    NaN raw opacity or NaN raw sigma (raw ±∞ are valid: they are the solid
//!    markers below), or zero area (renders nothing);
//! 2. `--min-opacity T`: remove α = sigmoid(raw) ≤ T (the paper's "dead" test
//!    `o ≤ opacity_dead`);
//! 3. `--max-sigma S`: remove σ = 0.01 + exp(raw) ≥ S (the game-engine
//!    variant removes σ ≥ 1);
//! 4. `--max-count N`: keep the N most opaque survivors (ties: lower index);
//! 5. `--solidify`: set every survivor to opacity 1 (raw +∞) and the hard
//!    window (raw sigma −∞, which splatkit reads as σ = 0; see
//!    [`crate::model::triangle_soup`]).
//!
//! Survivors keep their order.

use serde::Serialize;

use crate::model::TriangleSoup;
use crate::model::triangle_soup::{SOLID_OPACITY_RAW, SOLID_SIGMA_RAW};

/// Thresholds (all optional; see the module docs for their order).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PruneParams {
    /// Remove triangles whose activated opacity is ≤ this.
    pub min_opacity: Option<f32>,
    /// Remove triangles whose activated sigma is ≥ this.
    pub max_sigma: Option<f32>,
    /// Keep at most this many (the most opaque).
    pub max_count: Option<usize>,
    /// Make survivors fully opaque with a hard window.
    pub solidify: bool,
}

/// What [`prune`] did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PruneReport {
    pub total: usize,
    pub kept: usize,
    pub removed_invalid: usize,
    pub removed_degenerate: usize,
    pub removed_opacity: usize,
    pub removed_sigma: usize,
    pub removed_count: usize,
    pub solidified: bool,
}

/// Zero-area test on the exact cross product (f64, so only truly degenerate
/// triangles — repeated or collinear vertices — are caught).
fn is_degenerate(t: &[[f32; 3]; 3]) -> bool {
    let d = |a: [f32; 3], b: [f32; 3]| [0, 1, 2].map(|k| b[k] as f64 - a[k] as f64);
    let (u, v) = (d(t[0], t[1]), d(t[0], t[2]));
    let c = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    c == [0.0; 3]
}

/// Filters `soup` by `p`. Pure and deterministic.
pub fn prune(soup: &TriangleSoup, p: &PruneParams) -> (TriangleSoup, PruneReport) {
    let n = soup.len();
    let mut r = PruneReport {
        total: n,
        solidified: p.solidify,
        ..Default::default()
    };
    let mut keep = vec![true; n];
    for (i, k) in keep.iter_mut().enumerate() {
        let t = &soup.triangles[i];
        if t.iter().flatten().any(|c| !c.is_finite())
            || soup.opacity_raw[i].is_nan()
            || soup.sigma_raw[i].is_nan()
        {
            r.removed_invalid += 1;
            *k = false;
        } else if is_degenerate(t) {
            r.removed_degenerate += 1;
            *k = false;
        } else if p.min_opacity.is_some_and(|th| soup.opacity(i) <= th) {
            r.removed_opacity += 1;
            *k = false;
        } else if p.max_sigma.is_some_and(|th| soup.sigma(i) >= th) {
            r.removed_sigma += 1;
            *k = false;
        }
    }
    if let Some(max) = p.max_count {
        let mut alive: Vec<usize> = (0..n).filter(|&i| keep[i]).collect();
        if alive.len() > max {
            // Most opaque first; raw logits order like activated opacities.
            alive.sort_by(|&a, &b| {
                soup.opacity_raw[b]
                    .total_cmp(&soup.opacity_raw[a])
                    .then(a.cmp(&b))
            });
            for &i in &alive[max..] {
                keep[i] = false;
            }
            r.removed_count = alive.len() - max;
        }
    }
    let mut out = soup.filter(&keep);
    r.kept = out.len();
    if p.solidify {
        out.opacity_raw
            .iter_mut()
            .for_each(|o| *o = SOLID_OPACITY_RAW);
        out.sigma_raw.iter_mut().for_each(|s| *s = SOLID_SIGMA_RAW);
    }
    (out, r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Extras;
    use crate::model::gaussians::logit;

    fn soup(opacities: &[f32], sigmas: &[f32]) -> TriangleSoup {
        let n = opacities.len();
        TriangleSoup {
            triangles: (0..n)
                .map(|i| {
                    [
                        [i as f32, 0.0, 0.0],
                        [i as f32 + 1.0, 0.0, 0.0],
                        [i as f32, 1.0, 0.0],
                    ]
                })
                .collect(),
            opacity_raw: opacities.iter().map(|&o| logit(o)).collect(),
            sigma_raw: sigmas.iter().map(|&s| (s - 0.01).ln()).collect(),
            sh_degree: 0,
            active_sh_degree: 0,
            sh_dc: (0..n).map(|i| [i as f32; 3]).collect(),
            sh_rest: vec![],
            extras: Extras::default(),
        }
    }

    #[test]
    fn thresholds_follow_the_papers_comparisons() {
        // Opacity exactly at the threshold is dead (o ≤ T); sigma exactly at
        // the threshold is removed (σ ≥ S). Values chosen away from f32
        // rounding except the boundary ones, which logit/exp reproduce to 1 ulp.
        let s = soup(&[0.05, 0.5, 0.9, 0.95, 0.99], &[0.5, 2.0, 0.5, 0.999, 0.1]);
        let p = PruneParams {
            min_opacity: Some(0.1),
            max_sigma: Some(1.0),
            ..Default::default()
        };
        let (out, r) = prune(&s, &p);
        assert_eq!(r.removed_opacity, 1);
        assert_eq!(r.removed_sigma, 1);
        assert_eq!(
            out.sh_dc.iter().map(|d| d[0]).collect::<Vec<_>>(),
            vec![2.0, 3.0, 4.0]
        );
    }

    #[test]
    fn max_count_keeps_the_most_opaque_in_order() {
        let s = soup(&[0.3, 0.9, 0.2, 0.8, 0.9], &[0.5; 5]);
        let (out, r) = prune(
            &s,
            &PruneParams {
                max_count: Some(3),
                ..Default::default()
            },
        );
        assert_eq!(r.removed_count, 2);
        // 0.9 (idx 1), 0.9 (idx 4), 0.8 (idx 3) survive, in file order.
        assert_eq!(
            out.sh_dc.iter().map(|d| d[0]).collect::<Vec<_>>(),
            vec![1.0, 3.0, 4.0]
        );
    }

    #[test]
    fn solidify_gives_opacity_one_and_hard_window() {
        let (out, _) = prune(
            &soup(&[0.3, 0.6], &[0.5, 3.0]),
            &PruneParams {
                solidify: true,
                ..Default::default()
            },
        );
        for i in 0..2 {
            assert_eq!(out.opacity(i), 1.0);
            assert_eq!(out.sigma(i), 0.0);
        }
    }

    #[test]
    fn invalid_and_degenerate_triangles_are_removed_and_counted() {
        let mut s = soup(&[0.5; 4], &[0.5; 4]);
        s.triangles[1][2][0] = f32::NAN;
        s.sigma_raw[2] = f32::NAN;
        s.triangles[3] = [[1.0, 1.0, 1.0]; 3];
        let (out, r) = prune(&s, &PruneParams::default());
        assert_eq!((r.removed_invalid, r.removed_degenerate, r.kept), (2, 1, 1));
        assert_eq!(out.len(), 1);
    }
}
