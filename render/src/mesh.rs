//! Opaque triangle-mesh rasteriser: a z-buffer with per-pixel face id,
//! barycentrics, depth and normal, for visibility tests and mesh depth maps.
//!
//! Each pixel's ray (through the pixel centre, integer + 0.5) is intersected
//! with the faces whose screen box touches its 16×16 tile (Möller–Trumbore
//! in camera space), so depth and barycentrics are exact and perspective
//! correct, and faces crossing the near plane are cut where they cross it.
//! The nearest hit with camera z > `near` wins; ties go to the lower face
//! index. Depth is camera z (not ray length). Faces are two-sided; the normal
//! is the geometric face normal turned toward the camera, in camera axes.

use glam::DVec3;
use rayon::prelude::*;

use crate::Camera;
use crate::tiles::{TILE, TileLists, render_tiles, tile_pixels, tile_rect};

/// The z-buffer outputs, row-major `width × height`.
#[derive(Clone, Debug, Default)]
pub struct MeshRender {
    pub width: usize,
    pub height: usize,
    /// Face index per pixel, `u32::MAX` where no face is hit.
    pub face: Vec<u32>,
    /// Barycentrics (of vertices 1 and 2; vertex 0 gets 1 − u − v).
    pub bary: Vec<[f32; 2]>,
    /// Camera z of the hit, 0 where nothing is hit.
    pub depth: Vec<f32>,
    /// Camera-space unit normal facing the camera, zero where nothing is hit.
    pub normal: Vec<[f32; 3]>,
}

/// No face at this pixel.
pub const NO_FACE: u32 = u32::MAX;

/// Face id, barycentrics, depth, normal of one pixel.
type Hit = (u32, [f32; 2], f32, [f32; 3]);

struct Face {
    /// The camera-space triangle, prepared once for all its pixels' rays.
    tri: RayTriangle,
    bbox: [f32; 4],
    depth: f32,
}

