//! Point-set registration in f64: closed-form similarity from
//! correspondences (Umeyama, solved with Horn's quaternion method), RANSAC
//! over given correspondences, and point-to-point ICP with optional scaling —
//! each reproducing the Open3D 0.10 behaviour the Tanks-and-Temples toolbox
//! relies on (see `eval_tsdf.md` §2.3).
//!
//! Conventions: transforms are glam [`DMat4`]s acting on column vectors,
//! `p' = M·[p, 1]`; a [`Similarity`] is `p' = s·R·p + t`, its matrix
//! `[[s·R, t], [0, 0, 0, 1]]`. Composition `a * b` applies `b` first. Point
//! sets are slices of `[f64; 3]`, as the callers store their clouds.

use glam::{DMat3, DMat4, DVec3};
use rand::RngExt;
use rayon::prelude::*;

use crate::geom::sampling::knn::NnIndex;
use crate::model::Similarity;
use crate::model::rng;
use crate::{Error, Result};

/// `m` applied to every point as Open3D's `PointCloud::Transform` does:
/// `M·[p, 1]` divided by its homogeneous coordinate
/// ([`DMat4::project_point3`]; the division is exact for affine matrices,
/// whose last row is `[0, 0, 0, 1]`). In order, in parallel.
pub fn transform_points(m: &DMat4, points: &[[f64; 3]]) -> Vec<[f64; 3]> {
    points
        .par_iter()
        .with_min_len(8192)
        .map(|p| m.project_point3(DVec3::from_array(*p)).to_array())
        .collect()
}

/// Least-squares similarity (or rigid transform when `with_scaling` is false)
/// mapping `src[i]` onto `dst[i]`: minimises `Σ‖s·R·src_i + t − dst_i‖²` over
/// proper rotations R, scales s > 0 (or s = 1) and translations t.
///
/// This is the Umeyama (1991) estimate that Open3D's
/// `TransformationEstimationPointToPoint(with_scaling)` computes with
/// `Eigen::umeyama`: rotation restricted to det = +1 (reflection-safe), scale
/// `s = Σ dst'·(R·src') / Σ‖src'‖²` on centred points. The rotation is found
/// with Horn's method — the unit quaternion maximising `Σ dst'·R·src'` is the
/// top eigenvector of a symmetric 4×4 matrix, computed here by cyclic Jacobi —
/// which gives the same optimum as Umeyama's SVD. Where the optimum is not
/// unique (collinear or coincident sources) either method returns one of the
/// optimal rotations, and they may differ.
///
/// Returns `None` when the slices are empty or differ in length, when with
/// scaling all sources coincide (Eigen would return NaNs), or when a
/// coordinate is not finite.
pub fn umeyama(src: &[[f64; 3]], dst: &[[f64; 3]], with_scaling: bool) -> Option<Similarity> {
    if src.is_empty() || src.len() != dst.len() {
        return None;
    }
    let inv_n = 1.0 / src.len() as f64;
    let mean = |pts: &[[f64; 3]]| {
        pts.iter()
            .fold(DVec3::ZERO, |m, p| m + DVec3::from_array(*p))
            * inv_n
    };
    let (ms, md) = (mean(src), mean(dst));
    // Cross-covariance S = Σ src'·dst'ᵀ (S[a][b] = Σ src'_a · dst'_b, so
    // column b gains src'·dst'_b) and the source spread.
    let mut s = DMat3::ZERO;
    let mut src_ss = 0.0;
    for (p, q) in src.iter().zip(dst) {
        let a = DVec3::from_array(*p) - ms;
        let b = DVec3::from_array(*q) - md;
        s += DMat3::from_cols(a * b.x, a * b.y, a * b.z);
        src_ss += a.dot(a);
    }
    if !src_ss.is_finite() || !s.is_finite() {
        return None;
    }
    let [[sxx, sxy, sxz], [syx, syy, syz], [szx, szy, szz]] = s.transpose().to_cols_array_2d();
    // Horn (1987), eq. for N with the quaternion ordered (w, x, y, z).
    let n = [
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ];
    let q = top_eigenvector4(n);
    let rotation = quat_to_matrix(q);
    let scale = if with_scaling {
        if src_ss <= 0.0 {
            return None;
        }
        // Σ dst'·(R src') = Σ_ab R[b][a] S[a][b] = trace(R·S), accumulated
        // in this order (a `trace()` of the glam product would round
        // differently).
        let mut num = 0.0;
        for a in 0..3 {
            for b in 0..3 {
                num += rotation.col(a)[b] * s.col(b)[a];
            }
        }
        num / src_ss
    } else {
        1.0
    };
    let translation = md - (rotation * ms) * scale;
    if !scale.is_finite() || !translation.is_finite() {
        return None;
    }
    Some(Similarity {
        rotation,
        scale,
        translation,
    })
}

