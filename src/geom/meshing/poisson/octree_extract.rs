//! Iso-surface extraction on the adaptive octree of the solve (the default;
//! [`super::extract`] is the uniform finest-depth alternative), in the manner
//! of Kazhdan, Klein, Dalal & Hoppe 2007 ("Unconstrained isosurface extraction
//! on arbitrary octrees"), which PoissonRecon uses.
//!
//! The octree: every cell of the complete levels is refined; above them a cell
//! of depth m is refined when it is the parent of a cell of depth m+1 in
//! PoissonRecon's tree (`Level::tree`: sibling groups holding normal data and
//! their neighbourhood), so leaves are as fine as Open3D's. Each leaf emits
//! polygons from iso-segments on its six faces, where each face is cut into
//! the finest sub-faces that the leaves on either side give it, and each
//! sub-face edge into the finest segments any leaf around that edge gives it
//! (a segment is split when one of the four cells around it is refined). Both
//! sides of every face therefore see the same segments with the same
//! crossings, so the mesh is watertight and edge-manifold across depth
//! changes (polygons may have more than three vertices there; they get a
//! minimum-area triangulation). On each sub-face the crossings pair up so
//! that runs of inside corners (χ > iso) stay apart, walking counter-clockwise
//! seen from outside the leaf, which orients every loop towards decreasing χ.
//!
//! Node values are exact χ (the finest level holding the point). Crossings on
//! a segment use PoissonRecon's quadratic fit (end values and central
//! differences at the segment's own spacing) or linear interpolation. Leaves
//! are visited by flooding from the leaves that hold samples across every
//! crossing, wave by wave, merged in a fixed order (thread-count independent).

use rayon::prelude::*;
use rustc_hash::{FxHashMap, FxHashSet};

use super::extract::{ExtractParams, IsoMesh, edge_root};
use super::grid::BitGrid;
use super::system::{Level, eval};
use crate::geom::meshing::marching_cubes::triangulate;

/// A point of the finest grid (depth D coordinates).
type Node = [i32; 3];

fn node_key(p: Node) -> u64 {
    (p[0] as u64) | ((p[1] as u64) << 21) | ((p[2] as u64) << 42)
}

struct Tree<'a> {
    levels: &'a [Level],
    d: u32,
    /// refined[m] for depths that are not complete-and-below (see `refined`).
    refined: Vec<Option<BitGrid>>,
    iso: f32,
    linear: bool,
}