/// Renders the mesh (`positions`, triangle `faces`) from `cam`.
pub fn render(positions: &[[f32; 3]], faces: &[[u32; 3]], cam: &Camera, near: f64) -> MeshRender {
    let (w, h) = (cam.width as usize, cam.height as usize);
    let mut out = MeshRender {
        width: w,
        height: h,
        face: vec![NO_FACE; w * h],
        bary: vec![[0.0; 2]; w * h],
        depth: vec![0.0; w * h],
        normal: vec![[0.0; 3]; w * h],
    };
    let (tw, th) = (w.div_ceil(TILE), h.div_ceil(TILE));
    if tw == 0 || th == 0 {
        return out;
    }
    let view: Vec<DVec3> = positions
        .par_iter()
        .map(|p| cam.to_camera(DVec3::from_array(p.map(f64::from))))
        .collect();
    let full = [0.0, 0.0, w as f32, h as f32];
    let prepared: Vec<Option<Face>> = faces
        .par_iter()
        .map(|f| {
            let idx = f.map(|i| i as usize);
            if idx.iter().any(|&i| i >= view.len()) {
                return None;
            }
            let v = idx.map(|i| view[i]);
            if v.iter().all(|p| p.z <= near) || v.iter().any(|p| !p.is_finite()) {
                return None;
            }
            // screen box; a face reaching behind the near plane may cover
            // any pixel, so it gets the whole image
            let bbox = if v.iter().all(|p| p.z > near) {
                let mut b = [
                    f32::INFINITY,
                    f32::INFINITY,
                    f32::NEG_INFINITY,
                    f32::NEG_INFINITY,
                ];
                for p in &v {
                    let (x, y) = (
                        (cam.fx * p.x / p.z + cam.cx) as f32,
                        (cam.fy * p.y / p.z + cam.cy) as f32,
                    );
                    b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
                }
                if b[2] < 0.0 || b[3] < 0.0 || b[0] > full[2] || b[1] > full[3] {
                    return None;
                }
                b
            } else {
                full
            };
            let depth = v.iter().map(|p| p.z).fold(f64::INFINITY, f64::min) as f32;
            Some(Face {
                tri: RayTriangle::new(&v),
                bbox,
                depth,
            })
        })
        .collect();
    let tiles = TileLists::build(
        &prepared,
        |f| f.as_ref().and_then(|f| tile_rect(f.bbox, w, h)),
        |f| f.as_ref().map_or(f32::INFINITY, |f| f.depth),
        w,
        h,
    );
    // Per tile, faces in order of their nearest vertex depth, each tested
    // only at the pixel centres inside its screen box: the cost follows the
    // covered area, not faces × tile pixels. A pixel's winner is the nearest
    // hit with ties to the lower face index, which does not depend on the
    // order the faces come in, so this equals testing every listed face at
    // every pixel.
    let tile = |ti: usize| -> Vec<Hit> {
        let (tx, ty) = (ti % tw, ti / tw);
        let (x0, y0) = (tx * TILE, ty * TILE);
        let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
        let tw_px = x1 - x0;
        let n_px = tw_px * (y1 - y0);
        // best (z, face, u, v) per tile pixel
        let mut best: Vec<(f64, u32, f64, f64)> = vec![(f64::INFINITY, NO_FACE, 0.0, 0.0); n_px];
        let mut uncovered = n_px;
        let mut far = f64::INFINITY; // max best z once every pixel is covered
        for (k, &fi) in tiles.list(ti).iter().enumerate() {
            let f = prepared[fi as usize].as_ref().expect("listed faces exist");
            let fd = f.depth as f64;
            if uncovered == 0 && k % 16 == 0 {
                far = best.iter().map(|b| b.0).fold(f64::NEG_INFINITY, f64::max);
            }
            if fd > far {
                break; // sorted by nearest vertex depth: nothing nearer follows
            }
            // pixel centres (x + 0.5) inside the box, widened by 0.01 px so
            // that f32 rounding of the box cannot drop a centre on its edge
            let span = |lo: f32, hi: f32, a: usize, b: usize| {
                let lo = ((lo as f64 - 0.51).ceil().max(a as f64)) as usize;
                let hi = (hi as f64 - 0.49).floor();
                if hi < a as f64 {
                    return (a, a);
                }
                // `as usize` saturates for huge boxes (a vertex at 1e38):
                // add without overflowing
                (lo.max(a), (hi as usize).saturating_add(1).min(b))
            };
            let (px0, px1) = span(f.bbox[0], f.bbox[2], x0, x1);
            let (py0, py1) = span(f.bbox[1], f.bbox[3], y0, y1);
            for y in py0..py1 {
                let dy = (y as f64 + 0.5 - cam.cy) / cam.fy;
                for x in px0..px1 {
                    let slot = &mut best[(y - y0) * tw_px + (x - x0)];
                    if fd > slot.0 {
                        continue;
                    }
                    let d = DVec3::new((x as f64 + 0.5 - cam.cx) / cam.fx, dy, 1.0);
                    if let Some((z, u, v)) = f.tri.hit(d)
                        && z > near
                        && (z < slot.0 || (z == slot.0 && fi < slot.1))
                    {
                        if slot.1 == NO_FACE {
                            uncovered -= 1;
                        }
                        *slot = (z, fi, u, v);
                    }
                }
            }
        }
        tile_pixels(ti, tw, w, h)
            .zip(best)
            .map(|((x, y), (z, fi, u, v))| {
                if fi == NO_FACE {
                    return (NO_FACE, [0.0; 2], 0.0, [0.0; 3]);
                }
                let f = prepared[fi as usize].as_ref().expect("winner exists");
                let d = DVec3::new(
                    (x as f64 + 0.5 - cam.cx) / cam.fx,
                    (y as f64 + 0.5 - cam.cy) / cam.fy,
                    1.0,
                );
                let n = f.tri.facing_normal(d);
                (fi, [u as f32, v as f32], z as f32, n.as_vec3().to_array())
            })
            .collect()
    };
    render_tiles(tw, th, w, h, tile, |o, (fi, b, z, n)| {
        out.face[o] = fi;
        out.bary[o] = b;
        out.depth[o] = z;
        out.normal[o] = n;
    });
    out
}

