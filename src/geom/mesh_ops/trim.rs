//! Density trimming of Poisson meshes by a per-vertex scalar (`density`).
//!
//! - [`trim_quantile`]: SuGaR's rule: remove every vertex whose value is
//!   below the q-quantile of all values (numpy's default, linear
//!   interpolation between order statistics), with its faces.
//! - [`trim_threshold`]: PoissonRecon `SurfaceTrimmer --trim t`: keep the part
//!   of the surface where the linearly interpolated value is ≥ t, clipping
//!   triangles along the iso-line of the value. A new vertex on an edge is
//!   shared by the faces on both sides of the edge (no cracks); its position,
//!   normal, colour and scalars are interpolated (the trimmed scalar is exactly
//!   t there), other extra vertex properties are copied from the nearer end.
//!
//! Both keep every attribute of the surviving vertices and faces and drop
//! vertices no face uses any more.

use rustc_hash::FxHashMap;

use crate::geom::mesh_ops::clean::{filter_faces, remove_unreferenced_vertices};
use crate::model::Mesh;
use crate::{Error, Result};

/// numpy `quantile(values, q)` with the default linear method.
pub fn quantile(values: &[f32], q: f64) -> f64 {
    let mut v: Vec<f64> = values
        .iter()
        .map(|&x| x as f64)
        .filter(|x| !x.is_nan())
        .collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_unstable_by(f64::total_cmp);
    let pos = q.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = (lo + 1).min(v.len() - 1);
    v[lo] + (pos - lo as f64) * (v[hi] - v[lo])
}

fn scalar<'a>(mesh: &'a Mesh, name: &str) -> Result<&'a [f32]> {
    mesh.scalar(name)
        .ok_or_else(|| Error::invalid(format!("the mesh has no per-vertex '{name}' to trim by")))
}

/// Keeps the faces whose three vertices are kept, then drops unused vertices.
/// Returns the mesh and how many vertices were removed.
fn keep_vertices(mut mesh: Mesh, keep_v: &[bool]) -> (Mesh, usize) {
    let keep_f: Vec<bool> = mesh
        .faces
        .iter()
        .map(|f| f.iter().all(|&v| keep_v[v as usize]))
        .collect();
    filter_faces(&mut mesh, &keep_f);
    let removed = remove_unreferenced_vertices(&mut mesh);
    (mesh, removed)
}

