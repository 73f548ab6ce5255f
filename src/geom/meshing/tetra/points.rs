//! GOF's tetrahedralisation vertices (`get_tetra_points` and
//! `get_frustum_mask` of its `scene/gaussian_model.py`).
//!
//! Per Gaussian (activated, 3-D-filtered values as
//! `get_scaling_with_3D_filter` gives them, i.e. [`Gaussians3`] as our
//! loader builds it): the 8 corners of trimesh's unit box (±0.5) scaled by 2,
//! then per axis by 3σ, rotated by the normalised quaternion (w, x, y, z) and
//! moved to the mean, i.e. mean + R·(±3σx, ±3σy, ±3σz). Corners come in
//! trimesh's order, corner k having signs (x, y, z) = (bit 2, bit 1, bit 0)
//! of k (0: −, 1: +). Layout: all corners first, Gaussian-major (Gaussian i's
//! corner k at 8i + k), then the N centres. Each point carries the scale
//! 3·max(σ) of its Gaussian (GOF's `vertices_scale`, used by the mesh filter).
//! Finally the points outside every view's frustum are dropped, keeping order.
//!
//! Frustum test (`get_frustum_mask`): a point is kept if in at least one
//! view its camera z lies in [near, far] (defaults 0.02 and 1e6, GOF's
//! `--near`/`--far`) and its projection u = fx·x/z + cx, v = fy·y/z + cy lies
//! in [0, W − 1] × [0, H − 1].
//!
//! Departures: GOF projects every view with the first camera's W/2, H/2 and
//! W − 1, H − 1; here each camera's own (cx, cy) and size are used (the same
//! for GOF's cameras when all share one size, their principal point being the
//! centre). Arithmetic is f64 from the f32 inputs, stored as f32 (GOF: f32
//! throughout). A zero quaternion is taken as the identity (GOF: NaN corners).

use rayon::prelude::*;
use splatkit_render::Camera;
use splatkit_render::gaussian::{Gaussians3, quat_matrix};

/// GOF's default near limit of the frustum test (camera z, scene units).
pub const DEFAULT_NEAR: f64 = 0.02;
/// GOF's default far limit of the frustum test (camera z, scene units).
pub const DEFAULT_FAR: f64 = 1e6;

/// The vertices of GOF's tetrahedralisation and their scales.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TetraPoints {
    /// Positions, world units (f32 storage, as GOF's float32 tensors).
    pub points: Vec<[f32; 3]>,
    /// Per point: 3·max σ of its Gaussian, world units.
    pub scales: Vec<f32>,
}

