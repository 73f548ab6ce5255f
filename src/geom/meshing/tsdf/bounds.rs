//! 2DGS's automatic fusion settings from the cameras alone
//! (`estimate_bounding_sphere` and `focus_point_fn` in its `mesh_utils.py`).
//!
//! - focus point: the point nearest to every optical axis in the least-squares
//!   sense ([`crate::model::rig::focus`], shared with every command);
//! - radius: the smallest distance from a camera centre to the focus point;
//! - `depth_trunc = 2·radius`, `voxel = depth_trunc / mesh_res` (2DGS
//!   default 1024), `sdf_trunc = 5·voxel`.

use glam::DVec3;

use crate::model::{Camera, rig};
use crate::{Error, Result};

/// The cameras' focus point and bounding-sphere radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSphere {
    pub center: DVec3,
    pub radius: f64,
}

/// The focus point and radius of `cams` ([`crate::model::rig::focus`]:
/// the point and the smallest camera distance). Errors when there is no
/// camera, when the optical axes are (nearly) parallel (the point is not
/// defined) or when the radius comes out zero or not finite.
pub fn camera_sphere(cams: &[Camera]) -> Result<CameraSphere> {
    if cams.is_empty() {
        return Err(Error::invalid(
            "no cameras to estimate the scene radius from",
        ));
    }
    let Some(f) = rig::focus(cams) else {
        return Err(Error::invalid(
            "the cameras' optical axes are all parallel: no focus point; give --depth-trunc, \
             --voxel and --sdf-trunc",
        ));
    };
    let radius = f.min_distance;
    if !(radius.is_finite() && radius > 0.0) {
        return Err(Error::invalid(format!(
            "scene radius from the cameras is {radius}: give --depth-trunc, --voxel and --sdf-trunc"
        )));
    }
    Ok(CameraSphere {
        center: f.point,
        radius,
    })
}

/// 2DGS's defaults: (voxel, sdf_trunc, depth_trunc) for a radius and a mesh
/// resolution.
pub fn auto_params(radius: f64, mesh_res: usize) -> (f64, f64, f64) {
    let depth_trunc = 2.0 * radius;
    let voxel = depth_trunc / mesh_res as f64;
    (voxel, 5.0 * voxel, depth_trunc)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DMat3;

    /// Cameras on a circle of radius 3 around (1, 2, 0.5), each looking at
    /// it: the focus point is the centre and the radius 3; one camera moved
    /// to distance 2 along its own axis makes the radius 2 (the minimum).
    #[test]
    fn ring_of_cameras_looking_at_a_point() {
        let target = DVec3::new(1.0, 2.0, 0.5);
        let mut cams = Vec::new();
        for k in 0..8 {
            let a = k as f64 * std::f64::consts::TAU / 8.0;
            let dist = if k == 3 { 2.0 } else { 3.0 };
            let pos = target + DVec3::new(a.cos(), 0.3, a.sin()).normalize() * dist;
            let z = (target - pos).normalize();
            let x = z.cross(DVec3::Y).normalize();
            let y = z.cross(x);
            let (r, t) = Camera::pose_from_c2w(DMat3::from_cols(x, y, z), pos);
            cams.push(Camera::pinhole("c", 64, 48, 50.0, 50.0, 32.0, 24.0, r, t));
        }
        let s = camera_sphere(&cams).unwrap();
        assert!((s.center - target).length() < 1e-9, "{:?}", s.center);
        assert!((s.radius - 2.0).abs() < 1e-9);
        let (v, st, dt) = auto_params(s.radius, 1024);
        assert!((dt - 4.0).abs() < 1e-9 && (v - 4.0 / 1024.0).abs() < 1e-12);
        assert!((st - 5.0 * v).abs() < 1e-12);
        assert!(camera_sphere(&[]).is_err());
        assert!(camera_sphere(&cams[..1]).is_err(), "one axis: no point");
    }
}