impl Tree<'_> {
    fn res(&self, m: u32) -> i32 {
        1 << m
    }

    fn in_domain(&self, m: u32, c: [i32; 3]) -> bool {
        let r = self.res(m);
        c.iter().all(|&x| (0..r).contains(&x))
    }

    fn refined(&self, m: u32, c: [i32; 3]) -> bool {
        if m >= self.d || !self.in_domain(m, c) {
            return false;
        }
        match &self.refined[m as usize] {
            None => true,
            Some(g) => g.contains(c),
        }
    }

    /// Exact χ at a finest-grid point.
    fn value(&self, p: Node) -> f32 {
        let r = self.res(self.d);
        if p.iter().any(|&c| c < 0 || c > r) {
            return f32::NAN;
        }
        let tz = (p[0] | p[1] | p[2] | (1 << self.d))
            .trailing_zeros()
            .min(self.d);
        for m in ((self.d - tz)..=self.d).rev() {
            let s = self.d - m;
            let q = [p[0] >> s, p[1] >> s, p[2] >> s];
            if let Some(v) = self.levels[m as usize].value(q) {
                return v;
            }
        }
        let u = [
            p[0] as f64 / r as f64,
            p[1] as f64 / r as f64,
            p[2] as f64 / r as f64,
        ];
        eval(self.levels, u).map_or(f32::NAN, |v| v as f32)
    }

    /// The leaf holding cell `c` of depth `m` (which must not be refined).
    fn leaf_of(&self, mut m: u32, mut c: [i32; 3]) -> (u32, [i32; 3]) {
        while m > 0 && !self.refined(m - 1, [c[0] >> 1, c[1] >> 1, c[2] >> 1]) {
            m -= 1;
            c = [c[0] >> 1, c[1] >> 1, c[2] >> 1];
        }
        (m, c)
    }

    /// Is the depth-m segment from node `u` along `axis` cut by a finer cell?
    fn split(&self, m: u32, u: [i32; 3], axis: usize) -> bool {
        if m >= self.d {
            return false;
        }
        let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
        for k in 0..4 {
            let mut cell = u;
            cell[b] -= k & 1;
            cell[c] -= k >> 1;
            if self.refined(m, cell) {
                return true;
            }
        }
        false
    }

    /// Finest-grid nodes along the depth-m segment from `u` along `axis`,
    /// both ends included, in increasing order.
    fn segment_nodes(&self, m: u32, u: [i32; 3], axis: usize, out: &mut Vec<Node>) {
        if self.split(m, u, axis) {
            let a = [2 * u[0], 2 * u[1], 2 * u[2]];
            let mut b = a;
            b[axis] += 1;
            self.segment_nodes(m + 1, a, axis, out);
            out.pop();
            self.segment_nodes(m + 1, b, axis, out);
        } else {
            let s = self.d - m;
            let mut v = u;
            v[axis] += 1;
            out.push([u[0] << s, u[1] << s, u[2] << s]);
            out.push([v[0] << s, v[1] << s, v[2] << s]);
        }
    }

    /// Sub-faces of face `f` (axis f/2, side f%2) of leaf (ℓ, c): squares
    /// (depth, low corner node) on the face plane.
    fn subfaces(&self, l: u32, c: [i32; 3], f: usize, out: &mut Vec<(u32, [i32; 3])>) {
        let (a, s) = (f / 2, (f % 2) as i32);
        let mut q = c;
        q[a] += s;
        let mut n = c;
        n[a] += if s == 1 { 1 } else { -1 };
        if !self.refined(l, n) {
            out.push((l, q));
            return;
        }
        self.subfaces_in(l + 1, n, a, s, 2 * q[a], out);
    }

    fn subfaces_in(
        &self,
        m: u32,
        parent: [i32; 3],
        a: usize,
        s: i32,
        plane: i32,
        out: &mut Vec<(u32, [i32; 3])>,
    ) {
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        for k in 0..4 {
            let mut ch = [2 * parent[0], 2 * parent[1], 2 * parent[2]];
            ch[a] += 1 - s; // the children touching the face
            ch[u] += k & 1;
            ch[v] += k >> 1;
            if self.refined(m, ch) {
                self.subfaces_in(m + 1, ch, a, s, 2 * plane, out);
            } else {
                let mut q = ch;
                q[a] = plane;
                out.push((m, q));
            }
        }
    }

    /// Position (finest-grid units) of the crossing between nodes a and b.
    fn crossing(&self, a: Node, b: Node, va: f32, vb: f32) -> [f64; 3] {
        let step = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let (da, db) = if self.linear {
            (0.0, 0.0)
        } else {
            let before = self.value([a[0] - step[0], a[1] - step[1], a[2] - step[2]]);
            let after = self.value([b[0] + step[0], b[1] + step[1], b[2] + step[2]]);
            let da = if before.is_nan() {
                vb - va
            } else {
                0.5 * (vb - before)
            };
            let db = if after.is_nan() {
                vb - va
            } else {
                0.5 * (after - va)
            };
            (da, db)
        };
        let t = edge_root(va, vb, da, db, self.iso, self.linear);
        [
            a[0] as f64 + t * step[0] as f64,
            a[1] as f64 + t * step[1] as f64,
            a[2] as f64 + t * step[2] as f64,
        ]
    }
}

/// A crossing: the key of its segment (end-node keys) and its position.
type Crossing = ((u64, u64), [f64; 3]);

struct LeafOut {
    /// Loops of crossings (positions in finest-grid units).
    loops: Vec<Vec<Crossing>>,
    /// Leaves across every crossing segment.
    next: Vec<(u32, [i32; 3])>,
}

