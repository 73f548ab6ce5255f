//! Quadric-error edge collapse (Garland–Heckbert 1997) that keeps the
//! topology of the surface: the engine behind `decimate`.
//!
//! Input: positions (any unit) and faces (`[u32; 3]`, orientation kept).
//! Output: the surviving faces (indices into the input vertices: a
//! surviving vertex keeps its index and so its attributes), the updated
//! positions of every vertex, and the largest collapse error.
//!
//! Rules, in the order they are applied:
//!
//! - Quadrics: each face adds the quadric of its plane to its corners,
//!   weighted by its area (squared distance × area, Open3D's
//!   `simplify_quadric_decimation` weighting); each border edge (one face)
//!   adds to its ends the quadric of the plane through the edge
//!   perpendicular to its face, weighted by [`BORDER_WEIGHT`] × length², so
//!   borders keep their shape.
//! - Cost of an edge: the summed quadric of its ends at the point that
//!   minimises it (the 3×3 solve), or, where that system is near singular
//!   or its solution lies more than one edge length from the edge's
//!   midpoint, at the best of the two ends and the midpoint.
//! - Order: in passes. Each pass costs every edge (in parallel), takes the
//!   cheapest quarter in order of cost (rounded to f32; ties in face
//!   order) and collapses each edge none of whose ends was touched by a
//!   collapse earlier in the pass (a collapse touches its survivor and the
//!   survivor's neighbours), so every collapse made is costed with the
//!   quadrics and positions of the moment. Passes go on until the target
//!   is met; a pass in which none of the cheapest quarter could go ranks
//!   all edges, and when none of those can go either, it stops. (Open3D
//!   keeps one heap of edges; the passes give the same Chamfer distance to
//!   the input — measured in docs/decimate.md — and cost the edges in
//!   parallel.)
//! - A collapse of edge `ab` (the end nearer the new point survives, with
//!   the summed quadric) is made only when
//!   1. the link condition holds (Dey, Edelsbrunner, Guha, Nekhayev 1999):
//!      every common neighbour of `a` and `b` is the third vertex of a face
//!      on `ab`; the edge has one or two faces and, with two faces `abx`,
//!      `aby`, `x ≠ y` and not both `axy` and `bxy` exist (a tetrahedron);
//!   2. when `a` and `b` are both on a border, `ab` is a border edge (an
//!      interior edge between two border points would pinch the surface);
//!   3. some face is left around `a` and `b` (a piece never vanishes);
//!   4. no face around `a` or `b` turns by more than [`MAX_TURN_DEG`] or
//!      loses all its area.
//!
//!   (1–2 keep a 2-manifold with border a 2-manifold of the same topology:
//!   no hole opens or closes, no handle goes, no piece splits or merges.)
//! - Vertices where the input is not a clean 2-manifold (an edge with more
//!   than two faces, more than one fan, a degenerate or duplicate face, two
//!   vertices on one point: [`super::manifold_check`]) are locked: never
//!   moved, never collapsed.
//! - Stop: when at most the target number of faces (or vertices) is left,
//!   or when no allowed collapse is left.
//!
//! The collapses of a pass are made one after another (each changes the
//! mesh the next is checked on); quadrics, costs and ranking are computed
//! in parallel, with results that do not depend on the thread count.

use glam::DVec3;
use rayon::prelude::*;

use super::clean::repeats_index;
use super::manifold_check::{VertexFaces, defect_vertices, vertex_stars};

/// Weight of the border-plane quadrics relative to the face quadrics.
pub const BORDER_WEIGHT: f64 = 10.0;

/// Largest turn of a face's normal a collapse may cause, in degrees.
pub const MAX_TURN_DEG: f64 = 75.0;

/// A pass collapses among the cheapest `1 / PASS_FRACTION` of the edges.
const PASS_FRACTION: usize = 4;

/// What the collapse stops at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// At most this many faces left.
    Faces(usize),
    /// At most this many used vertices left.
    Vertices(usize),
}

/// Result of [`collapse_edges`].
pub struct Collapsed {
    /// Surviving faces, as indices into the input vertices.
    pub faces: Vec<[u32; 3]>,
    /// Positions of every input vertex (moved where a collapse placed a
    /// survivor).
    pub positions: Vec<[f32; 3]>,
    /// Largest quadric error of a collapse made, as a distance: the square
    /// root of the error over the quadric's total weight.
    pub max_error: f64,
    /// Vertices locked because the input is not a clean manifold there.
    pub locked: usize,
}