/// The rotation matrix (rows) of quaternion (w, x, y, z), normalised; the
/// identity for a zero or non-finite-norm quaternion.
fn rotation(q: [f32; 4]) -> [[f64; 3]; 3] {
    let q = q.map(f64::from);
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if !(n > 0.0 && n.is_finite()) {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    quat_matrix(q.map(|v| v / n))
}

/// All 9N candidate points (8N corners then N centres, see the module doc)
/// and their scales, before the frustum test.
pub fn box_points(g: &Gaussians3) -> TetraPoints {
    let n = g.len();
    let corners: Vec<[[f32; 3]; 8]> = (0..n)
        .into_par_iter()
        .map(|i| {
            let r = rotation(g.rotations[i]);
            let m = g.means[i].map(f64::from);
            let s = g.scales[i].map(|v| 3.0 * v as f64);
            std::array::from_fn(|k| {
                let sign = |bit: usize| if k >> bit & 1 == 1 { 1.0 } else { -1.0 };
                let v = [sign(2) * s[0], sign(1) * s[1], sign(0) * s[2]];
                std::array::from_fn(|a| {
                    (m[a] + r[a][0] * v[0] + r[a][1] * v[1] + r[a][2] * v[2]) as f32
                })
            })
        })
        .collect();
    let scale: Vec<f32> = g
        .scales
        .iter()
        .map(|s| 3.0 * s[0].max(s[1]).max(s[2]))
        .collect();
    let mut points = Vec::with_capacity(9 * n);
    points.extend(corners.iter().flatten());
    points.extend_from_slice(&g.means);
    let mut scales = Vec::with_capacity(9 * n);
    scales.extend(scale.iter().flat_map(|&s| [s; 8]));
    scales.extend_from_slice(&scale);
    TetraPoints { points, scales }
}

/// GOF's `get_frustum_mask`: per point, whether some camera sees it (camera
/// z in [near, far], projection in [0, W − 1] × [0, H − 1]). No cameras: no
/// point is kept. NaN points are never kept.
pub fn frustum_mask(points: &[[f32; 3]], cams: &[Camera], near: f64, far: f64) -> Vec<bool> {
    points
        .par_iter()
        .map(|p| {
            let w = glam::DVec3::from_array(p.map(f64::from));
            cams.iter().any(|cam| {
                let c = cam.to_camera(w);
                let (u, v) = (cam.fx * c.x / c.z + cam.cx, cam.fy * c.y / c.z + cam.cy);
                c.z >= near
                    && c.z <= far
                    && u >= 0.0
                    && u <= cam.width as f64 - 1.0
                    && v >= 0.0
                    && v <= cam.height as f64 - 1.0
            })
        })
        .collect()
}

/// GOF's `get_tetra_points`: [`box_points`] kept where [`frustum_mask`]
/// holds, in order.
pub fn tetra_points(g: &Gaussians3, cams: &[Camera], near: f64, far: f64) -> TetraPoints {
    let all = box_points(g);
    let keep = frustum_mask(&all.points, cams, near, far);
    let (points, scales) = all
        .points
        .into_iter()
        .zip(all.scales)
        .zip(keep)
        .filter_map(|(ps, k)| k.then_some(ps))
        .unzip();
    TetraPoints { points, scales }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat3, DQuat, DVec3};

    fn one(mean: [f32; 3], scale: [f32; 3], rot: [f32; 4]) -> Gaussians3 {
        Gaussians3 {
            means: vec![mean],
            scales: vec![scale],
            rotations: vec![rot],
            opacities: vec![0.5],
            sh: vec![[0.0; 3]],
            sh_degree: 0,
        }
    }

    fn camera(w: u32, h: u32) -> Camera {
        let (cx, cy) = (w as f64 / 2.0, h as f64 / 2.0);
        Camera::pinhole("c", w, h, 50.0, 50.0, cx, cy, DMat3::IDENTITY, DVec3::ZERO)
    }

    /// An axis-aligned Gaussian: the corners are exactly mean ± 3σ in
    /// trimesh's order, then the centre; scales 3·max σ.
    #[test]
    fn axis_aligned_corners() {
        let (m, s) = ([1.0f32, -2.0, 3.0], [0.1f32, 0.2, 0.05]);
        let t = box_points(&one(m, s, [2.0, 0.0, 0.0, 0.0]));
        assert_eq!(t.points.len(), 9);
        let signs = [
            [-1, -1, -1],
            [-1, -1, 1],
            [-1, 1, -1],
            [-1, 1, 1],
            [1, -1, -1],
            [1, -1, 1],
            [1, 1, -1],
            [1, 1, 1],
        ];
        for (k, sg) in signs.iter().enumerate() {
            let want: [f32; 3] =
                std::array::from_fn(|a| (m[a] as f64 + sg[a] as f64 * 3.0 * s[a] as f64) as f32);
            assert_eq!(t.points[k], want, "corner {k}");
        }
        assert_eq!(t.points[8], m);
        assert_eq!(t.scales, vec![3.0 * 0.2f32; 9]);
    }

    /// A rotated Gaussian: each corner's offset from the mean, brought back
    /// by glam's rotation of the quaternion, is (±3σx, ±3σy, ±3σz).
    #[test]
    fn rotated_corners() {
        let q = [0.8f32, 0.3, -0.2, 0.5];
        let (m, s) = ([0.5f32, 0.25, -1.0], [0.3f32, 0.1, 0.2]);
        let t = box_points(&one(m, s, q));
        let rot = DQuat::from_xyzw(q[1] as f64, q[2] as f64, q[3] as f64, q[0] as f64).normalize();
        for k in 0..8 {
            let d =
                DVec3::from_array(t.points[k].map(f64::from)) - DVec3::from_array(m.map(f64::from));
            let local = rot.inverse() * d;
            let sg = [(k >> 2) & 1, (k >> 1) & 1, k & 1].map(|b| if b == 1 { 1.0 } else { -1.0 });
            for a in 0..3 {
                assert!(
                    (local[a] - sg[a] * 3.0 * s[a] as f64).abs() < 1e-6,
                    "corner {k} axis {a}"
                );
            }
        }
    }

    /// Points behind the camera, before `near`, beyond `far` or outside
    /// [0, W − 1] are dropped; the others kept; any view suffices.
    #[test]
    fn frustum_rules() {
        let cam = camera(101, 81); // u = 50·x/z + 50.5
        let pts = [
            [0.0, 0.0, 5.0],  // kept
            [0.0, 0.0, -5.0], // behind
            [0.0, 0.0, 0.01], // before near 0.02
            [0.0, 0.0, 2e6],  // beyond far
            [0.5, 0.0, 50.0], // u = 51: kept
            [5.05, 0.0, 5.0], // u = 101.000002 > W − 1 = 100
            [4.95, 0.0, 5.0], // u = 99.999998: kept
            [-4.9, 0.0, 5.0], // u = 1.5: kept
        ];
        let mask = frustum_mask(&pts, std::slice::from_ref(&cam), DEFAULT_NEAR, DEFAULT_FAR);
        assert_eq!(
            mask,
            vec![true, false, false, false, true, false, true, true]
        );
        // a second camera turned around sees the point behind the first
        let back = Camera::pinhole(
            "b",
            101,
            81,
            50.0,
            50.0,
            50.5,
            40.5,
            DMat3::from_diagonal(DVec3::new(-1.0, 1.0, -1.0)),
            DVec3::ZERO,
        );
        let mask2 = frustum_mask(&pts, &[cam, back], DEFAULT_NEAR, DEFAULT_FAR);
        assert!(mask2[1]);
        assert!(
            frustum_mask(&pts, &[], DEFAULT_NEAR, DEFAULT_FAR)
                .iter()
                .all(|&k| !k)
        );
    }

    /// `tetra_points` keeps the frustum's points in order with their scales.
    #[test]
    fn filtered_in_order() {
        let mut g = one([0.0, 0.0, 5.0], [0.1, 0.1, 0.1], [1.0, 0.0, 0.0, 0.0]);
        g.means.push([0.0, 0.0, -5.0]);
        g.scales.push([0.2, 0.3, 0.1]);
        g.rotations.push([1.0, 0.0, 0.0, 0.0]);
        g.opacities.push(0.5);
        g.sh.push([0.0; 3]);
        let all = box_points(&g);
        let t = tetra_points(&g, &[camera(101, 81)], DEFAULT_NEAR, DEFAULT_FAR);
        let want: Vec<usize> = [0, 1, 2, 3, 4, 5, 6, 7, 16].into();
        assert_eq!(
            t.points,
            want.iter().map(|&i| all.points[i]).collect::<Vec<_>>()
        );
        assert_eq!(t.scales, vec![3.0 * 0.1f32; 9]);
    }
}
