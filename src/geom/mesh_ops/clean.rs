//! Mesh clean-up steps, each a pure function on [`Mesh`] that keeps every
//! per-vertex and per-face attribute aligned and returns how much it removed.
//! Semantics follow Open3D's `remove_*` methods (which SuGaR runs after
//! decimation), stated per function. All are deterministic.

use rustc_hash::FxHashMap;

use crate::model::Mesh;

/// Removes faces where `keep` is false, with their per-face attributes.
pub fn filter_faces(mesh: &mut Mesh, keep: &[bool]) {
    let mut it = keep.iter();
    mesh.faces
        .retain(|_| *it.next().expect("one flag per face"));
    if let Some(c) = &mut mesh.face_colors {
        let mut it = keep.iter();
        c.retain(|_| *it.next().expect("one flag per face"));
    }
    for p in &mut mesh.extras.item {
        p.data = p.data.filter(keep);
    }
}

/// Replaces every per-vertex array by its rows `idx`.
pub fn gather_vertices(mesh: &mut Mesh, idx: &[usize]) {
    fn g<T: Copy>(v: &[T], idx: &[usize]) -> Vec<T> {
        idx.iter().map(|&i| v[i]).collect()
    }
    mesh.vertices = g(&mesh.vertices, idx);
    if let Some(n) = &mut mesh.normals {
        *n = g(n, idx);
    }
    if let Some(c) = &mut mesh.vertex_colors {
        *c = g(c, idx);
    }
    for (_, s) in &mut mesh.vertex_scalars {
        *s = g(s, idx);
    }
    for p in &mut mesh.extras.vertex {
        p.data = p.data.gather(idx);
    }
}

/// Drops vertices no face references (Open3D
/// `remove_unreferenced_vertices`), reindexing faces and attributes.
/// Returns how many were dropped.
pub fn remove_unreferenced_vertices(mesh: &mut Mesh) -> usize {
    let n = mesh.vertices.len();
    let mut used = vec![false; n];
    for f in &mesh.faces {
        for &v in f {
            used[v as usize] = true;
        }
    }
    let mut map = vec![u32::MAX; n];
    let mut idx = Vec::new();
    for (i, &u) in used.iter().enumerate() {
        if u {
            map[i] = idx.len() as u32;
            idx.push(i);
        }
    }
    if idx.len() == n {
        return 0;
    }
    for f in &mut mesh.faces {
        for v in f.iter_mut() {
            *v = map[*v as usize];
        }
    }
    gather_vertices(mesh, &idx);
    n - idx.len()
}

/// The key two positions share exactly when they are the same point:
/// their bits, with `-0.0` taken as `+0.0`.
pub fn position_key(p: &[f32; 3]) -> [u32; 3] {
    p.map(|c| if c == 0.0 { 0 } else { c.to_bits() })
}

/// Whether face `f` names one vertex twice (Open3D's degenerate triangle).
pub fn repeats_index(f: &[u32; 3]) -> bool {
    f[0] == f[1] || f[1] == f[2] || f[0] == f[2]
}

/// Merges vertices with bit-identical positions into the first of them
/// (Open3D `remove_duplicated_vertices`); faces are re-pointed, the merged
/// copies' attributes are dropped. Returns how many vertices went.
pub fn merge_duplicate_vertices(mesh: &mut Mesh) -> usize {
    let mut first: FxHashMap<[u32; 3], u32> = FxHashMap::default();
    let mut map = Vec::with_capacity(mesh.vertices.len());
    let mut any = false;
    for (i, p) in mesh.vertices.iter().enumerate() {
        let key = position_key(p);
        let j = *first.entry(key).or_insert(i as u32);
        any |= j != i as u32;
        map.push(j);
    }
    if !any {
        return 0;
    }
    for f in &mut mesh.faces {
        for v in f.iter_mut() {
            *v = map[*v as usize];
        }
    }
    remove_unreferenced_vertices(mesh)
}

