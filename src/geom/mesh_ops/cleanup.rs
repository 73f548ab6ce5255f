//! The clean-up sequence of `clean` as one call on a mesh: the steps of
//! [`crate::geom::mesh_ops::clean`] in the order SuGaR's V2 code runs Open3D's
//! (duplicate vertices, degenerate faces, duplicate faces, non-manifold
//! edges), then the optional connected-component filters and unreferenced
//! vertices, with a count of what each step removed.

use serde::Serialize;

use crate::geom::mesh_ops::clean::{
    ComponentFilter, filter_components, merge_duplicate_vertices, remove_degenerate_faces,
    remove_duplicate_faces, remove_non_manifold_edges, remove_unreferenced_vertices,
};
use crate::model::Mesh;

/// Which steps to run.
#[derive(Clone, Copy, Debug)]
pub struct CleanSteps {
    pub merge: bool,
    pub degenerate: bool,
    pub duplicates: bool,
    pub nonmanifold: bool,
    pub unreferenced: bool,
    pub components: ComponentFilter,
}

impl Default for CleanSteps {
    fn default() -> Self {
        CleanSteps {
            merge: true,
            degenerate: true,
            duplicates: true,
            nonmanifold: true,
            unreferenced: true,
            components: ComponentFilter::default(),
        }
    }
}

/// What each step removed.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CleanReport {
    pub vertices_before: usize,
    pub faces_before: usize,
    pub merged_vertices: usize,
    pub degenerate_faces: usize,
    pub duplicate_faces: usize,
    pub nonmanifold_faces: usize,
    pub unreferenced_vertices: usize,
    pub components: usize,
    pub removed_components: usize,
    pub removed_component_faces: usize,
    pub vertices_after: usize,
    pub faces_after: usize,
}

/// Runs the steps on a mesh.
pub fn clean_mesh(mesh: &mut Mesh, s: &CleanSteps) -> CleanReport {
    let mut r = CleanReport {
        vertices_before: mesh.vertices.len(),
        faces_before: mesh.faces.len(),
        ..Default::default()
    };
    if s.merge {
        r.merged_vertices = merge_duplicate_vertices(mesh);
    }
    if s.degenerate {
        r.degenerate_faces = remove_degenerate_faces(mesh);
    }
    if s.duplicates {
        r.duplicate_faces = remove_duplicate_faces(mesh);
    }
    if s.nonmanifold {
        r.nonmanifold_faces = remove_non_manifold_edges(mesh);
    }
    let c = &s.components;
    if c.keep_largest.is_some() || c.min_faces.is_some() || c.min_area_fraction.is_some() {
        let (n, rc, rf) = filter_components(mesh, c);
        r.components = n;
        r.removed_components = rc;
        r.removed_component_faces = rf;
    }
    if s.unreferenced {
        r.unreferenced_vertices = remove_unreferenced_vertices(mesh);
    }
    r.vertices_after = mesh.vertices.len();
    r.faces_after = mesh.faces.len();
    r
}
