//! The whole of GOF's extraction (`marching_tetrahedra_with_binary_search`):
//! tetra points → Delaunay tetrahedralisation → opacity field at the points
//! → marching tetrahedra on `alpha − level` → binary search on the cut edges
//! → optional edge filter → optional vertex colours.
//!
//! GOF fixes the level at 0.5 and the search at 8 steps; both are options
//! here with those defaults. Colours are GOF's `--texture_mesh` colours: the
//! field's colour at each final vertex (the view where the point's
//! accumulated opacity is smallest), as `(c·255)` truncated to u8; values
//! outside [0, 1] are clamped first (GOF casts without clamping, which wraps).

use std::time::Instant;

use splatkit_render::Camera;
use splatkit_render::gaussian::Gaussians3;
use splatkit_render::gaussian_integrate::{IntegrateSettings, OpacityField, opacity_field};

use super::marching::march;
use super::points::tetra_points;
use super::refine::{bisect_edges, cut_mesh};
use crate::Result;
use crate::geom::delaunay::tetrahedralize_within;
use crate::model::Mesh;

/// Options of [`extract`]; `Default` gives GOF's.
#[derive(Clone, Debug)]
pub struct TetraOptions {
    /// The opacity level meshed (GOF: sdf = alpha − 0.5).
    pub level: f32,
    /// Binary-search steps per cut edge (GOF: 8).
    pub steps: usize,
    /// Frustum limits of the tetra points, camera z (GOF: 0.02, 1e6).
    pub near: f64,
    pub far: f64,
    /// GOF's `--filter_mesh`: drop vertices of cut edges longer than the
    /// sum of their ends' scales.
    pub filter: bool,
    /// GOF's `--texture_mesh`: vertex colours from the field.
    pub colors: bool,
    /// Background and 2-D kernel of the integration.
    pub integrate: IntegrateSettings,
    /// Keep every view's binned Gaussians between field evaluations (faster;
    /// memory grows with the number of views). Off: each evaluation prepares
    /// one view at a time.
    pub keep_views: bool,
    /// Memory limit of the tetrahedralisation, bytes (the caller's budget).
    pub max_bytes: u64,
}

impl Default for TetraOptions {
    fn default() -> Self {
        TetraOptions {
            level: 0.5,
            steps: 8,
            near: super::DEFAULT_NEAR,
            far: super::DEFAULT_FAR,
            filter: false,
            colors: true,
            integrate: IntegrateSettings::default(),
            keep_views: true,
            max_bytes: u64::MAX,
        }
    }
}

/// What [`extract`] did: counts and seconds per stage.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct TetraReport {
    pub gaussians: usize,
    pub points: usize,
    pub tetrahedra: usize,
    pub cut_edges: usize,
    pub vertices: usize,
    pub faces: usize,
    pub seconds_points: f64,
    pub seconds_delaunay: f64,
    pub seconds_field: f64,
    pub seconds_marching: f64,
    pub seconds_search: f64,
}

/// The stages [`extract`] reports to `progress` as it starts them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    Points,
    Delaunay,
    Field,
    Marching,
    /// Binary-search step `k` of `n`.
    Search(usize, usize),
    Colors,
}

/// GOF's mesh of `g` (activated, 3-D-filtered values) seen from `cams`.
/// Errors: no camera, or none of the points in any view (nothing to
/// tetrahedralise), or a failure of the tetrahedralisation.
pub fn extract(
    g: &Gaussians3,
    cams: &[Camera],
    opts: &TetraOptions,
    mut progress: impl FnMut(Stage),
) -> Result<(Mesh, TetraReport)> {
    if cams.is_empty() {
        return Err(crate::Error::invalid(
            "tetra-mesh needs at least one camera",
        ));
    }
    let mut report = TetraReport {
        gaussians: g.len(),
        ..Default::default()
    };
    let t = Instant::now();
    progress(Stage::Points);
    let tp = tetra_points(g, cams, opts.near, opts.far);
    report.points = tp.points.len();
    report.seconds_points = t.elapsed().as_secs_f64();
    if tp.points.len() < 4 {
        return Err(crate::Error::invalid(format!(
            "only {} tetra points lie in a camera's view (need at least 4): do the cameras see the scene?",
            tp.points.len()
        )));
    }

    let t = Instant::now();
    progress(Stage::Delaunay);
    let p64: Vec<[f64; 3]> = tp.points.iter().map(|p| p.map(f64::from)).collect();
    // geom::delaunay's tets have robust::orient3d > 0, i.e. a negative
    // signed volume; marching tetrahedra wants CGAL's positive ones (its
    // triangles then face free space): swap the first two corners.
    let tets: Vec<[u32; 4]> = tetrahedralize_within(&p64, opts.max_bytes)?
        .into_iter()
        .map(|[a, b, c, d]| [b, a, c, d])
        .collect();
    drop(p64);
    report.tetrahedra = tets.len();
    report.seconds_delaunay = t.elapsed().as_secs_f64();

    let t = Instant::now();
    progress(Stage::Field);
    let kept = opts
        .keep_views
        .then(|| OpacityField::new(g, cams, &opts.integrate));
    let eval = |pts: &[[f32; 3]]| -> (Vec<f32>, Vec<[f32; 3]>) {
        match &kept {
            Some(f) => f.evaluate(pts),
            None => opacity_field(g, cams, pts, &opts.integrate),
        }
    };
    let sdf = |alpha: Vec<f32>| -> Vec<f32> { alpha.into_iter().map(|a| a - opts.level).collect() };
    let values = sdf(eval(&tp.points).0);
    report.seconds_field = t.elapsed().as_secs_f64();

    let t = Instant::now();
    progress(Stage::Marching);
    let cut = march(&tets, &values);
    drop(tets);
    report.cut_edges = cut.edges.len();
    report.seconds_marching = t.elapsed().as_secs_f64();

    let t = Instant::now();
    let mut step = 0;
    let vertices = bisect_edges(&tp.points, &values, &cut, opts.steps, |m| {
        progress(Stage::Search(step, opts.steps));
        step += 1;
        Ok(sdf(eval(m).0))
    })?;
    let mut mesh = cut_mesh(
        &tp.points,
        opts.filter.then_some(&tp.scales[..]),
        &cut,
        vertices,
    );
    if opts.colors {
        progress(Stage::Colors);
        let (_, rgb) = eval(&mesh.vertices);
        mesh.vertex_colors = Some(
            rgb.iter()
                .map(|c| {
                    let [r, g, b] = c.map(|v| (v.clamp(0.0, 1.0) * 255.0) as u8);
                    [r, g, b, 255]
                })
                .collect(),
        );
    }
    report.seconds_search = t.elapsed().as_secs_f64();
    report.vertices = mesh.vertices.len();
    report.faces = mesh.faces.len();
    Ok((mesh, report))
}