/// Symmetric quadric `p'Ap + 2b'p + c` with its total weight.
#[derive(Clone, Copy, Debug, Default)]
struct Quadric {
    /// xx, xy, xz, yy, yz, zz.
    a: [f64; 6],
    b: [f64; 3],
    c: f64,
    w: f64,
}

impl Quadric {
    /// `w` × squared distance to the plane `n·p + d = 0` (`n` unit).
    fn plane(n: DVec3, d: f64, w: f64) -> Self {
        Quadric {
            a: [
                w * n.x * n.x,
                w * n.x * n.y,
                w * n.x * n.z,
                w * n.y * n.y,
                w * n.y * n.z,
                w * n.z * n.z,
            ],
            b: [w * d * n.x, w * d * n.y, w * d * n.z],
            c: w * d * d,
            w,
        }
    }

    fn add(&mut self, o: &Quadric) {
        for i in 0..6 {
            self.a[i] += o.a[i];
        }
        for i in 0..3 {
            self.b[i] += o.b[i];
        }
        self.c += o.c;
        self.w += o.w;
    }

    fn sum(&self, o: &Quadric) -> Quadric {
        let mut q = *self;
        q.add(o);
        q
    }

    fn eval(&self, p: DVec3) -> f64 {
        let a = &self.a;
        let DVec3 { x, y, z } = p;
        let v = a[0] * x * x
            + 2.0 * a[1] * x * y
            + 2.0 * a[2] * x * z
            + a[3] * y * y
            + 2.0 * a[4] * y * z
            + a[5] * z * z
            + 2.0 * (self.b[0] * x + self.b[1] * y + self.b[2] * z)
            + self.c;
        v.max(0.0)
    }

    /// The minimiser of the quadric, where the system is well conditioned.
    fn minimiser(&self) -> Option<DVec3> {
        let [a00, a01, a02, a11, a12, a22] = self.a;
        let c00 = a11 * a22 - a12 * a12;
        let c01 = a02 * a12 - a01 * a22;
        let c02 = a01 * a12 - a02 * a11;
        let det = a00 * c00 + a01 * c01 + a02 * c02;
        let scale = a00.abs().max(a11.abs()).max(a22.abs());
        if !positive(det.abs() - 1e-9 * scale * scale * scale) {
            return None;
        }
        let c11 = a00 * a22 - a02 * a02;
        let c12 = a01 * a02 - a00 * a12;
        let c22 = a00 * a11 - a01 * a01;
        let [b0, b1, b2] = self.b;
        // p = -A⁻¹ b, A⁻¹ = cofactors / det (symmetric).
        let p = DVec3::new(
            -(c00 * b0 + c01 * b1 + c02 * b2) / det,
            -(c01 * b0 + c11 * b1 + c12 * b2) / det,
            -(c02 * b0 + c12 * b1 + c22 * b2) / det,
        );
        p.is_finite().then_some(p)
    }
}

/// (b − a) × (c − a) of a triangle's corners: twice its area along its
/// normal.
fn face_cross(c: [DVec3; 3]) -> DVec3 {
    (c[1] - c[0]).cross(c[2] - c[0])
}

/// How many of the faces in `around` (the faces of one end of an edge)
/// hold the other end `b`.
fn faces_on_edge(around: &[u32], faces: &[[u32; 3]], b: u32) -> usize {
    around
        .iter()
        .filter(|&&f| faces[f as usize].contains(&b))
        .count()
}

/// `x > 0` (false for NaN).
fn positive(x: f64) -> bool {
    x > 0.0
}

struct State {
    pos: Vec<DVec3>,
    quad: Vec<Quadric>,
    faces: Vec<[u32; 3]>,
    face_alive: Vec<bool>,
    /// Faces around each vertex (live ones only).
    around: Vec<Vec<u32>>,
    border: Vec<bool>,
    locked: Vec<bool>,
    faces_left: usize,
    vertices_left: usize,
    /// Scratch marks for the link test (`stamp` = this test's value).
    mark: Vec<u32>,
    stamp: u32,
    cos_max_turn: f64,
}

