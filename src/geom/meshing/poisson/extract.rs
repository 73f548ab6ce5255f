//! Iso-surface extraction of the solved indicator function on the virtual
//! uniform grid of the finest depth D.
//!
//! The grid is walked in 8³-cell blocks, starting from the blocks that hold
//! samples and flooding into neighbouring blocks wherever the surface leaves
//! a block, wave by wave (each wave in parallel, merged in Morton order, so
//! the output does not depend on the thread count). Node values come from
//! the finest level that holds the point (exact: the accumulated solution is
//! trilinear inside every cell of a level).
//!
//! Polygons come from the shared table of [`crate::geom::meshing::marching_cubes`]
//! with inside = χ > iso, so loops face decreasing χ (outward: χ ≈ 1
//! inside); loops of more than three vertices get a minimum-area
//! triangulation.
//!
//! Edge roots are linear, or (default) the quadratic that PoissonRecon fits
//! from the end values and finite-difference derivatives along the edge.

use rayon::prelude::*;
use rustc_hash::{FxHashMap, FxHashSet};

use crate::geom::meshing::marching_cubes::{edge_corners, table, triangulate};

use super::grid::{BS, morton};
use super::system::Level;

/// Extraction settings.
#[derive(Clone, Copy, Debug)]
pub struct ExtractParams {
    /// The iso-value.
    pub iso: f64,
    /// Linear edge roots instead of the quadratic fit.
    pub linear: bool,
}

/// A mesh in unit-cube coordinates with per-vertex ∇χ.
#[derive(Clone, Debug, Default)]
pub struct IsoMesh {
    /// Vertex positions (unit cube).
    pub vertices: Vec<[f64; 3]>,
    /// Gradient of χ at each vertex (unit-cube units).
    pub gradients: Vec<[f32; 3]>,
    /// Triangles, outward (towards decreasing χ) counter-clockwise.
    pub triangles: Vec<[u32; 3]>,
}

struct BlockOut {
    keys: Vec<u64>,
    pos: Vec<[f64; 3]>,
    grad: Vec<[f32; 3]>,
    tris: Vec<[u32; 3]>,
    exits: [bool; 6],
}

const N: usize = 11; // block nodes o-1 ..= o+9

/// Node values of a block (nodes `o-1 ..= o+9`), NaN outside the cube.
fn block_values(levels: &[Level], o: [i32; 3]) -> Vec<f32> {
    let fine = levels.last().expect("at least one level");
    let res = fine.res;
    let d = fine.depth;
    let mut v = vec![f32::NAN; N * N * N];
    fine.bricks.gather(
        &fine.y,
        [o[0] - 1, o[1] - 1, o[2] - 1],
        [N, N, N],
        &mut v,
        f32::NAN,
    );
    let inside = |q: [i32; 3]| q.iter().all(|&c| (0..=res).contains(&c));
    let mut missing: Vec<usize> = (0..N * N * N)
        .filter(|&i| {
            let q = [
                o[0] - 1 + (i % N) as i32,
                o[1] - 1 + ((i / N) % N) as i32,
                o[2] - 1 + (i / (N * N)) as i32,
            ];
            v[i].is_nan() && inside(q)
        })
        .collect();
    for lev in levels.iter().rev().skip(1) {
        if missing.is_empty() {
            break;
        }
        let shift = d - lev.depth;
        let scale = 1.0 / (1u32 << shift) as f64;
        // coarse node box covering the block
        let lo = [
            (o[0] - 1) >> shift,
            (o[1] - 1) >> shift,
            (o[2] - 1) >> shift,
        ];
        let hi = [
            (o[0] + 9) >> shift,
            (o[1] + 9) >> shift,
            (o[2] + 9) >> shift,
        ];
        let cd = [
            (hi[0] - lo[0] + 2) as usize,
            (hi[1] - lo[1] + 2) as usize,
            (hi[2] - lo[2] + 2) as usize,
        ];
        let mut c = vec![f32::NAN; cd[0] * cd[1] * cd[2]];
        lev.bricks.gather(&lev.y, lo, cd, &mut c, f32::NAN);
        let cres = lev.res;
        missing.retain(|&i| {
            let q = [
                o[0] - 1 + (i % N) as i32,
                o[1] - 1 + ((i / N) % N) as i32,
                o[2] - 1 + (i / (N * N)) as i32,
            ];
            let t = [
                q[0] as f64 * scale,
                q[1] as f64 * scale,
                q[2] as f64 * scale,
            ];
            let cell = [
                (t[0].floor() as i32).clamp(0, cres - 1),
                (t[1].floor() as i32).clamp(0, cres - 1),
                (t[2].floor() as i32).clamp(0, cres - 1),
            ];
            let f = [
                t[0] - cell[0] as f64,
                t[1] - cell[1] as f64,
                t[2] - cell[2] as f64,
            ];
            let mut s = 0.0f64;
            for k in 0..8i32 {
                let g = [
                    cell[0] + (k & 1) - lo[0],
                    cell[1] + ((k >> 1) & 1) - lo[1],
                    cell[2] + (k >> 2) - lo[2],
                ];
                if g.iter().zip(&cd).any(|(&a, &b)| a < 0 || a as usize >= b) {
                    return true;
                }
                let val = c[g[0] as usize + cd[0] * (g[1] as usize + cd[1] * g[2] as usize)];
                if val.is_nan() {
                    return true;
                }
                let w = (if k & 1 == 1 { f[0] } else { 1.0 - f[0] })
                    * (if (k >> 1) & 1 == 1 { f[1] } else { 1.0 - f[1] })
                    * (if k >> 2 == 1 { f[2] } else { 1.0 - f[2] });
                s += w * val as f64;
            }
            v[i] = s as f32;
            false
        });
    }
    v
}

