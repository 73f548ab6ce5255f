//! The incremental Delaunay structure: tets with neighbour links, an
//! "infinite vertex" closing the convex hull, stochastic visibility walks
//! for point location and Bowyer–Watson cavity insertion.
//!
//! Conventions:
//! - Tet `t` has vertices `v[0..4]` (indices into the points it was given,
//!   or [`INF`]) and
//!   neighbours `n[0..4]`, `n[i]` being the tet across the face opposite
//!   `v[i]`.
//! - Every tet is positive (`predicates::orient > 0`); an infinite tet is
//!   positive when its `INF` replaced by any point strictly outside the hull
//!   face it stands on makes a positive tet.
//! - A point is in conflict with a finite tet when it is inside its
//!   circumsphere (perturbed, [`predicates::conflict_sos`]); with an infinite
//!   tet when it is strictly outside its hull face, or on the face's plane and
//!   in conflict with the finite tet across that face (inside the face's
//!   circumcircle, perturbed alike).

use rustc_hash::FxHashMap;

use super::predicates::{conflict_sos, orient};
use crate::{Error, Result};

/// The infinite vertex.
pub(super) const INF: u32 = u32::MAX;
/// `v[0]` of a deleted tet (its slot is on the free list).
const DEAD: u32 = u32::MAX - 1;
/// No tet.
const NONE: u32 = u32::MAX;

/// Bytes one tet slot takes (vertices, neighbours, mark).
pub(super) const TET_BYTES: u64 = 33;

#[derive(Clone, Copy, Debug)]
struct Tet {
    v: [u32; 4],
    n: [u32; 4],
}

/// One face of the cavity's boundary, staged before the cavity is replaced.
#[derive(Clone, Copy)]
struct NewTet {
    /// Vertices of the new tet (the cavity tet's, with `p` at `opp`).
    v: [u32; 4],
    /// Position of the new point in `v`.
    opp: u8,
    /// The tet outside the cavity across the face opposite `p`.
    outer: u32,
    /// The slot of `outer.n` that pointed at the cavity tet.
    outer_slot: u8,
}

pub(super) struct Triangulation<'a> {
    pts: &'a [[f64; 3]],
    tets: Vec<Tet>,
    /// 0: untouched; 1: in the current cavity; 2: tested, not in conflict.
    mark: Vec<u8>,
    free: Vec<u32>,
    /// The most recently created tet: where the next walk starts.
    hint: u32,
    /// Most tet slots allowed (from the memory limit).
    max_tets: usize,
    rng: u64,
    stack: Vec<u32>,
    cavity: Vec<u32>,
    outside: Vec<u32>,
    staged: Vec<NewTet>,
    edges: FxHashMap<u64, (u32, u8)>,
}

impl<'a> Triangulation<'a> {
    /// The triangulation of the positive tet `a, b, c, d` (indices into
    /// `pts`) and its four infinite tets, with room for `capacity` tets.
    pub(super) fn new(
        pts: &'a [[f64; 3]],
        [a, b, c, d]: [u32; 4],
        capacity: usize,
        max_tets: usize,
    ) -> Self {
        let mut tets = Vec::with_capacity(capacity);
        let mut mark = Vec::with_capacity(capacity);
        let first = [a, b, c, d];
        tets.push(Tet {
            v: first,
            n: [NONE; 4],
        });
        for j in 0..4 {
            let mut v = first;
            v[j] = INF;
            // Replacing v[j] by a point beyond face j flips the sign; a swap
            // of two other vertices restores it.
            v.swap((j + 1) % 4, (j + 2) % 4);
            tets.push(Tet { v, n: [NONE; 4] });
        }
        mark.resize(tets.len(), 0);
        let mut tri = Triangulation {
            pts,
            tets,
            mark,
            free: Vec::new(),
            hint: 0,
            max_tets,
            rng: 0x9E37_79B9_7F4A_7C15,
            stack: Vec::new(),
            cavity: Vec::new(),
            outside: Vec::new(),
            staged: Vec::new(),
            edges: FxHashMap::default(),
        };
        tri.link_by_faces(&[0, 1, 2, 3, 4]);
        tri
    }

    /// Links the tets `ids` with each other through their shared faces.
    fn link_by_faces(&mut self, ids: &[u32]) {
        let mut faces: FxHashMap<[u32; 3], (u32, usize)> = FxHashMap::default();
        for &t in ids {
            for i in 0..4 {
                let mut f = [0u32; 3];
                let mut k = 0;
                for (j, &v) in self.tets[t as usize].v.iter().enumerate() {
                    if j != i {
                        f[k] = v;
                        k += 1;
                    }
                }
                f.sort_unstable();
                if let Some((u, ui)) = faces.remove(&f) {
                    self.tets[t as usize].n[i] = u;
                    self.tets[u as usize].n[ui] = t;
                } else {
                    faces.insert(f, (t, i));
                }
            }
        }
    }

