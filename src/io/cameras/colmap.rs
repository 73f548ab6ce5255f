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

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat3, DQuat, DVec3};

use super::check_rotation;
use crate::io::source::{read_input, werr, write_output};
use crate::model::{Camera, CameraModel};
use crate::{Error, Result};

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
        let by_id: HashMap<u32, &ColmapCamera> = self.cameras.iter().map(|c| (c.id, c)).collect();
        self.images
            .iter()
            .map(|im| {
                let err = |msg: String| {
                    Error::invalid(format!("COLMAP image '{}' (id {}): {msg}", im.name, im.id))
                };
                let cam = by_id.get(&im.camera_id).ok_or_else(|| {
                    err(format!(
                        "refers to camera {} which the model does not hold",
                        im.camera_id
                    ))
                })?;
                let (fx, fy, cx, cy, model) = cam
                    .intrinsics()
                    .ok_or_else(|| err(format!("camera {} has a bad parameter count", cam.id)))?;
                let rotation = im
                    .rotation()
                    .ok_or_else(|| err(format!("degenerate quaternion {:?}", im.qvec)))?;
                let (width, height) = match (u32::try_from(cam.width), u32::try_from(cam.height)) {
                    (Ok(w), Ok(h)) => (w, h),
                    _ => {
                        return Err(err(format!(
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

    /// Writes `cameras.txt`, `images.txt` and `points3D.txt` into `dir`
    /// (which must exist), in COLMAP's text layout. Floats are written with
    /// Rust's shortest round-trip formatting, so reading back is exact.
    pub fn write_text(&self, dir: &Path) -> Result<()> {
        write_output(&dir.join("cameras.txt"), |w| {
            let mut s = String::new();
            s.push_str("# Camera list with one line of data per camera:\n");
            s.push_str("#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n");
            s.push_str(&format!("# Number of cameras: {}\n", self.cameras.len()));
            for c in &self.cameras {
                s.push_str(&format!(
                    "{} {} {} {}",
                    c.id,
                    c.model_name(),
                    c.width,
                    c.height
                ));
                for p in &c.params {
                    s.push_str(&format!(" {p:?}"));
                }
                s.push('\n');
            }
            w.write_all(s.as_bytes()).map_err(werr)
        })?;
        write_output(&dir.join("images.txt"), |w| {
            let n_obs: usize = self.images.iter().map(|i| i.points2d.len()).sum();
            writeln!(w, "# Image list with two lines of data per image:").map_err(werr)?;
            writeln!(
                w,
                "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME"
            )
            .map_err(werr)?;
            writeln!(w, "#   POINTS2D[] as (X, Y, POINT3D_ID)").map_err(werr)?;
            writeln!(
                w,
                "# Number of images: {}, mean observations per image: {}",
                self.images.len(),
                n_obs as f64 / self.images.len().max(1) as f64
            )
            .map_err(werr)?;
            for im in &self.images {
                let [qw, qx, qy, qz] = im.qvec;
                let [tx, ty, tz] = im.tvec;
                writeln!(
                    w,
                    "{} {qw:?} {qx:?} {qy:?} {qz:?} {tx:?} {ty:?} {tz:?} {} {}",
                    im.id, im.camera_id, im.name
                )
                .map_err(werr)?;
                let mut line = String::new();
                for (k, p) in im.points2d.iter().enumerate() {
                    if k > 0 {
                        line.push(' ');
                    }
                    line.push_str(&format!("{:?} {:?} {}", p.x, p.y, p.point3d_id));
                }
                writeln!(w, "{line}").map_err(werr)?;
            }
            Ok(())
        })?;
        write_output(&dir.join("points3D.txt"), |w| {
            let n_track: usize = self.points3d.iter().map(|p| p.track.len()).sum();
            writeln!(w, "# 3D point list with one line of data per point:").map_err(werr)?;
            writeln!(
                w,
                "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)"
            )
            .map_err(werr)?;
            writeln!(
                w,
                "# Number of points: {}, mean track length: {}",
                self.points3d.len(),
                n_track as f64 / self.points3d.len().max(1) as f64
            )
            .map_err(werr)?;
            for p in &self.points3d {
                write!(
                    w,
                    "{} {:?} {:?} {:?} {} {} {} {:?}",
                    p.id, p.xyz.x, p.xyz.y, p.xyz.z, p.rgb[0], p.rgb[1], p.rgb[2], p.error
                )
                .map_err(werr)?;
                for t in &p.track {
                    write!(w, " {} {}", t.image_id, t.point2d_idx).map_err(werr)?;
                }
                writeln!(w).map_err(werr)?;
            }
            Ok(())
        })
    }

    /// Writes `cameras.bin`, `images.bin` and `points3D.bin` into `dir`
    /// (which must exist), byte-compatible with COLMAP's binary writer.
    pub fn write_binary(&self, dir: &Path) -> Result<()> {
        let files = [
            ("cameras.bin", encode_cameras_bin(&self.cameras)),
            ("images.bin", encode_images_bin(&self.images)),
            ("points3D.bin", encode_points3d_bin(&self.points3d)),
        ];
        for (name, bytes) in files {
            write_output(&dir.join(name), |w| w.write_all(&bytes).map_err(werr))?;
        }
        Ok(())
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

// ---------------------------------------------------------------------------
// Binary

/// A bounds-checked little-endian reader whose errors name the file, the
/// record being read and the byte offset.
struct Cursor<'a> {
    name: &'a str,
    data: &'a [u8],
    pos: usize,
    record: &'static str,
    index: usize,
}

impl<'a> Cursor<'a> {
    fn new(name: &'a str, data: &'a [u8]) -> Self {
        Cursor {
            name,
            data,
            pos: 0,
            record: "header",
            index: 0,
        }
    }

    fn at(&mut self, record: &'static str, index: usize) {
        self.record = record;
        self.index = index;
    }

    fn left(&self) -> usize {
        self.data.len() - self.pos
    }

    fn where_(&self) -> String {
        if self.record == "header" {
            "header".to_string()
        } else {
            format!("{} record {}", self.record, self.index)
        }
    }

    fn err(&self, msg: impl std::fmt::Display) -> Error {
        Error::format(
            self.name,
            format!("{} at byte offset {}: {msg}", self.where_(), self.pos),
        )
    }

    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8]> {
        if self.left() < n {
            return Err(self.err(format_args!(
                "truncated: {field} needs {n} bytes, only {} left",
                self.left()
            )));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn arr<const N: usize>(&mut self, field: &str) -> Result<[u8; N]> {
        Ok(self
            .take(N, field)?
            .try_into()
            .expect("take returns N bytes"))
    }
    fn u64(&mut self, field: &str) -> Result<u64> {
        Ok(u64::from_le_bytes(self.arr(field)?))
    }
    fn i64(&mut self, field: &str) -> Result<i64> {
        Ok(i64::from_le_bytes(self.arr(field)?))
    }
    fn u32(&mut self, field: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.arr(field)?))
    }
    fn i32(&mut self, field: &str) -> Result<i32> {
        Ok(i32::from_le_bytes(self.arr(field)?))
    }
    fn f64(&mut self, field: &str) -> Result<f64> {
        Ok(f64::from_le_bytes(self.arr(field)?))
    }

    /// A declared element count, checked against the bytes left given the
    /// smallest possible size of one element, before anything is allocated.
    fn count(&mut self, field: &str, min_each: usize) -> Result<usize> {
        let start = self.pos;
        let n = self.u64(field)?;
        let need = usize::try_from(n)
            .ok()
            .and_then(|n| n.checked_mul(min_each))
            .filter(|&need| need <= self.left());
        match need {
            Some(_) => Ok(n as usize),
            None => {
                self.pos = start;
                Err(self.err(format_args!(
                    "{field} = {n} needs at least {n} × {min_each} bytes, only {} left (truncated or corrupt file)",
                    self.left() - 8
                )))
            }
        }
    }

    /// A NUL-terminated string.
    fn cstring(&mut self, field: &str) -> Result<String> {
        let rest = &self.data[self.pos..];
        let Some(end) = rest.iter().position(|&b| b == 0) else {
            return Err(self.err(format_args!(
                "truncated: {field} has no terminating NUL byte"
            )));
        };
        let s = String::from_utf8_lossy(&rest[..end]).into_owned();
        self.pos += end + 1;
        Ok(s)
    }

    fn finish(&self) -> Result<()> {
        if self.left() != 0 {
            return Err(Error::format(
                self.name,
                format!(
                    "{} bytes of trailing data at byte offset {} after the last record",
                    self.left(),
                    self.pos
                ),
            ));
        }
        Ok(())
    }
}

fn parse_cameras_bin(f: &Loaded) -> Result<Vec<ColmapCamera>> {
    decode_cameras_bin(&f.name, &f.bytes)
}
fn parse_images_bin(f: &Loaded) -> Result<Vec<ColmapImage>> {
    decode_images_bin(&f.name, &f.bytes)
}
fn parse_points3d_bin(f: &Loaded) -> Result<Vec<Point3D>> {
    decode_points3d_bin(&f.name, &f.bytes)
}

/// Parses the bytes of a `cameras.bin`; `name` is used in errors.
pub fn decode_cameras_bin(name: &str, data: &[u8]) -> Result<Vec<ColmapCamera>> {
    let mut c = Cursor::new(name, data);
    // Smallest camera record: ids, size and 3 parameters.
    let n = c.count("num_cameras", 4 + 4 + 8 + 8 + 3 * 8)?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        c.at("camera", i);
        let id = c.u32("camera_id")?;
        let model_id = c.i32("model_id")?;
        let Some((model, np)) = model_by_id(model_id) else {
            c.pos -= 4;
            return Err(c.err(format_args!(
                "unknown camera model id {model_id} (known: 0..={})",
                CAMERA_MODELS.len() - 1
            )));
        };
        let width = c.u64("width")?;
        let height = c.u64("height")?;
        let mut params = Vec::with_capacity(np);
        for _ in 0..np {
            params.push(c.f64(model)?);
        }
        out.push(ColmapCamera {
            id,
            model_id,
            width,
            height,
            params,
        });
    }
    c.finish()?;
    Ok(out)
}

/// Parses the bytes of an `images.bin`; `name` is used in errors. Images are
/// returned in file order.
pub fn decode_images_bin(name: &str, data: &[u8]) -> Result<Vec<ColmapImage>> {
    let mut c = Cursor::new(name, data);
    // Smallest image record: id, 7 doubles, camera id, empty name + NUL, point count.
    let n = c.count("num_reg_images", 4 + 7 * 8 + 4 + 1 + 8)?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        c.at("image", i);
        let id = c.u32("image_id")?;
        let mut qvec = [0.0; 4];
        for q in &mut qvec {
            *q = c.f64("qvec")?;
        }
        let mut tvec = [0.0; 3];
        for t in &mut tvec {
            *t = c.f64("tvec")?;
        }
        let camera_id = c.u32("camera_id")?;
        let name = c.cstring("name")?;
        let np = c.count("num_points2D", 24)?;
        let mut points2d = Vec::with_capacity(np);
        for _ in 0..np {
            let x = c.f64("point2D x")?;
            let y = c.f64("point2D y")?;
            let point3d_id = c.i64("point3D_id")?;
            points2d.push(Point2D { x, y, point3d_id });
        }
        out.push(ColmapImage {
            id,
            qvec,
            tvec,
            camera_id,
            name,
            points2d,
        });
    }
    c.finish()?;
    Ok(out)
}

/// Parses the bytes of a `points3D.bin`; `name` is used in errors.
pub fn decode_points3d_bin(name: &str, data: &[u8]) -> Result<Vec<Point3D>> {
    let mut c = Cursor::new(name, data);
    // Smallest point record: id, xyz, rgb, error, empty track.
    let n = c.count("num_points", 8 + 24 + 3 + 8 + 8)?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        c.at("point", i);
        let id = c.u64("point3D_id")?;
        let x = c.f64("xyz")?;
        let y = c.f64("xyz")?;
        let z = c.f64("xyz")?;
        let rgb = c.arr::<3>("rgb")?;
        let error = c.f64("error")?;
        let nt = c.count("track_length", 8)?;
        let mut track = Vec::with_capacity(nt);
        for _ in 0..nt {
            let image_id = c.u32("track image_id")?;
            let point2d_idx = c.u32("track point2D_idx")?;
            track.push(TrackElement {
                image_id,
                point2d_idx,
            });
        }
        out.push(Point3D {
            id,
            xyz: DVec3::new(x, y, z),
            rgb,
            error,
            track,
        });
    }
    c.finish()?;
    Ok(out)
}

/// The bytes of a `cameras.bin` holding `cameras`.
pub fn encode_cameras_bin(cameras: &[ColmapCamera]) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&(cameras.len() as u64).to_le_bytes());
    for c in cameras {
        b.extend_from_slice(&c.id.to_le_bytes());
        b.extend_from_slice(&c.model_id.to_le_bytes());
        b.extend_from_slice(&c.width.to_le_bytes());
        b.extend_from_slice(&c.height.to_le_bytes());
        for p in &c.params {
            b.extend_from_slice(&p.to_le_bytes());
        }
    }
    b
}

/// The bytes of an `images.bin` holding `images` (in the given order).
pub fn encode_images_bin(images: &[ColmapImage]) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&(images.len() as u64).to_le_bytes());
    for im in images {
        b.extend_from_slice(&im.id.to_le_bytes());
        for v in im.qvec.iter().chain(&im.tvec) {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&im.camera_id.to_le_bytes());
        b.extend_from_slice(im.name.as_bytes());
        b.push(0);
        b.extend_from_slice(&(im.points2d.len() as u64).to_le_bytes());
        for p in &im.points2d {
            b.extend_from_slice(&p.x.to_le_bytes());
            b.extend_from_slice(&p.y.to_le_bytes());
            b.extend_from_slice(&p.point3d_id.to_le_bytes());
        }
    }
    b
}