/// Rotation matrix of the quaternion (w, x, y, z), normalised first.
///
/// Written out rather than as glam's `DMat3::from_quat` of a normalised
/// `DQuat`: glam normalises by multiplying with 1/‖q‖ and builds the diagonal
/// as 1 − 2(y² + z²), both of which round differently from this form, and
/// every RANSAC / ICP result (hence the TnT numbers) follows these roundings.
fn quat_to_matrix(q: [f64; 4]) -> DMat3 {
    let norm = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let [w, x, y, z] = q.map(|c| c / norm);
    let rows = [
        [
            w * w + x * x - y * y - z * z,
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            w * w - x * x + y * y - z * z,
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            w * w - x * x - y * y + z * z,
        ],
    ];
    DMat3::from_cols_array_2d(&rows).transpose()
}

/// Unit eigenvector of the largest eigenvalue of a symmetric 4×4 matrix, by
/// cyclic Jacobi rotations (converges quadratically; 4×4 needs a handful of
/// sweeps). A zero matrix gives (1, 0, 0, 0).
///
/// Kept on row-major arrays: glam has no symmetric eigen-solver, and the
/// rotations below work on rows and columns in place, in an order that fixes
/// the rounding of every RANSAC / ICP result.
fn top_eigenvector4(mut a: [[f64; 4]; 4]) -> [f64; 4] {
    let mut v = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    for _sweep in 0..64 {
        let off: f64 = (0..4)
            .flat_map(|p| (p + 1..4).map(move |q| (p, q)))
            .map(|(p, q)| a[p][q] * a[p][q])
            .sum();
        let diag: f64 = (0..4).map(|k| a[k][k] * a[k][k]).sum();
        // Off-diagonal mass below rounding level of the diagonal: converged.
        if off == 0.0 || off <= 1e-34 * diag {
            break;
        }
        for p in 0..3 {
            for q in p + 1..4 {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = if theta >= 0.0 {
                    1.0 / (theta + theta.hypot(1.0))
                } else {
                    -1.0 / (-theta + theta.hypot(1.0))
                };
                let c = 1.0 / t.hypot(1.0);
                let s = t * c;
                // A ← Aᵀ-rotation on columns p, q, then on rows p, q.
                for row in a.iter_mut() {
                    let (kp, kq) = (row[p], row[q]);
                    row[p] = c * kp - s * kq;
                    row[q] = s * kp + c * kq;
                }
                let (rp, rq) = (a[p], a[q]);
                for k in 0..4 {
                    a[p][k] = c * rp[k] - s * rq[k];
                    a[q][k] = s * rp[k] + c * rq[k];
                }
                for row in v.iter_mut() {
                    let (kp, kq) = (row[p], row[q]);
                    row[p] = c * kp - s * kq;
                    row[q] = s * kp + c * kq;
                }
            }
        }
    }
    let best = (0..4)
        .max_by(|&i, &j| a[i][i].total_cmp(&a[j][j]))
        .unwrap_or(0);
    [v[0][best], v[1][best], v[2][best], v[3][best]]
}

/// Outcome of a registration: the transform (source → target) and how well
/// it fits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegistrationResult {
    /// Source-to-target transform.
    pub transformation: DMat4,
    /// Fraction of the correspondences (RANSAC) or source points (ICP) that
    /// are inliers.
    pub fitness: f64,
    /// RMS distance of the inliers (0 when there are none).
    pub inlier_rmse: f64,
}

