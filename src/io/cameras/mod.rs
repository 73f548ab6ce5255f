//! Camera readers and writers.
//!
//! Every reader produces [`Camera`]s in one convention (see
//! [`splatkit_render::camera`]): OpenCV camera axes (x right, y down,
//! z forward), a world-to-camera pose `x_cam = R · x_world + t` in f64, and
//! intrinsics fx, fy, cx, cy in pixels with pixel centres at integer + 0.5.
//!
//! | format | module | order of the cameras returned |
//! |---|---|---|
//! | COLMAP `sparse/0` (binary `.bin` or text `.txt`) | [`colmap`] | by image name (as 3DGS sorts them) |
//! | 3DGS `cameras.json` | [`gs_json`] | by `img_name` (as 3DGS and SuGaR sort them), stable |
//! | NeRF / nerfstudio `transforms*.json` | [`nerf_json`] | file order of `frames` (as 3DGS reads them) |
//! | NeuS / IDR `cameras_sphere.npz` | [`npz`] | by index `i` of `world_mat_i` |
//!
//! [`read_cameras`] detects the format of a file or folder; [`write_gs_json`]
//! and [`write_transforms_json`] write the two JSON formats, and
//! [`colmap::ColmapModel::write_text`] writes a COLMAP text model.

pub mod colmap;
pub mod gs_json;
pub mod nerf_json;
pub mod npz;

use std::io::Read;
use std::path::{Path, PathBuf};

use crate::model::Camera;
use crate::{Error, Result};

pub use gs_json::write_gs_json;
pub use nerf_json::write_transforms_json;

/// A camera file format this module reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraFormat {
    /// COLMAP binary model: a folder with `cameras.bin` and `images.bin`.
    ColmapBinary,
    /// COLMAP text model: a folder with `cameras.txt` and `images.txt`.
    ColmapText,
    /// 3DGS `cameras.json`: a JSON array of camera objects.
    GsJson,
    /// NeRF-synthetic / nerfstudio `transforms*.json`: a JSON object with `frames`.
    NerfTransforms,
    /// NeuS / IDR `cameras_sphere.npz` (or `cameras.npz`).
    NeusNpz,
}

impl CameraFormat {
    /// A short human-readable name (`"colmap-bin"`, `"colmap-txt"`, `"3dgs-json"`,
    /// `"transforms-json"`, `"neus-npz"`), used in messages and `--format` values.
    pub fn name(self) -> &'static str {
        match self {
            CameraFormat::ColmapBinary => "colmap-bin",
            CameraFormat::ColmapText => "colmap-txt",
            CameraFormat::GsJson => "3dgs-json",
            CameraFormat::NerfTransforms => "transforms-json",
            CameraFormat::NeusNpz => "neus-npz",
        }
    }
}

/// Finds the camera data at `path` and its format.
///
/// A directory is searched in this order: COLMAP model in the directory itself,
/// in `sparse/0`, in `sparse` (binary preferred over text); then `cameras.json`,
/// `transforms_train.json`, `transforms.json`, `cameras_sphere.npz`, `cameras.npz`.
/// A file is recognised by name or extension: `cameras.bin`/`images.bin`/
/// `cameras.txt`/`images.txt` (the model in its folder), `.npz`, and `.json`
/// whose first non-blank character is `[` (3DGS list) or `{` (transforms object).
///
/// Returns the format and the path to hand to that format's reader (the COLMAP
/// model folder, or the file), or `None` when nothing is recognised.
pub fn resolve_camera_source(path: &Path) -> Option<(CameraFormat, PathBuf)> {
    if path.is_dir() {
        for dir in [
            path.to_path_buf(),
            path.join("sparse/0"),
            path.join("sparse"),
        ] {
            if let Some(f) = colmap_dir_format(&dir) {
                return Some((f, dir));
            }
        }
        let candidates: [(&str, CameraFormat); 5] = [
            ("cameras.json", CameraFormat::GsJson),
            ("transforms_train.json", CameraFormat::NerfTransforms),
            ("transforms.json", CameraFormat::NerfTransforms),
            ("cameras_sphere.npz", CameraFormat::NeusNpz),
            ("cameras.npz", CameraFormat::NeusNpz),
        ];
        return candidates
            .into_iter()
            .map(|(name, f)| (f, path.join(name)))
            .find(|(_, p)| p.is_file());
    }
    let file_name = path.file_name()?.to_str()?.to_ascii_lowercase();
    match file_name.as_str() {
        "cameras.bin" | "images.bin" | "points3d.bin" | "cameras.txt" | "images.txt"
        | "points3d.txt" => {
            let dir = match path.parent() {
                Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
                _ => PathBuf::from("."),
            };
            return colmap_dir_format(&dir).map(|f| (f, dir));
        }
        _ => {}
    }
    if file_name.ends_with(".npz") {
        return Some((CameraFormat::NeusNpz, path.to_path_buf()));
    }
    if file_name.ends_with(".json") {
        let mut head = [0u8; 4096];
        let mut file = std::fs::File::open(path).ok()?;
        let n = file.read(&mut head).ok()?;
        let first = head[..n].iter().find(|b| !b.is_ascii_whitespace())?;
        return match first {
            b'[' => Some((CameraFormat::GsJson, path.to_path_buf())),
            b'{' => Some((CameraFormat::NerfTransforms, path.to_path_buf())),
            _ => None,
        };
    }
    None
}