/// Ray from the camera centre along `d` (d.z = 1) against triangle `v`
/// (camera space, Möller–Trumbore): camera z of the hit and barycentrics
/// (u, v) of vertices 1 and 2. Degenerate (zero-area) triangles never hit.
pub fn intersect(v: &[DVec3; 3], d: DVec3) -> Option<(f64, f64, f64)> {
    RayTriangle::new(v).hit(d)
}

/// A triangle (camera space) prepared for many rays from the camera centre:
/// the parts of Möller–Trumbore that do not depend on the ray are computed
/// once, with the same operations, so [`RayTriangle::hit`] gives exactly
/// what [`intersect`] gives.
#[derive(Clone, Copy, Debug)]
pub struct RayTriangle {
    e1: DVec3,
    e2: DVec3,
    s: DVec3,
    q: DVec3,
    e2q: f64,
    degenerate: bool,
}

impl RayTriangle {
    pub fn new(v: &[DVec3; 3]) -> RayTriangle {
        let e1 = v[1] - v[0];
        let e2 = v[2] - v[0];
        let s = -v[0];
        let q = s.cross(e1);
        let n = e1.cross(e2);
        RayTriangle {
            e1,
            e2,
            s,
            q,
            e2q: e2.dot(q),
            degenerate: n.dot(n) == 0.0,
        }
    }

    /// The unit normal turned toward a ray along `d` (zero for a degenerate
    /// triangle, which never wins a pixel).
    pub fn facing_normal(&self, d: DVec3) -> DVec3 {
        let n = self.e1.cross(self.e2);
        let l = n.length();
        if l == 0.0 {
            return DVec3::ZERO;
        }
        let n = n / l;
        if n.dot(d) > 0.0 { -n } else { n }
    }

