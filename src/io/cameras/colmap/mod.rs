//! COLMAP sparse models (`sparse/0`): binary (`cameras.bin`, `images.bin`,
//! `points3D.bin`) and text (`cameras.txt`, `images.txt`, `points3D.txt`).
//!
//! Conventions of the files (all binary values little-endian):
//! - images store the **world-to-camera** pose `x_cam = R(q) · x_world + t`
//!   with the quaternion `q` **w-first** (qw, qx, qy, qz); camera axes are
//!   OpenCV (x right, y down, z forward), the same as [`Camera`], so poses are
//!   taken over unchanged (the quaternion is normalised first);
//! - intrinsics are in pixels with the centre of the top-left pixel at
//!   (0.5, 0.5), again the [`Camera`] convention;
//! - PINHOLE and SIMPLE_PINHOLE cameras become [`CameraModel::Pinhole`];
//!   every other model is read with its focal length(s) and principal point
//!   and becomes [`CameraModel::Distorted`] holding the remaining parameters.
//!
//! `rigs.bin` / `frames.bin` (COLMAP ≥ 3.12) are ignored. Cameras are
//! returned sorted by image name, as 3DGS sorts them.

mod binary;
#[cfg(test)]
mod tests;
mod text;

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat3, DQuat, DVec3};

use super::check_rotation;
use crate::io::source::read_input;
use crate::model::{Camera, CameraModel};
use crate::{Error, Result};

pub use binary::{
    decode_cameras_bin, decode_images_bin, decode_points3d_bin, encode_cameras_bin,
    encode_images_bin, encode_points3d_bin,
};
use binary::{parse_cameras_bin, parse_images_bin, parse_points3d_bin};
pub use text::{decode_cameras_txt, decode_images_txt, decode_points3d_txt};
use text::{parse_cameras_txt, parse_images_txt, parse_points3d_txt};

/// COLMAP camera models: (model id, name, number of parameters). The id is
/// what `cameras.bin` stores; the name is what `cameras.txt` stores.
pub const CAMERA_MODELS: [(i32, &str, usize); 16] = [
    (0, "SIMPLE_PINHOLE", 3),
    (1, "PINHOLE", 4),
    (2, "SIMPLE_RADIAL", 4),
    (3, "RADIAL", 5),
    (4, "OPENCV", 8),
    (5, "OPENCV_FISHEYE", 8),
    (6, "FULL_OPENCV", 12),
    (7, "FOV", 5),
    (8, "SIMPLE_RADIAL_FISHEYE", 4),
    (9, "RADIAL_FISHEYE", 5),
    (10, "THIN_PRISM_FISHEYE", 12),
    (11, "RAD_TAN_THIN_PRISM_FISHEYE", 16),
    (12, "SIMPLE_DIVISION", 4),
    (13, "DIVISION", 5),
    (14, "SIMPLE_FISHEYE", 3),
    (15, "FISHEYE", 4),
];

/// Name and parameter count of COLMAP camera model `id`, if known.
pub fn model_by_id(id: i32) -> Option<(&'static str, usize)> {
    CAMERA_MODELS
        .iter()
        .find(|m| m.0 == id)
        .map(|&(_, name, n)| (name, n))
}

/// Id and parameter count of the COLMAP camera model called `name`, if known.
pub fn model_by_name(name: &str) -> Option<(i32, usize)> {
    CAMERA_MODELS
        .iter()
        .find(|m| m.1 == name)
        .map(|&(id, _, n)| (id, n))
}

/// One entry of `cameras.bin` / `cameras.txt`.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapCamera {
    /// Camera id (images refer to it).
    pub id: u32,
    /// Model id, see [`CAMERA_MODELS`].
    pub model_id: i32,
    /// Image width in pixels.
    pub width: u64,
    /// Image height in pixels.
    pub height: u64,
    /// Model parameters as stored (focal length(s), principal point, then
    /// distortion), in pixels for the first ones.
    pub params: Vec<f64>,
}