fn colmap_dir_format(dir: &Path) -> Option<CameraFormat> {
    if dir.join("cameras.bin").is_file() && dir.join("images.bin").is_file() {
        Some(CameraFormat::ColmapBinary)
    } else if dir.join("cameras.txt").is_file() && dir.join("images.txt").is_file() {
        Some(CameraFormat::ColmapText)
    } else {
        None
    }
}

/// The format of the camera data at `path` (see [`resolve_camera_source`] for
/// the rules), or `None` when it is not recognised.
pub fn detect_camera_format(path: &Path) -> Option<CameraFormat> {
    resolve_camera_source(path).map(|(f, _)| f)
}

/// Reads the cameras at `path`, a file or a folder, detecting the format with
/// [`resolve_camera_source`]. NeuS `.npz` cameras are returned in the
/// normalised (unit-sphere) frame, i.e. with `scale_mat` applied (use
/// [`npz::read_neus_cameras`] for the other choice and for the `scale_mat`).
///
/// Cameras are in OpenCV axes with a world-to-camera pose; their order is the
/// one each format's reference code uses (see the module table).
pub fn read_cameras(path: &Path) -> Result<Vec<Camera>> {
    let Some((format, p)) = resolve_camera_source(path) else {
        return Err(Error::format(
            path.display(),
            "no cameras found: expected a COLMAP model folder (cameras.bin + images.bin, or \
             .txt, in the folder, sparse/0 or sparse), cameras.json, transforms*.json or a .npz",
        ));
    };
    let source = p.display().to_string();
    let (cams, intrinsics_file, poses_file) = match format {
        CameraFormat::ColmapBinary | CameraFormat::ColmapText => {
            // Errors name the file inside the model folder that holds the
            // bad record.
            let ext = if format == CameraFormat::ColmapBinary {
                "bin"
            } else {
                "txt"
            };
            let cameras_file = p.join(format!("cameras.{ext}")).display().to_string();
            let images_file = p.join(format!("images.{ext}")).display().to_string();
            let cams = colmap::ColmapModel::read_without_points(&p)?
                .to_cameras_from(&images_file, &cameras_file)?;
            (cams, cameras_file, images_file)
        }
        CameraFormat::GsJson => (gs_json::read_gs_json(&p)?, source.clone(), source),
        CameraFormat::NerfTransforms => {
            (nerf_json::read_transforms_json(&p)?, source.clone(), source)
        }
        CameraFormat::NeusNpz => (
            npz::read_neus_cameras(&p, &npz::NpzOptions::default())?.cameras,
            source.clone(),
            source,
        ),
    };
    validate_cameras_from(&intrinsics_file, &poses_file, &cams)?;
    Ok(cams)
}

/// The most pixels one image may have: 2^28 (16384 × 16384), the limit
/// `--size` enforces too. Images are allocated as several f32 planes, so this
/// bounds one view's memory to a few GB before anything is allocated.
pub const MAX_PIXELS: u64 = 1 << 28;

/// The checks every camera source passes before any command uses it (the
/// readers check their own syntax; these are the rules that make a camera
/// usable): at least one camera; width and height > 0 with width·height ≤
/// [`MAX_PIXELS`]; fx, fy finite and non-zero; cx, cy finite; a finite pose;
/// names unique (commands name their outputs after them). `source` names the
/// file in the error, with the camera's index and name.
pub fn validate_cameras(source: &str, cams: &[Camera]) -> Result<()> {
    validate_cameras_from(source, source, cams)
}