fn edge_key(p: [i32; 3], axis: usize) -> u64 {
    (p[0] as u64) | ((p[1] as u64) << 21) | ((p[2] as u64) << 42) | ((axis as u64) << 62)
}

fn process_block(levels: &[Level], b: [i32; 3], prm: &ExtractParams) -> BlockOut {
    let fine = levels.last().expect("levels");
    let res = fine.res;
    let o = [b[0] * BS, b[1] * BS, b[2] * BS];
    let v = block_values(levels, o);
    let iso = prm.iso as f32;
    let at = |x: usize, y: usize, z: usize| v[x + N * (y + N * z)];
    // derivative along `axis` at padded node (x,y,z), per cell width
    let deriv = |x: usize, y: usize, z: usize, axis: usize| -> f32 {
        let mut q = [x, y, z];
        let c = at(x, y, z);
        q[axis] += 1;
        let up = if q[axis] < N {
            at(q[0], q[1], q[2])
        } else {
            f32::NAN
        };
        q[axis] -= 2;
        let dn = if q[axis] < N {
            at(q[0], q[1], q[2])
        } else {
            f32::NAN
        };
        match (up.is_nan(), dn.is_nan()) {
            (false, false) => 0.5 * (up - dn),
            (false, true) => up - c,
            (true, false) => c - dn,
            _ => 0.0,
        }
    };
    let tab = table();
    let mut out = BlockOut {
        keys: Vec::new(),
        pos: Vec::new(),
        grad: Vec::new(),
        tris: Vec::new(),
        exits: [false; 6],
    };
    let mut local: FxHashMap<u64, u32> = FxHashMap::default();
    let inv = 1.0 / res as f64;
    for z in 0..8usize {
        for y in 0..8usize {
            for x in 0..8usize {
                let g = [o[0] + x as i32, o[1] + y as i32, o[2] + z as i32];
                if g.iter().any(|&c| c >= res) {
                    continue;
                }
                let mut case = 0usize;
                let mut vals = [0.0f32; 8];
                for (k, val) in vals.iter_mut().enumerate() {
                    *val = at(x + 1 + (k & 1), y + 1 + ((k >> 1) & 1), z + 1 + (k >> 2));
                    if *val > iso {
                        case |= 1 << k;
                    }
                }
                if case == 0 || case == 255 {
                    continue;
                }
                let cell = [x, y, z];
                for (axis, side) in [(0, 0), (0, 7), (1, 0), (1, 7), (2, 0), (2, 7)] {
                    if cell[axis] == side {
                        out.exits[2 * axis + usize::from(side == 7)] = true;
                    }
                }
                for lp in &tab[case] {
                    let mut poly: Vec<u32> = Vec::with_capacity(lp.len());
                    for &e in lp {
                        let (ca, cb) = edge_corners(e as usize);
                        let axis = (e / 4) as usize;
                        let pa = [x + 1 + (ca & 1), y + 1 + ((ca >> 1) & 1), z + 1 + (ca >> 2)];
                        let ga = [
                            g[0] + (ca & 1) as i32,
                            g[1] + ((ca >> 1) & 1) as i32,
                            g[2] + (ca >> 2) as i32,
                        ];
                        let key = edge_key(ga, axis);
                        let id = *local.entry(key).or_insert_with(|| {
                            let (va, vb) = (vals[ca], vals[cb]);
                            let mut pb = pa;
                            pb[axis] += 1;
                            let t = edge_root(
                                va,
                                vb,
                                deriv(pa[0], pa[1], pa[2], axis),
                                deriv(pb[0], pb[1], pb[2], axis),
                                iso,
                                prm.linear,
                            );
                            let mut p =
                                [ga[0] as f64 * inv, ga[1] as f64 * inv, ga[2] as f64 * inv];
                            p[axis] += t * inv;
                            let mut gr = [0.0f32; 3];
                            for (k, gk) in gr.iter_mut().enumerate() {
                                let d0 = deriv(pa[0], pa[1], pa[2], k);
                                let d1 = deriv(pb[0], pb[1], pb[2], k);
                                *gk = ((1.0 - t as f32) * d0 + t as f32 * d1) * res as f32;
                            }
                            out.keys.push(key);
                            out.pos.push(p);
                            out.grad.push(gr);
                            (out.pos.len() - 1) as u32
                        });
                        poly.push(id);
                    }
                    triangulate(&poly, &out.pos, &mut out.tris);
                }
            }
        }
    }
    out
}