impl ColmapCamera {
    /// The model's name (`"PINHOLE"`, …); the model id is always a known one
    /// for cameras read by this module.
    pub fn model_name(&self) -> &'static str {
        model_by_id(self.model_id).map_or("UNKNOWN", |m| m.0)
    }

    /// `(fx, fy, cx, cy, model)` in pixels, or `None` for an unknown model
    /// id or a wrong parameter count. Models with a single focal length
    /// (SIMPLE_*, RADIAL, RADIAL_FISHEYE) store `f, cx, cy, …`, the others
    /// `fx, fy, cx, cy, …`; the parameters after those are the distortion.
    pub fn intrinsics(&self) -> Option<(f64, f64, f64, f64, CameraModel)> {
        let (name, n) = model_by_id(self.model_id)?;
        if self.params.len() != n {
            return None;
        }
        let p = &self.params;
        let single = matches!(
            name,
            "SIMPLE_PINHOLE"
                | "SIMPLE_RADIAL"
                | "RADIAL"
                | "SIMPLE_RADIAL_FISHEYE"
                | "RADIAL_FISHEYE"
                | "SIMPLE_DIVISION"
                | "SIMPLE_FISHEYE"
        );
        let (fx, fy, cx, cy, rest) = if single {
            (p[0], p[0], p[1], p[2], &p[3..])
        } else {
            (p[0], p[1], p[2], p[3], &p[4..])
        };
        let model = if name == "PINHOLE" || name == "SIMPLE_PINHOLE" {
            CameraModel::Pinhole
        } else {
            CameraModel::Distorted {
                name: name.to_string(),
                params: rest.to_vec(),
            }
        };
        Some((fx, fy, cx, cy, model))
    }
}

/// One 2D observation of an image: pixel position (COLMAP convention, top-left
/// pixel centre at (0.5, 0.5)) and the id of its 3D point, or −1 when none.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point2D {
    /// Pixel x.
    pub x: f64,
    /// Pixel y.
    pub y: f64,
    /// Id of the observed 3D point, −1 when the observation is not triangulated.
    pub point3d_id: i64,
}

/// One entry of `images.bin` / `images.txt`.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapImage {
    /// Image id (tracks refer to it).
    pub id: u32,
    /// World-to-camera rotation as a quaternion, **w first**: (qw, qx, qy, qz).
    pub qvec: [f64; 4],
    /// World-to-camera translation.
    pub tvec: [f64; 3],
    /// Id of the camera (intrinsics) of this image.
    pub camera_id: u32,
    /// Image file name, relative to the images folder (extension kept).
    pub name: String,
    /// 2D observations, in file order (track entries index into this list).
    pub points2d: Vec<Point2D>,
}

impl ColmapImage {
    /// The world-to-camera rotation of the (normalised) quaternion, or `None`
    /// when the quaternion is zero or not finite.
    pub fn rotation(&self) -> Option<DMat3> {
        let [w, x, y, z] = self.qvec;
        let q = DQuat::from_xyzw(x, y, z, w);
        let n = q.length();
        if !(n.is_finite() && n > 0.0) {
            return None;
        }
        Some(DMat3::from_quat(q / n))
    }
}

/// One track element: the observation `point2d_idx` of image `image_id`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TrackElement {
    /// Image id.
    pub image_id: u32,
    /// Index into that image's [`ColmapImage::points2d`].
    pub point2d_idx: u32,
}

/// One entry of `points3D.bin` / `points3D.txt`.
#[derive(Clone, Debug, PartialEq)]
pub struct Point3D {
    /// Point id (observations refer to it).
    pub id: u64,
    /// Position in world coordinates.
    pub xyz: DVec3,
    /// Colour, 8 bits per channel.
    pub rgb: [u8; 3],
    /// Mean reprojection error in pixels as COLMAP stored it (−1 when unknown).
    pub error: f64,
    /// The observations of this point.
    pub track: Vec<TrackElement>,
}

