//! The generic Chamfer evaluation between any two point sets: accuracy
//! (prediction → GT) and completeness (GT → prediction) distance
//! statistics, Chamfer-L1 = (mean acc + mean comp)/2, Chamfer-L2 =
//! (mean acc² + mean comp²)/2, precision / recall / F-score at thresholds
//! (strict `<`), normal consistency when both sides have normals
//! (mean |n·n'| over nearest-neighbour pairs, both directions averaged).
//!
//! Meshes become points by area-uniform sampling (seeded), by the DTU
//! up-sampling rule, or by taking their vertices ([`mesh_cloud`]).

use clap::ValueEnum;
use serde::Serialize;

use crate::geom::sampling::knn::NnIndex;
use crate::geom::sampling::sample::{dtu_mesh_points_par, sample_area_uniform_with_faces};
use crate::geom::sampling::stats::DistanceStats;
use crate::model::Mesh;
use crate::{Error, Result};

/// How a mesh becomes points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SampleMode {
    /// Area-uniform random samples (`--count`, seeded).
    Area,
    /// The DTU up-sampling rule at `--spacing` (vertices + samples).
    Dtu,
    /// The mesh vertices only.
    Vertices,
}

/// Points, with normals when the source has them.
#[derive(Clone, Debug, Default)]
pub struct Cloud {
    pub points: Vec<[f64; 3]>,
    pub normals: Option<Vec<[f64; 3]>>,
}

/// Options of the generic mode.
#[derive(Clone, Debug, Serialize)]
pub struct GenericParams {
    pub sample: SampleMode,
    /// Samples per mesh for `Area`.
    pub count: usize,
    /// Spacing for `Dtu`.
    pub spacing: f64,
    /// F-score thresholds.
    pub thresholds: Vec<f64>,
    /// Distances ≥ this are discarded before the statistics (DTU style).
    pub max_dist: Option<f64>,
    pub seed: u64,
}

impl GenericParams {
    /// Points as they are: a point cloud's points, a mesh's vertices.
    pub fn vertices() -> Self {
        GenericParams {
            sample: SampleMode::Vertices,
            count: 0,
            spacing: 0.0,
            thresholds: Vec::new(),
            max_dist: None,
            seed: 0,
        }
    }
}

/// Precision / recall / F-score at one threshold.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FScore {
    pub tau: f64,
    pub precision: f64,
    pub recall: f64,
    pub fscore: f64,
}

/// Result of the generic mode.
#[derive(Clone, Debug, Serialize)]
pub struct GenericReport {
    pub accuracy: DistanceStats,
    pub completeness: DistanceStats,
    pub chamfer_l1: f64,
    pub chamfer_l2: f64,
    pub fscores: Vec<FScore>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub normal_consistency: Option<f64>,
    pub pred_points: usize,
    pub gt_points: usize,
    /// Distances discarded by `max_dist` (accuracy, completeness).
    pub discarded: [usize; 2],
}

/// f32 points widened to f64.
pub fn f64_points(v: &[[f32; 3]]) -> Vec<[f64; 3]> {
    v.iter().map(|p| p.map(f64::from)).collect()
}

fn normalize(n: [f64; 3]) -> [f64; 3] {
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if l > 0.0 && l.is_finite() {
        n.map(|c| c / l)
    } else {
        [0.0; 3]
    }
}

/// Points of a mesh by `p.sample`.
pub fn mesh_cloud(m: &Mesh, p: &GenericParams) -> Result<Cloud> {
    let verts = f64_points(&m.vertices);
    Ok(match p.sample {
        SampleMode::Vertices => Cloud {
            points: verts,
            normals: m.normals.as_ref().map(|n| f64_points(n)),
        },
        SampleMode::Dtu => Cloud {
            points: dtu_mesh_points_par(&verts, &m.faces, p.spacing)?,
            normals: None,
        },
        SampleMode::Area => {
            let (points, faces) =
                sample_area_uniform_with_faces(&verts, &m.faces, p.count, p.seed)?;
            let normals = faces
                .iter()
                .map(|&f| {
                    let [a, b, c] = m.faces[f as usize].map(|i| verts[i as usize]);
                    let (u, v) = (
                        [0, 1, 2].map(|k| b[k] - a[k]),
                        [0, 1, 2].map(|k| c[k] - a[k]),
                    );
                    normalize([
                        u[1] * v[2] - u[2] * v[1],
                        u[2] * v[0] - u[0] * v[2],
                        u[0] * v[1] - u[1] * v[0],
                    ])
                })
                .collect();
            Cloud {
                points,
                normals: Some(normals),
            }
        }
    })
}