/// Position of the iso-crossing on an edge as a fraction in [0, 1].
pub(crate) fn edge_root(va: f32, vb: f32, da: f32, db: f32, iso: f32, linear: bool) -> f64 {
    let (va, vb, iso) = (va as f64, vb as f64, iso as f64);
    let lin = ((iso - va) / (vb - va)).clamp(0.0, 1.0);
    if linear {
        return lin;
    }
    let diff = vb - va;
    let avg = 0.5 * (da as f64 + db as f64);
    if avg == 0.0 || avg.signum() != diff.signum() {
        return lin;
    }
    let d0 = da as f64 * diff / avg;
    // P(t) = va + d0 t + (diff - d0) t², P(t) = iso
    let a = diff - d0;
    let (b, c) = (d0, va - iso);
    let roots: Vec<f64> = if a.abs() < 1e-12 * diff.abs().max(1e-30) {
        vec![-c / b]
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return lin;
        }
        let s = disc.sqrt();
        vec![(-b - s) / (2.0 * a), (-b + s) / (2.0 * a)]
    };
    let ok: Vec<f64> = roots
        .into_iter()
        .filter(|t| (0.0..=1.0).contains(t))
        .collect();
    if ok.is_empty() {
        lin
    } else {
        ok.iter().sum::<f64>() / ok.len() as f64
    }
}

/// Extracts the iso-surface, flooding from the blocks holding `seeds`
/// (unit-cube points, usually the samples).
pub fn extract(levels: &[Level], seeds: &[[f64; 3]], prm: &ExtractParams) -> IsoMesh {
    let fine = levels.last().expect("levels");
    let res = fine.res;
    let nblocks = (res + BS - 1) / BS;
    let mut visited: FxHashSet<[i32; 3]> = FxHashSet::default();
    let mut wave: Vec<[i32; 3]> = Vec::new();
    for p in seeds {
        let c = [
            ((p[0] * res as f64).floor() as i32).clamp(0, res - 1),
            ((p[1] * res as f64).floor() as i32).clamp(0, res - 1),
            ((p[2] * res as f64).floor() as i32).clamp(0, res - 1),
        ];
        let b = [c[0] / BS, c[1] / BS, c[2] / BS];
        if visited.insert(b) {
            wave.push(b);
        }
    }
    let mut mesh = IsoMesh::default();
    let mut ids: FxHashMap<u64, u32> = FxHashMap::default();
    while !wave.is_empty() {
        wave.sort_unstable_by_key(|b| morton(*b));
        let mut next = Vec::new();
        // Chunks bound the memory of block outputs waiting to be merged.
        for chunk in wave.chunks(2048) {
            let outs: Vec<BlockOut> = chunk
                .par_iter()
                .map(|&b| process_block(levels, b, prm))
                .collect();
            merge_blocks(
                chunk,
                outs,
                &mut mesh,
                &mut ids,
                &mut visited,
                &mut next,
                nblocks,
            );
        }
        wave = next;
    }
    mesh
}

fn merge_blocks(
    chunk: &[[i32; 3]],
    outs: Vec<BlockOut>,
    mesh: &mut IsoMesh,
    ids: &mut FxHashMap<u64, u32>,
    visited: &mut FxHashSet<[i32; 3]>,
    next: &mut Vec<[i32; 3]>,
    nblocks: i32,
) {
    for (b, o) in chunk.iter().zip(outs) {
        let map: Vec<u32> = o
            .keys
            .iter()
            .enumerate()
            .map(|(i, k)| {
                *ids.entry(*k).or_insert_with(|| {
                    mesh.vertices.push(o.pos[i]);
                    mesh.gradients.push(o.grad[i]);
                    (mesh.vertices.len() - 1) as u32
                })
            })
            .collect();
        mesh.triangles.extend(
            o.tris
                .iter()
                .map(|t| [map[t[0] as usize], map[t[1] as usize], map[t[2] as usize]]),
        );
        for (f, &exit) in o.exits.iter().enumerate() {
            if !exit {
                continue;
            }
            let mut nb = *b;
            nb[f / 2] += if f % 2 == 1 { 1 } else { -1 };
            if nb.iter().all(|&c| (0..nblocks).contains(&c)) && visited.insert(nb) {
                next.push(nb);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadratic_root_matches_exact_quadratic() {
        // f(t) = t² on [0,1] crossing 0.25 at t = 0.5: derivatives 0 and 2.
        let t = edge_root(0.0, 1.0, 0.0, 2.0, 0.25, false);
        assert!((t - 0.5).abs() < 1e-12, "{t}");
        assert!((edge_root(0.0, 1.0, 0.0, 2.0, 0.25, true) - 0.25).abs() < 1e-12);
    }
}