/// A COLMAP sparse model.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ColmapModel {
    /// Cameras (intrinsics), in file order.
    pub cameras: Vec<ColmapCamera>,
    /// Registered images, sorted by name (3DGS order).
    pub images: Vec<ColmapImage>,
    /// 3D points, in file order (empty when the model has no points3D file or
    /// was read with [`ColmapModel::read_without_points`]).
    pub points3d: Vec<Point3D>,
}

impl ColmapModel {
    /// Reads the model in folder `dir`: binary when `cameras.bin` and
    /// `images.bin` exist, text otherwise. `points3D.{bin,txt}` is read when
    /// present (an absent one gives no points).
    pub fn read(dir: &Path) -> Result<Self> {
        Self::read_impl(dir, true)
    }

    /// Like [`ColmapModel::read`] without reading the 3D points (which can be
    /// millions), for when only the cameras are needed.
    pub fn read_without_points(dir: &Path) -> Result<Self> {
        Self::read_impl(dir, false)
    }

    fn read_impl(dir: &Path, with_points: bool) -> Result<Self> {
        let binary = dir.join("cameras.bin").is_file() && dir.join("images.bin").is_file();
        let mut model = if binary {
            let cameras = parse_cameras_bin(&load(&dir.join("cameras.bin"))?)?;
            let images = parse_images_bin(&load(&dir.join("images.bin"))?)?;
            let p = dir.join("points3D.bin");
            let points3d = if with_points && p.is_file() {
                parse_points3d_bin(&load(&p)?)?
            } else {
                Vec::new()
            };
            ColmapModel {
                cameras,
                images,
                points3d,
            }
        } else {
            if !dir.join("cameras.txt").is_file() {
                return Err(Error::format(
                    dir.display(),
                    "not a COLMAP model: neither cameras.bin + images.bin nor cameras.txt + \
                     images.txt in this folder",
                ));
            }
            let cameras = parse_cameras_txt(&load(&dir.join("cameras.txt"))?)?;
            let images = parse_images_txt(&load(&dir.join("images.txt"))?)?;
            let p = dir.join("points3D.txt");
            let points3d = if with_points && p.is_file() {
                parse_points3d_txt(&load(&p)?)?
            } else {
                Vec::new()
            };
            ColmapModel {
                cameras,
                images,
                points3d,
            }
        };
        model.images.sort_by(|a, b| a.name.cmp(&b.name));
        Ok(model)
    }

    /// One [`Camera`] per image, in the order of [`ColmapModel::images`]
    /// (by name). The name keeps the extension. Errors name the image when
    /// its camera id is missing, its quaternion is degenerate or its size
    /// does not fit `u32`.
    pub fn to_cameras(&self) -> Result<Vec<Camera>> {
        self.to_cameras_from("COLMAP images", "COLMAP cameras")
    }

    /// [`ColmapModel::to_cameras`] for a model read from files: an error in
    /// an image's record (missing camera id, degenerate quaternion) names
    /// `images_file`, one in its camera's record (parameter count, size)
    /// names `cameras_file`.
    pub fn to_cameras_from(&self, images_file: &str, cameras_file: &str) -> Result<Vec<Camera>> {
        let by_id: HashMap<u32, &ColmapCamera> = self.cameras.iter().map(|c| (c.id, c)).collect();
        self.images
            .iter()
            .map(|im| {
                let err = |msg: String| {
                    Error::format(
                        images_file,
                        format!("image '{}' (id {}): {msg}", im.name, im.id),
                    )
                };
                let cam = by_id.get(&im.camera_id).ok_or_else(|| {
                    err(format!(
                        "refers to camera {} which the model does not hold",
                        im.camera_id
                    ))
                })?;
                let cam_err = |msg: String| {
                    Error::format(
                        cameras_file,
                        format!("camera {} (of image '{}'): {msg}", cam.id, im.name),
                    )
                };
                let (fx, fy, cx, cy, model) = cam
                    .intrinsics()
                    .ok_or_else(|| cam_err("bad parameter count for its model".into()))?;
                let rotation = im
                    .rotation()
                    .ok_or_else(|| err(format!("degenerate quaternion {:?}", im.qvec)))?;
                let (width, height) = match (u32::try_from(cam.width), u32::try_from(cam.height)) {
                    (Ok(w), Ok(h)) => (w, h),
                    _ => {
                        return Err(cam_err(format!(
                            "image size {}x{} is too large",
                            cam.width, cam.height
                        )));
                    }
                };
                Ok(Camera {
                    name: im.name.clone(),
                    width,
                    height,
                    fx,
                    fy,
                    cx,
                    cy,
                    rotation,
                    translation: DVec3::from_array(im.tvec),
                    model,
                })
            })
            .collect()
    }

