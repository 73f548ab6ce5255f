//! Tanks-and-Temples F-score (the `python_toolbox/evaluation` pipeline of
//! `isl-org/TanksAndTemples` at `3c2c212`, run with Open3D 0.10 semantics;
//! `eval_tsdf.md` §2.3) as one pure function, [`evaluate_tnt`], plus the
//! per-scene thresholds; [`plot`] draws the precision/recall curves.
//!
//! Units are those of the ground truth (metres for TnT). Trajectory poses are
//! camera-to-world 4×4 matrices ([`DMat4`]), as in the `.log` files read by
//! `io::tnt`. The returned transformation maps the reconstruction into the
//! ground-truth frame; in JSON, transforms are written row by row
//! (`[[m00, m01, m02, m03], …]`), the layout of the TnT files.

use glam::DMat4;
use serde::{Serialize, Serializer};

use crate::geom::alignment::crop::Crop;
use crate::geom::alignment::registration::{
    IcpParams, RansacParams, icp_point_to_point, ransac_on_correspondences, transform_points,
};
use crate::geom::sampling::knn::NnIndex;
use crate::geom::sampling::voxel::{uniform_down_sample, voxel_down_sample};
use crate::model::CropVolume;
use crate::{Error, Result};

pub mod plot;

pub use plot::{PrPlot, plot_pr_curves};

/// Per-scene thresholds τ in metres, from the toolbox's `config.py`.
pub const TNT_THRESHOLDS: [(&str, f64); 7] = [
    ("Barn", 0.01),
    ("Caterpillar", 0.005),
    ("Church", 0.025),
    ("Courthouse", 0.025),
    ("Ignatius", 0.003),
    ("Meetingroom", 0.01),
    ("Truck", 0.005),
];

/// τ (metres) of a TnT scene by name, ignoring ASCII case; `None` for scenes
/// not in [`TNT_THRESHOLDS`].
pub fn tnt_threshold(scene: &str) -> Option<f64> {
    TNT_THRESHOLDS
        .iter()
        .find(|(s, _)| s.eq_ignore_ascii_case(scene))
        .map(|&(_, t)| t)
}

/// Settings of the TnT pipeline. [`Default`] gives the toolbox's values with
/// RANSAC seed 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TntParams {
    /// Trajectory alignment: correspondence-based RANSAC on camera centres
    /// (toolbox: max distance 0.2, 6 samples, 100000 iterations, similarity).
    pub ransac: RansacParams,
    /// ICP stops after this many updates (toolbox: 30, Open3D's default).
    pub icp_max_iteration: usize,
    /// ICP stops when |Δfitness| is below this (toolbox: 1e-6) and
    /// |ΔRMSE| below `icp_relative_rmse`.
    pub icp_relative_fitness: f64,
    /// Toolbox: 20 — the second positional argument of
    /// `ICPConvergenceCriteria(1e-6, 20)`, meant as max_iteration, lands here.
    pub icp_relative_rmse: f64,
    /// The last refinement pass keeps every k-th point, k = round(n / this),
    /// when the cropped cloud has more points than this (toolbox: 4e6).
    pub max_point_number: usize,
    /// The curves span distances [0, plot_stretch·τ) (toolbox: 5).
    pub plot_stretch: f64,
}

impl Default for TntParams {
    fn default() -> Self {
        TntParams {
            ransac: RansacParams::default(),
            icp_max_iteration: 30,
            icp_relative_fitness: 1e-6,
            icp_relative_rmse: 20.0,
            max_point_number: 4_000_000,
            plot_stretch: 5.0,
        }
    }
}

/// One ICP refinement pass.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TntIcpPass {
    /// "voxel τ", "voxel τ/2" or "uniform".
    pub downsampling: String,
    /// Voxel size of the pass, or the uniform rate k (1 = all points).
    pub downsampling_value: f64,
    /// ICP max correspondence distance (80τ, 20τ, 2τ).
    pub max_correspondence_distance: f64,
    /// Source / target points after crop and downsampling.
    pub source_points: usize,
    /// See `source_points`.
    pub target_points: usize,
    /// ICP fitness (matched fraction of the source) after the last update.
    pub fitness: f64,
    /// ICP inlier RMSE after the last update.
    pub inlier_rmse: f64,
    /// Updates applied.
    pub iterations: usize,
    /// Reconstruction → ground truth after this pass.
    #[serde(serialize_with = "serialize_rows")]
    pub transformation: DMat4,
}