/// (b − a) × (c − a): twice the triangle's area times its unit normal
/// (counter-clockwise winding).
pub fn triangle_cross(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

/// The corners of face `f` in f64.
pub fn face_corners(m: &Mesh, f: &[u32; 3]) -> [[f64; 3]; 3] {
    f.map(|i| m.vertices[i as usize].map(|x| x as f64))
}

/// Area of face `f`.
pub fn face_area(m: &Mesh, f: &[u32; 3]) -> f64 {
    let [a, b, c] = face_corners(m, f);
    let x = triangle_cross(a, b, c);
    0.5 * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
}

/// Signed enclosed volume (positive for a closed mesh whose faces wind
/// counter-clockwise seen from outside).
pub fn signed_volume(m: &Mesh) -> f64 {
    m.faces
        .iter()
        .map(|f| {
            let [a, b, c] = face_corners(m, f);
            let x = triangle_cross([0.0; 3], b, c);
            (a[0] * x[0] + a[1] * x[1] + a[2] * x[2]) / 6.0
        })
        .sum()
}

fn area2(m: &Mesh, f: &[u32; 3]) -> f64 {
    2.0 * face_area(m, f)
}

/// Removes faces with a repeated vertex index (Open3D
/// `remove_degenerate_triangles`) and, beyond Open3D, faces of exactly zero
/// area (three distinct but collinear or coincident vertices). Returns how
/// many faces went.
pub fn remove_degenerate_faces(mesh: &mut Mesh) -> usize {
    let keep: Vec<bool> = mesh
        .faces
        .iter()
        .map(|f| !repeats_index(f) && area2(mesh, f) > 0.0)
        .collect();
    let n = keep.iter().filter(|k| !**k).count();
    if n > 0 {
        filter_faces(mesh, &keep);
    }
    n
}

/// Removes faces with the same vertex set as an earlier face, whatever
/// their order or winding (Open3D `remove_duplicated_triangles`). Returns
/// how many went.
pub fn remove_duplicate_faces(mesh: &mut Mesh) -> usize {
    let mut seen: FxHashMap<[u32; 3], ()> = FxHashMap::default();
    let keep: Vec<bool> = mesh
        .faces
        .iter()
        .map(|f| {
            let mut k = *f;
            k.sort_unstable();
            seen.insert(k, ()).is_none()
        })
        .collect();
    let n = keep.iter().filter(|k| !**k).count();
    if n > 0 {
        filter_faces(mesh, &keep);
    }
    n
}

/// Makes every edge have at most two faces (Open3D
/// `remove_non_manifold_edges`): while an edge has more than two faces, its
/// adjacent face with the smallest area is removed (ties: the later face).
/// Edges are visited in order of their vertex indices. Returns how many
/// faces went.
pub fn remove_non_manifold_edges(mesh: &mut Mesh) -> usize {
    let mut edges: FxHashMap<(u32, u32), Vec<u32>> = FxHashMap::default();
    for (i, f) in mesh.faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            edges
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(i as u32);
        }
    }
    let mut bad: Vec<(u32, u32)> = edges
        .iter()
        .filter(|(_, v)| v.len() > 2)
        .map(|(k, _)| *k)
        .collect();
    if bad.is_empty() {
        return 0;
    }
    bad.sort_unstable();
    let mut alive = vec![true; mesh.faces.len()];
    for e in bad {
        let mut faces: Vec<u32> = edges[&e]
            .iter()
            .copied()
            .filter(|&f| alive[f as usize])
            .collect();
        faces.sort_by(|&a, &b| {
            area2(mesh, &mesh.faces[a as usize])
                .total_cmp(&area2(mesh, &mesh.faces[b as usize]))
                .then(b.cmp(&a))
        });
        let excess = faces.len().saturating_sub(2);
        for &f in faces.iter().take(excess) {
            alive[f as usize] = false;
        }
    }
    let n = alive.iter().filter(|a| !**a).count();
    filter_faces(mesh, &alive);
    n
}

/// Connected components over shared edges: a label per face, labels
/// numbered by their first face.
pub fn face_components(mesh: &Mesh) -> Vec<u32> {
    let nf = mesh.faces.len();
    let mut parent: Vec<u32> = (0..nf as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    let mut owner: FxHashMap<(u32, u32), u32> = FxHashMap::default();
    for (i, f) in mesh.faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            match owner.entry((a.min(b), a.max(b))) {
                std::collections::hash_map::Entry::Occupied(o) => {
                    let (x, y) = (find(&mut parent, i as u32), find(&mut parent, *o.get()));
                    if x != y {
                        parent[x.max(y) as usize] = x.min(y);
                    }
                }
                std::collections::hash_map::Entry::Vacant(v) => {
                    v.insert(i as u32);
                }
            }
        }
    }
    let mut label = vec![u32::MAX; nf];
    let mut next = 0;
    let mut root_label: FxHashMap<u32, u32> = FxHashMap::default();
    for (i, l) in label.iter_mut().enumerate() {
        let r = find(&mut parent, i as u32);
        *l = *root_label.entry(r).or_insert_with(|| {
            next += 1;
            next - 1
        });
    }
    label
}

/// Which components to keep.
#[derive(Clone, Copy, Debug, Default)]
pub struct ComponentFilter {
    /// Keep the N components with the most faces (ties: the earlier one).
    pub keep_largest: Option<usize>,
    /// Drop components with fewer faces.
    pub min_faces: Option<usize>,
    /// Drop components whose area is below this fraction of the total.
    pub min_area_fraction: Option<f64>,
}