/// [`validate_cameras`] for a source that keeps intrinsics and poses in two
/// files (a COLMAP model): image size and focal length errors name
/// `intrinsics`, pose and name errors (and "no cameras") name `poses`.
pub fn validate_cameras_from(intrinsics: &str, poses: &str, cams: &[Camera]) -> Result<()> {
    if cams.is_empty() {
        return Err(Error::format(poses, "holds no cameras"));
    }
    let mut names = std::collections::HashMap::with_capacity(cams.len());
    for (i, c) in cams.iter().enumerate() {
        let in_file = |source: &str, what: String| {
            Error::format(source, format!("camera {i} ({:?}): {what}", c.name))
        };
        let bad = |what: String| in_file(intrinsics, what);
        let bad_pose = |what: String| in_file(poses, what);
        if c.width == 0 || c.height == 0 {
            return Err(bad(format!(
                "image size {}x{} has a zero side",
                c.width, c.height
            )));
        }
        if u64::from(c.width) * u64::from(c.height) > MAX_PIXELS {
            return Err(bad(format!(
                "image size {}x{} exceeds the limit of {MAX_PIXELS} pixels (2^28, e.g. 16384x16384)",
                c.width, c.height
            )));
        }
        if !(c.fx.is_finite() && c.fy.is_finite() && c.fx != 0.0 && c.fy != 0.0) {
            return Err(bad(format!(
                "focal length fx = {}, fy = {} (must be finite and non-zero)",
                c.fx, c.fy
            )));
        }
        if !(c.cx.is_finite() && c.cy.is_finite()) {
            return Err(bad(format!(
                "principal point ({}, {}) is not finite",
                c.cx, c.cy
            )));
        }
        if !(c.rotation.is_finite() && c.translation.is_finite()) {
            return Err(bad_pose("the pose holds a NaN or infinite value".into()));
        }
        if let Some(j) = names.insert(c.name.as_str(), i) {
            return Err(bad_pose(format!(
                "has the same name as camera {j}: outputs named after cameras would overwrite each other"
            )));
        }
    }
    Ok(())
}

/// Width and height in pixels of a PNG or JPEG image, read from its header
/// by the `imagesize` crate (PNG: the IHDR chunk; JPEG: the first
/// start-of-frame marker, reached by seeking over the segments before it)
/// without decoding the pixels or reading the rest of the file.
pub fn image_dimensions(path: &Path) -> Result<(u32, u32)> {
    let name = path.display().to_string();
    let size = imagesize::size(path).map_err(|e| match e {
        imagesize::ImageError::IoError(e) if e.kind() != std::io::ErrorKind::UnexpectedEof => {
            Error::io(&name, e)
        }
        imagesize::ImageError::NotSupported => Error::format(
            &name,
            "not a PNG or JPEG image (unknown signature); cannot read its size",
        ),
        _ => Error::format(
            &name,
            "the PNG or JPEG header ends before it gives the image size (truncated or corrupt file)",
        ),
    })?;
    match (u32::try_from(size.width), u32::try_from(size.height)) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => Err(Error::format(
            &name,
            format!(
                "the image header gives an unusable size {}x{}",
                size.width, size.height
            ),
        )),
    }
}

/// Checks that `r` is a rotation matrix within `tol` (max abs entry of
/// `RᵀR − I`, and det > 0). Returns a description of the defect otherwise.
pub(crate) fn check_rotation(r: glam::DMat3, tol: f64) -> std::result::Result<(), String> {
    let e = r.transpose() * r - glam::DMat3::IDENTITY;
    let dev = e.to_cols_array().iter().fold(0.0f64, |m, v| {
        if v.is_nan() {
            f64::INFINITY
        } else {
            m.max(v.abs())
        }
    });
    if dev > tol {
        return Err(format!("is not orthonormal (max |RᵀR − I| = {dev:.3e})"));
    }
    if r.determinant() <= 0.0 {
        return Err("is a reflection (determinant < 0), not a rotation".into());
    }
    Ok(())
}

/// Maps a `serde_json` error to a format error on `path` naming line and column.
pub(crate) fn json_error(path: &str, e: serde_json::Error) -> Error {
    Error::format(path, format!("invalid JSON: {e}"))
}

#[cfg(test)]
pub(crate) mod test_util {
    //! Helpers shared by the camera tests.
    use glam::{DMat3, DVec3};

    use crate::model::Camera;

    /// Asserts that two camera lists project `points` to the same pixels (to
    /// `tol_px`) and have the same centres (to `tol_c`), pairing them in order.
    pub fn assert_same_projections(
        a: &[Camera],
        b: &[Camera],
        points: &[DVec3],
        tol_px: f64,
        tol_c: f64,
    ) {
        assert_eq!(a.len(), b.len());
        let mut worst = 0.0f64;
        for (ca, cb) in a.iter().zip(b) {
            assert_eq!((ca.width, ca.height), (cb.width, cb.height), "{}", ca.name);
            let dc = (ca.center() - cb.center()).length();
            assert!(dc <= tol_c, "camera {}: centres differ by {dc}", ca.name);
            let mut n = 0;
            for p in points {
                match (ca.project(*p), cb.project(*p)) {
                    (Some((pa, _)), Some((pb, _))) => {
                        worst = worst.max((pa - pb).length());
                        n += 1;
                    }
                    (None, None) => {}
                    _ => panic!(
                        "camera {}: point {p} is in front of only one camera",
                        ca.name
                    ),
                }
            }
            assert!(n > 0, "camera {}: no point projects", ca.name);
        }
        assert!(
            worst <= tol_px,
            "max projection difference {worst} px > {tol_px}"
        );
    }