/// Parameters of [`ransac_on_correspondences`]. [`Default`] gives the TnT
/// toolbox's trajectory-alignment settings with seed 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RansacParams {
    /// A correspondence is an inlier when `‖T·src − dst‖ <` this (TnT: 0.2).
    pub max_correspondence_distance: f64,
    /// Correspondences drawn per hypothesis, with replacement (TnT: 6; ≥ 3).
    pub ransac_n: usize,
    /// Hypotheses evaluated, all of them (TnT: 100000).
    pub max_iteration: usize,
    /// Estimate a similarity (true, TnT) or a rigid transform.
    pub with_scaling: bool,
    /// Seed of the sampling; equal seeds give equal results whatever the
    /// thread count.
    pub seed: u64,
}

impl Default for RansacParams {
    fn default() -> Self {
        RansacParams {
            max_correspondence_distance: 0.2,
            ransac_n: 6,
            max_iteration: 100_000,
            with_scaling: true,
            seed: 0,
        }
    }
}

/// Iterations per RNG stream. Fixed (not derived from the thread count) so
/// results depend only on the seed.
const RANSAC_CHUNK: usize = 512;

/// One scored hypothesis; ordered by inlier count (more is better), then
/// RMSE (lower is better), then iteration (earlier is better).
#[derive(Clone, Copy)]
struct Hypothesis {
    inliers: usize,
    rmse: f64,
    iteration: usize,
    transformation: DMat4,
}

fn better(a: Hypothesis, b: Hypothesis) -> Hypothesis {
    let a_wins = a.inliers > b.inliers
        || (a.inliers == b.inliers
            && (a.rmse < b.rmse || (a.rmse == b.rmse && a.iteration < b.iteration)));
    if a_wins { a } else { b }
}

/// RANSAC over given correspondences `src[i] ↔ dst[i]`, reproducing Open3D
/// 0.10's `registration_ransac_based_on_correspondence` as the TnT toolbox
/// calls it:
///
/// - every one of `max_iteration` iterations runs (no early exit);
/// - each draws `ransac_n` correspondences uniformly **with replacement** and
///   fits [`umeyama`] to them;
/// - the hypothesis is scored on all correspondences: inliers are those with
///   `‖T·src_i − dst_i‖² < max_dist²`; fitness = inliers / n, RMSE =
///   sqrt(mean inlier squared distance);
/// - the best fitness wins, ties broken by lower RMSE (and then, here, by the
///   earlier iteration, which is what Open3D's strict "better replaces" loop
///   keeps); hypotheses with no inlier never win, so when none has an
///   inlier the result is the identity with fitness 0 and RMSE 0;
/// - no final refit on the inliers.
///
/// The only intended difference: Open3D seeds `std::mt19937` from
/// `std::random_device` (results vary run to run) and draws `rng() % n`; this
/// function draws from the crate's generator, one stream per block of 512
/// iterations ([`rng::stream`]`(seed, block)`), so the result is reproducible and
/// independent of the rayon thread count. Degenerate samples (all drawn
/// sources equal) score no inliers, as Eigen's NaN transform does in Open3D.
///
/// Errors: slices of different lengths, fewer correspondences than
/// `ransac_n`, `ransac_n < 3`, or a distance that is not finite and > 0.
pub fn ransac_on_correspondences(
    src: &[[f64; 3]],
    dst: &[[f64; 3]],
    params: &RansacParams,
) -> Result<RegistrationResult> {
    let n = src.len();
    if dst.len() != n {
        return Err(Error::invalid(format!(
            "RANSAC needs as many targets as sources: {} vs {}",
            n,
            dst.len()
        )));
    }
    if params.ransac_n < 3 {
        return Err(Error::invalid(format!(
            "RANSAC sample size must be at least 3, got {}",
            params.ransac_n
        )));
    }
    if n < params.ransac_n {
        return Err(Error::invalid(format!(
            "RANSAC needs at least {} correspondences, got {n}",
            params.ransac_n
        )));
    }
    let max_d = params.max_correspondence_distance;
    if !(max_d.is_finite() && max_d > 0.0) {
        return Err(Error::invalid(format!(
            "RANSAC max correspondence distance must be finite and > 0, got {max_d}"
        )));
    }
    let max_d2 = max_d * max_d;
    let chunks = params.max_iteration.div_ceil(RANSAC_CHUNK);
    let best = (0..chunks)
        .into_par_iter()
        .filter_map(|chunk| {
            let mut rng = rng::stream(params.seed, chunk as u64);
            let first = chunk * RANSAC_CHUNK;
            let last = (first + RANSAC_CHUNK).min(params.max_iteration);
            let mut s = vec![[0.0; 3]; params.ransac_n];
            let mut d = vec![[0.0; 3]; params.ransac_n];
            let mut best: Option<Hypothesis> = None;
            for iteration in first..last {
                for (sk, dk) in s.iter_mut().zip(d.iter_mut()) {
                    let i = rng.random_range(0..n);
                    *sk = src[i];
                    *dk = dst[i];
                }
                let Some(sim) = umeyama(&s, &d, params.with_scaling) else {
                    continue;
                };
                let t = sim.matrix();
                let (mut inliers, mut err2) = (0usize, 0.0f64);
                for (p, q) in src.iter().zip(dst) {
                    let e = t
                        .project_point3(DVec3::from_array(*p))
                        .distance_squared(DVec3::from_array(*q));
                    if e < max_d2 {
                        inliers += 1;
                        err2 += e;
                    }
                }
                if inliers == 0 {
                    continue;
                }
                let h = Hypothesis {
                    inliers,
                    rmse: (err2 / inliers as f64).sqrt(),
                    iteration,
                    transformation: t,
                };
                best = Some(match best {
                    None => h,
                    Some(b) => better(h, b),
                });
            }
            best
        })
        .reduce_with(better);
    Ok(match best {
        None => RegistrationResult {
            transformation: DMat4::IDENTITY,
            fitness: 0.0,
            inlier_rmse: 0.0,
        },
        Some(h) => RegistrationResult {
            transformation: h.transformation,
            fitness: h.inliers as f64 / n as f64,
            inlier_rmse: h.rmse,
        },
    })
}

