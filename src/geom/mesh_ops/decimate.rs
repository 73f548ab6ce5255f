//! Quadric-error decimation to an explicit face or vertex count that keeps
//! the topology of the mesh, with the engine in
//! [`crate::geom::mesh_ops::edge_collapse`] (Garland–Heckbert edge
//! collapses, area-weighted plane quadrics as Open3D's
//! `simplify_quadric_decimation`, survivors at the error-minimising point,
//! every collapse checked against the link condition).
//!
//! On a mesh in which `clean` finds nothing, the output has nothing for it
//! to find (no two vertices on one point, no degenerate, duplicate or
//! non-manifold face) and every piece keeps its Euler characteristic
//! `V − E + F`. The price: a target can be missed from above where no
//! collapse keeps the topology (a closed piece stops at a tetrahedron, a
//! torus at a few dozen faces, thin parts at their handles).
//!
//! Vertices at bit-identical positions are welded first, as `clean`
//! merges them (faces refer to the first of them). Defects already in the
//! input are left as they are (their vertices do not move).
//!
//! Attributes: surviving vertices keep their colours and scalars (their
//! identity is kept; only positions move); normals, when present, are
//! recomputed from the faces (area-weighted). Per-face colours, extra face
//! properties and per-corner texture coordinates (with the texture) are
//! dropped: collapsed faces have no single source.

use std::borrow::Cow;

use crate::geom::mesh_ops::clean::{
    merge_duplicate_vertices, position_key, remove_unreferenced_vertices, vertex_normals,
};
use crate::geom::mesh_ops::edge_collapse::{Stop, collapse_edges};
use crate::model::Mesh;
use crate::{Error, Result};

/// What to decimate to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// At most this many faces.
    Faces(usize),
    /// At most this many vertices.
    Vertices(usize),
    /// This fraction of the faces.
    Ratio(f64),
}

/// Result counts.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct DecimateReport {
    pub faces_before: usize,
    pub vertices_before: usize,
    pub faces_after: usize,
    pub vertices_after: usize,
    /// Largest error of a collapse made, as a distance (square root of the
    /// quadric error over its weight) relative to the longest side of the
    /// bounding box.
    pub relative_error: f32,
    /// Vertices that never moved because the input is not a clean manifold
    /// there (0 on `clean`'s output).
    pub locked_vertices: usize,
}

/// Whether two vertices (used or not) sit on one point.
fn has_shared_points(v: &[[f32; 3]]) -> bool {
    let mut seen = rustc_hash::FxHashSet::default();
    v.iter().any(|p| !seen.insert(position_key(p)))
}

/// Decimates `mesh` to `target`. A target at or above the current size
/// returns the mesh unchanged.
pub fn decimate(mesh: &Mesh, target: Target) -> Result<(Mesh, DecimateReport)> {
    let nf = mesh.faces.len();
    let nv = mesh.vertices.len();
    let mut report = DecimateReport {
        faces_before: nf,
        vertices_before: nv,
        ..Default::default()
    };
    let stop = match target {
        Target::Faces(f) => Stop::Faces(f),
        Target::Ratio(r) if (0.0..=1.0).contains(&r) => {
            Stop::Faces((r * nf as f64).round() as usize)
        }
        Target::Ratio(r) => {
            return Err(Error::invalid(format!("ratio must be in [0, 1] (got {r})")));
        }
        Target::Vertices(v) => Stop::Vertices(v),
    };
    let unchanged = match stop {
        Stop::Faces(f) => f >= nf,
        Stop::Vertices(v) => v >= nv,
    };
    if unchanged {
        report.faces_after = nf;
        report.vertices_after = nv;
        return Ok((mesh.clone(), report));
    }
    let mut work = Cow::Borrowed(mesh);
    if has_shared_points(&mesh.vertices) {
        merge_duplicate_vertices(work.to_mut());
    }
    let done = collapse_edges(&work.vertices, &work.faces, stop);
    let mut out = work.into_owned();
    out.vertices = done.positions;
    out.faces = done.faces;
    // Per-face attributes cannot follow collapsed faces.
    out.face_colors = None;
    out.uvs = None;
    out.texture = None;
    out.extras.item.clear();
    remove_unreferenced_vertices(&mut out);
    if out.normals.is_some() {
        out.normals = Some(vertex_normals(&out));
    }
    let extent = bbox_extent(mesh);
    report.faces_after = out.faces.len();
    report.vertices_after = out.vertices.len();
    report.relative_error = if extent > 0.0 {
        (done.max_error / extent) as f32
    } else {
        0.0
    };
    report.locked_vertices = done.locked;
    Ok((out, report))
}

/// Longest side of the bounding box of the vertices.
fn bbox_extent(m: &Mesh) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &m.vertices {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k] as f64);
            hi[k] = hi[k].max(p[k] as f64);
        }
    }
    (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::uv_sphere;

    fn closed_and_outward(m: &Mesh) -> (bool, f64) {
        let mut e: rustc_hash::FxHashMap<(u32, u32), usize> = Default::default();
        for f in &m.faces {
            for k in 0..3 {
                *e.entry((f[k], f[(k + 1) % 3])).or_default() += 1;
            }
        }
        let vol = crate::geom::mesh_ops::clean::signed_volume(m);
        let closed = e
            .iter()
            .all(|(&(a, b), &c)| c == 1 && e.get(&(b, a)) == Some(&1));
        (closed, vol)
    }

    /// 200k faces → 2k faces. A sphere tessellated with 2k faces has edges
    /// of ~0.08 and flat triangles sag ~0.3 % below the sphere; QEM with
    /// optimal placement keeps vertices near the surface, so the bound on the
    /// vertex radius error is 1 % and the volume stays within 2 % of 4π/3.
    #[test]
    fn sphere_stays_round_closed_and_outward() {
        let m = uv_sphere(224, 1.0);
        assert!(m.faces.len() > 190_000, "{}", m.faces.len());
        let (d, r) = decimate(&m, Target::Faces(2000)).unwrap();
        assert!(
            d.faces.len() <= 2000 && d.faces.len() > 1800,
            "{}",
            d.faces.len()
        );
        assert_eq!(r.faces_after, d.faces.len());
        let worst = d
            .vertices
            .iter()
            .map(|p| ((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 1.0).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 0.01, "radius error {worst}");
        let (closed, vol) = closed_and_outward(&d);
        assert!(closed, "watertight and consistently oriented");
        let want = 4.0 / 3.0 * std::f64::consts::PI;
        assert!((vol - want).abs() < 0.02 * want, "volume {vol}");
    }

    #[test]
    fn vertex_target_and_ratio() {
        let m = uv_sphere(60, 1.0);
        let (d, _) = decimate(&m, Target::Vertices(500)).unwrap();
        assert!(
            d.vertices.len() <= 500 && d.vertices.len() > 400,
            "{}",
            d.vertices.len()
        );
        let (d, _) = decimate(&m, Target::Ratio(0.5)).unwrap();
        assert!((d.faces.len() as f64 - 0.5 * m.faces.len() as f64).abs() <= 2.0);
        let (same, _) = decimate(&m, Target::Faces(1 << 30)).unwrap();
        assert_eq!(same, m);
        assert!(decimate(&m, Target::Ratio(1.5)).is_err());
    }
}
