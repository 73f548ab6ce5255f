//! The DTU Chamfer protocol (DTUeval-python `eval.py` as 2DGS / Triangle
//! Splatting run it; `eval_tsdf.md` §1.3), deterministic.
//!
//! Steps, all in millimetres:
//! 1. prediction points: in mesh mode all mesh vertices (unreferenced ones
//!    too) followed by the DTU up-sampling of every triangle at 0.2 mm
//!    ([`crate::geom::sample::dtu_mesh_points`]); in point mode the points;
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
use crate::geom::downsample::{greedy_radius_downsample, seeded_permutation};
use crate::geom::knn::NnIndex;
use crate::geom::sample::dtu_mesh_points_par;
use crate::geom::stats::mean_below;
use crate::io::dtu::{ObsMask, bb_filter};

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
