//! Screened Poisson surface reconstruction (Kazhdan & Hoppe 2013) as
//! PoissonRecon 18.75 and Open3D 0.20 implement it with their defaults:
//! degree-1 FEM basis, Neumann boundary, degree-2 normal splatting at each
//! sample's kernel-density depth, screening toward ½ at per-node sample
//! centroids, one cascadic coarse-to-fine Gauss–Seidel pass, iso-value = the
//! weighted mean of χ at the samples, and per-vertex `density` = the depth
//! estimate. See `docs/poisson.md` and the module docs of each step:
//!
//! - [`samples`]: normalisation into the unit cube and leaf merging;
//! - [`density`]: the kernel-density depth estimate;
//! - [`system`]: the sparse multilevel grid, right-hand side, screening and solve;
//! - [`extract`]: iso-surface extraction.
//!
//! Units: input and output in world units; internally the unit cube, whose
//! side is `scale × largest bounding-box extent` (so one finest cell is
//! `side / 2^depth` world units, reported as `cell_size`).

pub mod bspline;
pub mod density;
pub mod extract;
pub mod grid;
pub mod octree_extract;
pub mod pipeline;
pub mod samples;
pub mod system;
#[cfg(test)]
mod tests;

use std::time::Instant;

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use serde::Serialize;

use crate::model::{Mesh, PointCloud};
use crate::{Error, Result};

/// Parameters, named and defaulted as in PoissonRecon / Open3D.
#[derive(Clone, Debug, Serialize)]
pub struct PoissonParams {
    /// Finest octree depth D (ignored when `width` is set).
    pub depth: u32,
    /// Levels up to this depth are complete.
    pub full_depth: u32,
    /// Target samples per node of the density estimate.
    pub samples_per_node: f64,
    /// Screening weight α; 0 gives unscreened Poisson.
    pub point_weight: f64,
    /// Cube side over the largest bounding-box extent.
    pub scale: f64,
    /// Gauss–Seidel sweeps per level.
    pub iters: usize,
    /// Linear instead of quadratic iso-vertex placement.
    pub linear_fit: bool,
    /// Finest cell width in world units; sets the depth to ⌈log2(side/width)⌉.
    pub width: Option<f64>,
    /// Extract on the uniform grid of the finest depth instead of the
    /// adaptive octree (more, smaller triangles where the solve is coarse).
    pub uniform_extraction: bool,
}

impl Default for PoissonParams {
    fn default() -> Self {
        PoissonParams {
            depth: 8,
            full_depth: 5,
            samples_per_node: 1.5,
            point_weight: 2.0,
            scale: 1.1,
            iters: 8,
            linear_fit: false,
            width: None,
            uniform_extraction: false,
        }
    }
}

/// What a reconstruction did, for `--json` and the summary.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PoissonStats {
    /// Points given.
    pub input_points: usize,
    /// Points dropped for a non-finite position or a zero / non-finite normal.
    pub dropped_points: usize,
    /// Merged samples (occupied finest cells).
    pub samples: usize,
    /// Depth used.
    pub depth: u32,
    /// World length of the finest cell.
    pub cell_size: f64,
    /// World centre and side of the reconstruction cube.
    pub cube_center: [f64; 3],
    pub cube_side: f64,
    /// The iso-value χ is cut at.
    pub iso_value: f64,
    /// Mean sample area ā (unit-cube units), the screening scale.
    pub mean_sample_area: f64,
    /// Solved nodes per depth.
    pub active_nodes: Vec<usize>,
    /// Output size.
    pub vertices: usize,
    pub faces: usize,
    /// Seconds per phase.
    pub seconds: Vec<(String, f64)>,
}

/// The reconstructed mesh (world units; per-vertex normals = −∇χ normalised,
/// colours when the input had them, scalar `density`) and statistics.
#[derive(Clone, Debug)]
pub struct PoissonOutput {
    pub mesh: Mesh,
    pub stats: PoissonStats,
    /// Per vertex, the depth at which the solver represents the surface
    /// there ([`system::support_level`]); the extraction itself is uniform
    /// at the finest depth, so a vertex stands for 4^(support − depth) of
    /// the vertices an octree-adaptive extraction would place.
    pub support_depth: Vec<u8>,
}

/// Checks for the degenerate inputs a Poisson solve cannot use.
fn check_spread(p: &[[f64; 3]]) -> Result<()> {
    if p.iter().all(|q| q == &p[0]) {
        return Err(Error::invalid(
            "all points are identical: there is no surface to reconstruct",
        ));
    }
    let n = p.len() as f64;
    let mut c = [0.0; 3];
    for q in p {
        for k in 0..3 {
            c[k] += q[k] / n;
        }
    }
    let d2 = |q: &[f64; 3], r: &[f64; 3]| (0..3).map(|k| (q[k] - r[k]).powi(2)).sum::<f64>();
    let far = p
        .iter()
        .copied()
        .fold(c, |a, q| if d2(&q, &c) > d2(&a, &c) { q } else { a });
    let r2 = d2(&far, &c);
    if r2 == 0.0 {
        return Err(Error::invalid(
            "all points are identical: there is no surface to reconstruct",
        ));
    }
    let u: Vec<f64> = (0..3).map(|k| (far[k] - c[k]) / r2.sqrt()).collect();
    let off_line = p.iter().any(|q| {
        let v = [q[0] - c[0], q[1] - c[1], q[2] - c[2]];
        let t = v[0] * u[0] + v[1] * u[1] + v[2] * u[2];
        let o = [v[0] - t * u[0], v[1] - t * u[1], v[2] - t * u[2]];
        o[0] * o[0] + o[1] * o[1] + o[2] * o[2] > 1e-12 * r2
    });
    if !off_line {
        return Err(Error::invalid(
            "all points are collinear: there is no surface to reconstruct",
        ));
    }
    Ok(())
}