/// Parameters of [`icp_point_to_point`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IcpParams {
    /// Source points farther than this from their nearest target point get
    /// no correspondence.
    pub max_correspondence_distance: f64,
    /// Estimate a similarity (true) or a rigid transform at each step.
    pub with_scaling: bool,
    /// Stop when |Δfitness| < this **and** |ΔRMSE| < `relative_rmse`.
    pub relative_fitness: f64,
    /// See `relative_fitness`.
    pub relative_rmse: f64,
    /// At most this many updates.
    pub max_iteration: usize,
}

impl IcpParams {
    /// The settings the TnT toolbox ends up with: scaling on, and
    /// `ICPConvergenceCriteria(1e-6, 20)` read positionally by pybind as
    /// relative_fitness = 1e-6, **relative_rmse = 20**, max_iteration = 30
    /// (the default) — so in effect: stop when |Δfitness| < 1e-6 or after 30
    /// updates.
    pub fn tnt(max_correspondence_distance: f64) -> Self {
        IcpParams {
            max_correspondence_distance,
            with_scaling: true,
            relative_fitness: 1e-6,
            relative_rmse: 20.0,
            max_iteration: 30,
        }
    }
}

/// Result of [`icp_point_to_point`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IcpResult {
    /// Final transform (the composed updates times `init`), fitness (matched
    /// source points / all source points) and inlier RMSE, evaluated after the
    /// last update.
    pub registration: RegistrationResult,
    /// Number of updates applied.
    pub iterations: usize,
}