/// Weighted linear quantile: value i counts `weights[i]` times (weights ≤ 0
/// and NaN values are ignored). Each order statistic sits at the centre of
/// its weight on the cumulative-weight axis and the quantile interpolates
/// linearly between the first and last centres; with equal weights this is
/// numpy's default (`quantile` with method "linear").
pub fn weighted_quantile(values: &[f32], weights: &[f64], q: f64) -> f64 {
    let mut v: Vec<(f64, f64)> = values
        .iter()
        .zip(weights)
        .filter(|(x, w)| !x.is_nan() && **w > 0.0)
        .map(|(&x, &w)| (x as f64, w))
        .collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    // Position of each order statistic on [0, 1]: (cumulative weight before
    // its centre) / (total − average weight), numpy's (i / (n − 1)) when equal.
    let mut cum = 0.0;
    let mut pos = Vec::with_capacity(v.len());
    for (_, w) in &v {
        pos.push(cum + 0.5 * w);
        cum += w;
    }
    let (p0, p1) = (pos[0], pos[pos.len() - 1]);
    if p1 <= p0 {
        return v[0].0;
    }
    let target = p0 + q.clamp(0.0, 1.0) * (p1 - p0);
    let i = pos.partition_point(|&p| p <= target).clamp(1, v.len() - 1);
    let (a, b) = (pos[i - 1], pos[i]);
    let s = if b > a {
        ((target - a) / (b - a)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    v[i - 1].0 + s * (v[i].0 - v[i - 1].0)
}

/// SuGaR trimming with per-vertex weights (how many vertices of an
/// octree-adaptive extraction each vertex stands for): the threshold is the
/// weighted q-quantile. Returns the mesh, the threshold and the number of
/// vertices removed.
pub fn trim_quantile_weighted(
    mesh: Mesh,
    name: &str,
    q: f64,
    weights: &[f64],
) -> Result<(Mesh, f64, usize)> {
    if !(0.0..=1.0).contains(&q) {
        return Err(Error::invalid(format!(
            "trim quantile must be in [0, 1] (got {q})"
        )));
    }
    let vals = scalar(&mesh, name)?.to_vec();
    let t = weighted_quantile(&vals, weights, q);
    let keep: Vec<bool> = vals.iter().map(|&v| (v as f64) >= t).collect();
    let (m, removed) = keep_vertices(mesh, &keep);
    Ok((m, t, removed))
}

/// SuGaR trimming: drops vertices with value < quantile(values, q) and their
/// faces. Returns the mesh, the threshold and the number of vertices removed.
pub fn trim_quantile(mesh: Mesh, name: &str, q: f64) -> Result<(Mesh, f64, usize)> {
    if !(0.0..=1.0).contains(&q) {
        return Err(Error::invalid(format!(
            "trim quantile must be in [0, 1] (got {q})"
        )));
    }
    let vals = scalar(&mesh, name)?.to_vec();
    let t = quantile(&vals, q);
    let keep: Vec<bool> = vals.iter().map(|&v| (v as f64) >= t).collect();
    let (m, removed) = keep_vertices(mesh, &keep);
    Ok((m, t, removed))
}

/// SurfaceTrimmer trimming: keeps the region where the interpolated value is
/// ≥ `t`, clipping faces along the iso-line. Returns the mesh and the number
/// of faces before minus after (negative when clipping split faces).
pub fn trim_threshold(mesh: Mesh, name: &str, t: f64) -> Result<(Mesh, i64)> {
    let vals: Vec<f64> = scalar(&mesh, name)?.iter().map(|&v| v as f64).collect();
    let faces_before = mesh.faces.len() as i64;
    let mut m = mesh;
    let inside = |v: u32| vals[v as usize] >= t;
    // New vertices on crossing edges, shared by both sides: (a, b, s) with
    // position a + s (b - a).
    let mut cuts: FxHashMap<(u32, u32), u32> = FxHashMap::default();
    let mut new_verts: Vec<(u32, u32, f64)> = Vec::new();
    let nv = m.vertices.len() as u32;
    let mut cut = |a: u32, b: u32| -> u32 {
        let key = (a.min(b), a.max(b));
        *cuts.entry(key).or_insert_with(|| {
            let (lo, hi) = key;
            let s =
                ((t - vals[lo as usize]) / (vals[hi as usize] - vals[lo as usize])).clamp(0.0, 1.0);
            new_verts.push((lo, hi, s));
            nv + new_verts.len() as u32 - 1
        })
    };
    let mut faces = Vec::with_capacity(m.faces.len());
    let mut src_face = Vec::with_capacity(m.faces.len());
    for (fi, f) in m.faces.iter().enumerate() {
        let ins = f.map(inside);
        if ins.iter().all(|&x| x) {
            faces.push(*f);
            src_face.push(fi);
            continue;
        }
        if !ins.iter().any(|&x| x) {
            continue;
        }
        // Clip the polygon against value ≥ t, keeping the winding.
        let mut poly = Vec::with_capacity(4);
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            if ins[k] {
                poly.push(a);
            }
            if ins[k] != ins[(k + 1) % 3] {
                poly.push(cut(a, b));
            }
        }
        for k in 1..poly.len() - 1 {
            faces.push([poly[0], poly[k], poly[k + 1]]);
            src_face.push(fi);
        }
    }
    // Per-face attributes follow their source face.
    if let Some(c) = &mut m.face_colors {
        *c = src_face.iter().map(|&i| c[i]).collect();
    }
    for p in &mut m.extras.item {
        p.data = p.data.gather(&src_face);
    }
    m.faces = faces;
    // Interpolated attributes of the new vertices.
    let lerp3 = |a: [f32; 3], b: [f32; 3], s: f64| -> [f32; 3] {
        let s = s as f32;
        [
            a[0] + s * (b[0] - a[0]),
            a[1] + s * (b[1] - a[1]),
            a[2] + s * (b[2] - a[2]),
        ]
    };
    for &(a, b, s) in &new_verts {
        let (a, b) = (a as usize, b as usize);
        let p = lerp3(m.vertices[a], m.vertices[b], s);
        m.vertices.push(p);
        if let Some(n) = &mut m.normals {
            let v = lerp3(n[a], n[b], s);
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            n.push(if l > 0.0 {
                [v[0] / l, v[1] / l, v[2] / l]
            } else {
                n[a]
            });
        }
        if let Some(c) = &mut m.vertex_colors {
            let mix =
                |k: usize| (c[a][k] as f64 + s * (c[b][k] as f64 - c[a][k] as f64)).round() as u8;
            let v = [mix(0), mix(1), mix(2), mix(3)];
            c.push(v);
        }
        for (n, v) in &mut m.vertex_scalars {
            let x = if n == name {
                t as f32
            } else {
                v[a] + s as f32 * (v[b] - v[a])
            };
            v.push(x);
        }
    }
    if !m.extras.vertex.is_empty() {
        let mut idx: Vec<usize> = (0..nv as usize).collect();
        idx.extend(
            new_verts
                .iter()
                .map(|&(a, b, s)| if s < 0.5 { a as usize } else { b as usize }),
        );
        for p in &mut m.extras.vertex {
            p.data = p.data.gather(&idx);
        }
    }
    remove_unreferenced_vertices(&mut m);
    let after = m.faces.len() as i64;
    Ok((m, faces_before - after))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An n×n grid of unit squares on [0, n]² (z = 0), value = x.
    fn grid(n: usize) -> Mesh {
        let mut v = Vec::new();
        let mut s = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                v.push([i as f32, j as f32, 0.0]);
                s.push(i as f32);
            }
        }
        let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let mut f = Vec::new();
        for j in 0..n {
            for i in 0..n {
                f.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                f.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        let mut m = Mesh::new(v, f);
        m.vertex_scalars.push(("density".into(), s));
        m
    }

    fn area(m: &Mesh) -> f64 {
        m.faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| m.vertices[i as usize]);
                let u = [b[0] - a[0], b[1] - a[1]];
                let w = [c[0] - a[0], c[1] - a[1]];
                0.5 * (u[0] * w[1] - u[1] * w[0]) as f64
            })
            .sum()
    }

    #[test]
    fn numpy_quantile() {
        // numpy.quantile([1, 2, 3, 4], 0.1) = 1.3; ([5, 1, 3], 0.5) = 3
        assert!((quantile(&[1.0, 2.0, 3.0, 4.0], 0.1) - 1.3).abs() < 1e-12);
        assert_eq!(quantile(&[5.0, 1.0, 3.0], 0.5), 3.0);
        // Equal weights reproduce numpy; weights move the centres: values
        // 1, 2, 3 with weights 1, 3, 1 have centres 0.5, 2.5, 4.5 on the
        // cumulative axis, so the median is 2 and the 0.1-quantile (at 0.9)
        // is 1 + 0.4/2 = 1.2.
        let w = weighted_quantile(&[1.0, 2.0, 3.0, 4.0], &[1.0; 4], 0.1);
        assert!((w - 1.3).abs() < 1e-12);
        let w = weighted_quantile(&[1.0, 2.0, 3.0], &[1.0, 3.0, 1.0], 0.5);
        assert!((w - 2.0).abs() < 1e-12);
        let w = weighted_quantile(&[3.0, 1.0, 2.0], &[1.0, 1.0, 3.0], 0.1);
        assert!((w - 1.2).abs() < 1e-12, "{w}");
    }

    #[test]
    fn quantile_trim_drops_low_vertices_and_their_faces() {
        // values are x ∈ {0..10} on 11 columns: q = 0.1 → threshold 1.0,
        // so column x = 0 goes with the 20 faces touching it.
        let (m, t, removed) = trim_quantile(grid(10), "density", 0.1).unwrap();
        assert!((t - 1.0).abs() < 1e-12);
        assert_eq!(removed, 11);
        assert_eq!(m.faces.len(), 200 - 20);
        assert!(m.scalar("density").unwrap().iter().all(|&v| v >= 1.0));
        assert!(m.validate().is_ok());
    }

    #[test]
    fn threshold_trim_clips_exactly_on_the_iso_line() {
        // Keep x ≥ 3.4 on a 10×10 grid: area exactly (10 − 3.4) · 10 = 66.
        let (m, _) = trim_threshold(grid(10), "density", 3.4).unwrap();
        assert!((area(&m) - 66.0).abs() < 1e-4, "{}", area(&m));
        let xs: Vec<f32> = m.vertices.iter().map(|v| v[0]).collect();
        assert!(xs.iter().all(|&x| x >= 3.4 - 1e-5));
        // New boundary vertices are shared: the cut line x = 3.4 has 11
        // vertices (one per horizontal grid line crossing it) plus the ones on
        // diagonals crossing it (10), and each boundary edge has one face.
        let on_cut = xs.iter().filter(|&&x| (x - 3.4).abs() < 1e-5).count();
        assert_eq!(on_cut, 21);
        let mut edges: FxHashMap<(u32, u32), usize> = FxHashMap::default();
        for f in &m.faces {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        // boundary = rectangle perimeter split at vertices: 20 on the cut
        // line, 10 + 10 on the top and bottom rows (7 grid cells + 2 partial… )
        let boundary = edges.values().filter(|&&c| c == 1).count();
        let interior_bad = edges.values().filter(|&&c| c > 2).count();
        assert_eq!(interior_bad, 0);
        // perimeter vertices: 21 on the cut, 10 on the right edge (x=10,
        // excluding corners counted below), 7 per top/bottom row (x = 4..=10)
        // → a closed boundary loop has as many edges as vertices: 21 + 9 + 7 + 7.
        assert_eq!(boundary, 21 + 9 + 7 + 7);
        assert!(
            (m.scalar("density")
                .unwrap()
                .iter()
                .cloned()
                .fold(f32::INFINITY, f32::min)
                - 3.4)
                .abs()
                < 1e-6
        );
    }
}