    /// A model with one COLMAP camera and one image per [`Camera`] (ids from
    /// 1, in the given order; no points). Pinhole cameras become PINHOLE;
    /// distorted ones keep their model when its name and parameter count are
    /// COLMAP's (models with a single focal length need fx = fy).
    pub fn from_cameras(cameras: &[Camera]) -> Result<Self> {
        let mut model = ColmapModel::default();
        for (i, c) in cameras.iter().enumerate() {
            let id = u32::try_from(i + 1)
                .map_err(|_| Error::invalid("more than 2^32 − 1 cameras for a COLMAP model"))?;
            let (model_id, params) = match &c.model {
                CameraModel::Pinhole => (1, vec![c.fx, c.fy, c.cx, c.cy]),
                CameraModel::Distorted { name, params } => {
                    let bad = || {
                        Error::invalid(format!(
                            "camera '{}': model {name} with {} parameters cannot be written as a COLMAP camera",
                            c.name,
                            params.len()
                        ))
                    };
                    let (mid, n) = model_by_name(name).ok_or_else(bad)?;
                    let single = n - params.len() == 3;
                    let mut p = if single {
                        if c.fx != c.fy {
                            return Err(bad());
                        }
                        vec![c.fx, c.cx, c.cy]
                    } else {
                        vec![c.fx, c.fy, c.cx, c.cy]
                    };
                    p.extend_from_slice(params);
                    if p.len() != n {
                        return Err(bad());
                    }
                    (mid, p)
                }
            };
            model.cameras.push(ColmapCamera {
                id,
                model_id,
                width: c.width as u64,
                height: c.height as u64,
                params,
            });
            let q = DQuat::from_mat3(&c.rotation).normalize();
            model.images.push(ColmapImage {
                id,
                qvec: [q.w, q.x, q.y, q.z],
                tvec: c.translation.to_array(),
                camera_id: id,
                name: c.name.clone(),
                points2d: Vec::new(),
            });
        }
        Ok(model)
    }
}

struct Loaded {
    name: String,
    bytes: crate::io::Input,
}

fn load(path: &Path) -> Result<Loaded> {
    let bytes = read_input(path)?;
    Ok(Loaded {
        name: path.display().to_string(),
        bytes,
    })
}

/// Checks that every camera of `cameras` has a proper rotation (used by the
/// writers of other formats, which store rotations as matrices), to the
/// readers' tolerance ([`super::gs_json::ROTATION_TOL`]), so a camera file
/// a reader accepted is also written back (a run that reads cameras and
/// writes them, as `train` does, never fails at the end over a rotation it
/// took at the start).
pub(crate) fn check_camera_rotations(cameras: &[Camera]) -> Result<()> {
    for c in cameras {
        check_rotation(c.rotation, super::gs_json::ROTATION_TOL)
            .map_err(|e| Error::invalid(format!("camera '{}': rotation {e}", c.name)))?;
    }
    Ok(())
}