/// Drops non-finite points (and their normals); returns how many went.
pub fn drop_non_finite(c: &mut Cloud) -> usize {
    let keep: Vec<bool> = c
        .points
        .iter()
        .map(|p| p.iter().all(|v| v.is_finite()))
        .collect();
    let n = keep.iter().filter(|k| !**k).count();
    if n > 0 {
        let mut it = keep.iter();
        c.points.retain(|_| *it.next().expect("flag"));
        if let Some(ns) = &mut c.normals {
            let mut it = keep.iter();
            ns.retain(|_| *it.next().expect("flag"));
        }
    }
    n
}

/// Generic Chamfer / F-score between two clouds.
pub fn chamfer_generic(pred: &Cloud, gt: &Cloud, p: &GenericParams) -> Result<GenericReport> {
    if pred.points.is_empty() || gt.points.is_empty() {
        return Err(Error::invalid(format!(
            "cannot compare: the prediction has {} points and the ground truth {}",
            pred.points.len(),
            gt.points.len()
        )));
    }
    let gt_index = NnIndex::new(&gt.points)?;
    let pred_index = NnIndex::new(&pred.points)?;
    let acc_nn = gt_index.nearest_all(&pred.points);
    let comp_nn = pred_index.nearest_all(&gt.points);
    let acc: Vec<f64> = acc_nn
        .iter()
        .map(|r| r.map_or(f64::INFINITY, |x| x.1))
        .collect();
    let comp: Vec<f64> = comp_nn
        .iter()
        .map(|r| r.map_or(f64::INFINITY, |x| x.1))
        .collect();
    let cap = p.max_dist.unwrap_or(f64::INFINITY);
    let kept = |d: &[f64]| -> Vec<f64> { d.iter().copied().filter(|&x| x < cap).collect() };
    let (acc_k, comp_k) = (kept(&acc), kept(&comp));
    // Statistics over no distance mean nothing (they would print as null
    // with exit 0): every distance of a side beyond --max-dist is an error.
    for (k, side, n) in [
        (&acc_k, "prediction → ground truth (accuracy)", acc.len()),
        (
            &comp_k,
            "ground truth → prediction (completeness)",
            comp.len(),
        ),
    ] {
        if k.is_empty() {
            return Err(Error::invalid(format!(
                "--max-dist {cap}: all {n} {side} distances are at or beyond it, so no \
                 statistic is left; raise --max-dist"
            )));
        }
    }
    let accuracy = DistanceStats::from_distances(&acc_k);
    let completeness = DistanceStats::from_distances(&comp_k);
    let mean_sq = |d: &[f64]| d.iter().map(|x| x * x).sum::<f64>() / d.len().max(1) as f64;
    let fscores = p
        .thresholds
        .iter()
        .map(|&tau| {
            let precision = acc.iter().filter(|&&d| d < tau).count() as f64 / acc.len() as f64;
            let recall = comp.iter().filter(|&&d| d < tau).count() as f64 / comp.len() as f64;
            let fscore = if precision + recall > 0.0 {
                2.0 * precision * recall / (precision + recall)
            } else {
                0.0
            };
            FScore {
                tau,
                precision,
                recall,
                fscore,
            }
        })
        .collect();
    let normal_consistency = match (&pred.normals, &gt.normals) {
        (Some(pn), Some(gn)) => {
            let dot = |a: [f64; 3], b: [f64; 3]| (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).abs();
            let one = |nn: &[Option<(usize, f64)>], src: &[[f64; 3]], dst: &[[f64; 3]]| {
                nn.iter()
                    .zip(src)
                    .map(|(r, &n)| r.map_or(0.0, |(j, _)| dot(normalize(n), normalize(dst[j]))))
                    .sum::<f64>()
                    / nn.len() as f64
            };
            Some((one(&acc_nn, pn, gn) + one(&comp_nn, gn, pn)) / 2.0)
        }
        _ => None,
    };
    Ok(GenericReport {
        chamfer_l1: (accuracy.mean + completeness.mean) / 2.0,
        chamfer_l2: (mean_sq(&acc_k) + mean_sq(&comp_k)) / 2.0,
        accuracy,
        completeness,
        fscores,
        normal_consistency,
        pred_points: pred.points.len(),
        gt_points: gt.points.len(),
        discarded: [acc.len() - acc_k.len(), comp.len() - comp_k.len()],
    })
}