    #[inline(always)]
    fn pt(&self, v: u32) -> [f64; 3] {
        self.pts[v as usize]
    }

    #[inline(always)]
    fn inf_pos(&self, t: u32) -> Option<usize> {
        self.tets[t as usize].v.iter().position(|&v| v == INF)
    }

    #[inline(always)]
    fn next_rand(&mut self) -> u64 {
        // xorshift64: a fixed sequence, so the walk is deterministic.
        let mut x = self.rng;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.rng = x;
        x
    }

    /// The four points of finite tet `t`.
    #[inline(always)]
    fn corners(&self, t: u32) -> [[f64; 3]; 4] {
        let v = self.tets[t as usize].v;
        [self.pt(v[0]), self.pt(v[1]), self.pt(v[2]), self.pt(v[3])]
    }

    /// Whether point `pid` is in conflict with tet `t` (module doc).
    fn conflict(&self, t: u32, pid: u32) -> bool {
        let p = self.pt(pid);
        let tet = &self.tets[t as usize];
        match tet.v.iter().position(|&v| v == INF) {
            None => conflict_sos(self.corners(t), tet.v, p, pid),
            Some(k) => {
                let mut q = [p; 4];
                for (j, &v) in tet.v.iter().enumerate() {
                    if j != k {
                        q[j] = self.pt(v);
                    }
                }
                let o = orient(q[0], q[1], q[2], q[3]);
                if o != 0.0 {
                    return o > 0.0;
                }
                let f = tet.n[k];
                conflict_sos(self.corners(f), self.tets[f as usize].v, p, pid)
            }
        }
    }