fn process_leaf(t: &Tree, l: u32, c: [i32; 3]) -> LeafOut {
    // A leaf has a handful of crossings: small vectors beat hash maps.
    let mut next_of: Vec<((u64, u64), (u64, u64))> = Vec::with_capacity(12);
    let mut pos: Vec<Crossing> = Vec::with_capacity(12);
    let mut vals: Vec<f32> = Vec::with_capacity(16);
    let mut crossings: Vec<(usize, bool)> = Vec::with_capacity(8);
    let mut neighbours = Vec::new();
    let mut subs = Vec::new();
    let mut ring: Vec<Node> = Vec::new();
    let mut seg: Vec<Node> = Vec::new();
    let mut memo: Vec<(Node, f32)> = Vec::with_capacity(16);
    for f in 0..6 {
        subs.clear();
        t.subfaces(l, c, f, &mut subs);
        let (a, s) = (f / 2, f % 2);
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        // corners counter-clockwise seen from outside the leaf
        let order: [(i32, i32); 4] = if s == 1 {
            [(0, 0), (1, 0), (1, 1), (0, 1)]
        } else {
            [(0, 0), (0, 1), (1, 1), (1, 0)]
        };
        for &(m, q) in &subs {
            ring.clear();
            for k in 0..4 {
                let (p0, p1) = (order[k], order[(k + 1) % 4]);
                let axis = if p0.0 != p1.0 { u } else { v };
                let forward = if axis == u { p1.0 > p0.0 } else { p1.1 > p0.1 };
                let mut lo = q;
                lo[u] += p0.0.min(p1.0);
                lo[v] += p0.1.min(p1.1);
                seg.clear();
                t.segment_nodes(m, lo, axis, &mut seg);
                if !forward {
                    seg.reverse();
                }
                ring.extend_from_slice(&seg[..seg.len() - 1]);
            }
            // Each node is on up to three faces of the leaf: look it up once.
            vals.clear();
            vals.extend(
                ring.iter()
                    .map(|&p| match memo.iter().find(|(q, _)| *q == p) {
                        Some(&(_, v)) => v,
                        None => {
                            let v = t.value(p);
                            memo.push((p, v));
                            v
                        }
                    }),
            );
            let inside = |i: usize| vals[i] > t.iso;
            let n = ring.len();
            crossings.clear();
            for i in 0..n {
                let j = (i + 1) % n;
                if inside(i) != inside(j) {
                    crossings.push((i, inside(j)));
                }
            }
            if crossings.is_empty() {
                continue;
            }
            let key = |i: usize| {
                let (x, y) = (node_key(ring[i]), node_key(ring[(i + 1) % n]));
                (x.min(y), x.max(y))
            };
            // pair each entering crossing with the next leaving one
            let k = crossings.len();
            for (ci, &(i, entering)) in crossings.iter().enumerate() {
                if !entering {
                    continue;
                }
                let (jl, _) = crossings[(ci + 1) % k];
                next_of.push((key(i), key(jl)));
            }
            for &(i, _) in &crossings {
                let kk = key(i);
                let j = (i + 1) % n;
                if !pos.iter().any(|(k2, _)| *k2 == kk) {
                    let (a, b) = if node_key(ring[i]) < node_key(ring[j]) {
                        (i, j)
                    } else {
                        (j, i)
                    };
                    pos.push((kk, t.crossing(ring[a], ring[b], vals[a], vals[b])));
                }
                // the leaves around this (minimal) segment
                let (p, q2) = (ring[i], ring[j]);
                let len = (q2[0] - p[0])
                    .abs()
                    .max((q2[1] - p[1]).abs())
                    .max((q2[2] - p[2]).abs());
                let m = t.d - len.trailing_zeros();
                let axis = (0..3).find(|&x| q2[x] != p[x]).expect("distinct nodes");
                let lo = if q2[axis] > p[axis] { p } else { q2 };
                let sh = t.d - m;
                let un = [lo[0] >> sh, lo[1] >> sh, lo[2] >> sh];
                let (b2, c2) = ((axis + 1) % 3, (axis + 2) % 3);
                for kk in 0..4 {
                    let mut cell = un;
                    cell[b2] -= kk & 1;
                    cell[c2] -= kk >> 1;
                    if t.in_domain(m, cell) {
                        neighbours.push(t.leaf_of(m, cell));
                    }
                }
            }
        }
    }
    // chain the segments into loops (deterministic start order)
    next_of.sort_unstable();
    let starts: Vec<(u64, u64)> = next_of.iter().map(|e| e.0).collect();
    let mut seen: Vec<(u64, u64)> = Vec::with_capacity(next_of.len());
    let find_pos = |k: (u64, u64)| pos.iter().find(|(k2, _)| *k2 == k).map(|e| e.1);
    let mut loops = Vec::new();
    for s in starts {
        if seen.contains(&s) {
            continue;
        }
        let mut lp = Vec::new();
        let mut k = s;
        let mut closed = false;
        while !seen.contains(&k) {
            seen.push(k);
            let Some(p) = find_pos(k) else { break };
            lp.push((k, p));
            match next_of.binary_search_by(|e| e.0.cmp(&k)) {
                Ok(i) => k = next_of[i].1,
                Err(_) => break,
            }
            if k == s {
                closed = true;
                break;
            }
        }
        if closed && lp.len() >= 3 {
            loops.push(lp);
        }
    }
    neighbours.sort_unstable();
    neighbours.dedup();
    LeafOut {
        loops,
        next: neighbours,
    }
}

