//! Where a triangle mesh is not a clean 2-manifold, and the Euler
//! characteristic of each of its pieces: the checks `decimate` runs on its
//! output to keep the topology of its input.
//!
//! Inputs are an index list (`[u32; 3]` per face, counter-clockwise or not:
//! orientation is not looked at) over `nv` vertices and, where positions
//! matter, the positions (`[f32; 3]`, any unit). "Defects" are what `clean`
//! removes (see [`crate::geom::mesh_ops::clean`]): two used vertices on one
//! point (bit-identical coordinates, `-0.0 == 0.0`), a degenerate face (a
//! repeated index or exactly zero area in f64), a duplicate face (the same
//! three vertices as another, in any order), an edge with more than two
//! faces; plus one `clean` does not look for: a vertex whose faces form more
//! than one fan (two surfaces touching at a point).

use rayon::prelude::*;
use rustc_hash::FxHashMap;

use crate::geom::mesh_ops::clean::{position_key, repeats_index, triangle_cross};

/// Faces around each vertex, as compressed rows: the faces of vertex `v`
/// are `faces[start[v]..start[v + 1]]`, in increasing order.
pub struct VertexFaces {
    pub start: Vec<u32>,
    pub faces: Vec<u32>,
}

impl VertexFaces {
    /// Builds the rows for `faces` over `nv` vertices (indices must be
    /// below `nv`).
    pub fn new(faces: &[[u32; 3]], nv: usize) -> Self {
        let mut start = vec![0u32; nv + 1];
        for f in faces {
            for &v in f {
                start[v as usize + 1] += 1;
            }
        }
        for i in 0..nv {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut rows = vec![0u32; start[nv] as usize];
        for (i, f) in faces.iter().enumerate() {
            for &v in f {
                rows[fill[v as usize] as usize] = i as u32;
                fill[v as usize] += 1;
            }
        }
        VertexFaces { start, faces: rows }
    }

    /// The faces of vertex `v`.
    pub fn of(&self, v: usize) -> &[u32] {
        &self.faces[self.start[v] as usize..self.start[v + 1] as usize]
    }
}

/// What the faces around one vertex say about it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VertexStar {
    /// Some face is used by the vertex.
    pub used: bool,
    /// An edge at the vertex has more than two faces, or its faces form
    /// more than one fan.
    pub nonmanifold: bool,
    /// Edges `(v, w)` with `w > v` (each edge counted at its lower end).
    pub edges_above: u32,
    /// Some edge at the vertex has one face only.
    pub border: bool,
}

/// The star of every vertex (in parallel; the result does not depend on
/// the thread count). Faces with a repeated index are skipped.
pub fn vertex_stars(faces: &[[u32; 3]], vf: &VertexFaces) -> Vec<VertexStar> {
    let nv = vf.start.len() - 1;
    (0..nv)
        .into_par_iter()
        .map_init(Vec::new, |pairs: &mut Vec<(u32, u32)>, v| {
            let around = vf.of(v);
            let nfaces = star_pairs(faces, around, v, pairs);
            if nfaces == 0 {
                return VertexStar::default();
            }
            // Fans: faces joined through a shared edge (v, w); union-find
            // over the local face slots.
            let mut parent: Vec<u32> = (0..around.len() as u32).collect();
            let mut joins = 0u32;
            let mut nonmanifold = false;
            let mut border = false;
            let mut edges_above = 0u32;
            let mut i = 0;
            while i < pairs.len() {
                let mut j = i + 1;
                while j < pairs.len() && pairs[j].0 == pairs[i].0 {
                    j += 1;
                }
                if pairs[i].0 as usize > v {
                    edges_above += 1;
                }
                match j - i {
                    1 => border = true,
                    2 => {
                        let (a, b) = (
                            root(&mut parent, pairs[i].1),
                            root(&mut parent, pairs[i + 1].1),
                        );
                        if a != b {
                            parent[a as usize] = b;
                            joins += 1;
                        }
                    }
                    _ => nonmanifold = true,
                }
                i = j;
            }
            VertexStar {
                used: true,
                nonmanifold: nonmanifold || nfaces - joins > 1,
                edges_above,
                border,
            }
        })
        .collect()
}