    /// Camera z and barycentrics (u, v) of the hit of the ray along `d`
    /// (d.z = 1), `None` when it misses.
    #[inline]
    pub fn hit(&self, d: DVec3) -> Option<(f64, f64, f64)> {
        let p = d.cross(self.e2);
        let det = self.e1.dot(p);
        if det.abs() < 1e-300 {
            return None;
        }
        let inv = 1.0 / det;
        let u = self.s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let vv = d.dot(self.q) * inv;
        if vv < 0.0 || u + vv > 1.0 {
            return None;
        }
        let t = self.e2q * inv; // d.z = 1, so t is the camera z
        if self.degenerate {
            return None;
        }
        Some((t, u, vv))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::test_camera;

    /// A unit square at z = 2 in front of a larger one at z = 5: every pixel
    /// of the small square's projection sees it at depth 2 with barycentrics
    /// that reproduce the hit point; the rest sees the big one at 5.
    #[test]
    fn occlusion_depth_and_barycentrics() {
        let cam = test_camera(40, 40, 40.0);
        let pos = [
            [-0.5f32, -0.5, 2.0],
            [0.5, -0.5, 2.0],
            [0.5, 0.5, 2.0],
            [-0.5, 0.5, 2.0],
            [-10.0, -10.0, 5.0],
            [10.0, -10.0, 5.0],
            [10.0, 10.0, 5.0],
            [-10.0, 10.0, 5.0],
        ];
        // the far quad first so that order does not decide occlusion
        let faces = [[4, 5, 6], [4, 6, 7], [0, 1, 2], [0, 2, 3]];
        let r = render(&pos, &faces, &cam, 0.01);
        for y in 0..40 {
            for x in 0..40 {
                let o = y * 40 + x;
                // the near square spans pixels 10..30 (±0.5·40/2 = ±10 px)
                let (px, py) = (x as f64 + 0.5 - 20.0, y as f64 + 0.5 - 20.0);
                if px.abs() < 10.0 && py.abs() < 10.0 {
                    assert!(r.face[o] == 2 || r.face[o] == 3, "({x},{y})");
                    assert!((r.depth[o] - 2.0).abs() < 1e-6);
                    let f = faces[r.face[o] as usize];
                    let [u, v] = r.bary[o].map(|c| c as f64);
                    let hit: Vec<f64> = (0..2)
                        .map(|k| {
                            (1.0 - u - v) * pos[f[0] as usize][k] as f64
                                + u * pos[f[1] as usize][k] as f64
                                + v * pos[f[2] as usize][k] as f64
                        })
                        .collect();
                    assert!((hit[0] - px / 20.0).abs() < 1e-6 && (hit[1] - py / 20.0).abs() < 1e-6);
                    assert_eq!(r.normal[o], [0.0, 0.0, -1.0]);
                } else {
                    assert!(r.face[o] <= 1, "({x},{y})");
                    assert!((r.depth[o] - 5.0).abs() < 1e-5);
                }
            }
        }
    }

    /// A floor plane that passes behind the camera is cut at the near plane
    /// and still fills the lower half of the view with exact depths.
    #[test]
    fn face_crossing_the_near_plane() {
        let cam = test_camera(20, 20, 20.0);
        let pos = [
            [-50.0f32, 1.0, -50.0],
            [50.0, 1.0, -50.0],
            [0.0, 1.0, 100.0],
        ];
        let r = render(&pos, &[[0, 1, 2]], &cam, 0.1);
        for y in 0..20 {
            for x in 0..20 {
                let o = y * 20 + x;
                let dy = (y as f64 + 0.5 - 10.0) / 20.0;
                if dy > 0.0 {
                    // the ray hits y = 1 at z = 1/dy
                    assert_eq!(r.face[o], 0, "({x},{y})");
                    assert!(((r.depth[o] as f64) - 1.0 / dy).abs() < 1e-4 / dy);
                } else {
                    assert_eq!(r.face[o], NO_FACE);
                }
            }
        }
    }

    /// Against a brute-force z-buffer (every face at every pixel, nearest hit
    /// with ties to the lower index): 3,000 small, overlapping random
    /// triangles, a few large ones, exact duplicates (ties), degenerate ones
    /// and some crossing the near plane, on a 70×50 image (partial tiles).
    /// Face ids, depths and barycentrics must be identical, bit for bit:
    /// the tiled, box-limited loop changes only which tests are skipped.
    #[test]
    fn equals_brute_force() {
        let cam = test_camera(70, 50, 60.0);
        let near = 0.3;
        let mut r = crate::testutil::Lcg(7);
        let mut pos: Vec<[f32; 3]> = Vec::new();
        let mut faces: Vec<[u32; 3]> = Vec::new();
        for i in 0..3000 {
            let c = [r.range(-0.7, 0.7), r.range(-0.5, 0.5), r.range(1.0, 3.0)];
            let size = if i % 100 == 0 { 0.8 } else { 0.05 };
            let b = pos.len() as u32;
            for _ in 0..3 {
                let mut p = [
                    c[0] + r.range(-size, size),
                    c[1] + r.range(-size, size),
                    c[2] + r.range(-size, size),
                ];
                if i % 250 == 7 {
                    p[2] = r.range(-0.5, 2.0); // may cross the near plane
                }
                pos.push(p);
            }
            faces.push([b, b + 1, b + 2]);
            if i % 97 == 0 {
                faces.push([b, b + 1, b + 2]); // duplicate: a depth tie
            }
            if i % 131 == 0 {
                faces.push([b, b, b + 2]); // degenerate
            }
        }
        let got = render(&pos, &faces, &cam, near);
        for y in 0..50 {
            for x in 0..70 {
                let d = DVec3::new(
                    (x as f64 + 0.5 - cam.cx) / cam.fx,
                    (y as f64 + 0.5 - cam.cy) / cam.fy,
                    1.0,
                );
                let mut best = (f64::INFINITY, NO_FACE, 0.0, 0.0);
                for (fi, f) in faces.iter().enumerate() {
                    let v = f.map(|i| DVec3::from_array(pos[i as usize].map(|c| c as f64)));
                    if let Some((z, u, vv)) = intersect(&v, d)
                        && z > near
                        && z < best.0
                    {
                        best = (z, fi as u32, u, vv);
                    }
                }
                let o = y * 70 + x;
                assert_eq!(got.face[o], best.1, "pixel ({x},{y})");
                if best.1 != NO_FACE {
                    assert_eq!(got.depth[o], best.0 as f32);
                    assert_eq!(got.bary[o], [best.2 as f32, best.3 as f32]);
                }
            }
        }
        assert!(got.face.iter().filter(|&&f| f != NO_FACE).count() > 3000);
    }
}
