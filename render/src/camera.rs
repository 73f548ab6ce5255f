//! Pinhole camera in OpenCV axes.
//!
//! Conventions (every camera reader converts into these):
//! - camera axes: x right, y down, z forward (OpenCV / COLMAP);
//! - pose: world-to-camera `x_cam = R · x_world + t`, stored in f64;
//! - intrinsics fx, fy, cx, cy in pixels; the centre of pixel (i, j) is at
//!   (i + 0.5, j + 0.5), so a principal point of (W/2, H/2) is the image centre.

use glam::{DMat3, DMat4, DVec2, DVec3};

/// The projection model a camera was stored with.
///
/// Only [`CameraModel::Pinhole`] can be used by commands that project points;
/// other models are read and reported so the user learns what the file holds
/// (see [`Camera::require_pinhole`]).
#[derive(Clone, Debug, PartialEq)]
pub enum CameraModel {
    /// Undistorted pinhole (COLMAP PINHOLE / SIMPLE_PINHOLE, 3DGS, NeRF, NeuS).
    Pinhole,
    /// Any other model, with its name and its extra (distortion) parameters as stored.
    Distorted { name: String, params: Vec<f64> },
}

/// One calibrated view.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Image name without directory (extension kept when the format stores one).
    pub name: String,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels (pixel centres at integer + 0.5).
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// World-to-camera rotation.
    pub rotation: DMat3,
    /// World-to-camera translation.
    pub translation: DVec3,
    /// Projection model (pinhole unless the source says otherwise).
    pub model: CameraModel,
}

impl Camera {
    /// A pinhole camera from intrinsics and a world-to-camera pose.
    #[allow(clippy::too_many_arguments)]
    pub fn pinhole(
        name: impl Into<String>,
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        rotation: DMat3,
        translation: DVec3,
    ) -> Self {
        Camera {
            name: name.into(),
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            rotation,
            translation,
            model: CameraModel::Pinhole,
        }
    }

    /// Builds the world-to-camera pose from a camera-to-world rotation (columns
    /// are the camera's x, y, z axes in world coordinates, OpenCV axes) and the
    /// camera centre in world coordinates.
    pub fn pose_from_c2w(c2w_rotation: DMat3, center: DVec3) -> (DMat3, DVec3) {
        let r = c2w_rotation.transpose();
        (r, -(r * center))
    }

    /// Camera centre in world coordinates, `C = -Rᵀ t`.
    pub fn center(&self) -> DVec3 {
        -(self.rotation.transpose() * self.translation)
    }

    /// Camera-to-world rotation (columns: camera x right, y down, z forward in world).
    pub fn c2w_rotation(&self) -> DMat3 {
        self.rotation.transpose()
    }

    /// 4×4 world-to-camera matrix.
    pub fn world_to_camera(&self) -> DMat4 {
        let mut m = DMat4::from_mat3(self.rotation);
        m.w_axis = self.translation.extend(1.0);
        m
    }

    /// 3×3 intrinsic matrix K.
    pub fn intrinsics(&self) -> DMat3 {
        DMat3::from_cols(
            DVec3::new(self.fx, 0.0, 0.0),
            DVec3::new(0.0, self.fy, 0.0),
            DVec3::new(self.cx, self.cy, 1.0),
        )
    }

    /// A point in camera coordinates.
    pub fn to_camera(&self, world: DVec3) -> DVec3 {
        self.rotation * world + self.translation
    }

    /// Projects a world point to pixel coordinates; `None` when it is not in
    /// front of the camera (z ≤ 0). Returns (pixel, depth z).
    pub fn project(&self, world: DVec3) -> Option<(DVec2, f64)> {
        let c = self.to_camera(world);
        if c.z <= 0.0 {
            return None;
        }
        Some((
            DVec2::new(self.fx * c.x / c.z + self.cx, self.fy * c.y / c.z + self.cy),
            c.z,
        ))
    }

    /// Horizontal field of view in radians.
    pub fn fov_x(&self) -> f64 {
        2.0 * (self.width as f64 / (2.0 * self.fx)).atan()
    }

    /// Vertical field of view in radians.
    pub fn fov_y(&self) -> f64 {
        2.0 * (self.height as f64 / (2.0 * self.fy)).atan()
    }

    /// `Ok` for pinhole cameras; otherwise a message naming the model, for
    /// commands that need undistorted input.
    pub fn require_pinhole(&self) -> Result<(), String> {
        match &self.model {
            CameraModel::Pinhole => Ok(()),
            CameraModel::Distorted { name, .. } => Err(format!(
                "camera '{}' uses the {name} model; this command needs undistorted \
                 (PINHOLE or SIMPLE_PINHOLE) cameras: run COLMAP's image_undistorter first",
                self.name
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn c2w_round_trip_and_projection_of_centre_ray() {
        // A camera at (1, 2, 3) looking down world -z (x right, y down => rotate 180° about x).
        let c2w = DMat3::from_cols(DVec3::X, -DVec3::Y, -DVec3::Z);
        let center = DVec3::new(1.0, 2.0, 3.0);
        let (r, t) = Camera::pose_from_c2w(c2w, center);
        let cam = Camera::pinhole("a", 640, 480, 500.0, 500.0, 320.0, 240.0, r, t);
        assert!((cam.center() - center).length() < 1e-12);
        // A point 5 units in front of the camera projects to the principal point.
        let (px, z) = cam.project(center - 5.0 * DVec3::Z).unwrap();
        assert!((px - DVec2::new(320.0, 240.0)).length() < 1e-9);
        assert!((z - 5.0).abs() < 1e-12);
        // Behind the camera: no projection.
        assert!(cam.project(center + DVec3::Z).is_none());
        // World +x is image right, world +y is image up (pixel y smaller).
        let (p2, _) = cam
            .project(center - 5.0 * DVec3::Z + DVec3::new(1.0, 1.0, 0.0))
            .unwrap();
        assert!((p2.x - 420.0).abs() < 1e-9 && (p2.y - 140.0).abs() < 1e-9);
    }
}