/// The bytes of a `points3D.bin` holding `points`.
pub fn encode_points3d_bin(points: &[Point3D]) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&(points.len() as u64).to_le_bytes());
    for p in points {
        b.extend_from_slice(&p.id.to_le_bytes());
        for v in p.xyz.to_array() {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&p.rgb);
        b.extend_from_slice(&p.error.to_le_bytes());
        b.extend_from_slice(&(p.track.len() as u64).to_le_bytes());
        for t in &p.track {
            b.extend_from_slice(&t.image_id.to_le_bytes());
            b.extend_from_slice(&t.point2d_idx.to_le_bytes());
        }
    }
    b
}

// ---------------------------------------------------------------------------
// Text

fn text(f: &Loaded) -> Result<&str> {
    std::str::from_utf8(&f.bytes).map_err(|e| {
        Error::format(
            &f.name,
            format!("not UTF-8 text (byte offset {})", e.valid_up_to()),
        )
    })
}

/// Data lines (1-based line number, trimmed text), skipping blanks and `#` comments.
fn data_lines(s: &str) -> impl Iterator<Item = (usize, &str)> {
    s.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

fn field<T: std::str::FromStr>(
    name: &str,
    line: usize,
    tok: Option<&str>,
    what: &str,
) -> Result<T> {
    let tok = tok.ok_or_else(|| Error::format(name, format!("line {line}: missing {what}")))?;
    tok.parse()
        .map_err(|_| Error::format(name, format!("line {line}: bad {what} '{tok}'")))
}

fn parse_cameras_txt(f: &Loaded) -> Result<Vec<ColmapCamera>> {
    decode_cameras_txt(&f.name, text(f)?)
}
fn parse_images_txt(f: &Loaded) -> Result<Vec<ColmapImage>> {
    decode_images_txt(&f.name, text(f)?)
}
fn parse_points3d_txt(f: &Loaded) -> Result<Vec<Point3D>> {
    decode_points3d_txt(&f.name, text(f)?)
}

/// Parses a `cameras.txt` (`CAMERA_ID MODEL WIDTH HEIGHT PARAMS…` per line);
/// `name` is used in errors, which give the line number.
pub fn decode_cameras_txt(name: &str, s: &str) -> Result<Vec<ColmapCamera>> {
    let mut out = Vec::new();
    for (ln, line) in data_lines(s) {
        let mut t = line.split_whitespace();
        let id = field(name, ln, t.next(), "CAMERA_ID")?;
        let model: String = field(name, ln, t.next(), "MODEL")?;
        let Some((model_id, np)) = model_by_name(&model) else {
            return Err(Error::format(
                name,
                format!("line {ln}: unknown camera model '{model}'"),
            ));
        };
        let width = field(name, ln, t.next(), "WIDTH")?;
        let height = field(name, ln, t.next(), "HEIGHT")?;
        let params = t
            .map(|p| field(name, ln, Some(p), "parameter"))
            .collect::<Result<Vec<f64>>>()?;
        if params.len() != np {
            return Err(Error::format(
                name,
                format!(
                    "line {ln}: model {model} takes {np} parameters, found {}",
                    params.len()
                ),
            ));
        }
        out.push(ColmapCamera {
            id,
            model_id,
            width,
            height,
            params,
        });
    }
    Ok(out)
}

/// Parses an `images.txt`: per image a line `IMAGE_ID QW QX QY QZ TX TY TZ
/// CAMERA_ID NAME`, then the line of its observations `X Y POINT3D_ID …`
/// (possibly empty). Errors give the line number.
pub fn decode_images_txt(name: &str, s: &str) -> Result<Vec<ColmapImage>> {
    let mut out = Vec::new();
    let mut lines = s.lines().enumerate().map(|(i, l)| (i + 1, l.trim()));
    while let Some((ln, line)) = lines.next() {
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut t = line.split_whitespace();
        let id = field(name, ln, t.next(), "IMAGE_ID")?;
        let mut qvec = [0.0; 4];
        for (q, w) in qvec.iter_mut().zip(["QW", "QX", "QY", "QZ"]) {
            *q = field(name, ln, t.next(), w)?;
        }
        let mut tvec = [0.0; 3];
        for (v, w) in tvec.iter_mut().zip(["TX", "TY", "TZ"]) {
            *v = field(name, ln, t.next(), w)?;
        }
        let camera_id = field(name, ln, t.next(), "CAMERA_ID")?;
        let rest: Vec<&str> = t.collect();
        if rest.is_empty() {
            return Err(Error::format(name, format!("line {ln}: missing NAME")));
        }
        // The observation line follows directly (it may be empty).
        let (pln, pline) = lines.next().unwrap_or((ln + 1, ""));
        let toks: Vec<&str> = pline.split_whitespace().collect();
        if !toks.len().is_multiple_of(3) {
            return Err(Error::format(
                name,
                format!(
                    "line {pln}: observations come in triples X Y POINT3D_ID, found {} values",
                    toks.len()
                ),
            ));
        }
        let points2d = toks
            .chunks_exact(3)
            .map(|c| {
                Ok(Point2D {
                    x: field(name, pln, Some(c[0]), "point2D X")?,
                    y: field(name, pln, Some(c[1]), "point2D Y")?,
                    point3d_id: field(name, pln, Some(c[2]), "POINT3D_ID")?,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        out.push(ColmapImage {
            id,
            qvec,
            tvec,
            camera_id,
            name: rest.join(" "),
            points2d,
        });
    }
    Ok(out)
}

/// Parses a `points3D.txt` (`POINT3D_ID X Y Z R G B ERROR TRACK…` per line);
/// errors give the line number.
pub fn decode_points3d_txt(name: &str, s: &str) -> Result<Vec<Point3D>> {
    let mut out = Vec::new();
    for (ln, line) in data_lines(s) {
        let mut t = line.split_whitespace();
        let id = field(name, ln, t.next(), "POINT3D_ID")?;
        let x = field(name, ln, t.next(), "X")?;
        let y = field(name, ln, t.next(), "Y")?;
        let z = field(name, ln, t.next(), "Z")?;
        let mut rgb = [0u8; 3];
        for (c, w) in rgb.iter_mut().zip(["R", "G", "B"]) {
            *c = field(name, ln, t.next(), w)?;
        }
        let error = field(name, ln, t.next(), "ERROR")?;
        let toks: Vec<&str> = t.collect();
        if !toks.len().is_multiple_of(2) {
            return Err(Error::format(
                name,
                format!(
                    "line {ln}: track comes in pairs IMAGE_ID POINT2D_IDX, found {} values",
                    toks.len()
                ),
            ));
        }
        let track = toks
            .chunks_exact(2)
            .map(|c| {
                Ok(TrackElement {
                    image_id: field(name, ln, Some(c[0]), "track IMAGE_ID")?,
                    point2d_idx: field(name, ln, Some(c[1]), "track POINT2D_IDX")?,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        out.push(Point3D {
            id,
            xyz: DVec3::new(x, y, z),
            rgb,
            error,
            track,
        });
    }
    Ok(out)
}

/// Checks that every camera of `cameras` has a proper rotation (used by the
/// writers of other formats, which store rotations as matrices).
pub(crate) fn check_camera_rotations(cameras: &[Camera]) -> Result<()> {
    for c in cameras {
        check_rotation(c.rotation, 1e-6)
            .map_err(|e| Error::invalid(format!("camera '{}': rotation {e}", c.name)))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::cameras::test_util::{assert_same_projections, rot};
    use crate::testing::shared_data;

    fn kunkun() -> Option<ColmapModel> {
        let p = shared_data("colmap-kunkun-figurine/sparse/0")?;
        Some(ColmapModel::read(&p).unwrap())
    }

    #[test]
    fn kunkun_cameras() {
        let Some(m) = kunkun() else { return };
        let cams = m.to_cameras().unwrap();
        assert_eq!(cams.len(), 64);
        assert_eq!(m.cameras.len(), 1);
        assert_eq!(m.points3d.len(), 1530);
        for c in &cams {
            assert_eq!((c.width, c.height), (1917, 1073));
            assert_eq!(c.model, CameraModel::Pinhole);
            // SOURCE.md gives fx 1920.924, fy 1918.599, cx 958.5, cy 536.5 (rounded to 1e-3).
            assert!((c.fx - 1920.924).abs() < 1e-3 && (c.fy - 1918.599).abs() < 1e-3);
            assert_eq!((c.cx, c.cy), (958.5, 536.5));
            check_rotation(c.rotation, 1e-12).unwrap();
        }
        // Sorted by name (3DGS order).
        assert!(cams.windows(2).all(|w| w[0].name < w[1].name));
        assert_eq!(cams[0].name, "0001.jpg");
    }

    /// Reprojection of the stored observations pins the pose convention
    /// (world-to-camera, w-first quaternion, OpenCV axes, +0.5 pixel centres):
    /// any error in it moves points by tens to thousands of pixels.
    #[test]
    fn kunkun_reprojection() {
        let Some(m) = kunkun() else { return };
        let cams = m.to_cameras().unwrap();
        let xyz: HashMap<u64, DVec3> = m.points3d.iter().map(|p| (p.id, p.xyz)).collect();
        let mut errs = Vec::new();
        for (im, cam) in m.images.iter().zip(&cams) {
            for p in &im.points2d {
                if p.point3d_id < 0 {
                    continue;
                }
                let x = xyz[&(p.point3d_id as u64)];
                let (px, _) = cam
                    .project(x)
                    .expect("observed point is in front of the camera");
                errs.push((px - glam::DVec2::new(p.x, p.y)).length());
            }
        }
        errs.sort_by(f64::total_cmp);
        let q = |f: f64| errs[((errs.len() - 1) as f64 * f) as usize];
        let (median, p95, max) = (q(0.5), q(0.95), errs[errs.len() - 1]);
        eprintln!(
            "kunkun: {} observations, reprojection median {median:.4} px, p95 {p95:.4} px, max {max:.4} px",
            errs.len()
        );
        // Measured: 7,725 observations, median 0.958 px, p95 2.694 px, max 3.964 px
        // (a phone-video capture; COLMAP filters observations above 4 px).
        assert!(median < 1.0, "median {median}");
        assert!(p95 < 3.0, "p95 {p95}");
        // Each point's stored mean error agrees with its observations' mean;
        // a principal point off by half a pixel breaks this agreement.
        let ratios = |shift: glam::DVec2| -> (f64, f64) {
            let mut per_point: HashMap<u64, (f64, usize)> = HashMap::new();
            for (im, cam) in m.images.iter().zip(&cams) {
                for p in im.points2d.iter().filter(|p| p.point3d_id >= 0) {
                    let (px, _) = cam.project(xyz[&(p.point3d_id as u64)]).unwrap();
                    let e = per_point.entry(p.point3d_id as u64).or_default();
                    e.0 += (px + shift - glam::DVec2::new(p.x, p.y)).length();
                    e.1 += 1;
                }
            }
            let mut r: Vec<f64> = m
                .points3d
                .iter()
                .map(|p| {
                    let (sum, n) = per_point[&p.id];
                    assert_eq!(n, p.track.len());
                    sum / n as f64 / p.error
                })
                .collect();
            r.sort_by(f64::total_cmp);
            (r[0], r[r.len() - 1])
        };
        let (lo, hi) = ratios(glam::DVec2::ZERO);
        eprintln!("kunkun: our mean error / stored error per point: {lo:.4}..{hi:.4}");
        // Measured 0.992..1.022: COLMAP computed the stored errors before
        // undistortion, so they differ by ~2% at most; 5% is a safe bound.
        assert!(lo > 0.95 && hi < 1.05, "{lo} {hi}");
        // Measured with a half-pixel shift of the projections: up to ×1000
        // for points with tiny stored errors. The check above can fail.
        let (_, hi_shift) = ratios(glam::DVec2::new(0.5, 0.5));
        assert!(hi_shift > 2.0, "{hi_shift}");
    }

    #[test]
    fn kunkun_track_links_are_consistent() {
        let Some(m) = kunkun() else { return };
        let by_id: HashMap<u32, &ColmapImage> = m.images.iter().map(|i| (i.id, i)).collect();
        for p in &m.points3d {
            for t in &p.track {
                let im = by_id[&t.image_id];
                assert_eq!(im.points2d[t.point2d_idx as usize].point3d_id, p.id as i64);
            }
        }
    }

    #[test]
    fn binary_and_text_round_trips_are_exact() {
        let Some(p) = shared_data("colmap-kunkun-figurine/sparse/0") else {
            return;
        };
        // Binary re-encoding reproduces the files byte for byte (images in file order).
        let cam_bytes = std::fs::read(p.join("cameras.bin")).unwrap();
        let img_bytes = std::fs::read(p.join("images.bin")).unwrap();
        let pts_bytes = std::fs::read(p.join("points3D.bin")).unwrap();
        assert_eq!(
            encode_cameras_bin(&decode_cameras_bin("c", &cam_bytes).unwrap()),
            cam_bytes
        );
        assert_eq!(
            encode_images_bin(&decode_images_bin("i", &img_bytes).unwrap()),
            img_bytes
        );
        assert_eq!(
            encode_points3d_bin(&decode_points3d_bin("p", &pts_bytes).unwrap()),
            pts_bytes
        );
        // Text round trip gives the same model.
        let m = ColmapModel::read(&p).unwrap();
        let dir = tempfile::tempdir().unwrap();
        m.write_text(dir.path()).unwrap();
        let back = ColmapModel::read(dir.path()).unwrap();
        assert_eq!(back, m);
        // And binary written by us reads back equal.
        let dir2 = tempfile::tempdir().unwrap();
        m.write_binary(dir2.path()).unwrap();
        assert_eq!(ColmapModel::read(dir2.path()).unwrap(), m);
    }

    fn small_model() -> ColmapModel {
        let cams = vec![
            Camera::pinhole(
                "b.png",
                64,
                48,
                50.0,
                51.0,
                32.0,
                24.0,
                rot(DVec3::new(0.1, 0.2, 0.3)),
                DVec3::new(0.5, -1.0, 4.0),
            ),
            Camera {
                model: CameraModel::Distorted {
                    name: "OPENCV".into(),
                    params: vec![0.01, -0.02, 0.001, 0.002],
                },
                ..Camera::pinhole(
                    "a.png",
                    64,
                    48,
                    50.0,
                    51.0,
                    31.0,
                    23.0,
                    rot(DVec3::new(-0.3, 0.0, 0.1)),
                    DVec3::new(0.0, 0.0, 5.0),
                )
            },
        ];
        let mut m = ColmapModel::from_cameras(&cams).unwrap();
        m.images[0].points2d = vec![
            Point2D {
                x: 1.5,
                y: 2.5,
                point3d_id: 7,
            },
            Point2D {
                x: 3.0,
                y: 4.0,
                point3d_id: -1,
            },
        ];
        m.points3d = vec![Point3D {
            id: 7,
            xyz: DVec3::new(0.1, 0.2, 0.3),
            rgb: [1, 2, 3],
            error: 0.25,
            track: vec![TrackElement {
                image_id: 1,
                point2d_idx: 0,
            }],
        }];
        m
    }

    #[test]
    fn from_cameras_round_trip_keeps_models_and_poses() {
        let m = small_model();
        let dir = tempfile::tempdir().unwrap();
        m.write_binary(dir.path()).unwrap();
        let back = ColmapModel::read(dir.path()).unwrap();
        let cams = back.to_cameras().unwrap();
        assert_eq!(cams[0].name, "a.png");
        assert_eq!(
            cams[0].model,
            CameraModel::Distorted {
                name: "OPENCV".into(),
                params: vec![0.01, -0.02, 0.001, 0.002]
            }
        );
        assert_eq!(cams[1].model, CameraModel::Pinhole);
        // The quaternion conversion loses only rounding: 1e-12 is ~1e4 ulps.
        let r = rot(DVec3::new(0.1, 0.2, 0.3));
        assert!(
            (cams[1].rotation - r)
                .to_cols_array()
                .iter()
                .all(|v| v.abs() < 1e-12)
        );
        assert!(cams[0].require_pinhole().is_err() && cams[1].require_pinhole().is_ok());
    }

    #[test]
    fn every_camera_model_reads_its_intrinsics() {
        for &(id, name, n) in &CAMERA_MODELS {
            let params: Vec<f64> = (0..n).map(|k| 10.0 + k as f64).collect();
            let c = ColmapCamera {
                id: 1,
                model_id: id,
                width: 20,
                height: 10,
                params: params.clone(),
            };
            let bytes = encode_cameras_bin(std::slice::from_ref(&c));
            assert_eq!(bytes.len(), 8 + 24 + 8 * n);
            let back = decode_cameras_bin("c", &bytes).unwrap();
            assert_eq!(back[0], c, "{name}");
            let (fx, fy, cx, cy, model) = c.intrinsics().unwrap();
            let single = fx == fy;
            assert_eq!(cx, if single { 11.0 } else { 12.0 }, "{name}");
            assert_eq!(cy, cx + 1.0);
            match model {
                CameraModel::Pinhole => {
                    assert!(name.ends_with("PINHOLE") && !name.contains("RADIAL"))
                }
                CameraModel::Distorted {
                    name: nm,
                    params: p,
                } => {
                    assert_eq!(nm, name);
                    assert_eq!(p.len(), n - if single { 3 } else { 4 });
                }
            }
        }
    }

    #[test]
    fn every_truncation_is_an_error_naming_file_record_and_offset() {
        let m = small_model();
        type Decode = fn(&str, &[u8]) -> Result<()>;
        let files: [(&str, Vec<u8>, Decode); 3] = [
            ("cameras.bin", encode_cameras_bin(&m.cameras), |n, b| {
                decode_cameras_bin(n, b).map(drop)
            }),
            ("images.bin", encode_images_bin(&m.images), |n, b| {
                decode_images_bin(n, b).map(drop)
            }),
            ("points3D.bin", encode_points3d_bin(&m.points3d), |n, b| {
                decode_points3d_bin(n, b).map(drop)
            }),
        ];
        for (name, bytes, decode) in files {
            decode(name, &bytes).unwrap();
            for len in 0..bytes.len() {
                let e = decode(name, &bytes[..len]).unwrap_err().to_string();
                assert!(e.starts_with(name), "{e}");
                assert!(e.contains("byte offset"), "{e}");
                assert!(e.contains("header") || e.contains("record"), "{e}");
            }
            // Trailing garbage is reported too.
            let mut long = bytes.clone();
            long.push(0);
            assert!(
                decode(name, &long)
                    .unwrap_err()
                    .to_string()
                    .contains("trailing")
            );
        }
        // A record index is named: cut inside the second image.
        let img = encode_images_bin(&m.images);
        let first_len = 8 + 4 + 56 + 4 + "b.png".len() + 1 + 8 + 2 * 24;
        assert!(first_len < img.len());
        let e = decode_images_bin("images.bin", &img[..img.len() - 5])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("image record 1") && e.contains("num_points2D"),
            "{e}"
        );
    }

    #[test]
    fn huge_declared_counts_are_rejected_before_allocating() {
        let mut b = u64::MAX.to_le_bytes().to_vec();
        b.extend_from_slice(&[0; 64]);
        let e = decode_images_bin("images.bin", &b).unwrap_err().to_string();
        assert!(
            e.contains("num_reg_images") && e.contains("byte offset 0"),
            "{e}"
        );
        assert!(decode_cameras_bin("cameras.bin", &b).is_err());
        assert!(decode_points3d_bin("points3D.bin", &b).is_err());
        // A huge num_points2D inside an image record.
        let m = small_model();
        let mut img = encode_images_bin(&m.images[..1]);
        let at = 8 + 4 + 56 + 4 + "b.png".len() + 1;
        img[at..at + 8].copy_from_slice(&(1u64 << 60).to_le_bytes());
        let e = decode_images_bin("images.bin", &img)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("num_points2D") && e.contains("image record 0"),
            "{e}"
        );
        // An unknown camera model id.
        let mut c = encode_cameras_bin(&m.cameras[..1]);
        c[12..16].copy_from_slice(&99i32.to_le_bytes());
        let e = decode_cameras_bin("cameras.bin", &c)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("unknown camera model id 99") && e.contains("byte offset 12"),
            "{e}"
        );
    }

    #[test]
    fn text_errors_name_the_line() {
        let e = decode_cameras_txt("cameras.txt", "# c\n1 PINHOLE 10 10 1 2 3\n").unwrap_err();
        assert!(e.to_string().contains("cameras.txt: line 2"), "{e}");
        let e = decode_cameras_txt("cameras.txt", "1 NOPE 10 10 1 2 3\n").unwrap_err();
        assert!(e.to_string().contains("unknown camera model 'NOPE'"), "{e}");
        let e = decode_images_txt("images.txt", "1 1 0 0 0 0 0 0 1 a.png\n1 2\n").unwrap_err();
        assert!(e.to_string().contains("images.txt: line 2"), "{e}");
        let e = decode_images_txt("images.txt", "1 1 0 0 x 0 0 0 1 a.png\n\n").unwrap_err();
        assert!(e.to_string().contains("line 1: bad QZ 'x'"), "{e}");
        let e = decode_points3d_txt("points3D.txt", "1 0 0 0 300 0 0 0\n").unwrap_err();
        assert!(e.to_string().contains("line 1: bad R '300'"), "{e}");
        // An image whose observation line is empty, as the last line without newline.
        let ims = decode_images_txt("images.txt", "1 1 0 0 0 0 0 0 1 a b.png\n").unwrap();
        assert_eq!(ims[0].name, "a b.png");
        assert!(ims[0].points2d.is_empty());
    }

    #[test]
    fn to_cameras_reports_missing_camera() {
        let mut m = small_model();
        m.images[0].camera_id = 42;
        let e = m.to_cameras().unwrap_err().to_string();
        assert!(e.contains("camera 42"), "{e}");
        let mut m = small_model();
        m.images[1].qvec = [0.0; 4];
        assert!(
            m.to_cameras()
                .unwrap_err()
                .to_string()
                .contains("quaternion")
        );
    }

    #[test]
    fn reader_and_from_cameras_agree_on_projections() {
        let m = small_model();
        let dir = tempfile::tempdir().unwrap();
        m.write_text(dir.path()).unwrap();
        let mut a = m.to_cameras().unwrap();
        a.sort_by(|x, y| x.name.cmp(&y.name));
        let b = ColmapModel::read(dir.path()).unwrap().to_cameras().unwrap();
        let pts = [DVec3::ZERO, DVec3::new(0.3, -0.2, 0.5)];
        // Text floats are written with round-trip formatting: exact.
        assert_same_projections(&a, &b, &pts, 0.0, 0.0);
    }
}
