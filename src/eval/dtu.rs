//! The DTU Chamfer protocol (DTUeval-python `eval.py` as 2DGS / Triangle
//! Splatting run it; `jzhangbs/DTUeval-python`, mesh mode), deterministic.
//!
//! Steps, all in millimetres:
//! 1. prediction points: in mesh mode all mesh vertices (unreferenced ones
//!    too) followed by the DTU up-sampling of every triangle at 0.2 mm
//!    ([`crate::geom::sampling::sample::dtu_mesh_points`]); in point mode the points;
//! 2. a seeded shuffle (the reference's is unseeded) and greedy radius
//!    downsampling at 0.2 mm (a point is kept iff no earlier-kept point lies
//!    within ≤ 0.2) → `data_down`;
//! 3. bounding-box filter with patch 60 (`BB_min − 60 ≤ p < BB_max + 120`,
//!    BB cast to f32) → `data_in`;
//! 4. ObsMask filter (grid index rounded half to even) → `data_in_obs`;
//! 5. accuracy `mean_d2s` = mean of the NN distances from `data_in_obs` to the
//!    STL points that are **< 20** (larger ones discarded, not clamped);
//! 6. completeness `mean_s2d` = mean of the NN distances from the STL points
//!    above the plane (`P·[x,y,z,1] > 0`) to `data_in`, those < 20;
//! 7. `overall` = (mean_d2s + mean_s2d) / 2.
//!
//! Distances are exact (k-d tree) and accumulated in f64 in point order, so a
//! given seed gives the same numbers on any thread count. Means over no
//! points are NaN (JSON `null`), as numpy's mean of an empty array.

use serde::Serialize;

use crate::Result;
use crate::geom::sampling::downsample::{greedy_radius_downsample, seeded_permutation};
use crate::geom::sampling::knn::NnIndex;
use crate::geom::sampling::sample::dtu_mesh_points_par;
use crate::geom::sampling::stats::mean_below;
use crate::model::ObsMask;

// The lookups of the reference's stage B (`eval.py` steps 5 and 6) on the
// mask that `io::dtu` reads: the protocol's rules, so they live here.
impl ObsMask {
    /// The voxel `[gx, gy, gz]` that `p` (mm) falls in, or `None` outside the
    /// grid; step 6 of the reference (`eval.py`):
    /// `g = np.around((p − BB[:1]) / Res).astype(np.int32)`, kept when
    /// `0 ≤ g < ObsMask.shape` on every axis.
    ///
    /// Exactly as there: `eval.py` has already replaced `BB` by
    /// `BB.astype(np.float32)` (for the bounding-box filter) when it computes
    /// `g`, so the minimum corner used is each `bb[0][i]` rounded to f32 and
    /// widened back (f64 − f32 is f64 in numpy); the subtraction and the
    /// division by `Res` are in f64, and `np.around` rounds half to even.
    pub fn voxel(&self, p: [f64; 3]) -> Option<[usize; 3]> {
        let mut g = [0usize; 3];
        for i in 0..3 {
            let min = f64::from(self.bb[0][i] as f32);
            let r = ((p[i] - min) / self.res).round_ties_even();
            // numpy casts to int32 and then compares; every in-range value
            // is an exact small integer, and NaN / huge values fall outside
            // either way.
            if !(r >= 0.0 && r < self.dims[i] as f64) {
                return None;
            }
            g[i] = r as usize;
        }
        Some(g)
    }

    /// True when `p` (mm) falls in an observed voxel: [`ObsMask::voxel`] is
    /// `Some` and the mask there is non-zero (the reference's `in_obs`).
    pub fn contains(&self, p: [f64; 3]) -> bool {
        self.voxel(p)
            .and_then(|[x, y, z]| self.mask.get(x + self.dims[0] * (y + self.dims[1] * z)))
            .is_some_and(|&m| m != 0)
    }
}

/// The bounding-box filter of the reference (`eval.py` step 5, `inbound`):
/// true when on every axis `BB_min − patch ≤ p < BB_max + 2·patch` (mm).
///
/// As there, `BB` has been cast to float32 first, and because numpy keeps a
/// float32 array float32 when a Python scalar is added, `BB_min − patch` and
/// `BB_max + 2·patch` are computed and rounded in f32 (`patch` and `2·patch`
/// rounded to f32 first); the comparison with the f64 point is in f64.
pub fn bb_filter(p: [f64; 3], bb: &[[f64; 3]; 2], patch: f64) -> bool {
    let lo_off = patch as f32;
    let hi_off = (patch * 2.0) as f32;
    (0..3).all(|i| {
        let lo = f64::from(bb[0][i] as f32 - lo_off);
        let hi = f64::from(bb[1][i] as f32 + hi_off);
        p[i] >= lo && p[i] < hi
    })
}