/// Extracts the iso-surface on the octree, flooding from the leaves that
/// hold `seeds` (unit-cube points). Gradients of the result are left empty
/// (normals come from the faces).
pub fn extract_octree(levels: &[Level], seeds: &[[f64; 3]], prm: &ExtractParams) -> IsoMesh {
    let d = levels.len() as u32 - 1;
    let refined: Vec<Option<BitGrid>> = (0..=d)
        .map(|m| {
            if m >= d || levels[m as usize + 1].complete {
                None
            } else {
                Some(levels[m as usize + 1].tree.parents())
            }
        })
        .collect();
    let t = Tree {
        levels,
        d,
        refined,
        iso: prm.iso as f32,
        linear: prm.linear,
    };
    let res = 1i32 << d;
    let mut visited: FxHashSet<(u32, [i32; 3])> = FxHashSet::default();
    let mut wave: Vec<(u32, [i32; 3])> = Vec::new();
    for p in seeds {
        let c = [
            ((p[0] * res as f64).floor() as i32).clamp(0, res - 1),
            ((p[1] * res as f64).floor() as i32).clamp(0, res - 1),
            ((p[2] * res as f64).floor() as i32).clamp(0, res - 1),
        ];
        let leaf = t.leaf_of(d, c);
        if visited.insert(leaf) {
            wave.push(leaf);
        }
    }
    let mut mesh = IsoMesh::default();
    let mut ids: FxHashMap<(u64, u64), u32> = FxHashMap::default();
    let inv = 1.0 / res as f64;
    while !wave.is_empty() {
        wave.sort_unstable();
        let mut next = Vec::new();
        for chunk in wave.chunks(8192) {
            let outs: Vec<LeafOut> = chunk
                .par_iter()
                .map(|&(l, c)| process_leaf(&t, l, c))
                .collect();
            for o in outs {
                for lp in &o.loops {
                    let poly: Vec<u32> = lp
                        .iter()
                        .map(|(k, p)| {
                            *ids.entry(*k).or_insert_with(|| {
                                mesh.vertices.push([p[0] * inv, p[1] * inv, p[2] * inv]);
                                (mesh.vertices.len() - 1) as u32
                            })
                        })
                        .collect();
                    triangulate(&poly, &mesh.vertices, &mut mesh.triangles);
                }
                for nb in o.next {
                    if visited.insert(nb) {
                        next.push(nb);
                    }
                }
            }
        }
        wave = next;
    }
    mesh
}
