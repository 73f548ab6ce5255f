//! 2DGS's `post_process_mesh`: drop the small connected pieces of a fused
//! mesh.
//!
//! Components are sets of faces joined by shared edges (by vertex index, as
//! Open3D's `cluster_connected_triangles`). The threshold is the face count
//! of the k-th largest component, raised to `min_faces` (2DGS: 50); every
//! component with fewer faces goes (ties stay, so more than k components can
//! remain), then the vertices no face uses. Unlike 2DGS before its PR #253,
//! k larger than the number of components is clamped instead of failing, and
//! an empty mesh stays empty.

use crate::geom::mesh_ops::clean::{face_components, filter_faces, remove_unreferenced_vertices};
use crate::model::Mesh;

/// What [`keep_largest_clusters`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClusterReport {
    /// Components before.
    pub clusters: usize,
    /// Components kept.
    pub kept: usize,
    /// Faces removed.
    pub faces_removed: usize,
    /// Vertices removed.
    pub vertices_removed: usize,
    /// The face-count threshold applied.
    pub threshold: usize,
}

/// Keeps the components with at least as many faces as the `k`-th largest
/// (k ≥ 1, clamped to the number of components) and at least `min_faces`.
pub fn keep_largest_clusters(mesh: &mut Mesh, k: usize, min_faces: usize) -> ClusterReport {
    let label = face_components(mesh);
    let nc = label.iter().map(|&l| l as usize + 1).max().unwrap_or(0);
    if nc == 0 {
        return ClusterReport::default();
    }
    let mut count = vec![0usize; nc];
    for &l in &label {
        count[l as usize] += 1;
    }
    let mut sorted = count.clone();
    sorted.sort_unstable();
    let k = k.clamp(1, nc);
    let threshold = sorted[nc - k].max(min_faces);
    let keep: Vec<bool> = label
        .iter()
        .map(|&l| count[l as usize] >= threshold)
        .collect();
    let faces_removed = keep.iter().filter(|k| !**k).count();
    let mut vertices_removed = 0;
    if faces_removed > 0 {
        filter_faces(mesh, &keep);
        vertices_removed = remove_unreferenced_vertices(mesh);
    }
    ClusterReport {
        clusters: nc,
        kept: count.iter().filter(|&&c| c >= threshold).count(),
        faces_removed,
        vertices_removed,
        threshold,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A strip of `n` faces (a fan of triangles sharing edges), offset so
    /// strips do not share vertices.
    fn strip(m: &mut Mesh, n: usize) {
        let base = m.vertices.len() as u32;
        for i in 0..n + 2 {
            m.vertices.push([i as f32, (i % 2) as f32, base as f32]);
        }
        for i in 0..n as u32 {
            m.faces.push([base + i, base + i + 1, base + i + 2]);
        }
    }

    /// Components of 100, 60, 60 and 10 faces: k = 1 keeps the 100; k = 2
    /// keeps 100 and both 60s (a tie at the threshold stays); k = 9 is
    /// clamped to 4 and the floor of 50 still drops the 10; an empty mesh
    /// is left alone.
    #[test]
    fn threshold_ties_clamp_and_floor() {
        let mut m = Mesh::default();
        for n in [60, 100, 10, 60] {
            strip(&mut m, n);
        }
        let mut a = m.clone();
        let r = keep_largest_clusters(&mut a, 1, 50);
        assert_eq!((r.clusters, r.kept, r.threshold), (4, 1, 100));
        assert_eq!(a.faces.len(), 100);
        assert_eq!(a.vertices.len(), 102);
        let mut b = m.clone();
        let r = keep_largest_clusters(&mut b, 2, 50);
        assert_eq!((r.kept, r.threshold, b.faces.len()), (3, 60, 220));
        let mut c = m.clone();
        let r = keep_largest_clusters(&mut c, 9, 50);
        assert_eq!((r.kept, r.threshold, r.faces_removed), (3, 50, 10));
        let mut e = Mesh::default();
        assert_eq!(
            keep_largest_clusters(&mut e, 1, 50),
            ClusterReport::default()
        );
    }
}