/// Reconstructs a mesh from an oriented point cloud (normals required; they
/// are taken to point outward). Points with a non-finite position or a zero
/// or non-finite normal are dropped and counted. Fewer than four usable
/// points, or points that are all identical or collinear, are an error.
pub fn reconstruct(cloud: &PointCloud, prm: &PoissonParams) -> Result<PoissonOutput> {
    reconstruct_with_progress(cloud, prm, &|_| {})
}

/// The five stages [`reconstruct_with_progress`] reports, in order.
pub const STAGES: [&str; 5] = ["merge", "density", "solve", "extract", "attributes"];

/// [`reconstruct`], calling `on_stage` with the name of each of [`STAGES`]
/// as it finishes (for progress bars).
pub fn reconstruct_with_progress(
    cloud: &PointCloud,
    prm: &PoissonParams,
    on_stage: &dyn Fn(&str),
) -> Result<PoissonOutput> {
    let mut secs = Vec::new();
    let mut clock = Instant::now();
    let mut lap = |name: &str, secs: &mut Vec<(String, f64)>| {
        secs.push((name.to_string(), clock.elapsed().as_secs_f64()));
        on_stage(name);
        clock = Instant::now();
    };
    let normals = cloud.normals.as_ref().ok_or_else(|| {
        Error::invalid("the points have no normals (nx, ny, nz): Poisson needs oriented points")
    })?;
    if prm.scale.is_nan() || prm.scale <= 1.0 || !prm.scale.is_finite() {
        return Err(Error::invalid(format!(
            "scale must be > 1 (got {})",
            prm.scale
        )));
    }
    if prm.samples_per_node.is_nan()
        || prm.samples_per_node <= 0.0
        || prm.point_weight.is_nan()
        || prm.point_weight < 0.0
    {
        return Err(Error::invalid(
            "samples-per-node must be > 0 and point-weight ≥ 0",
        ));
    }
    let mut pos = Vec::with_capacity(cloud.len());
    let mut nrm = Vec::with_capacity(cloud.len());
    let mut col = cloud
        .colors
        .as_ref()
        .map(|_| Vec::with_capacity(cloud.len()));
    for (i, (p, n)) in cloud.positions.iter().zip(normals).enumerate() {
        let len = (n[0] as f64).hypot(n[1] as f64).hypot(n[2] as f64);
        if p.iter().all(|c| c.is_finite()) && len.is_finite() && len > 0.0 {
            pos.push([p[0] as f64, p[1] as f64, p[2] as f64]);
            nrm.push([n[0] as f64 / len, n[1] as f64 / len, n[2] as f64 / len]);
            if let (Some(c), Some(src)) = (&mut col, &cloud.colors) {
                c.push(src[i]);
            }
        }
    }
    let dropped = cloud.len() - pos.len();
    if pos.len() < 4 {
        return Err(Error::invalid(format!(
            "need at least 4 points with a finite position and a non-zero normal, got {} ({} dropped)",
            pos.len(),
            dropped
        )));
    }
    check_spread(&pos)?;
    let norm = samples::normalization(&pos, prm.scale).expect("spread checked");
    let depth = match prm.width {
        Some(w) if w > 0.0 => (norm.side / w).log2().ceil().max(2.0) as u32,
        Some(w) => return Err(Error::invalid(format!("width must be > 0 (got {w})"))),
        None => prm.depth,
    };
    if !(2..=16).contains(&depth) {
        return Err(Error::invalid(match prm.width {
            Some(w) => format!(
                "a cell width of {w:?} needs octree depth {depth} for a cube side of {:.6} \
                 (depth = ⌈log2(side / width)⌉), and the depth must be in 2..=16: use a width \
                 of at least {:.3e}",
                norm.side,
                norm.side / 65536.0
            ),
            None => format!("depth must be in 2..=16 (got {depth})"),
        }));
    }
    let unit: Vec<[f64; 3]> = pos.par_iter().map(|p| norm.to_unit(*p)).collect();
    drop(pos);
    let samples = samples::merge(&unit, &nrm, col.as_deref(), depth);
    drop((unit, nrm, col));
    lap("merge", &mut secs);

    let kernel_depth = depth - 2;
    let field = density::DensityField::build(&samples, kernel_depth, prm.samples_per_node);
    let (sd_depth, sd_area): (Vec<f64>, Vec<f64>) = samples
        .pos
        .par_iter()
        .map(|p| field.depth_and_area(*p))
        .unzip();
    lap("density", &mut secs);

    let sp = system::SolverParams {
        depth,
        full_depth: prm.full_depth,
        point_weight: prm.point_weight,
        iters: prm.iters,
    };
    let sd = system::SampleDepths {
        depth: sd_depth,
        area: sd_area,
    };
    let (levels, solve_stats) = system::solve(&samples, &sd, &sp);
    lap("solve", &mut secs);

    // Weighted mean of the field at the samples. Summed in fixed chunks of
    // 4096 whose partial sums are added in order: a rayon `reduce` pairs
    // partial sums as work stealing happens to split them, which changed
    // the last bits of the iso value from run to run.
    let (num, den) = samples
        .pos
        .par_chunks(4096)
        .zip(samples.weight.par_chunks(4096))
        .map(|(ps, ws)| {
            ps.iter()
                .zip(ws)
                .fold((0.0, 0.0), |acc, (p, w)| match system::eval(&levels, *p) {
                    Some(v) => (acc.0 + w * v, acc.1 + w),
                    None => acc,
                })
        })
        .collect::<Vec<(f64, f64)>>()
        .into_iter()
        .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    let iso = if den > 0.0 { num / den } else { 0.5 };
    let xp = extract::ExtractParams {
        iso,
        linear: prm.linear_fit,
    };
    let (iso_mesh, support) = if prm.uniform_extraction {
        let m = extract::extract(&levels, &samples.pos, &xp);
        let s: Vec<u8> = m
            .vertices
            .par_iter()
            .map(|u| system::support_level(&levels, *u) as u8)
            .collect();
        (m, s)
    } else {
        let m = octree_extract::extract_octree(&levels, &samples.pos, &xp);
        let s = vec![depth as u8; m.vertices.len()];
        (m, s)
    };
    drop(levels);
    lap("extract", &mut secs);

    let vertices: Vec<[f32; 3]> = iso_mesh
        .vertices
        .par_iter()
        .map(|u| {
            let w = norm.to_world(*u);
            [w[0] as f32, w[1] as f32, w[2] as f32]
        })
        .collect();
    let normals: Option<Vec<[f32; 3]>> = (!iso_mesh.gradients.is_empty()).then(|| {
        iso_mesh
            .gradients
            .par_iter()
            .map(|g| {
                let l = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
                if l > 0.0 {
                    [-g[0] / l, -g[1] / l, -g[2] / l]
                } else {
                    [0.0; 3]
                }
            })
            .collect()
    });
    let dens: Vec<f32> = iso_mesh
        .vertices
        .par_iter()
        .map(|u| field.depth_and_area(*u).0 as f32)
        .collect();
    let colors = samples
        .color
        .as_ref()
        .map(|c| vertex_colors(&samples.pos, c, &iso_mesh.vertices));
    let mut mesh = Mesh::new(vertices, iso_mesh.triangles);
    mesh.normals = Some(match normals {
        Some(n) => n,
        None => crate::geom::mesh_ops::clean::vertex_normals(&mesh),
    });
    mesh.vertex_colors = colors;
    mesh.vertex_scalars.push(("density".to_string(), dens));
    lap("attributes", &mut secs);

    let stats = PoissonStats {
        input_points: cloud.len(),
        dropped_points: dropped,
        samples: samples.len(),
        depth,
        cell_size: norm.side / (1u64 << depth) as f64,
        cube_center: norm.center,
        cube_side: norm.side,
        iso_value: iso,
        mean_sample_area: solve_stats.mean_area,
        active_nodes: solve_stats.active_per_level,
        vertices: mesh.vertices.len(),
        faces: mesh.faces.len(),
        seconds: secs,
    };
    Ok(PoissonOutput {
        mesh,
        stats,
        support_depth: support,
    })
}

/// Vertex colours: inverse-distance mean of the 4 nearest samples' colours.
fn vertex_colors(spos: &[[f64; 3]], scol: &[[f32; 3]], verts: &[[f64; 3]]) -> Vec<[u8; 4]> {
    let Ok(tree) = ImmutableKdTree::<f64, 3>::new_from_slice(spos) else {
        return vec![[128, 128, 128, 255]; verts.len()];
    };
    verts
        .par_iter()
        .map(|v| {
            let nn = tree
                .query(v)
                .nearest_n::<SquaredEuclidean<f64>>(std::num::NonZero::new(4).expect("4 > 0"))
                .execute();
            let mut acc = [0.0f64; 3];
            let mut ws = 0.0;
            for r in nn {
                let w = 1.0 / (r.distance.sqrt() + 1e-9);
                let c = scol[r.item as usize];
                for k in 0..3 {
                    acc[k] += w * c[k] as f64;
                }
                ws += w;
            }
            let c = |k: usize| (acc[k] / ws).round().clamp(0.0, 255.0) as u8;
            [c(0), c(1), c(2), 255]
        })
        .collect()
}