impl State {
    /// Best point for collapsing `a`–`b` and its cost.
    fn placement(&self, a: u32, b: u32) -> (DVec3, f64) {
        let q = self.quad[a as usize].sum(&self.quad[b as usize]);
        let (pa, pb) = (self.pos[a as usize], self.pos[b as usize]);
        let mid = 0.5 * (pa + pb);
        if let Some(p) = q.minimiser()
            && p.distance(mid) <= pa.distance(pb)
        {
            return (p, q.eval(p));
        }
        let mut best = (pa, q.eval(pa));
        for p in [pb, mid] {
            let e = q.eval(p);
            if e < best.1 {
                best = (p, e);
            }
        }
        best
    }

    /// Drops dead faces from `v`'s list.
    fn tidy(&mut self, v: u32) {
        let alive = &self.face_alive;
        self.around[v as usize].retain(|&f| alive[f as usize]);
    }

    fn has_face(&self, v: u32, x: u32, y: u32) -> bool {
        self.around[v as usize].iter().any(|&f| {
            let t = self.faces[f as usize];
            t.contains(&x) && t.contains(&y)
        })
    }

    /// Whether collapsing `a` into `b` at `p` keeps the topology and the
    /// faces' orientation (the rules of the module doc).
    fn allowed(&mut self, a: u32, b: u32, p: DVec3) -> bool {
        let mut thirds = [u32::MAX; 2];
        let mut shared = 0;
        for &f in &self.around[a as usize] {
            let t = self.faces[f as usize];
            if t.contains(&b) {
                if shared == 2 {
                    return false;
                }
                thirds[shared] = t[0] ^ t[1] ^ t[2] ^ a ^ b;
                shared += 1;
            }
        }
        if shared == 0 {
            return false;
        }
        if shared == 2 && thirds[0] == thirds[1] {
            return false;
        }
        if self.border[a as usize] && self.border[b as usize] && shared != 1 {
            return false;
        }
        // Common neighbours: mark a's, then meet them from b (each counted
        // once: its mark is cleared when met).
        self.stamp = self.stamp.wrapping_add(1).max(1);
        let stamp = self.stamp;
        for &f in &self.around[a as usize] {
            for w in self.faces[f as usize] {
                self.mark[w as usize] = stamp;
            }
        }
        let mut common = 0;
        for k in 0..self.around[b as usize].len() {
            let f = self.around[b as usize][k];
            for w in self.faces[f as usize] {
                if w == a || w == b || self.mark[w as usize] != stamp {
                    continue;
                }
                if !thirds[..shared].contains(&w) {
                    return false;
                }
                self.mark[w as usize] = 0;
                common += 1;
            }
        }
        if common != shared {
            return false;
        }
        if shared == 2 {
            let (x, y) = (thirds[0], thirds[1]);
            if self.has_face(a, x, y) && self.has_face(b, x, y) {
                return false;
            }
        }
        let left = self.around[a as usize].len() + self.around[b as usize].len() - 2 * shared;
        if left == 0 {
            return false;
        }
        for v in [a, b] {
            for &f in &self.around[v as usize] {
                let t = self.faces[f as usize];
                if t.contains(&a) && t.contains(&b) {
                    continue;
                }
                let before = face_cross(t.map(|u| self.pos[u as usize]));
                let after = face_cross(t.map(|u| if u == v { p } else { self.pos[u as usize] }));
                let (lb, la) = (before.length(), after.length());
                if !positive(la) || before.dot(after) < self.cos_max_turn * lb * la {
                    return false;
                }
            }
        }
        true
    }

    /// Collapses `a` into `b`, `b` moving to `p`.
    fn collapse(&mut self, a: u32, b: u32, p: DVec3) {
        let qa = self.quad[a as usize];
        self.quad[b as usize].add(&qa);
        self.pos[b as usize] = p;
        self.border[b as usize] |= self.border[a as usize];
        self.vertices_left -= 1;
        let moved = std::mem::take(&mut self.around[a as usize]);
        let mut thirds = [u32::MAX; 2];
        let mut dead = 0;
        for f in moved {
            let t = &mut self.faces[f as usize];
            if t.contains(&b) {
                self.face_alive[f as usize] = false;
                self.faces_left -= 1;
                thirds[dead] = t[0] ^ t[1] ^ t[2] ^ a ^ b;
                dead += 1;
            } else {
                for u in t.iter_mut() {
                    if *u == a {
                        *u = b;
                    }
                }
                self.around[b as usize].push(f);
            }
        }
        self.tidy(b);
        // Every list holds live faces only.
        for &x in &thirds[..dead] {
            self.tidy(x);
        }
    }