/// Serialises a transform as its 4 rows.
fn serialize_rows<S: Serializer>(m: &DMat4, s: S) -> std::result::Result<S::Ok, S::Error> {
    m.transpose().to_cols_array_2d().serialize(s)
}

/// Everything [`evaluate_tnt`] measures.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TntReport {
    /// Distance threshold τ.
    pub tau: f64,
    /// Fraction of evaluated reconstruction points closer than τ to the GT.
    pub precision: f64,
    /// Fraction of evaluated GT points closer than τ to the reconstruction.
    pub recall: f64,
    /// 2PR/(P+R); 0 when P = R = 0.
    pub fscore: f64,
    /// Final reconstruction → ground-truth transform (after the 3 ICP passes).
    #[serde(serialize_with = "serialize_rows")]
    pub transformation: DMat4,
    /// Transform from the trajectory alignment (RANSAC) alone.
    #[serde(serialize_with = "serialize_rows")]
    pub trajectory_transformation: DMat4,
    /// RANSAC fitness (fraction of cameras within the max distance).
    pub trajectory_fitness: f64,
    /// RANSAC inlier RMSE.
    pub trajectory_rmse: f64,
    /// The refinement passes, in order (r2, r3, r of the toolbox).
    pub refinement: Vec<TntIcpPass>,
    /// Reconstruction points evaluated (after transform, crop, voxel τ/2).
    pub source_points: usize,
    /// GT points evaluated (after crop, voxel τ/2).
    pub target_points: usize,
    /// Evaluated reconstruction points with distance < τ.
    pub source_within_tau: usize,
    /// Evaluated GT points with distance < τ.
    pub target_within_tau: usize,
    /// Histogram edges `arange(0, plot_stretch·τ, τ/100)` (numpy's length
    /// rule: ceil(stop/step) values, value i = i·step); `[0]` when either
    /// cloud is empty, as in the toolbox.
    pub bin_edges: Vec<f64>,
    /// Precision curve: entry i = fraction of reconstruction distances below
    /// `bin_edges[i+1]` (numpy `histogram` + `cumsum`: the last bin also
    /// counts distances equal to the last edge). `[0]` when a cloud is empty.
    pub cum_precision: Vec<f64>,
    /// Recall curve, same layout, for the GT distances.
    pub cum_recall: Vec<f64>,
    /// The evaluated reconstruction points, in the GT frame (for colouring).
    #[serde(skip)]
    pub source_eval_points: Vec<[f64; 3]>,
    /// Distance of each evaluated reconstruction point to the GT.
    #[serde(skip)]
    pub source_distances: Vec<f64>,
    /// The evaluated GT points.
    #[serde(skip)]
    pub target_eval_points: Vec<[f64; 3]>,
    /// Distance of each evaluated GT point to the reconstruction.
    #[serde(skip)]
    pub target_distances: Vec<f64>,
}

/// The point set of the 2DGS variant of the evaluation
/// (`scripts/eval_tnt/run.py`): all mesh vertices followed by the centroid
/// (mean of the 3 vertices) of each face, in face order. (2DGS loads the
/// mesh with trimesh, which first merges duplicate vertices; pass a mesh
/// already merged to match it.) The official toolbox uses the vertices only.
///
/// Errors: a face index out of range (named by face).
pub fn vertices_and_face_centroids(
    vertices: &[[f64; 3]],
    faces: &[[u32; 3]],
) -> Result<Vec<[f64; 3]>> {
    let mut out = Vec::with_capacity(vertices.len() + faces.len());
    out.extend_from_slice(vertices);
    for (i, f) in faces.iter().enumerate() {
        let v = |k: usize| {
            vertices.get(f[k] as usize).ok_or_else(|| {
                Error::invalid(format!(
                    "face {i} references vertex {} but there are only {} vertices",
                    f[k],
                    vertices.len()
                ))
            })
        };
        let (a, b, c) = (v(0)?, v(1)?, v(2)?);
        out.push([
            (a[0] + b[0] + c[0]) / 3.0,
            (a[1] + b[1] + c[1]) / 3.0,
            (a[2] + b[2] + c[2]) / 3.0,
        ]);
    }
    Ok(out)
}

