//! Marching cubes over a [`TsdfVolume`] with the rules of Open3D's
//! `ScalableTSDFVolume::ExtractTriangleMesh`:
//! - a cube is the 8 voxel centres (b·16 + (x, y, z) + corner); corners past
//!   the block come from the neighbouring block;
//! - a cube with any corner of weight 0, or in a block that does not exist,
//!   is skipped;
//! - a corner is inside when its tsdf is < 0 (exactly 0 is outside);
//! - one vertex per crossing edge, shared by every cube (and block) that
//!   holds the edge, at `(lower corner + 0.5)·voxel + f0/(f0 + f1)·voxel`
//!   along the edge's axis, f0 = |tsdf| at its lower corner and f1 at the
//!   upper one (f64); colour `(f1·c0 + f0·c1)/(f0 + f1)`, written as
//!   round(clamp(c/255, 0, 1)·255);
//! - triangles are counter-clockwise seen from the positive (free-space)
//!   side: their normals point out of the surface, toward the cameras.
//!
//! Departures, both on purpose: the polygons come from the shared
//! [`crate::geom::meshing::marching_cubes`] table, which is crack-free where Open3D's
//! Lorensen/Bourke table is not (on ambiguous faces only; the vertex set is
//! the same, see that module); and vertices are numbered in sorted order of
//! (voxel x, y, z, axis) of their edge, triangles in sorted order of block
//! then cube (z, y, x), instead of Open3D's hash-map iteration order, so the
//! output is the same for every thread count and run.

use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::volume::{TsdfVolume, UNIT};
use crate::geom::meshing::marching_cubes::{edge_corners, table, triangulate};
use crate::model::Mesh;

/// Padded block side: the block's 16 voxels plus one from the + neighbour.
const P: usize = UNIT + 1;

/// An edge of the voxel grid: its lower voxel (global index) and axis.
type EdgeKey = [i32; 4];

/// One block's share of the mesh, in block-local vertex indices.
struct BlockMesh {
    keys: Vec<EdgeKey>,
    pos: Vec<[f64; 3]>,
    rgb: Vec<[u8; 3]>,
    tris: Vec<[u32; 3]>,
}

/// The voxel values a block's cubes read: tsdf, weight and colour on the
/// padded 17³ grid (weight 0 where the neighbour block is missing).
struct Padded {
    f: Vec<f32>,
    w: Vec<f32>,
    c: Option<Vec<[f32; 3]>>,
}

#[inline]
fn pidx(x: usize, y: usize, z: usize) -> usize {
    (x * P + y) * P + z
}

fn gather(vol: &TsdfVolume, key: [i32; 3]) -> Padded {
    let n = P * P * P;
    let color = vol.has_color();
    let mut out = Padded {
        f: vec![0.0; n],
        w: vec![0.0; n],
        c: color.then(|| vec![[0.0; 3]; n]),
    };
    for dx in 0..2i32 {
        for dy in 0..2i32 {
            for dz in 0..2i32 {
                let Some(b) = vol.block([key[0] + dx, key[1] + dy, key[2] + dz]) else {
                    continue;
                };
                // the part of the padded grid this block fills
                let range = |d: i32| if d == 0 { 0..UNIT } else { 0..1 };
                for x in range(dx) {
                    for y in range(dy) {
                        for z in range(dz) {
                            let src = (x * UNIT + y) * UNIT + z;
                            let dst = pidx(
                                x + dx as usize * UNIT,
                                y + dy as usize * UNIT,
                                z + dz as usize * UNIT,
                            );
                            out.f[dst] = b.tsdf[src];
                            out.w[dst] = b.weight[src];
                            if let (Some(oc), Some(bc)) = (out.c.as_mut(), b.color.as_ref()) {
                                oc[dst] = bc[src];
                            }
                        }
                    }
                }
            }
        }
    }
    out
}