/// Point-to-point ICP, reproducing Open3D 0.10's `registration_icp` with
/// `TransformationEstimationPointToPoint(with_scaling)`:
///
/// 1. transform a copy of `source` by `init`; match each point to its nearest
///    target point when closer than `max_correspondence_distance` (Open3D's
///    hybrid search with one neighbour; the boundary is excluded); fitness =
///    matches / |source|, RMSE = sqrt(mean matched squared distance), both 0
///    without matches;
/// 2. up to `max_iteration` times: fit [`umeyama`] to the matches, apply it to
///    the working copy, compose `T ← update·T`, re-match; stop when
///    |Δfitness| < `relative_fitness` and |ΔRMSE| < `relative_rmse`.
///
/// Where Eigen would return a NaN update (a degenerate match set, e.g. a
/// single match with scaling) or Open3D the identity (no match), the update
/// here is the identity, which then stops the loop.
///
/// Errors: a non-finite point in either cloud, or a distance that is not
/// finite and > 0.
pub fn icp_point_to_point(
    source: &[[f64; 3]],
    target: &[[f64; 3]],
    init: &DMat4,
    params: &IcpParams,
) -> Result<IcpResult> {
    let max_d = params.max_correspondence_distance;
    if !(max_d.is_finite() && max_d > 0.0) {
        return Err(Error::invalid(format!(
            "ICP max correspondence distance must be finite and > 0, got {max_d}"
        )));
    }
    if let Some(i) = source.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        return Err(Error::invalid(format!(
            "ICP source point {i} has a non-finite coordinate: {:?}",
            source[i]
        )));
    }
    let index = NnIndex::new(target)?;
    let mut pcd = if *init == DMat4::IDENTITY {
        source.to_vec()
    } else {
        transform_points(init, source)
    };
    let mut transformation = *init;
    let mut matches = Vec::new();
    let mut current = correspond(&index, target, &pcd, max_d, &mut matches);
    let mut iterations = 0;
    for _ in 0..params.max_iteration {
        let (s, d): (Vec<[f64; 3]>, Vec<[f64; 3]>) =
            matches.iter().map(|&(i, j)| (pcd[i], target[j])).unzip();
        let update = umeyama(&s, &d, params.with_scaling)
            .map(|sim| sim.matrix())
            .unwrap_or(DMat4::IDENTITY);
        transformation = update * transformation;
        pcd = transform_points(&update, &pcd);
        iterations += 1;
        let previous = current;
        current = correspond(&index, target, &pcd, max_d, &mut matches);
        if (previous.0 - current.0).abs() < params.relative_fitness
            && (previous.1 - current.1).abs() < params.relative_rmse
        {
            break;
        }
    }
    Ok(IcpResult {
        registration: RegistrationResult {
            transformation,
            fitness: current.0,
            inlier_rmse: current.1,
        },
        iterations,
    })
}