/// The data of one Tanks-and-Temples evaluation: the reconstruction, the
/// two trajectories and the scene's ground truth. Units are those of each
/// file (the ground truth's: metres for TnT); poses are camera-to-world.
#[derive(Clone, Copy, Debug)]
pub struct TntInput<'a> {
    /// The reconstruction's points, in its own frame.
    pub rec_points: &'a [[f64; 3]],
    /// The reconstruction's camera-to-world poses.
    pub rec_traj: &'a [DMat4],
    /// The reference COLMAP poses, frame i corresponding to `rec_traj[i]`.
    pub gt_traj: &'a [DMat4],
    /// `_trans.txt`: reference COLMAP frame → GT frame.
    pub gt_trans: &'a DMat4,
    /// The scene's crop volume (GT frame).
    pub crop: &'a CropVolume,
    /// The ground-truth points (GT frame).
    pub gt_points: &'a [[f64; 3]],
}

/// Runs the Tanks-and-Temples evaluation of a reconstruction.
///
/// Inputs: `input` ([`TntInput`]: the reconstruction, both trajectories,
/// the GT transform, crop volume and points) and `tau` (τ, GT units).
///
/// Steps, as the toolbox's `run.py`:
/// 1. **Alignment**: RANSAC ([`ransac_on_correspondences`], Open3D 0.10
///    semantics, seeded) from the reconstruction's camera centres to the
///    reference centres mapped by `gt_trans`, correspondences i ↔ i.
/// 2. **Refinement**, three passes, each starting from the previous T: the
///    reconstruction transformed by T and the GT are cropped, downsampled —
///    voxel τ, then voxel τ/2, then uniform every k-th point with
///    k = round(n/`max_point_number`) (half to even, like Python's `round`)
///    only when n exceeds it — and registered by point-to-point ICP with
///    scaling at max distance 80τ, 20τ, 2τ; T ← T_icp·T.
/// 3. **Evaluation**: the reconstruction transformed by the final T, cropped
///    and voxel-downsampled at τ/2, against the cropped GT downsampled at
///    τ/2; exact nearest-neighbour distances both ways; precision =
///    #(d_s < τ)/|S|, recall = #(d_t < τ)/|T| (strict), F = 2PR/(P+R).
///
/// When either evaluated cloud is empty, P = R = F = 0 and the curves are
/// `[0]` (the toolbox's behaviour); when P = R = 0 otherwise, F = 0 (the
/// toolbox divides by zero). Randomness is only in RANSAC, through
/// `params.ransac.seed`.
///
/// Errors: τ not finite and > 0; trajectories of different lengths (a
/// full-video log is reduced by the caller with the scene's frame mapping,
/// [`crate::io::tnt::FrameMapping::sparse`]); fewer frames
/// than the RANSAC sample size; non-finite points.
pub fn evaluate_tnt(input: &TntInput, tau: f64, params: &TntParams) -> Result<TntReport> {
    let TntInput {
        rec_points,
        rec_traj,
        gt_traj,
        gt_trans,
        crop,
        gt_points,
    } = *input;
    if !(tau.is_finite() && tau > 0.0) {
        return Err(Error::invalid(format!(
            "threshold τ must be finite and > 0, got {tau}"
        )));
    }
    if !(params.plot_stretch.is_finite() && params.plot_stretch > 0.0) {
        return Err(Error::invalid(format!(
            "plot stretch must be finite and > 0, got {}",
            params.plot_stretch
        )));
    }
    if rec_traj.len() != gt_traj.len() {
        return Err(Error::invalid(format!(
            "the reconstruction trajectory has {} frames but the reference has {}; \
             frames must correspond one to one (a full-video log of more than 1600 frames is \
             reduced by <Scene>_mapping_reference.txt in the ground-truth folder)",
            rec_traj.len(),
            gt_traj.len()
        )));
    }
    for (what, pts) in [("reconstruction", rec_points), ("ground-truth", gt_points)] {
        if let Some(i) = pts.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
            return Err(Error::invalid(format!(
                "{what} point {i} has a non-finite coordinate: {:?}",
                pts[i]
            )));
        }
    }

    // 1. Trajectory alignment.
    // A camera-to-world pose's centre is its translation column.
    let centre = |m: &DMat4| m.w_axis.truncate();
    let src: Vec<[f64; 3]> = rec_traj.iter().map(|m| centre(m).to_array()).collect();
    let dst: Vec<[f64; 3]> = gt_traj
        .iter()
        .map(|m| gt_trans.project_point3(centre(m)).to_array())
        .collect();
    let ransac = ransac_on_correspondences(&src, &dst, &params.ransac)?;

    // 2. Refinement.
    let gt_crop = crop.crop(gt_points);
    let icp = |dist: f64| IcpParams {
        max_correspondence_distance: dist,
        with_scaling: true,
        relative_fitness: params.icp_relative_fitness,
        relative_rmse: params.icp_relative_rmse,
        max_iteration: params.icp_max_iteration,
    };
    let mut t = ransac.transformation;
    let mut passes = Vec::with_capacity(3);
    let gt_half = voxel_down_sample(&gt_crop, tau / 2.0)?;
    let gt_full = voxel_down_sample(&gt_crop, tau)?;
    for (name, voxel, dist, g) in [
        ("voxel τ", tau, 80.0 * tau, &gt_full),
        ("voxel τ/2", tau / 2.0, 20.0 * tau, &gt_half),
    ] {
        let s = voxel_down_sample(&crop.crop(&transform_points(&t, rec_points)), voxel)?;
        let r = icp_point_to_point(&s, g, &DMat4::IDENTITY, &icp(dist))?;
        t = r.registration.transformation * t;
        passes.push(TntIcpPass {
            downsampling: name.to_string(),
            downsampling_value: voxel,
            max_correspondence_distance: dist,
            source_points: s.len(),
            target_points: g.len(),
            fitness: r.registration.fitness,
            inlier_rmse: r.registration.inlier_rmse,
            iterations: r.iterations,
            transformation: t,
        });
    }
    drop(gt_full);
    {
        let uniform = |pts: Vec<[f64; 3]>| -> Result<(Vec<[f64; 3]>, usize)> {
            if pts.len() > params.max_point_number && params.max_point_number > 0 {
                let k =
                    (pts.len() as f64 / params.max_point_number as f64).round_ties_even() as usize;
                Ok((uniform_down_sample(&pts, k.max(1))?, k.max(1)))
            } else {
                Ok((pts, 1))
            }
        };
        let (s, ks) = uniform(crop.crop(&transform_points(&t, rec_points)))?;
        let (g, _) = uniform(gt_crop.clone())?;
        let dist = 2.0 * tau;
        let r = icp_point_to_point(&s, &g, &DMat4::IDENTITY, &icp(dist))?;
        t = r.registration.transformation * t;
        passes.push(TntIcpPass {
            downsampling: "uniform".to_string(),
            downsampling_value: ks as f64,
            max_correspondence_distance: dist,
            source_points: s.len(),
            target_points: g.len(),
            fitness: r.registration.fitness,
            inlier_rmse: r.registration.inlier_rmse,
            iterations: r.iterations,
            transformation: t,
        });
    }

    // 3. Evaluation.
    let s = voxel_down_sample(&crop.crop(&transform_points(&t, rec_points)), tau / 2.0)?;
    let g = gt_half;
    let d_s = NnIndex::new(&g)?.nearest_distances(&s);
    let d_t = NnIndex::new(&s)?.nearest_distances(&g);
    let mut report = TntReport {
        tau,
        precision: 0.0,
        recall: 0.0,
        fscore: 0.0,
        transformation: t,
        trajectory_transformation: ransac.transformation,
        trajectory_fitness: ransac.fitness,
        trajectory_rmse: ransac.inlier_rmse,
        refinement: passes,
        source_points: s.len(),
        target_points: g.len(),
        source_within_tau: d_s.iter().filter(|&&d| d < tau).count(),
        target_within_tau: d_t.iter().filter(|&&d| d < tau).count(),
        bin_edges: vec![0.0],
        cum_precision: vec![0.0],
        cum_recall: vec![0.0],
        source_eval_points: s,
        source_distances: d_s,
        target_eval_points: g,
        target_distances: d_t,
    };
    if !report.source_distances.is_empty() && !report.target_distances.is_empty() {
        report.precision = report.source_within_tau as f64 / report.source_distances.len() as f64;
        report.recall = report.target_within_tau as f64 / report.target_distances.len() as f64;
        let sum = report.precision + report.recall;
        report.fscore = if sum > 0.0 {
            2.0 * report.precision * report.recall / sum
        } else {
            0.0
        };
        report.bin_edges = histogram_edges(tau, params.plot_stretch);
        report.cum_precision = cumulative_histogram(&report.source_distances, &report.bin_edges);
        report.cum_recall = cumulative_histogram(&report.target_distances, &report.bin_edges);
    }
    Ok(report)
}