/// Removes the components the filter rejects, then unreferenced vertices.
/// Returns (components before, components removed, faces removed).
pub fn filter_components(mesh: &mut Mesh, flt: &ComponentFilter) -> (usize, usize, usize) {
    let label = face_components(mesh);
    let nc = label.iter().map(|&l| l as usize + 1).max().unwrap_or(0);
    let mut faces = vec![0usize; nc];
    let mut area = vec![0f64; nc];
    for (i, f) in mesh.faces.iter().enumerate() {
        faces[label[i] as usize] += 1;
        area[label[i] as usize] += 0.5 * area2(mesh, f);
    }
    let total: f64 = area.iter().sum();
    let mut keep_c = vec![true; nc];
    if let Some(n) = flt.keep_largest {
        let mut order: Vec<usize> = (0..nc).collect();
        order.sort_by(|&a, &b| faces[b].cmp(&faces[a]).then(a.cmp(&b)));
        for &c in order.iter().skip(n) {
            keep_c[c] = false;
        }
    }
    for c in 0..nc {
        if flt.min_faces.is_some_and(|m| faces[c] < m)
            || flt.min_area_fraction.is_some_and(|f| area[c] < f * total)
        {
            keep_c[c] = false;
        }
    }
    let keep: Vec<bool> = label.iter().map(|&l| keep_c[l as usize]).collect();
    let removed_faces = keep.iter().filter(|k| !**k).count();
    if removed_faces > 0 {
        filter_faces(mesh, &keep);
        remove_unreferenced_vertices(mesh);
    }
    (nc, keep_c.iter().filter(|k| !**k).count(), removed_faces)
}

/// Area-weighted vertex normals from the faces (unit length; zero for
/// vertices of zero-area faces only).
pub fn vertex_normals(mesh: &Mesh) -> Vec<[f32; 3]> {
    let mut acc = vec![[0.0f64; 3]; mesh.vertices.len()];
    for f in &mesh.faces {
        let [a, b, c] = face_corners(mesh, f);
        let x = triangle_cross(a, b, c);
        for &i in f {
            for k in 0..3 {
                acc[i as usize][k] += x[k];
            }
        }
    }
    acc.iter()
        .map(|n| {
            let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if l > 0.0 {
                [(n[0] / l) as f32, (n[1] / l) as f32, (n[2] / l) as f32]
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad_fan() -> Mesh {
        // Three triangles sharing edge (0,1) — a non-manifold "book" — plus
        // a duplicate of face 0 with flipped winding, a degenerate face and an
        // unreferenced vertex 6.
        let v = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 1.0, 0.0],  // big
            [0.5, -0.1, 0.0], // small
            [0.5, 0.0, 2.0],  // biggest
            [0.0, 0.0, 0.0],  // duplicate of vertex 0
            [9.0, 9.0, 9.0],  // unreferenced
        ];
        let f = vec![
            [0, 1, 2],
            [1, 0, 3],
            [0, 1, 4],
            [2, 1, 0],
            [0, 0, 1],
            [5, 2, 4],
        ];
        let mut m = Mesh::new(v, f);
        m.vertex_scalars
            .push(("density".into(), (0..7).map(|i| i as f32).collect()));
        m
    }

    #[test]
    fn each_step_removes_what_it_should() {
        let mut m = quad_fan();
        assert_eq!(merge_duplicate_vertices(&mut m), 2); // vertex 5 merged, vertex 6 unreferenced
        assert_eq!(m.vertices.len(), 5);
        assert_eq!(m.faces[5], [0, 2, 4]);
        assert_eq!(m.scalar("density").unwrap(), &[0.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(remove_degenerate_faces(&mut m), 1);
        assert_eq!(remove_duplicate_faces(&mut m), 1); // [2,1,0] duplicates [0,1,2]
        // edge (0,1) now has faces [0,1,2], [1,0,3], [0,1,4]: the smallest
        // (the one through vertex 3, area 0.05) goes.
        assert_eq!(remove_non_manifold_edges(&mut m), 1);
        assert_eq!(m.faces, vec![[0, 1, 2], [0, 1, 4], [0, 2, 4]]);
        assert_eq!(remove_unreferenced_vertices(&mut m), 1); // vertex 3
        assert_eq!(m.scalar("density").unwrap(), &[0.0, 1.0, 2.0, 4.0]);
        assert!(m.validate().is_ok());
    }

    #[test]
    fn components_keep_largest_and_min_faces() {
        // two disjoint strips: 4 faces and 2 faces
        let mut v = Vec::new();
        for i in 0..6 {
            v.push([i as f32, 0.0, 0.0]);
            v.push([i as f32, 1.0, 0.0]);
        }
        let strip = |s: u32, n: u32| -> Vec<[u32; 3]> {
            (0..n)
                .flat_map(|k| {
                    let a = 2 * (s + k);
                    [[a, a + 2, a + 1], [a + 1, a + 2, a + 3]]
                })
                .collect()
        };
        let mut f = strip(0, 2);
        f.extend(strip(3, 1));
        let mut m = Mesh::new(v, f);
        assert_eq!(face_components(&m), vec![0, 0, 0, 0, 1, 1]);
        let mut m2 = m.clone();
        let r = filter_components(
            &mut m2,
            &ComponentFilter {
                keep_largest: Some(1),
                ..Default::default()
            },
        );
        assert_eq!(r, (2, 1, 2));
        assert_eq!(m2.faces.len(), 4);
        assert_eq!(m2.vertices.len(), 6);
        let r = filter_components(
            &mut m,
            &ComponentFilter {
                min_area_fraction: Some(0.5),
                ..Default::default()
            },
        );
        assert_eq!(r.1, 1);
    }
}