    /// A rotation from an axis-angle vector (radians).
    pub fn rot(v: DVec3) -> DMat3 {
        let a = v.length();
        if a == 0.0 {
            DMat3::IDENTITY
        } else {
            DMat3::from_axis_angle(v / a, a)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::shared_data;

    #[test]
    fn png_and_jpeg_headers() {
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("a.png");
        let mut bytes = vec![0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a, 0, 0, 0, 13];
        bytes.extend_from_slice(b"IHDR");
        bytes.extend_from_slice(&1917u32.to_be_bytes());
        bytes.extend_from_slice(&1073u32.to_be_bytes());
        std::fs::write(&png, &bytes).unwrap();
        assert_eq!(image_dimensions(&png).unwrap(), (1917, 1073));
        // Every truncation of the header is an error naming the file, never a panic.
        for n in 0..24 {
            std::fs::write(&png, &bytes[..n]).unwrap();
            let e = image_dimensions(&png).unwrap_err().to_string();
            assert!(e.contains("a.png"), "{e}");
        }
        // JPEG: SOI, an APP0 segment, then SOF0 with height 600, width 800.
        let jpg = dir.path().join("b.jpg");
        let mut j = vec![0xff, 0xd8, 0xff, 0xe0, 0x00, 0x06, 1, 2, 3, 4];
        j.extend_from_slice(&[0xff, 0xc0, 0x00, 0x11, 8, 0x02, 0x58, 0x03, 0x20, 3]);
        std::fs::write(&jpg, &j).unwrap();
        assert_eq!(image_dimensions(&jpg).unwrap(), (800, 600));
        for n in 0..j.len() - 1 {
            std::fs::write(&jpg, &j[..n]).unwrap();
            assert!(image_dimensions(&jpg).is_err());
        }
    }

    #[test]
    fn real_png_header() {
        let Some(p) = shared_data("nerf-synthetic-lego-subset/train/r_0.png") else {
            return;
        };
        assert_eq!(image_dimensions(&p).unwrap(), (800, 800));
    }

    #[test]
    fn detection_of_the_shared_data_sets() {
        let cases = [
            ("colmap-kunkun-figurine", CameraFormat::ColmapBinary),
            (
                "colmap-kunkun-figurine/sparse/0",
                CameraFormat::ColmapBinary,
            ),
            (
                "colmap-kunkun-figurine/sparse/0/images.bin",
                CameraFormat::ColmapBinary,
            ),
            ("nerf-synthetic-lego-subset", CameraFormat::NerfTransforms),
            (
                "nerf-synthetic-lego-subset/transforms_train.json",
                CameraFormat::NerfTransforms,
            ),
            ("dtu-scan24-neus", CameraFormat::NeusNpz),
            ("dtu-scan24-neus/cameras_large.npz", CameraFormat::NeusNpz),
        ];
        for (rel, f) in cases {
            let Some(p) = shared_data(rel) else { return };
            assert_eq!(detect_camera_format(&p), Some(f), "{rel}");
            assert!(!read_cameras(&p).unwrap().is_empty(), "{rel}");
        }
        let Some(p) = shared_data("colmap-kunkun-figurine/images") else {
            return;
        };
        assert_eq!(detect_camera_format(&p), None);
        let e = read_cameras(&p).unwrap_err().to_string();
        assert!(
            e.contains("images") && e.contains("no cameras found"),
            "{e}"
        );
    }

    #[test]
    fn detection_of_written_json() {
        let dir = tempfile::tempdir().unwrap();
        let (r, t) = Camera::pose_from_c2w(glam::DMat3::IDENTITY, glam::DVec3::ZERO);
        let cams = vec![Camera::pinhole("a", 4, 2, 3.0, 3.0, 2.0, 1.0, r, t)];
        let gs = dir.path().join("cams.json");
        let tf = dir.path().join("tf.json");
        write_gs_json(&gs, &cams).unwrap();
        write_transforms_json(&tf, &cams).unwrap();
        assert_eq!(detect_camera_format(&gs), Some(CameraFormat::GsJson));
        assert_eq!(
            detect_camera_format(&tf),
            Some(CameraFormat::NerfTransforms)
        );
        assert_eq!(detect_camera_format(dir.path()), None);
        std::fs::rename(&gs, dir.path().join("cameras.json")).unwrap();
        assert_eq!(detect_camera_format(dir.path()), Some(CameraFormat::GsJson));
        assert_eq!(read_cameras(dir.path()).unwrap().len(), 1);
    }
}