/// The prediction: a mesh (up-sampled) or points (used as they are).
#[derive(Clone, Debug)]
pub enum DtuPrediction<'a> {
    Mesh {
        vertices: &'a [[f64; 3]],
        faces: &'a [[u32; 3]],
    },
    Points(&'a [[f64; 3]]),
}

/// Protocol constants (the reference script's defaults).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DtuParams {
    /// Up-sampling and downsampling spacing, mm (`--downsample_density 0.2`).
    pub density: f64,
    /// Bounding-box patch, mm (`--patch_size 60`).
    pub patch: f64,
    /// Distances ≥ this are discarded, mm (`--max_dist 20`).
    pub max_dist: f64,
    /// Colour scale of the visualisations, mm (`--visualize_threshold 10`).
    pub vis_threshold: f64,
    /// Seed of the shuffle before downsampling.
    pub seed: u64,
}

impl Default for DtuParams {
    fn default() -> Self {
        DtuParams {
            density: 0.2,
            patch: 60.0,
            max_dist: 20.0,
            vis_threshold: 10.0,
            seed: 0,
        }
    }
}

/// The protocol's result, with the reference `results.json` keys first.
#[derive(Clone, Debug, Serialize)]
pub struct DtuReport {
    pub mean_d2s: f64,
    pub mean_s2d: f64,
    pub overall: f64,
    /// Prediction points before downsampling.
    pub points_sampled: usize,
    /// After downsampling (`data_down`).
    pub points_down: usize,
    /// Inside the patch bounding box (`data_in`).
    pub points_in_bb: usize,
    /// Inside the ObsMask (`data_in_obs`).
    pub points_in_obs: usize,
    /// d2s distances below max_dist (the ones averaged).
    pub d2s_used: usize,
    /// STL points above the plane.
    pub stl_above_plane: usize,
    /// s2d distances below max_dist.
    pub s2d_used: usize,
    pub params: DtuParams,
    /// Per-point data for the visualisations (not serialised).
    #[serde(skip)]
    pub vis: DtuVis,
}

/// What the two visualisation clouds need.
#[derive(Clone, Debug, Default)]
pub struct DtuVis {
    /// `data_down` points.
    pub data_down: Vec<[f64; 3]>,
    /// d2s distance per `data_down` point; NaN where the point is outside the
    /// BB or the ObsMask.
    pub d2s: Vec<f64>,
    /// s2d distance per STL point; NaN below the plane.
    pub s2d: Vec<f64>,
}

/// Runs the protocol. `stl` are the GT points (mm), `obs` the ObsMask, `plane`
/// the ground plane `P`.
/// The k-d tree of the STL points is built while the prediction is sampled
/// and thinned (the two share the rayon pool), and the tree of `data_in`
/// while the accuracy distances are computed.
pub fn evaluate_dtu(
    pred: &DtuPrediction,
    stl: &[[f64; 3]],
    obs: &ObsMask,
    plane: [f64; 4],
    params: &DtuParams,
) -> Result<DtuReport> {
    let (stl_index, sampled) = rayon::join(
        || NnIndex::new(stl),
        || -> Result<(usize, Vec<[f64; 3]>)> {
            let points = match pred {
                DtuPrediction::Mesh { vertices, faces } => {
                    dtu_mesh_points_par(vertices, faces, params.density)?
                }
                DtuPrediction::Points(p) => p.to_vec(),
            };
            // Non-finite points cannot be measured: they are dropped before
            // anything else (the reference would propagate NaN into its means).
            let points: Vec<[f64; 3]> = points
                .into_iter()
                .filter(|p| p.iter().all(|c| c.is_finite()))
                .collect();
            let order = seeded_permutation(points.len(), params.seed);
            let kept = greedy_radius_downsample(&points, &order, params.density)?;
            Ok((points.len(), kept.iter().map(|&i| points[i]).collect()))
        },
    );
    let stl_index = stl_index?;
    let (points_sampled, data_down) = sampled?;
    let in_bb: Vec<bool> = data_down
        .iter()
        .map(|&p| bb_filter(p, &obs.bb, params.patch))
        .collect();
    let data_in: Vec<[f64; 3]> = data_down
        .iter()
        .zip(&in_bb)
        .filter(|(_, b)| **b)
        .map(|(p, _)| *p)
        .collect();
    let in_obs: Vec<bool> = data_down
        .iter()
        .zip(&in_bb)
        .map(|(&p, &b)| b && obs.contains(p))
        .collect();
    let data_in_obs: Vec<[f64; 3]> = data_down
        .iter()
        .zip(&in_obs)
        .filter(|(_, b)| **b)
        .map(|(p, _)| *p)
        .collect();

    let (d2s, data_in_index) = rayon::join(
        || stl_index.nearest_distances(&data_in_obs),
        || NnIndex::new(&data_in),
    );
    let data_in_index = data_in_index?;
    let (mean_d2s, d2s_used) = mean_below(&d2s, params.max_dist);

    let above: Vec<bool> = stl
        .iter()
        .map(|p| plane[0] * p[0] + plane[1] * p[1] + plane[2] * p[2] + plane[3] > 0.0)
        .collect();
    let stl_above: Vec<[f64; 3]> = stl
        .iter()
        .zip(&above)
        .filter(|(_, a)| **a)
        .map(|(p, _)| *p)
        .collect();
    let s2d = data_in_index.nearest_distances(&stl_above);
    let (mean_s2d, s2d_used) = mean_below(&s2d, params.max_dist);

    // Per-point distances for the visualisations.
    let mut vis_d2s = vec![f64::NAN; data_down.len()];
    let mut it = d2s.iter();
    for (v, &o) in vis_d2s.iter_mut().zip(&in_obs) {
        if o {
            *v = *it.next().expect("one distance per ObsMask point");
        }
    }
    let mut vis_s2d = vec![f64::NAN; stl.len()];
    let mut it = s2d.iter();
    for (v, &a) in vis_s2d.iter_mut().zip(&above) {
        if a {
            *v = *it.next().expect("one distance per point above the plane");
        }
    }
    Ok(DtuReport {
        mean_d2s,
        mean_s2d,
        overall: (mean_d2s + mean_s2d) / 2.0,
        points_sampled,
        points_down: data_down.len(),
        points_in_bb: data_in.len(),
        points_in_obs: data_in_obs.len(),
        d2s_used,
        stl_above_plane: stl_above.len(),
        s2d_used,
        params: params.clone(),
        vis: DtuVis {
            data_down,
            d2s: vis_d2s,
            s2d: vis_s2d,
        },
    })
}