/// Matches each point of `pcd` to its nearest target point within `max_d`
/// (strictly), filling `matches` with (source index, target index) in source
/// order; returns (fitness, inlier RMSE).
fn correspond(
    index: &NnIndex,
    target: &[[f64; 3]],
    pcd: &[[f64; 3]],
    max_d: f64,
    matches: &mut Vec<(usize, usize)>,
) -> (f64, f64) {
    matches.clear();
    let max_d2 = max_d * max_d;
    let mut err2 = 0.0;
    for (i, nn) in index.nearest_all(pcd).into_iter().enumerate() {
        let Some((j, _)) = nn else { continue };
        let e = DVec3::from_array(pcd[i]).distance_squared(DVec3::from_array(target[j]));
        if e < max_d2 {
            matches.push((i, j));
            err2 += e;
        }
    }
    if matches.is_empty() {
        (0.0, 0.0)
    } else {
        (
            matches.len() as f64 / pcd.len() as f64,
            (err2 / matches.len() as f64).sqrt(),
        )
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Rotation from an axis (normalised here) and an angle, by Rodrigues'
    /// formula (rows as written): an independent way to build ground-truth
    /// rotations.
    pub(crate) fn axis_angle(axis: [f64; 3], angle: f64) -> DMat3 {
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        let [x, y, z] = axis.map(|c| c / n);
        let (s, c) = angle.sin_cos();
        let t = 1.0 - c;
        DMat3::from_cols_array_2d(&[
            [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
            [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
            [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
        ])
        .transpose()
    }

    /// `m` applied to one point, as [`transform_points`] does.
    fn transform_point(m: &DMat4, p: &[f64; 3]) -> [f64; 3] {
        m.project_point3(DVec3::from_array(*p)).to_array()
    }

    fn known_similarity() -> Similarity {
        Similarity {
            rotation: axis_angle([0.3, -1.0, 0.5], 2.1),
            scale: 1.7,
            translation: DVec3::new(0.4, -2.0, 3.5),
        }
    }

    fn random_points(n: usize, seed: u64, half: f64) -> Vec<[f64; 3]> {
        let mut rng = rng::seeded(seed);
        (0..n)
            .map(|_| {
                [
                    rng.random_range(-half..half),
                    rng.random_range(-half..half),
                    rng.random_range(-half..half),
                ]
            })
            .collect()
    }

    fn max_abs_diff(a: &DMat4, b: &DMat4) -> f64 {
        (*a - *b)
            .abs()
            .to_cols_array()
            .into_iter()
            .fold(0.0, f64::max)
    }

    fn det3(r: &DMat3) -> f64 {
        r.determinant()
    }

    #[test]
    fn umeyama_recovers_known_similarity() {
        let truth = known_similarity();
        let m = truth.matrix();
        for n in [3usize, 6, 200] {
            let src = random_points(n, n as u64, 2.0);
            let dst: Vec<[f64; 3]> = src.iter().map(|p| transform_point(&m, p)).collect();
            let est = umeyama(&src, &dst, true).unwrap();
            // Noiseless data: only rounding error (~1e-15 relative) remains;
            // 1e-9 leaves room for the conditioning of 3-point fits.
            assert!(max_abs_diff(&est.matrix(), &m) < 1e-9, "n={n}: {est:?}");
            assert!((est.scale - 1.7).abs() < 1e-9);
            // Without scaling, a rigid truth is recovered the same way.
            let rigid = Similarity {
                scale: 1.0,
                ..truth
            }
            .matrix();
            let dst: Vec<[f64; 3]> = src.iter().map(|p| transform_point(&rigid, p)).collect();
            let est = umeyama(&src, &dst, false).unwrap();
            assert!(max_abs_diff(&est.matrix(), &rigid) < 1e-9, "n={n}");
            assert_eq!(est.scale, 1.0);
        }
    }

    /// Every rotation angle including the 180° case, where the quaternion's w
    /// is 0 and a naive method breaks.
    #[test]
    fn umeyama_handles_half_turns_and_identity() {
        let src = random_points(20, 5, 1.0);
        for angle in [0.0, 1e-8, 0.5, std::f64::consts::PI] {
            let m = Similarity {
                rotation: axis_angle([1.0, 2.0, 3.0], angle),
                scale: 0.3,
                translation: DVec3::new(1.0, 0.0, -1.0),
            }
            .matrix();
            let dst: Vec<[f64; 3]> = src.iter().map(|p| transform_point(&m, p)).collect();
            let est = umeyama(&src, &dst, true).unwrap();
            assert!(max_abs_diff(&est.matrix(), &m) < 1e-9, "angle {angle}");
        }
    }

    /// A mirrored target: the result is still a proper rotation, and it is
    /// optimal — no nearby rotation (with its own optimal scale and
    /// translation) fits better.
    #[test]
    fn umeyama_is_reflection_safe() {
        let src = random_points(50, 9, 1.0);
        let dst: Vec<[f64; 3]> = src.iter().map(|p| [-p[0], p[1] * 0.5, p[2]]).collect();
        let est = umeyama(&src, &dst, true).unwrap();
        assert!((det3(&est.rotation) - 1.0).abs() < 1e-12);
        let cost = |m: &DMat4| -> f64 {
            src.iter()
                .zip(&dst)
                .map(|(p, q)| {
                    DVec3::from_array(transform_point(m, p)).distance_squared(DVec3::from_array(*q))
                })
                .sum()
        };
        let best = cost(&est.matrix());
        for axis in [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, -1.0],
        ] {
            for angle in [1e-3, -1e-3] {
                let r = axis_angle(axis, angle) * est.rotation;
                // Re-fit scale and translation for the perturbed rotation
                // (scale = Σ dst'·R src' / Σ|src'|²).
                let n = src.len() as f64;
                let mean = |pts: &[[f64; 3]]| {
                    pts.iter()
                        .fold(DVec3::ZERO, |a, p| a + DVec3::from_array(*p) / n)
                };
                let (ms, md) = (mean(&src), mean(&dst));
                let (mut num, mut den) = (0.0, 0.0);
                for (p, q) in src.iter().zip(&dst) {
                    let a = DVec3::from_array(*p) - ms;
                    let b = DVec3::from_array(*q) - md;
                    num += (r * a).dot(b);
                    den += a.length_squared();
                }
                let s = num / den;
                let sim = Similarity {
                    rotation: r,
                    scale: s,
                    translation: md - s * (r * ms),
                };
                assert!(
                    cost(&sim.matrix()) >= best - 1e-12,
                    "axis {axis:?} angle {angle}"
                );
            }
        }
    }

    #[test]
    fn umeyama_degenerate_inputs() {
        assert!(umeyama(&[], &[], true).is_none());
        assert!(umeyama(&[[0.0; 3]], &[[0.0; 3], [1.0; 3]], true).is_none());
        // All sources equal: no scale (None), but a rigid fit is a translation.
        let src = [[1.0, 2.0, 3.0]; 4];
        let dst = [[0.0, 0.0, 1.0]; 4];
        assert!(umeyama(&src, &dst, true).is_none());
        let rigid = umeyama(&src, &dst, false).unwrap();
        assert_eq!(transform_point(&rigid.matrix(), &src[0]), dst[0]);
        assert!(umeyama(&[[f64::NAN, 0.0, 0.0]; 3], &[[0.0; 3]; 3], true).is_none());
    }

    /// 30 % of the correspondences are gross outliers; RANSAC with the TnT
    /// settings (fewer iterations) still recovers the exact similarity, because
    /// an all-inlier sample fits the inliers exactly (RMSE ≈ 0) and so wins.
    fn outlier_problem() -> (Vec<[f64; 3]>, Vec<[f64; 3]>, DMat4) {
        let truth = known_similarity().matrix();
        let src = random_points(100, 21, 3.0);
        let mut dst: Vec<[f64; 3]> = src.iter().map(|p| transform_point(&truth, p)).collect();
        let junk = random_points(30, 22, 10.0);
        for (k, j) in junk.into_iter().enumerate() {
            // Every third-ish correspondence (30 of 100) is replaced.
            let i = (k * 10) / 3;
            dst[i] = [
                dst[i][0] + 1.0 + j[0].abs(),
                dst[i][1] + j[1],
                dst[i][2] + j[2],
            ];
        }
        (src, dst, truth)
    }

    #[test]
    fn ransac_recovers_similarity_with_outliers() {
        let (src, dst, truth) = outlier_problem();
        let params = RansacParams {
            max_iteration: 3000,
            seed: 7,
            ..Default::default()
        };
        let r = ransac_on_correspondences(&src, &dst, &params).unwrap();
        assert!((r.fitness - 0.7).abs() < 1e-12, "fitness {}", r.fitness);
        // Exact fit of inliers: rounding error only (coordinates ~10).
        assert!(max_abs_diff(&r.transformation, &truth) < 1e-9);
        assert!(r.inlier_rmse < 1e-9);
    }

    #[test]
    fn ransac_is_deterministic_across_thread_counts() {
        let (src, mut dst, _) = outlier_problem();
        // Add noise so that many hypotheses differ and ties are meaningful.
        let noise = random_points(dst.len(), 99, 0.05);
        for (d, e) in dst.iter_mut().zip(noise) {
            for k in 0..3 {
                d[k] += e[k];
            }
        }
        let params = RansacParams {
            max_iteration: 5000,
            seed: 12345,
            ..Default::default()
        };
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| ransac_on_correspondences(&src, &dst, &params).unwrap())
        };
        let a = run(1);
        let b = run(2);
        let c = run(3);
        assert_eq!(a, b);
        assert_eq!(a, c);
        // A different seed explores different samples (same best fitness
        // class, but a different best hypothesis among noisy fits).
        let other =
            ransac_on_correspondences(&src, &dst, &RansacParams { seed: 1, ..params }).unwrap();
        assert_ne!(a.transformation, other.transformation);
    }

    #[test]
    fn ransac_errors_and_no_inlier_case() {
        let p = RansacParams::default();
        let s = random_points(10, 1, 1.0);
        assert!(ransac_on_correspondences(&s, &s[..9], &p).is_err());
        assert!(ransac_on_correspondences(&s[..5], &s[..5], &p).is_err());
        assert!(ransac_on_correspondences(&s, &s, &RansacParams { ransac_n: 2, ..p }).is_err());
        assert!(
            ransac_on_correspondences(
                &s,
                &s,
                &RansacParams {
                    max_correspondence_distance: 0.0,
                    ..p
                }
            )
            .is_err()
        );
        // All sources coincide: every sample is degenerate, nothing scores,
        // and the result is Open3D's initial one.
        let same = vec![[1.0, 1.0, 1.0]; 10];
        let r = ransac_on_correspondences(
            &same,
            &s,
            &RansacParams {
                max_iteration: 50,
                ..p
            },
        )
        .unwrap();
        assert_eq!(r.transformation, DMat4::IDENTITY);
        assert_eq!((r.fitness, r.inlier_rmse), (0.0, 0.0));
    }

    /// A surface-like cloud: a bumpy triaxial ellipsoid sampled on a
    /// Fibonacci lattice (about 0.03 apart), closed and without symmetry, so
    /// all six degrees of freedom and the scale are constrained.
    fn surface_cloud() -> Vec<[f64; 3]> {
        let n = 6000;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let phi = golden * i as f64;
                let (x, y) = (r * phi.cos(), r * phi.sin());
                let bump = 1.0 + 0.15 * (3.0 * x).sin() * (2.0 * y + 0.5).cos();
                [bump * x, 0.7 * bump * y, 0.5 * bump * z]
            })
            .collect()
    }

    #[test]
    fn icp_with_scaling_converges_to_small_similarity() {
        let target = surface_cloud();
        // Source = inverse of a small similarity applied to the target, so
        // ICP from the identity must find `truth`.
        let truth = Similarity {
            rotation: axis_angle([0.2, 1.0, -0.4], 0.04),
            scale: 1.03,
            translation: DVec3::new(0.02, -0.015, 0.01),
        };
        let tm = truth.matrix();
        let inv = invert_similarity(&truth);
        let source: Vec<[f64; 3]> = target.iter().map(|p| transform_point(&inv, p)).collect();
        let r = icp_point_to_point(
            &source,
            &target,
            &DMat4::IDENTITY,
            &IcpParams {
                max_iteration: 200,
                relative_fitness: 0.0,
                relative_rmse: 1e-12,
                ..IcpParams::tnt(0.2)
            },
        )
        .unwrap();
        // Correspondences become exact once within half the grid spacing,
        // after which the fit is exact up to rounding.
        assert!(
            max_abs_diff(&r.registration.transformation, &tm) < 1e-9,
            "{:?} after {} iterations",
            r.registration,
            r.iterations
        );
        assert_eq!(r.registration.fitness, 1.0);
        assert!(r.registration.inlier_rmse < 1e-9);
    }

    /// With the TnT criteria the loop stops on the first update that leaves
    /// the fitness unchanged; starting at the answer, that is one update.
    #[test]
    fn icp_tnt_criteria_stop_on_fitness() {
        let target = surface_cloud();
        let r =
            icp_point_to_point(&target, &target, &DMat4::IDENTITY, &IcpParams::tnt(0.05)).unwrap();
        assert_eq!(r.iterations, 1);
        assert!(max_abs_diff(&r.registration.transformation, &DMat4::IDENTITY) < 1e-12);
        // init is composed: a pre-transformed source comes back to it.
        let shift = Similarity {
            rotation: axis_angle([0.0, 0.0, 1.0], 0.0),
            scale: 1.0,
            translation: DVec3::new(0.001, 0.0, 0.0),
        };
        let src: Vec<[f64; 3]> = target
            .iter()
            .map(|p| transform_point(&invert_similarity(&shift), p))
            .collect();
        let r = icp_point_to_point(&src, &target, &shift.matrix(), &IcpParams::tnt(0.05)).unwrap();
        assert!(max_abs_diff(&r.registration.transformation, &shift.matrix()) < 1e-12);
        // No matches: identity update, fitness 0, stop.
        let far: Vec<[f64; 3]> = target.iter().map(|p| [p[0] + 10.0, p[1], p[2]]).collect();
        let r = icp_point_to_point(&far, &target, &DMat4::IDENTITY, &IcpParams::tnt(0.05)).unwrap();
        assert_eq!(r.registration.fitness, 0.0);
        assert_eq!(r.registration.transformation, DMat4::IDENTITY);
        assert!(
            icp_point_to_point(&far, &target, &DMat4::IDENTITY, &IcpParams::tnt(-1.0)).is_err()
        );
    }

    /// Inverse of a similarity as a matrix: (1/s)·Rᵀ·(p − t).
    pub(crate) fn invert_similarity(s: &Similarity) -> DMat4 {
        let rt = s.rotation.transpose() / s.scale;
        let t = -(s.rotation.transpose() * s.translation) / s.scale;
        DMat4::from_cols(
            rt.x_axis.extend(0.0),
            rt.y_axis.extend(0.0),
            rt.z_axis.extend(0.0),
            t.extend(1.0),
        )
    }
}