    fn done(&self, stop: Stop) -> bool {
        match stop {
            Stop::Faces(n) => self.faces_left <= n,
            Stop::Vertices(n) => self.vertices_left <= n,
        }
    }

    /// The cheapest `1 / PASS_FRACTION` of the live edges with two
    /// unlocked ends (at least one; all of them with `all`), cheapest
    /// first, as `(a, b)`; an edge
    /// is listed once, from the face where it runs from the lower index to
    /// the higher (or its only face, on a border). Cost as f32; ties in
    /// face order. Costed in parallel; the result does not depend on the
    /// thread count. Returns the ranked edges and how many edges there were.
    fn ranked_edges(&self, all: bool) -> (Vec<(u32, u32)>, usize) {
        let edges: Vec<(u32, u32)> = self
            .faces
            .par_iter()
            .zip(&self.face_alive)
            .filter(|(_, alive)| **alive)
            .flat_map_iter(|(t, _)| {
                (0..3).filter_map(move |k| {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    if self.locked[a as usize] || self.locked[b as usize] {
                        return None;
                    }
                    // On a border (one face) the edge has no reverse.
                    let once =
                        a < b || faces_on_edge(&self.around[a as usize], &self.faces, b) == 1;
                    once.then_some((a.min(b), a.max(b)))
                })
            })
            .collect();
        // Costs are ≥ 0, so their f32 bits order as the values do; the low
        // half keeps the edge's place, so equal costs keep face order.
        let mut keys: Vec<u64> = edges
            .par_iter()
            .enumerate()
            .map(|(i, &(a, b))| ((self.placement(a, b).1 as f32).to_bits() as u64) << 32 | i as u64)
            .collect();
        let cheap = if all {
            keys.len()
        } else {
            keys.len().div_ceil(PASS_FRACTION).max(1).min(keys.len())
        };
        if cheap < keys.len() {
            keys.select_nth_unstable(cheap);
            keys.truncate(cheap);
        }
        keys.par_sort_unstable();
        let n = edges.len();
        (
            keys.iter()
                .map(|k| edges[(k & 0xffff_ffff) as usize])
                .collect(),
            n,
        )
    }
}