/// Colour of one visualisation point, as the reference colours them: blue
/// where not evaluated (NaN), green at or beyond `max_dist`, otherwise white
/// blended to red by `min(d, vis_threshold) / vis_threshold`. Returned as
/// RGB8 (`round(c·255)`, as Open3D writes colours).
pub fn vis_color(d: f64, params: &DtuParams) -> [u8; 3] {
    if d.is_nan() {
        return [0, 0, 255];
    }
    if d >= params.max_dist {
        return [0, 255, 0];
    }
    let a = d.min(params.vis_threshold) / params.vis_threshold;
    // R·a + W·(1 − a) = (1, 1 − a, 1 − a).
    let c = ((1.0 - a) * 255.0).round() as u8;
    [255, c, c]
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::model::obs_mask::mask_with;

    #[test]
    fn obs_mask_uses_bb_min_rounded_to_f32() {
        // BB_min x = 0.1, Res = 1, p x = 3.6. numpy 2.4:
        // np.around((3.6 - np.float32(0.1)) / 1.0) = 3.0 (the reference),
        // np.around((3.6 - 0.1) / 1.0) = 4.0 (f64 BB would pick voxel 4).
        let m = mask_with(&[[3, 0, 0]], [0.1, 0.0, 0.0], 1.0);
        assert_eq!(m.voxel([3.6, 0.0, 0.0]), Some([3, 0, 0]));
        assert!(m.contains([3.6, 0.0, 0.0]));
    }

    #[test]
    fn bb_filter_boundaries() {
        // numpy 2.4: BB = np.array([[0.1, -5, 0], [10.3, 5, 1]]).astype(np.float32);
        // BB[:1] - 60.0 -> float32 [-59.900001525878906, -65, -60],
        // BB[1:] + 120.0 -> float32 [130.3000030517578, 125, 121].
        let bb = [[0.1, -5.0, 0.0], [10.3, 5.0, 1.0]];
        let lo_x = -59.900001525878906;
        let hi_x = 130.3000030517578;
        let inside = |x: f64| bb_filter([x, 0.0, 0.0], &bb, 60.0);
        assert!(inside(lo_x), "≤ at the minimum");
        assert!(!inside(lo_x - 1e-12));
        assert!(!inside(hi_x), "strict < at the maximum");
        assert!(inside(hi_x - 1e-12));
        // Points that f64 arithmetic would classify the other way
        // (0.1 − 60 = −59.9 and 10.3 + 120 = 130.3 in f64).
        assert!(inside(-59.9000001));
        assert!(inside(130.3000001));
        // Exactly representable bounds on the other axes.
        assert!(bb_filter([0.0, -65.0, -60.0], &bb, 60.0));
        assert!(!bb_filter([0.0, -65.0000001, 0.0], &bb, 60.0));
        assert!(!bb_filter([0.0, 125.0, 0.0], &bb, 60.0));
        assert!(bb_filter([0.0, 124.9999999, 120.9999999], &bb, 60.0));
        assert!(!bb_filter([0.0, 0.0, 121.0], &bb, 60.0));
        assert!(!bb_filter([f64::NAN, 0.0, 0.0], &bb, 60.0));
    }
}