/// Fills `pairs` with `(w, slot)` for every other corner `w` of the faces
/// of `v` (`slot` = the face's place in `around`), sorted; faces with a
/// repeated index are skipped. Returns how many faces were used.
fn star_pairs(faces: &[[u32; 3]], around: &[u32], v: usize, pairs: &mut Vec<(u32, u32)>) -> u32 {
    pairs.clear();
    let mut nfaces = 0u32;
    for (k, &fi) in around.iter().enumerate() {
        let f = faces[fi as usize];
        if repeats_index(&f) {
            continue;
        }
        nfaces += 1;
        for &w in &f {
            if w as usize != v {
                pairs.push((w, k as u32));
            }
        }
    }
    pairs.sort_unstable();
    nfaces
}

/// Union-find root with path halving.
fn root(p: &mut [u32], mut i: u32) -> u32 {
    while p[i as usize] != i {
        p[i as usize] = p[p[i as usize] as usize];
        i = p[i as usize];
    }
    i
}

/// Vertices touched by a defect (see the module doc), as a flag per
/// vertex: the ends of an edge with more than two faces, a vertex with more
/// than one fan, the corners of degenerate and duplicate faces, and used
/// vertices sharing a point.
pub fn defect_vertices(
    faces: &[[u32; 3]],
    positions: &[[f32; 3]],
    stars: &[VertexStar],
) -> Vec<bool> {
    let mut bad: Vec<bool> = stars.iter().map(|s| s.nonmanifold).collect();
    let mut seen: FxHashMap<[u32; 3], u32> = FxHashMap::default();
    for (i, f) in faces.iter().enumerate() {
        let p = f.map(|v| positions[v as usize].map(f64::from));
        let x = triangle_cross(p[0], p[1], p[2]);
        let degenerate = repeats_index(f) || x[0] * x[0] + x[1] * x[1] + x[2] * x[2] == 0.0;
        let mut key = *f;
        key.sort_unstable();
        let duplicate = match seen.insert(key, i as u32) {
            Some(first) => {
                for &v in &faces[first as usize] {
                    bad[v as usize] = true;
                }
                true
            }
            None => false,
        };
        if degenerate || duplicate {
            for &v in f {
                bad[v as usize] = true;
            }
        }
    }
    let mut at: FxHashMap<[u32; 3], u32> = FxHashMap::default();
    for (v, s) in stars.iter().enumerate() {
        if !s.used {
            continue;
        }
        let key = position_key(&positions[v]);
        if let Some(&other) = at.get(&key) {
            bad[other as usize] = true;
            bad[v] = true;
        } else {
            at.insert(key, v as u32);
        }
    }
    bad
}

/// Pieces of the mesh (vertices joined through face edges) and each
/// piece's Euler characteristic `V − E + F` over its used vertices.
pub struct Pieces {
    /// Piece of each vertex (`u32::MAX` for an unused vertex).
    pub label: Vec<u32>,
    /// `V − E + F` of each piece.
    pub euler: Vec<i64>,
}