    /// A tet in conflict with point `pid`: a stochastic visibility walk from
    /// the hint, ending in the finite tet that contains the point or at the
    /// infinite tet whose hull face it is strictly beyond. A walk longer
    /// than the number of tets falls back to a scan of every tet.
    fn locate(&mut self, pid: u32) -> Result<u32> {
        let p = self.pt(pid);
        let mut t = self.hint;
        if let Some(k) = self.inf_pos(t) {
            t = self.tets[t as usize].n[k];
        }
        let mut prev = NONE;
        let limit = self.tets.len() + 1000;
        let mut steps = 0usize;
        'walk: loop {
            steps += 1;
            if steps > limit {
                return self.locate_by_scan(pid);
            }
            let tet = self.tets[t as usize];
            let q0 = self.corners(t);
            let r = (self.next_rand() >> 32) as usize;
            for j in 0..4 {
                let i = (r + j) & 3;
                let nb = tet.n[i];
                if nb == prev {
                    continue;
                }
                let mut q = q0;
                q[i] = p;
                if orient(q[0], q[1], q[2], q[3]) < 0.0 {
                    prev = t;
                    t = nb;
                    if self.tets[nb as usize].v.contains(&INF) {
                        return Ok(nb);
                    }
                    continue 'walk;
                }
            }
            return Ok(t);
        }
    }

    /// A tet in conflict with `pid`, by testing every live tet.
    #[cold]
    fn locate_by_scan(&self, pid: u32) -> Result<u32> {
        (0..self.tets.len() as u32)
            .find(|&t| self.tets[t as usize].v[0] != DEAD && self.conflict(t, pid))
            .ok_or_else(|| {
                Error::invalid(format!(
                    "Delaunay: no tet is in conflict with the point inserted {pid}th (internal inconsistency)"
                ))
            })
    }

    /// Inserts point `pid` (not equal to any vertex): the tets in conflict
    /// with it (a star-shaped cavity around it) are replaced by the tets
    /// joining it to the cavity's boundary faces.
    pub(super) fn insert(&mut self, pid: u32) -> Result<()> {
        let start = self.locate(pid)?;
        self.grow_cavity(start, pid);
        self.stage_new_tets(pid)?;
        self.replace_cavity(pid)
    }

    /// Collects the conflict region around `start` in `self.cavity`.
    fn grow_cavity(&mut self, start: u32, pid: u32) {
        self.cavity.clear();
        self.outside.clear();
        self.stack.clear();
        self.mark[start as usize] = 1;
        self.cavity.push(start);
        self.stack.push(start);
        while let Some(t) = self.stack.pop() {
            for i in 0..4 {
                let nb = self.tets[t as usize].n[i];
                if self.mark[nb as usize] != 0 {
                    continue;
                }
                if self.conflict(nb, pid) {
                    self.mark[nb as usize] = 1;
                    self.cavity.push(nb);
                    self.stack.push(nb);
                } else {
                    self.mark[nb as usize] = 2;
                    self.outside.push(nb);
                }
            }
        }
    }

    /// Stages one new tet per boundary face of the cavity (before anything
    /// is changed, so that slot reuse cannot confuse the back links), and
    /// checks that each finite one is positive.
    fn stage_new_tets(&mut self, pid: u32) -> Result<()> {
        self.staged.clear();
        let p = self.pt(pid);
        let mut bad = false;
        for &t in &self.cavity {
            let tet = self.tets[t as usize];
            for i in 0..4 {
                let outer = tet.n[i];
                if self.mark[outer as usize] != 2 {
                    continue;
                }
                let outer_slot = self.tets[outer as usize]
                    .n
                    .iter()
                    .position(|&x| x == t)
                    .unwrap_or(0) as u8;
                let mut v = tet.v;
                v[i] = pid;
                if !v.contains(&INF) {
                    let q = [
                        if i == 0 { p } else { self.pt(v[0]) },
                        if i == 1 { p } else { self.pt(v[1]) },
                        if i == 2 { p } else { self.pt(v[2]) },
                        if i == 3 { p } else { self.pt(v[3]) },
                    ];
                    bad |= orient(q[0], q[1], q[2], q[3]) <= 0.0;
                }
                self.staged.push(NewTet {
                    v,
                    opp: i as u8,
                    outer,
                    outer_slot,
                });
            }
        }
        for &t in self.cavity.iter().chain(self.outside.iter()) {
            self.mark[t as usize] = 0;
        }
        if bad {
            return Err(Error::invalid(format!(
                "Delaunay: inserting the point inserted {pid}th would make a flat tet (internal inconsistency)"
            )));
        }
        Ok(())
    }

    /// Replaces the cavity by the staged tets and links them.
    fn replace_cavity(&mut self, pid: u32) -> Result<()> {
        let needed = self.staged.len();
        let spare = self.cavity.len() + self.free.len();
        if needed > spare && self.tets.len() + (needed - spare) > self.max_tets {
            return Err(Error::invalid(format!(
                "Delaunay: more than {} tets would exceed the memory limit",
                self.max_tets
            )));
        }
        self.edges.clear();
        if self.edges.capacity() > 4096 {
            self.edges.shrink_to(64);
        }
        let mut last = NONE;
        for k in 0..needed {
            let s = self.staged[k];
            let id = if k < self.cavity.len() {
                self.cavity[k]
            } else if let Some(f) = self.free.pop() {
                f
            } else {
                self.tets.push(Tet {
                    v: [DEAD; 4],
                    n: [NONE; 4],
                });
                self.mark.push(0);
                (self.tets.len() - 1) as u32
            };
            let mut n = [NONE; 4];
            n[s.opp as usize] = s.outer;
            self.tets[id as usize] = Tet { v: s.v, n };
            self.tets[s.outer as usize].n[s.outer_slot as usize] = id;
            // The three faces through `pid`: the face opposite v[j] holds
            // the edge of the two vertices other than v[j] and pid.
            for j in 0..4 {
                if j == s.opp as usize {
                    continue;
                }
                let mut e = [0u32; 2];
                let mut m = 0;
                for (l, &v) in s.v.iter().enumerate() {
                    if l != j && l != s.opp as usize {
                        e[m] = v;
                        m += 1;
                    }
                }
                let key = ((e[0].min(e[1]) as u64) << 32) | e[0].max(e[1]) as u64;
                if let Some((u, uj)) = self.edges.remove(&key) {
                    self.tets[id as usize].n[j] = u;
                    self.tets[u as usize].n[uj as usize] = id;
                } else {
                    self.edges.insert(key, (id, j as u8));
                }
            }
            last = id;
        }
        for k in needed..self.cavity.len() {
            let t = self.cavity[k];
            self.tets[t as usize] = Tet {
                v: [DEAD; 4],
                n: [NONE; 4],
            };
            self.free.push(t);
        }
        if !self.edges.is_empty() || last == NONE {
            return Err(Error::invalid(format!(
                "Delaunay: the cavity of the point inserted {pid}th is not a closed ball (internal inconsistency)"
            )));
        }
        self.hint = last;
        Ok(())
    }

    /// The finite tets, in slot order, vertex k renamed `names[k]`.
    pub(super) fn finite_tets(&self, names: &[u32]) -> Vec<[u32; 4]> {
        self.tets
            .iter()
            .filter(|t| t.v[0] != DEAD && !t.v.contains(&INF))
            .map(|t| t.v.map(|k| names[k as usize]))
            .collect()
    }
}