fn block_mesh(vol: &TsdfVolume, key: [i32; 3]) -> BlockMesh {
    let pad = gather(vol, key);
    let voxel = vol.params().voxel;
    let tab = table();
    let mut out = BlockMesh {
        keys: Vec::new(),
        pos: Vec::new(),
        rgb: Vec::new(),
        tris: Vec::new(),
    };
    let mut local: FxHashMap<EdgeKey, u32> = FxHashMap::default();
    let g0 = [
        key[0] * UNIT as i32,
        key[1] * UNIT as i32,
        key[2] * UNIT as i32,
    ];
    let corner = |k: usize| [k & 1, (k >> 1) & 1, k >> 2];
    for z in 0..UNIT {
        for y in 0..UNIT {
            for x in 0..UNIT {
                let mut case = 0usize;
                let mut f = [0.0f32; 8];
                let mut idx = [0usize; 8];
                let mut skip = false;
                for k in 0..8 {
                    let o = corner(k);
                    let i = pidx(x + o[0], y + o[1], z + o[2]);
                    if pad.w[i] == 0.0 {
                        skip = true;
                        break;
                    }
                    idx[k] = i;
                    f[k] = pad.f[i];
                    if f[k] < 0.0 {
                        case |= 1 << k;
                    }
                }
                if skip || case == 0 || case == 255 {
                    continue;
                }
                for lp in &tab[case] {
                    let mut poly: Vec<u32> = Vec::with_capacity(lp.len());
                    for &e in lp {
                        let (ca, cb) = edge_corners(e as usize);
                        let axis = e as usize / 4;
                        let oa = corner(ca);
                        let ek: EdgeKey = [
                            g0[0] + (x + oa[0]) as i32,
                            g0[1] + (y + oa[1]) as i32,
                            g0[2] + (z + oa[2]) as i32,
                            axis as i32,
                        ];
                        let id = *local.entry(ek).or_insert_with(|| {
                            let f0 = (f[ca] as f64).abs();
                            let f1 = (f[cb] as f64).abs();
                            let mut p = [
                                (ek[0] as f64 + 0.5) * voxel,
                                (ek[1] as f64 + 0.5) * voxel,
                                (ek[2] as f64 + 0.5) * voxel,
                            ];
                            p[axis] += f0 * voxel / (f0 + f1);
                            let rgb = match &pad.c {
                                Some(c) => {
                                    let (c0, c1) = (c[idx[ca]], c[idx[cb]]);
                                    std::array::from_fn(|k| {
                                        let v = (f1 * c0[k] as f64 + f0 * c1[k] as f64)
                                            / (f0 + f1)
                                            / 255.0;
                                        (v.clamp(0.0, 1.0) * 255.0).round() as u8
                                    })
                                }
                                None => [0; 3],
                            };
                            out.keys.push(ek);
                            out.pos.push(p);
                            out.rgb.push(rgb);
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

/// The iso-surface tsdf = 0 of the volume as a mesh (with vertex colours when
/// the volume keeps colour); empty when nothing was observed on both sides.
pub fn extract_mesh(vol: &TsdfVolume) -> Mesh {
    let mut keys: Vec<[i32; 3]> = vol.keys().to_vec();
    keys.par_sort_unstable();
    let parts: Vec<BlockMesh> = keys.par_iter().map(|&k| block_mesh(vol, k)).collect();
    // canonical vertex numbering: sorted edge keys
    let mut all: Vec<(EdgeKey, [f64; 3], [u8; 3])> = parts
        .iter()
        .flat_map(|b| {
            b.keys
                .iter()
                .zip(&b.pos)
                .zip(&b.rgb)
                .map(|((k, p), c)| (*k, *p, *c))
        })
        .collect();
    all.par_sort_unstable_by_key(|v| v.0);
    all.dedup_by_key(|v| v.0);
    let id: FxHashMap<EdgeKey, u32> = all
        .iter()
        .enumerate()
        .map(|(i, v)| (v.0, i as u32))
        .collect();
    let mut faces = Vec::with_capacity(parts.iter().map(|b| b.tris.len()).sum());
    for b in &parts {
        let map: Vec<u32> = b.keys.iter().map(|k| id[k]).collect();
        faces.extend(
            b.tris
                .iter()
                .map(|t| [map[t[0] as usize], map[t[1] as usize], map[t[2] as usize]]),
        );
    }
    let mut mesh = Mesh::new(
        all.iter()
            .map(|v| [v.1[0] as f32, v.1[1] as f32, v.1[2] as f32])
            .collect(),
        faces,
    );
    if vol.has_color() {
        mesh.vertex_colors = Some(all.iter().map(|v| [v.2[0], v.2[1], v.2[2], 255]).collect());
    }
    mesh
}