/// Labels the pieces of `faces` and counts their Euler characteristic;
/// labels are numbered in order of each piece's lowest vertex. Faces with
/// a repeated index are left out.
pub fn pieces(faces: &[[u32; 3]], stars: &[VertexStar]) -> Pieces {
    let nv = stars.len();
    let mut parent: Vec<u32> = (0..nv as u32).collect();
    for f in faces.iter().filter(|f| !repeats_index(f)) {
        let mut r0 = root(&mut parent, f[0]);
        for &w in &f[1..] {
            let r = root(&mut parent, w);
            if r != r0 {
                // The lower index becomes the root, so each root is its
                // piece's lowest vertex.
                let (lo, hi) = (r.min(r0), r.max(r0));
                parent[hi as usize] = lo;
                r0 = lo;
            }
        }
    }
    let mut label = vec![u32::MAX; nv];
    let mut euler: Vec<i64> = Vec::new();
    for v in 0..nv {
        if !stars[v].used {
            continue;
        }
        let r = root(&mut parent, v as u32) as usize;
        let l = if r == v {
            euler.push(0);
            (euler.len() - 1) as u32
        } else {
            label[r]
        };
        label[v] = l;
        euler[l as usize] += 1 - stars[v].edges_above as i64;
    }
    for f in faces {
        if !repeats_index(f) {
            euler[label[f[0] as usize] as usize] += 1;
        }
    }
    Pieces { label, euler }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stars(faces: &[[u32; 3]], nv: usize) -> Vec<VertexStar> {
        vertex_stars(faces, &VertexFaces::new(faces, nv))
    }

    /// A closed tetrahedron: every vertex one closed fan, χ = 2; a lone
    /// triangle beside it is a second piece with χ = 1.
    #[test]
    fn tetrahedron_and_triangle() {
        let f = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2], [4, 5, 6]];
        let s = stars(&f, 7);
        assert!(s.iter().all(|s| s.used && !s.nonmanifold));
        let p = pieces(&f, &s);
        assert_eq!(p.euler, vec![2, 1]);
        assert_eq!(p.label, vec![0, 0, 0, 0, 1, 1, 1]);
    }

    /// Three faces on one edge (a book): both ends non-manifold. Two
    /// triangles touching at one vertex (a bow tie): that vertex only.
    #[test]
    fn book_and_bow_tie() {
        let s = stars(&[[0, 1, 2], [1, 0, 3], [0, 1, 4]], 5);
        assert_eq!(
            s.iter().map(|s| s.nonmanifold).collect::<Vec<_>>(),
            [true, true, false, false, false]
        );
        let s = stars(&[[0, 1, 2], [0, 3, 4]], 5);
        assert_eq!(
            s.iter().map(|s| s.nonmanifold).collect::<Vec<_>>(),
            [true, false, false, false, false]
        );
    }

    /// Defects: a duplicate face marks both copies' corners, a zero-area
    /// face its corners, two used vertices on one point both; an unused
    /// vertex on a used one's point is not a defect.
    #[test]
    fn defects_found() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0],
            [-0.0, 0.0, 0.0],
            [5.0, 5.0, 5.0],
            [6.0, 5.0, 5.0],
            [5.0, 6.0, 5.0],
        ];
        let f = [[0, 1, 2], [0, 1, 3]];
        let s = stars(&f, 8);
        assert_eq!(
            defect_vertices(&f, &p, &s),
            [true, true, false, true, false, false, false, false]
        );
        let f = [[5, 6, 7], [7, 6, 5]];
        let s = stars(&f, 8);
        assert_eq!(defect_vertices(&f, &p, &s)[5..], [true, true, true]);
        let f = [[0, 1, 2], [4, 6, 7]];
        let s = stars(&f, 8);
        let d = defect_vertices(&f, &p, &s);
        assert!(d[0] && d[4] && !d[1] && !d[6]);
    }

    /// Piece labels equal those of a plain flood fill on random faces over
    /// few vertices (many merges in every order: a union that forgot an
    /// earlier merge in the same face split pieces here).
    #[test]
    fn pieces_match_a_flood_fill() {
        let mut x = 12345u64;
        let mut next = |n: u32| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((x >> 33) % n as u64) as u32
        };
        for _ in 0..50 {
            let nv = 60;
            let faces: Vec<[u32; 3]> = (0..25).map(|_| [next(nv), next(nv), next(nv)]).collect();
            let s = stars(&faces, nv as usize);
            let p = pieces(&faces, &s);
            // Flood fill: relax labels to the minimum over each face.
            let mut lab: Vec<u32> = (0..nv).collect();
            loop {
                let mut changed = false;
                for f in faces.iter().filter(|f| !repeats_index(f)) {
                    let m = f.iter().map(|&v| lab[v as usize]).min().unwrap();
                    for &v in f {
                        if lab[v as usize] != m {
                            lab[v as usize] = m;
                            changed = true;
                        }
                    }
                }
                if !changed {
                    break;
                }
            }
            for a in 0..nv as usize {
                for b in 0..nv as usize {
                    if s[a].used && s[b].used {
                        assert_eq!(lab[a] == lab[b], p.label[a] == p.label[b], "{faces:?}");
                    }
                }
            }
        }
    }
}
