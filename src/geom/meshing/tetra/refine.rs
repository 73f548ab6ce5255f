//! GOF's refinement of a marching-tetrahedra cut (`extract_mesh.py`,
//! `marching_tetrahedra_with_binary_search`): each cut edge is halved
//! `steps` times (GOF: 8) by evaluating the field at its midpoint, then its
//! vertex is the midpoint of the last bracket; `--filter_mesh` keeps only
//! the vertices of edges no longer than the sum of their end points'
//! scales, and the faces whose three vertices are all kept.
//!
//! Rules, as GOF writes them:
//! - the bracket starts as (left, right) = the edge's (a, b) ends (a < b)
//!   with their values; each step evaluates m = (left + right)/2 (f32
//!   arithmetic) and moves `left` to m when m's value has the same strict
//!   sign as left's (both < 0 or both > 0), otherwise `right` (a value of
//!   exactly 0 moves `right`);
//! - the vertex is (left + right)/2 after the last step (not evaluated);
//! - the filter compares the *initial* edge length |a − b| with
//!   scale(a) + scale(b) (GOF's per-point scale: 3 × the largest σ of the
//!   Gaussian the point came from); a vertex is kept when length ≤ scale.
//!   Kept vertices keep their order; vertices whose faces all go stay (GOF
//!   removes no unreferenced vertex).

use super::marching::TetCut;
use crate::Result;
use crate::model::Mesh;

/// The refined position of every cut edge of `cut` (same order as
/// `cut.edges`), by `steps` halvings. `points`/`values` are the
/// tetrahedralisation's vertices and field values; `field` evaluates the
/// field at a batch of points (one call per step, all edges at once).
pub fn bisect_edges(
    points: &[[f32; 3]],
    values: &[f32],
    cut: &TetCut,
    steps: usize,
    mut field: impl FnMut(&[[f32; 3]]) -> Result<Vec<f32>>,
) -> Result<Vec<[f32; 3]>> {
    let mut left: Vec<[f32; 3]> = cut.edges.iter().map(|e| points[e[0] as usize]).collect();
    let mut right: Vec<[f32; 3]> = cut.edges.iter().map(|e| points[e[1] as usize]).collect();
    let mut left_value: Vec<f32> = cut.edges.iter().map(|e| values[e[0] as usize]).collect();
    let mid =
        |l: &[f32; 3], r: &[f32; 3]| -> [f32; 3] { std::array::from_fn(|k| (l[k] + r[k]) / 2.0) };
    for _ in 0..steps {
        let m: Vec<[f32; 3]> = left.iter().zip(&right).map(|(l, r)| mid(l, r)).collect();
        let mv = field(&m)?;
        assert_eq!(mv.len(), m.len(), "the field gives one value per point");
        for i in 0..m.len() {
            let same = (mv[i] < 0.0 && left_value[i] < 0.0) || (mv[i] > 0.0 && left_value[i] > 0.0);
            if same {
                left[i] = m[i];
                left_value[i] = mv[i];
            } else {
                right[i] = m[i];
            }
        }
    }
    Ok(left.iter().zip(&right).map(|(l, r)| mid(l, r)).collect())
}

/// The mesh of `cut` with vertex positions `vertices` (one per cut edge),
/// optionally filtered as GOF's `--filter_mesh` (`scales`: per
/// tetrahedralisation vertex, see the module docs). Faces keep `cut`'s
/// order and orientation.
pub fn cut_mesh(
    points: &[[f32; 3]],
    scales: Option<&[f32]>,
    cut: &TetCut,
    vertices: Vec<[f32; 3]>,
) -> Mesh {
    let Some(scales) = scales else {
        return Mesh {
            vertices,
            faces: cut.faces.clone(),
            ..Default::default()
        };
    };
    let keep: Vec<bool> = cut
        .edges
        .iter()
        .map(|&[a, b]| {
            let (pa, pb) = (points[a as usize], points[b as usize]);
            let d = (0..3)
                .map(|k| (pa[k] - pb[k]) * (pa[k] - pb[k]))
                .sum::<f32>()
                .sqrt();
            d <= scales[a as usize] + scales[b as usize]
        })
        .collect();
    let mut new_index = vec![u32::MAX; keep.len()];
    let mut kept = Vec::new();
    for (i, v) in vertices.into_iter().enumerate() {
        if keep[i] {
            new_index[i] = kept.len() as u32;
            kept.push(v);
        }
    }
    let faces = cut
        .faces
        .iter()
        .filter(|f| f.iter().all(|&v| keep[v as usize]))
        .map(|f| f.map(|v| new_index[v as usize]))
        .collect();
    Mesh {
        vertices: kept,
        faces,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::super::marching::march;
    use super::*;

    /// A field that is a plane's signed distance: after n steps every vertex
    /// is within |edge|/2^(n+1) of the plane, along its edge.
    #[test]
    fn bisection_converges_on_a_plane() {
        let points = vec![
            [0.0f32, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let plane = |p: &[f32; 3]| p[0] + p[1] + p[2] - 0.3;
        let values: Vec<f32> = points.iter().map(plane).collect();
        let cut = march(&[[0, 1, 2, 3]], &values);
        assert_eq!(cut.edges.len(), 3);
        let mut calls = 0;
        let v = bisect_edges(&points, &values, &cut, 8, |m| {
            calls += 1;
            Ok(m.iter().map(plane).collect())
        })
        .unwrap();
        assert_eq!(calls, 8);
        for (p, e) in v.iter().zip(&cut.edges) {
            // on the axis edge from the origin: x = 0.3 within 1/2^9
            let k = e[1] as usize - 1;
            assert!((p[k] - 0.3).abs() <= 1.0 / 512.0 + 1e-6, "{p:?}");
        }
    }

    /// The side rule: a midpoint value of exactly 0 moves `right`; the
    /// bracket's left end keeps its sign.
    #[test]
    fn zero_at_the_midpoint_moves_right() {
        let points = vec![
            [0.0f32, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let values = vec![1.0f32, -1.0, -1.0, -1.0];
        let cut = march(&[[0, 1, 2, 3]], &values);
        let v = bisect_edges(&points, &values, &cut, 1, |m| Ok(vec![0.0; m.len()])).unwrap();
        // left = a (value 1), right = midpoint: the vertex is at a quarter
        for p in v {
            assert!((p.iter().sum::<f32>() - 0.25).abs() < 1e-7, "{p:?}");
        }
    }

    /// The filter keeps vertices of edges no longer than the summed scales,
    /// and faces with all three kept; order is kept.
    #[test]
    fn filter_keeps_short_edges() {
        let points = vec![
            [0.0f32, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 3.0],
        ];
        let values = vec![1.0f32, -1.0, -1.0, -1.0];
        let cut = march(&[[0, 1, 2, 3]], &values);
        let mids: Vec<[f32; 3]> = cut
            .edges
            .iter()
            .map(|e| {
                std::array::from_fn(|k| (points[e[0] as usize][k] + points[e[1] as usize][k]) / 2.0)
            })
            .collect();
        // scales 0.5 each: edges of length 1 stay, the one of length 3 goes
        let m = cut_mesh(&points, Some(&[0.5; 4]), &cut, mids.clone());
        assert_eq!(m.vertices.len(), 2);
        assert_eq!(m.faces.len(), 0);
        let m = cut_mesh(&points, Some(&[1.5; 4]), &cut, mids.clone());
        assert_eq!((m.vertices.len(), m.faces.len()), (3, 1));
        let m = cut_mesh(&points, None, &cut, mids);
        assert_eq!((m.vertices.len(), m.faces.len()), (3, 1));
    }
}