/// `np.arange(0, stretch·τ, τ/100)`: ceil(stop/step) values i·step.
fn histogram_edges(tau: f64, stretch: f64) -> Vec<f64> {
    let step = tau / 100.0;
    let n = ((tau * stretch) / step).ceil() as usize;
    (0..n).map(|i| i as f64 * step).collect()
}

/// `np.cumsum(np.histogram(d, edges)[0]) / len(d)`: entry i counts the
/// distances in [edges[0], edges[i+1]) — the last one in [edges[0],
/// edges[last]] — divided by the number of distances (all of them, including
/// those beyond the last edge).
fn cumulative_histogram(d: &[f64], edges: &[f64]) -> Vec<f64> {
    if edges.len() < 2 {
        return Vec::new();
    }
    let mut sorted = d.to_vec();
    sorted.sort_unstable_by(f64::total_cmp);
    let below = |x: f64| sorted.partition_point(|&v| v < x);
    let at_most = |x: f64| sorted.partition_point(|&v| v <= x);
    let start = below(edges[0]);
    let nb = edges.len() - 1;
    let num = d.len() as f64;
    (0..nb)
        .map(|i| {
            let upto = if i + 1 == nb {
                at_most(edges[i + 1])
            } else {
                below(edges[i + 1])
            };
            (upto - start) as f64 / num
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::alignment::registration::tests::axis_angle;
    use crate::model::Similarity;
    use crate::model::crop::Axis;
    use glam::{DMat3, DVec3};

    const TAU: f64 = 0.01;

    /// Lattice point (i, j, k)·τ: the scene lives on a grid of spacing τ, so
    /// every point sits at a voxel centre for the voxel sizes τ and τ/2 used
    /// by the pipeline (the grid origin is the cloud's minimum minus half a
    /// voxel), and each voxel holds at most one point: voxel averaging is the
    /// identity on these sets and the expected numbers can be counted.
    fn lattice(i: i64, j: i64, k: i64) -> [f64; 3] {
        [i as f64 * TAU, j as f64 * TAU, k as f64 * TAU]
    }

    /// Surface of the box [0, 0.6]×[0, 0.4]×[0, 0.3].
    fn box_surface() -> Vec<[f64; 3]> {
        let mut v = Vec::new();
        for i in 0..=60 {
            for j in 0..=40 {
                for k in 0..=30 {
                    if i == 0 || i == 60 || j == 0 || j == 40 || k == 0 || k == 30 {
                        v.push(lattice(i, j, k));
                    }
                }
            }
        }
        v
    }

    /// A size×size horizontal plate at height k·τ starting at (i0, j0).
    fn plate(i0: i64, j0: i64, k: i64, size: i64) -> Vec<[f64; 3]> {
        let mut v = Vec::new();
        for i in i0..i0 + size {
            for j in j0..j0 + size {
                v.push(lattice(i, j, k));
            }
        }
        v
    }

    /// Plates, all at least 0.2 m = 20τ from each other and from the box:
    /// A (10×10, will be displaced), B (will be missing from the
    /// reconstruction), C (only in the reconstruction, > 80τ from everything
    /// so even the first ICP pass ignores it), D (below the crop volume).
    ///
    /// A is kept small because the first two ICP passes (80τ, 20τ) do match
    /// the displaced points and are pulled by them: with 100 of 11 000
    /// points the box ends up about 0.14τ off after those passes (measured;
    /// a 400-point A gave 0.48τ), safely below the τ/2 at which the last pass
    /// would start matching box points to wrong lattice neighbours.
    fn plates() -> [Vec<[f64; 3]>; 4] {
        [
            plate(80, 0, 10, 10),
            plate(0, 60, 5, 20),
            plate(200, 0, 10, 20),
            plate(10, 10, -30, 20),
        ]
    }

    fn crop() -> CropVolume {
        CropVolume {
            orthogonal_axis: Axis::Z,
            axis_min: -0.1,
            axis_max: 0.5,
            bounding_polygon: vec![
                [-0.1, -0.1, 0.0],
                [2.3, -0.1, 0.0],
                [2.3, 0.9, 0.0],
                [-0.1, 0.9, 0.0],
            ],
        }
    }

    fn pose(r: &DMat3, c: DVec3) -> DMat4 {
        DMat4::from_cols(
            r.x_axis.extend(0.0),
            r.y_axis.extend(0.0),
            r.z_axis.extend(0.0),
            c.extend(1.0),
        )
    }

    fn inverse(s: &Similarity) -> Similarity {
        let rt = s.rotation.transpose();
        Similarity {
            rotation: rt,
            scale: 1.0 / s.scale,
            translation: -(rt * s.translation) / s.scale,
        }
    }

    /// Cameras (camera-to-world, GT frame) on a wavy ring around the scene,
    /// looking at its middle.
    fn gt_frame_cameras() -> Vec<(DMat3, DVec3)> {
        (0..40)
            .map(|i| {
                let th = i as f64 / 40.0 * std::f64::consts::TAU;
                let c = DVec3::new(
                    1.0 + 1.6 * th.cos(),
                    0.4 + 1.6 * th.sin(),
                    0.8 + 0.2 * (3.0 * th).sin(),
                );
                // Yaw towards the centre, then pitch down a little.
                let r = axis_angle([0.0, 0.0, 1.0], th + std::f64::consts::PI)
                    * axis_angle([0.0, 1.0, 0.0], 0.3);
                (r, c)
            })
            .collect()
    }

    struct Setup {
        gt_points: Vec<[f64; 3]>,
        gt_traj: Vec<DMat4>,
        gt_trans: DMat4,
        rec_traj: Vec<DMat4>,
        /// GT frame → reconstruction frame.
        s: Similarity,
    }

    impl Setup {
        /// The evaluation's input for reconstruction points `rec` with
        /// camera poses `rec_traj`, cropped by `crop`.
        fn input<'a>(
            &'a self,
            rec: &'a [[f64; 3]],
            rec_traj: &'a [DMat4],
            crop: &'a CropVolume,
        ) -> TntInput<'a> {
            TntInput {
                rec_points: rec,
                rec_traj,
                gt_traj: &self.gt_traj,
                gt_trans: &self.gt_trans,
                crop,
                gt_points: &self.gt_points,
            }
        }
    }

    fn setup() -> Setup {
        let [a, b, _c, d] = plates();
        let mut gt_points = box_surface();
        gt_points.extend(&a);
        gt_points.extend(&b);
        gt_points.extend(&d);
        // `_trans.txt`: reference COLMAP frame → GT frame.
        let g = Similarity {
            rotation: axis_angle([0.0, 0.0, 1.0], 0.3),
            scale: 0.8,
            translation: DVec3::new(0.5, -0.2, 1.0),
        };
        let g_inv = inverse(&g);
        let s = Similarity {
            rotation: axis_angle([1.0, 2.0, -1.0], 0.7),
            scale: 2.5,
            translation: DVec3::new(3.0, -1.0, 0.5),
        };
        let cams = gt_frame_cameras();
        let gt_traj = cams
            .iter()
            .map(|(r, c)| pose(&(g_inv.rotation * *r), g_inv.matrix().project_point3(*c)))
            .collect();
        let rec_traj = cams
            .iter()
            .map(|(r, c)| pose(&(s.rotation * *r), s.matrix().project_point3(*c)))
            .collect();
        Setup {
            gt_points,
            gt_traj,
            gt_trans: g.matrix(),
            rec_traj,
            s,
        }
    }

    fn max_abs_diff(a: &DMat4, b: &DMat4) -> f64 {
        (*a - *b)
            .abs()
            .to_cols_array()
            .into_iter()
            .fold(0.0, f64::max)
    }

    /// The reconstruction is an exact similarity of the GT (points and
    /// cameras): the pipeline recovers its inverse and scores F = 1.
    #[test]
    fn exact_copy_scores_one_and_recovers_the_transform() {
        let su = setup();
        let rec: Vec<[f64; 3]> = transform_points(&su.s.matrix(), &su.gt_points);
        let rep = evaluate_tnt(
            &su.input(&rec, &su.rec_traj, &crop()),
            TAU,
            &TntParams::default(),
        )
        .unwrap();
        let want = inverse(&su.s).matrix();
        // Noiseless inputs: rounding error only (coordinates of order 5,
        // ~1e-15 relative per operation); 1e-9 is far below anything the
        // evaluation at τ = 1e-2 could notice.
        assert!(max_abs_diff(&rep.transformation, &want) < 1e-9, "{rep:?}");
        assert!(max_abs_diff(&rep.trajectory_transformation, &want) < 1e-9);
        assert_eq!(rep.trajectory_fitness, 1.0);
        let n = box_surface().len() + 100 + 400; // box + A + B; D is cropped
        assert_eq!((rep.source_points, rep.target_points), (n, n));
        assert_eq!((rep.precision, rep.recall, rep.fscore), (1.0, 1.0, 1.0));
        assert_eq!(rep.bin_edges.len(), 500);
        assert!(rep.cum_precision.iter().all(|&c| c == 1.0));
        assert!(rep.cum_recall.iter().all(|&c| c == 1.0));
        assert_eq!(rep.refinement.len(), 3);
        for p in &rep.refinement {
            assert_eq!(p.fitness, 1.0, "{p:?}");
        }
    }

    /// Displace plate A by 3.337τ (off the histogram edges), drop plate B,
    /// add plate C: precision, recall and both curves take the values counted
    /// by hand, and the final ICP pass (2τ) still recovers the transform
    /// exactly because the displaced points fall outside its reach.
    #[test]
    fn perturbed_copy_gives_the_counted_precision_and_recall() {
        let su = setup();
        let [a, b, c, d] = plates();
        let dz = 3.337 * TAU;
        let mut rec_gt_frame = box_surface();
        rec_gt_frame.extend(a.iter().map(|p| [p[0], p[1], p[2] + dz]));
        rec_gt_frame.extend(&c);
        rec_gt_frame.extend(&d);
        let rec = transform_points(&su.s.matrix(), &rec_gt_frame);
        let rep = evaluate_tnt(
            &su.input(&rec, &su.rec_traj, &crop()),
            TAU,
            &TntParams::default(),
        )
        .unwrap();
        let want = inverse(&su.s).matrix();
        // As above: exact up to rounding once the last pass has run.
        assert!(max_abs_diff(&rep.transformation, &want) < 1e-9, "{rep:?}");
        let nbox = box_surface().len();
        let (na, nb, nc) = (a.len(), b.len(), c.len());
        let n_rec = nbox + na + nc; // box, moved A, C (D cropped)
        let n_gt = nbox + na + nb; // box, A, B (D cropped)
        assert_eq!((rep.source_points, rep.target_points), (n_rec, n_gt));
        assert_eq!(rep.source_within_tau, nbox);
        assert_eq!(rep.target_within_tau, nbox);
        // Same integer counts divided the same way: exact equality.
        let p = nbox as f64 / n_rec as f64;
        let r = nbox as f64 / n_gt as f64;
        assert_eq!(rep.precision, p);
        assert_eq!(rep.recall, r);
        assert!((rep.fscore - 2.0 * p * r / (p + r)).abs() < 1e-15);
        // Curves: A's distance 3.337τ lies in bin 333 ([3.33τ, 3.34τ)), so
        // entries up to 332 count the box only and later ones add A; B and C
        // are beyond 5τ.
        for (i, (&cp, &cr)) in rep.cum_precision.iter().zip(&rep.cum_recall).enumerate() {
            let (wp, wr) = if i < 333 {
                (nbox as f64 / n_rec as f64, nbox as f64 / n_gt as f64)
            } else {
                (
                    (nbox + na) as f64 / n_rec as f64,
                    (nbox + na) as f64 / n_gt as f64,
                )
            };
            assert_eq!((cp, cr), (wp, wr), "bin {i}");
        }
        // The displaced points are outside the last pass's 2τ reach.
        let last = &rep.refinement[2];
        assert_eq!(last.fitness, nbox as f64 / n_rec as f64);
    }

    #[test]
    fn empty_evaluation_and_errors() {
        let su = setup();
        let rec = transform_points(&su.s.matrix(), &su.gt_points);
        // A crop volume that holds nothing: the toolbox's all-zero result.
        let mut nothing = crop();
        nothing.axis_min = 10.0;
        nothing.axis_max = 11.0;
        let params = TntParams {
            ransac: RansacParams {
                max_iteration: 200,
                ..Default::default()
            },
            ..Default::default()
        };
        let rep = evaluate_tnt(&su.input(&rec, &su.rec_traj, &nothing), TAU, &params).unwrap();
        assert_eq!((rep.precision, rep.recall, rep.fscore), (0.0, 0.0, 0.0));
        assert_eq!(
            (rep.bin_edges.clone(), rep.cum_precision.clone()),
            (vec![0.0], vec![0.0])
        );
        let run = |tau: f64, rec_traj: &[DMat4]| {
            evaluate_tnt(&su.input(&rec, rec_traj, &crop()), tau, &params)
        };
        assert!(run(0.0, &su.rec_traj).is_err());
        assert!(run(f64::NAN, &su.rec_traj).is_err());
        let e = run(TAU, &su.rec_traj[..39]).unwrap_err().to_string();
        assert!(e.contains("39 frames"), "{e}");
    }

    #[test]
    fn histogram_follows_numpy() {
        // np.histogram([0, .5, 1, 2.5, 3, 7], [0, 1, 2, 3]) = [2, 1, 2]:
        // half-open bins except the last, which includes 3.
        let c = cumulative_histogram(&[0.0, 0.5, 1.0, 2.5, 3.0, 7.0], &[0.0, 1.0, 2.0, 3.0]);
        assert_eq!(c, vec![2.0 / 6.0, 3.0 / 6.0, 5.0 / 6.0]);
        // np.arange(0, 5τ, τ/100) has 500 values for every TnT τ (checked
        // with numpy 2.4, including τ = 0.003 where 5τ/(τ/100) rounds to
        // 499.99999999999994), value i being i·(τ/100).
        for (_, tau) in TNT_THRESHOLDS {
            let e = histogram_edges(tau, 5.0);
            assert_eq!(e.len(), 500, "τ = {tau}");
            assert_eq!(e[1], tau / 100.0);
            assert_eq!(e[499], 499.0 * (tau / 100.0));
        }
    }

    #[test]
    fn thresholds_and_centroids() {
        assert_eq!(tnt_threshold("Ignatius"), Some(0.003));
        assert_eq!(tnt_threshold("barn"), Some(0.01));
        assert_eq!(tnt_threshold("Family"), None);
        let v = [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 3.0, 6.0]];
        let pts = vertices_and_face_centroids(&v, &[[0, 1, 2]]).unwrap();
        assert_eq!(pts.len(), 4);
        assert_eq!(pts[3], [1.0, 1.0, 2.0]);
        let e = vertices_and_face_centroids(&v, &[[0, 1, 2], [0, 1, 3]])
            .unwrap_err()
            .to_string();
        assert!(e.contains("face 1") && e.contains("vertex 3"), "{e}");
    }
}