/// Collapses edges of `faces` over `positions` until `stop` (see the module
/// doc).
pub fn collapse_edges(positions: &[[f32; 3]], faces: &[[u32; 3]], stop: Stop) -> Collapsed {
    let nv = positions.len();
    let vf = VertexFaces::new(faces, nv);
    let stars = vertex_stars(faces, &vf);
    let locked = defect_vertices(faces, positions, &stars);
    let n_locked = locked.iter().filter(|l| **l).count();
    let pos: Vec<DVec3> = positions
        .iter()
        .map(|p| DVec3::from(p.map(f64::from)))
        .collect();

    // Face planes (parallel), then summed per vertex in face order.
    let planes: Vec<Quadric> = faces
        .par_iter()
        .map(|t| {
            let c = t.map(|v| pos[v as usize]);
            let n = face_cross(c);
            let l = n.length();
            if !positive(l) {
                return Quadric::default();
            }
            let n = n / l;
            Quadric::plane(n, -n.dot(c[0]), 0.5 * l)
        })
        .collect();
    let mut quad = vec![Quadric::default(); nv];
    for (t, q) in faces.iter().zip(&planes) {
        for &v in t {
            quad[v as usize].add(q);
        }
    }
    // Border edges: the edge (v, w) of a face with no other face on it.
    // (Face lists come in increasing face order from `VertexFaces`.)
    let around: Vec<Vec<u32>> = (0..nv).map(|v| vf.of(v).to_vec()).collect();
    let border: Vec<bool> = stars.iter().map(|s| s.border).collect();
    for t in faces {
        for k in 0..3 {
            let (v, w) = (t[k], t[(k + 1) % 3]);
            if !border[v as usize] || !border[w as usize] {
                continue;
            }
            if faces_on_edge(vf.of(v as usize), faces, w) != 1 {
                continue;
            }
            let (pv, pw) = (pos[v as usize], pos[w as usize]);
            let e = pw - pv;
            let m = e.cross(face_cross(t.map(|u| pos[u as usize])));
            let lm = m.length();
            if !positive(lm) {
                continue;
            }
            let m = m / lm;
            let q = Quadric::plane(m, -m.dot(pv), BORDER_WEIGHT * e.length_squared());
            quad[v as usize].add(&q);
            quad[w as usize].add(&q);
        }
    }
    let face_alive: Vec<bool> = faces.iter().map(|t| !repeats_index(t)).collect();
    let mut st = State {
        pos,
        quad,
        faces: faces.to_vec(),
        faces_left: face_alive.iter().filter(|a| **a).count(),
        face_alive,
        around,
        border,
        locked,
        vertices_left: stars.iter().filter(|s| s.used).count(),
        mark: vec![0; nv],
        stamp: 0,
        cos_max_turn: MAX_TURN_DEG.to_radians().cos(),
    };
    for v in 0..nv as u32 {
        st.tidy(v);
    }

    let mut max_error = 0.0f64;
    // Pass stamp per vertex: touched by a collapse in this pass.
    let mut touched = vec![0u32; nv];
    let mut pass = 0u32;
    let mut full = false;
    while !st.done(stop) {
        pass += 1;
        let (edges, total) = st.ranked_edges(full);
        let mut made = 0usize;
        for &(a, b) in &edges {
            if st.done(stop) {
                break;
            }
            if touched[a as usize] == pass || touched[b as usize] == pass {
                continue;
            }
            let (p, cost) = st.placement(a, b);
            // The end nearer the new point survives (keeps its attributes);
            // a border end survives an interior one.
            let (pa, pb) = (st.pos[a as usize], st.pos[b as usize]);
            let a_stays = match (st.border[a as usize], st.border[b as usize]) {
                (true, false) => true,
                (false, true) => false,
                _ => p.distance(pa) <= p.distance(pb),
            };
            let (gone, stays) = if a_stays { (b, a) } else { (a, b) };
            if !st.allowed(gone, stays, p) {
                continue;
            }
            let w = st.quad[a as usize].w + st.quad[b as usize].w;
            if w > 0.0 {
                max_error = max_error.max((cost / w).sqrt());
            }
            st.collapse(gone, stays, p);
            made += 1;
            for &f in &st.around[stays as usize] {
                for v in st.faces[f as usize] {
                    touched[v as usize] = pass;
                }
            }
        }
        if made == 0 {
            // None of the cheapest could go: rank them all once more; stop
            // when none of all could.
            if full || edges.len() == total {
                break;
            }
            full = true;
        } else {
            full = false;
        }
    }

    let faces_out = st
        .faces
        .iter()
        .zip(&st.face_alive)
        .filter(|(_, a)| **a)
        .map(|(t, _)| *t)
        .collect();
    let positions_out = st.pos.iter().map(|p| p.as_vec3().to_array()).collect();
    Collapsed {
        faces: faces_out,
        positions: positions_out,
        max_error,
        locked: n_locked,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::mesh_ops::manifold_check::pieces;

    fn stars_of(faces: &[[u32; 3]], nv: usize) -> Vec<super::super::manifold_check::VertexStar> {
        vertex_stars(faces, &VertexFaces::new(faces, nv))
    }

    /// (pieces' Euler characteristics, whether any vertex is non-manifold).
    fn shape(faces: &[[u32; 3]], nv: usize) -> (Vec<i64>, bool) {
        let s = stars_of(faces, nv);
        (pieces(faces, &s).euler, s.iter().any(|s| s.nonmanifold))
    }

    /// A closed tetrahedron cannot lose a face without two faces landing on
    /// the same three vertices: it is where a closed piece stops.
    #[test]
    fn tetrahedron_is_the_end() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        let f = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
        let out = collapse_edges(&p, &f, Stop::Faces(0));
        assert_eq!(out.faces.len(), 4);
        assert_eq!(out.positions, p.to_vec());
    }

    /// An `n`×`n` grid of the unit square in z = 0, two faces per cell.
    fn grid(n: usize) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                p.push([i as f32 / n as f32, j as f32 / n as f32, 0.0]);
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
        (p, f)
    }

    /// A flat square stays the square: every used vertex stays in z = 0
    /// (all plane quadrics agree), border vertices stay on the border
    /// (border planes; a border point never leaves its line), the four
    /// corners stay (two border planes meet there), the disk stays a disk
    /// (χ = 1) and every face keeps its upward orientation.
    #[test]
    fn flat_square_keeps_its_border() {
        let (p, f) = grid(24);
        let out = collapse_edges(&p, &f, Stop::Faces(40));
        assert!(
            out.faces.len() <= 40 && out.faces.len() >= 38,
            "{}",
            out.faces.len()
        );
        let used: std::collections::BTreeSet<u32> = out.faces.iter().flatten().copied().collect();
        let s = stars_of(&out.faces, p.len());
        for &v in &used {
            let q = out.positions[v as usize];
            assert!(q[2].abs() < 1e-6, "vertex {v} left the plane: {q:?}");
            if s[v as usize].border {
                let on = |c: f32| c.abs() < 1e-6 || (c - 1.0).abs() < 1e-6;
                assert!(on(q[0]) || on(q[1]), "border vertex {v} at {q:?}");
            }
        }
        for corner in [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]] {
            assert!(
                used.iter()
                    .any(|&v| out.positions[v as usize][..2] == corner),
                "corner {corner:?} kept"
            );
        }
        assert_eq!(shape(&out.faces, p.len()), (vec![1], false));
        for t in &out.faces {
            let c = t.map(|v| DVec3::from(out.positions[v as usize].map(f64::from)));
            assert!(face_cross(c).z > 0.0, "face {t:?} turned over");
        }
    }

    /// A torus whose tube is 1/50 of its ring: the cheapest collapses run
    /// around the tube, and taken blindly they pinch it. Down to 60 faces it
    /// stays one closed manifold piece of genus 1 (χ = 0).
    #[test]
    fn thin_torus_stays_a_torus() {
        let m = crate::testing::torus_mesh(200, 8, 1.0, 0.02);
        let (p, f) = (m.vertices, m.faces);
        assert_eq!(shape(&f, p.len()), (vec![0], false));
        let out = collapse_edges(&p, &f, Stop::Faces(60));
        assert!(out.faces.len() <= 60, "{}", out.faces.len());
        assert_eq!(shape(&out.faces, p.len()), (vec![0], false));
    }

    /// Three faces on one edge (a book): a fine grid's first diagonal
    /// (vertices 0 and 14, two faces) gets a third face standing up. The
    /// two ends of that edge are locked (never move, never collapse); the
    /// rest decimates.
    #[test]
    fn non_manifold_vertices_are_locked() {
        let (mut p, mut f) = grid(12);
        p.push([0.04, 0.04, 0.5]);
        let top = p.len() as u32 - 1;
        f.push([0, 14, top]);
        let out = collapse_edges(&p, &f, Stop::Faces(60));
        assert_eq!(out.locked, 2);
        for v in [0usize, 14] {
            assert_eq!(out.positions[v], p[v], "locked vertex {v} moved");
        }
        assert!(out.faces.len() <= 60, "{}", out.faces.len());
        let book = out
            .faces
            .iter()
            .filter(|t| t.contains(&0) && t.contains(&14))
            .count();
        assert_eq!(book, 3, "the book's three faces stay");
    }

    /// The same output for 1 and 2 threads.
    #[test]
    fn threads_do_not_change_the_result() {
        let m = crate::testing::uv_sphere(40, 1.0);
        let run = |n: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
                .install(|| collapse_edges(&m.vertices, &m.faces, Stop::Faces(300)))
        };
        let (a, b) = (run(1), run(2));
        assert_eq!(a.faces, b.faces);
        assert_eq!(a.positions, b.positions);
    }

    /// The quadric minimiser: the corner of three orthogonal planes is
    /// found to rounding, a quadric of one plane has none (singular), and
    /// the value is the weighted squared distance.
    #[test]
    fn quadric_minimiser() {
        let mut q = Quadric::plane(DVec3::X, -1.0, 1.0);
        assert!(q.minimiser().is_none());
        q.add(&Quadric::plane(DVec3::Y, -2.0, 2.0));
        q.add(&Quadric::plane(DVec3::Z, 3.0, 0.5));
        let p = q.minimiser().unwrap();
        assert!(p.distance(DVec3::new(1.0, 2.0, -3.0)) < 1e-12, "{p:?}");
        assert!(q.eval(p) < 1e-20);
        assert!((q.eval(DVec3::new(0.0, 2.0, -3.0)) - 1.0).abs() < 1e-12);
    }
}
