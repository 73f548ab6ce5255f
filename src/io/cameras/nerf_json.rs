//! NeRF-synthetic / nerfstudio `transforms*.json`.
//!
//! A JSON object with `frames`, a list of `{file_path, transform_matrix}`,
//! where `transform_matrix` is the 4×4 **camera-to-world** matrix (rows) in
//! **OpenGL camera axes** (x right, y up, z backward). The reader converts to
//! OpenCV axes by negating the camera's y and z axes (the 2nd and 3rd
//! columns of the rotation), as 3DGS's `readCamerasFromTransforms` does, then
//! inverts to world-to-camera. A 3×4 matrix (no last row) is accepted; the
//! rotation block must be orthonormal (no scale), the last row `[0, 0, 0, 1]`.
//!
//! Intrinsics, each looked up in the frame first, then at the top level (as
//! nerfstudio allows per-frame values):
//! - `w`, `h`: image size; when absent, the size of the first frame's image
//!   (PNG or JPEG header), `file_path` resolved against the JSON's folder
//!   with `.png` appended when it has no extension (NeRF-synthetic paths
//!   such as `./train/r_0` have none);
//! - `fl_x`, else `0.5 · w / tan(0.5 · camera_angle_x)`;
//! - `fl_y`, else `0.5 · h / tan(0.5 · camera_angle_y)`, else `fl_x` (square
//!   pixels, as 3DGS derives FoVy from the focal length);
//! - `cx`, `cy`, else `w / 2`, `h / 2` (nerfstudio's cx/cy use pixel centres
//!   at +0.5, like [`Camera`]);
//! - `camera_model` `OPENCV` (`k1 k2 p1 p2`) or `OPENCV_FISHEYE`
//!   (`k1 k2 k3 k4`) with non-zero coefficients gives a
//!   [`CameraModel::Distorted`] camera; otherwise the camera is pinhole.
//!
//! Cameras keep the order of `frames` (3DGS reads them in file order) and are
//! named by `file_path` without its directory.

use std::path::{Path, PathBuf};

use glam::{DMat3, DVec3};
use serde_json::{Map, Value, json};

use super::gs_json::{ROTATION_TOL, numbers};
use super::{check_rotation, image_dimensions, json_error};
use crate::io::source::{read_input, werr, write_output};
use crate::model::{Camera, CameraModel};
use crate::{Error, Result};

/// Reads a `transforms*.json` (see the module docs for the conventions).
/// Errors name the file, the frame index and the key.
pub fn read_transforms_json(path: &Path) -> Result<Vec<Camera>> {
    let input = read_input(path)?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    parse_transforms_json(&input.name, &input, &dir)
}

/// Parses the bytes of a `transforms*.json`; `name` is used in errors and
/// `dir` is the folder that `file_path`s are relative to (for the image size
/// when `w`/`h` are absent).
pub fn parse_transforms_json(name: &str, bytes: &[u8], dir: &Path) -> Result<Vec<Camera>> {
    let v: Value = serde_json::from_slice(bytes).map_err(|e| json_error(name, e))?;
    let Value::Object(top) = v else {
        return Err(Error::format(
            name,
            "expected a JSON object with 'frames' (transforms.json)",
        ));
    };
    let frames = top
        .get("frames")
        .ok_or_else(|| Error::format(name, "missing key 'frames'"))?
        .as_array()
        .ok_or_else(|| Error::format(name, "key 'frames' is not a list"))?;
    // Image size from the first frame's image, read only when some frame needs it.
    let mut first_size: Option<(u32, u32)> = None;
    let mut cams = Vec::with_capacity(frames.len());
    for (i, f) in frames.iter().enumerate() {
        let err = |msg: String| Error::format(name, format!("frame {i}: {msg}"));
        let Value::Object(frame) = f else {
            return Err(err("expected a JSON object".into()));
        };
        let lookup = |key: &str| frame.get(key).or_else(|| top.get(key));
        let number = |key: &str| -> Result<Option<f64>> {
            match lookup(key) {
                None | Some(Value::Null) => Ok(None),
                Some(v) => v
                    .as_f64()
                    .filter(|x| x.is_finite())
                    .map(Some)
                    .ok_or_else(|| err(format!("key '{key}' is not a number"))),
            }
        };
        let file_path = frame
            .get("file_path")
            .ok_or_else(|| err("missing key 'file_path'".into()))?
            .as_str()
            .ok_or_else(|| err("key 'file_path' is not a string".into()))?;
        let (width, height) = match (number("w")?, number("h")?) {
            (Some(w), Some(h)) => (
                pixels(w).ok_or_else(|| err(format!("bad width w = {w}")))?,
                pixels(h).ok_or_else(|| err(format!("bad height h = {h}")))?,
            ),
            _ => match first_size {
                Some(s) => s,
                None => {
                    let first = frames[0]
                        .get("file_path")
                        .and_then(Value::as_str)
                        .ok_or_else(|| Error::format(name, "frame 0: missing key 'file_path'"))?;
                    let img = image_path(dir, first);
                    let s = image_dimensions(&img).map_err(|e| {
                        Error::format(
                            name,
                            format!(
                                "no 'w'/'h' keys, and the first frame's image gives no size: {e}"
                            ),
                        )
                    })?;
                    first_size = Some(s);
                    s
                }
            },
        };
        let (w, h) = (width as f64, height as f64);
        let fx = match (number("fl_x")?, number("camera_angle_x")?) {
            (Some(f), _) => f,
            (None, Some(a)) => 0.5 * w / (0.5 * a).tan(),
            (None, None) => return Err(err("missing key 'camera_angle_x' (or 'fl_x')".into())),
        };
        let fy = match (number("fl_y")?, number("camera_angle_y")?) {
            (Some(f), _) => f,
            (None, Some(a)) => 0.5 * h / (0.5 * a).tan(),
            (None, None) => fx,
        };
        if !(fx > 0.0 && fx.is_finite() && fy > 0.0 && fy.is_finite()) {
            return Err(err(format!(
                "focal lengths fx = {fx}, fy = {fy} are not positive"
            )));
        }
        let cx = number("cx")?.unwrap_or(w / 2.0);
        let cy = number("cy")?.unwrap_or(h / 2.0);
        let model = distortion(lookup("camera_model"), &number).map_err(err)?;

        let m = frame
            .get("transform_matrix")
            .ok_or_else(|| err("missing key 'transform_matrix'".into()))?;
        let rows = m
            .as_array()
            .filter(|r| r.len() == 4 || r.len() == 3)
            .and_then(|r| r.iter().map(numbers::<4>).collect::<Option<Vec<_>>>())
            .ok_or_else(|| {
                err("key 'transform_matrix' is not a 4×4 list of rows of numbers".into())
            })?;
        if rows.len() == 4 {
            let last = rows[3];
            if (last[0].abs() + last[1].abs() + last[2].abs() + (last[3] - 1.0).abs()) > 1e-6 {
                return Err(err(format!(
                    "key 'transform_matrix' has last row {last:?}, expected [0, 0, 0, 1]"
                )));
            }
        }
        let gl = DMat3::from_cols_array_2d(&[
            [rows[0][0], rows[1][0], rows[2][0]],
            [rows[0][1], rows[1][1], rows[2][1]],
            [rows[0][2], rows[1][2], rows[2][2]],
        ]);
        check_rotation(gl, ROTATION_TOL)
            .map_err(|e| err(format!("the rotation of 'transform_matrix' {e}")))?;
        let center = DVec3::new(rows[0][3], rows[1][3], rows[2][3]);
        let cv = DMat3::from_cols(gl.x_axis, -gl.y_axis, -gl.z_axis);
        let (rotation, translation) = Camera::pose_from_c2w(cv, center);
        let cam_name = file_path
            .rsplit('/')
            .next()
            .unwrap_or(file_path)
            .to_string();
        cams.push(Camera {
            name: cam_name,
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            rotation,
            translation,
            model,
        });
    }
    Ok(cams)
}

fn pixels(v: f64) -> Option<u32> {
    (v >= 1.0 && v <= u32::MAX as f64 && v.fract() == 0.0).then_some(v as u32)
}

/// The image a `file_path` names: relative to `dir`, `.png` appended when the
/// path has no extension (or the path as written does not exist).
fn image_path(dir: &Path, file_path: &str) -> PathBuf {
    let p = dir.join(file_path);
    if p.is_file() {
        return p;
    }
    let mut s = p.clone().into_os_string();
    s.push(".png");
    let with_png = PathBuf::from(s);
    if with_png.is_file() { with_png } else { p }
}

type NumberLookup<'a> = dyn Fn(&str) -> Result<Option<f64>> + 'a;

fn distortion(
    model: Option<&Value>,
    number: &NumberLookup<'_>,
) -> std::result::Result<CameraModel, String> {
    let name = match model {
        None | Some(Value::Null) => return Ok(CameraModel::Pinhole),
        Some(v) => v.as_str().ok_or("key 'camera_model' is not a string")?,
    };
    let keys: &[&str] = match name {
        "OPENCV" => &["k1", "k2", "p1", "p2"],
        "OPENCV_FISHEYE" => &["k1", "k2", "k3", "k4"],
        "PINHOLE" | "SIMPLE_PINHOLE" => &[],
        other => {
            return Err(format!(
                "camera_model '{other}' is not supported (OPENCV, OPENCV_FISHEYE, PINHOLE)"
            ));
        }
    };
    let mut params = Vec::with_capacity(keys.len());
    for k in keys {
        params.push(number(k).map_err(|e| e.to_string())?.unwrap_or(0.0));
    }
    // nerfstudio writes OPENCV with all-zero coefficients for undistorted data.
    if name == "OPENCV" && params.iter().all(|&p| p == 0.0) || keys.is_empty() {
        return Ok(CameraModel::Pinhole);
    }
    Ok(CameraModel::Distorted {
        name: name.to_string(),
        params,
    })
}

/// Intrinsics of one camera as transforms.json keys.
fn intrinsics_json(c: &Camera) -> Result<Map<String, Value>> {
    let mut o = Map::new();
    o.insert("fl_x".into(), json!(c.fx));
    o.insert("fl_y".into(), json!(c.fy));
    o.insert("cx".into(), json!(c.cx));
    o.insert("cy".into(), json!(c.cy));
    o.insert("w".into(), json!(c.width));
    o.insert("h".into(), json!(c.height));
    match &c.model {
        CameraModel::Pinhole => {}
        CameraModel::Distorted { name, params } => {
            let keys: &[&str] = match name.as_str() {
                "OPENCV" => &["k1", "k2", "p1", "p2"],
                "OPENCV_FISHEYE" => &["k1", "k2", "k3", "k4"],
                _ => &[],
            };
            if keys.is_empty() || params.len() != keys.len() {
                return Err(Error::invalid(format!(
                    "camera '{}': model {name} with {} parameters cannot be written to \
                     transforms.json (OPENCV or OPENCV_FISHEYE only)",
                    c.name,
                    params.len()
                )));
            }
            o.insert("camera_model".into(), json!(name));
            for (k, p) in keys.iter().zip(params) {
                o.insert((*k).into(), json!(p));
            }
        }
    }
    Ok(o)
}

/// The transforms.json value for `cameras`: `camera_angle_x` (and `_y`) of
/// the first camera; `fl_x fl_y cx cy w h` (+ distortion) at the top level
/// when all cameras share them, otherwise in every frame; frames in the given
/// order with `file_path` = the camera name and `transform_matrix` = the
/// OpenGL camera-to-world matrix.
pub fn transforms_json_value(cameras: &[Camera]) -> Result<Value> {
    super::colmap::check_camera_rotations(cameras)?;
    let mut top = Map::new();
    let intr = cameras
        .iter()
        .map(intrinsics_json)
        .collect::<Result<Vec<_>>>()?;
    let shared = intr.windows(2).all(|w| w[0] == w[1]);
    if let Some(c) = cameras.first() {
        top.insert("camera_angle_x".into(), json!(c.fov_x()));
        top.insert("camera_angle_y".into(), json!(c.fov_y()));
        if shared {
            top.extend(intr[0].clone());
        }
    }
    let frames = cameras
        .iter()
        .zip(intr)
        .map(|(c, intr)| {
            let cv = c.c2w_rotation();
            let gl = DMat3::from_cols(cv.x_axis, -cv.y_axis, -cv.z_axis);
            let t = c.center();
            let rows = [
                [gl.x_axis.x, gl.y_axis.x, gl.z_axis.x, t.x],
                [gl.x_axis.y, gl.y_axis.y, gl.z_axis.y, t.y],
                [gl.x_axis.z, gl.y_axis.z, gl.z_axis.z, t.z],
                [0.0, 0.0, 0.0, 1.0],
            ];
            let mut f = Map::new();
            f.insert("file_path".into(), json!(c.name));
            f.insert("transform_matrix".into(), json!(rows));
            if !shared {
                f.extend(intr);
            }
            Value::Object(f)
        })
        .collect::<Vec<_>>();
    top.insert("frames".into(), Value::Array(frames));
    Ok(Value::Object(top))
}

/// Writes `cameras` as a `transforms.json` to `path` (`-` = stdout),
/// atomically; see [`transforms_json_value`] for the content.
pub fn write_transforms_json(path: &Path, cameras: &[Camera]) -> Result<()> {
    let v = transforms_json_value(cameras)?;
    write_output(path, |w| {
        serde_json::to_writer_pretty(&mut *w, &v).map_err(|e| werr(e.into()))?;
        w.write_all(b"\n").map_err(werr)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::cameras::colmap::ColmapModel;
    use crate::io::cameras::test_util::{assert_same_projections, rot};
    use crate::testing::shared_data;

    #[test]
    fn lego_cameras() {
        let Some(p) = shared_data("nerf-synthetic-lego-subset/transforms_train.json") else {
            return;
        };
        let cams = read_transforms_json(&p).unwrap();
        assert_eq!(cams.len(), 100);
        let f = 0.5 * 800.0 / (0.5 * 0.6911112070083618f64).tan();
        assert!((f - 1111.1).abs() < 0.05, "{f}");
        assert_eq!(cams[0].name, "r_0");
        let mut radii = Vec::new();
        let mut worst_px = 0.0f64;
        for c in &cams {
            assert_eq!(
                (c.width, c.height),
                (800, 800),
                "size from r_0.png's header"
            );
            assert_eq!((c.fx, c.fy, c.cx, c.cy), (f, f, 400.0, 400.0));
            assert_eq!(c.model, CameraModel::Pinhole);
            radii.push(c.center().length());
            // The cameras look at the object's centre, the world origin.
            let (px, _) = c
                .project(DVec3::ZERO)
                .expect("origin in front of every camera");
            worst_px = worst_px.max((px - glam::DVec2::new(400.0, 400.0)).length());
        }
        let (rmin, rmax) = radii
            .iter()
            .fold((f64::MAX, 0.0f64), |(a, b), &r| (a.min(r), b.max(r)));
        eprintln!(
            "lego: radius {rmin:.6}..{rmax:.6}, origin off-centre by at most {worst_px:.3e} px"
        );
        // Measured: radius 4.031127..4.031130 (float32 rounding of the stored
        // matrices), origin at the image centre to 1.4e-3 px (the Blender
        // cameras track the origin); the bounds leave a few times that margin.
        assert!(rmin > 4.031 && rmax < 4.0312, "{rmin} {rmax}");
        assert!(worst_px < 1e-2, "{worst_px}");
        // Upper hemisphere: the lego scene's cameras have z >= 0 (Blender z up),
        // and OpenGL -> OpenCV turns camera up (+y GL) into image up (-y CV):
        // the world +z axis (scene up) points up in every image.
        for c in &cams {
            let (top, _) = c.project(DVec3::new(0.0, 0.0, 0.5)).unwrap();
            assert!(
                top.y < 400.0,
                "camera {}: world up appears downward",
                c.name
            );
        }
    }

    #[test]
    fn colmap_to_transforms_and_back() {
        let Some(p) = shared_data("colmap-kunkun-figurine/sparse/0") else {
            return;
        };
        let m = ColmapModel::read(&p).unwrap();
        let mut cams = m.to_cameras().unwrap();
        // Make the principal points differ from the centre to check they survive.
        for (i, c) in cams.iter_mut().enumerate() {
            c.cx += 0.25 * i as f64;
        }
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("transforms.json");
        write_transforms_json(&out, &cams).unwrap();
        let back = read_transforms_json(&out).unwrap();
        let pts: Vec<DVec3> = m.points3d.iter().map(|p| p.xyz).collect();
        // As for cameras.json: exact JSON floats, sign flips are exact, the
        // inversion costs a few ulps (~1e-13 relative of ~2e3 px coordinates).
        assert_same_projections(&cams, &back, &pts, 1e-6, 1e-9);
        for (a, b) in cams.iter().zip(&back) {
            assert_eq!((a.fx, a.fy, a.cx, a.cy), (b.fx, b.fy, b.cx, b.cy));
        }
    }

    #[test]
    fn intrinsics_fallbacks_and_distortion() {
        let dir = tempfile::tempdir().unwrap();
        let id = "[[1,0,0,0],[0,1,0,0],[0,0,1,2],[0,0,0,1]]";
        let s = format!(
            r#"{{"camera_angle_x": 1.0, "camera_angle_y": 0.5, "w": 200, "h": 100,
                "frames": [{{"file_path": "a/x.jpg", "transform_matrix": {id}}},
                           {{"file_path": "y", "transform_matrix": {id}, "fl_x": 7, "cx": 3,
                             "camera_model": "OPENCV", "k1": 0.1}}]}}"#
        );
        let cams = parse_transforms_json("t.json", s.as_bytes(), dir.path()).unwrap();
        let c = &cams[0];
        assert_eq!(c.name, "x.jpg");
        assert!((c.fx - 100.0 / 0.5f64.tan()).abs() < 1e-12);
        assert!((c.fy - 50.0 / 0.25f64.tan()).abs() < 1e-12);
        assert_eq!((c.cx, c.cy), (100.0, 50.0));
        // OpenGL camera at z = 2 looking down -z: the origin is 2 in front.
        let (px, z) = c.project(DVec3::ZERO).unwrap();
        assert_eq!(z, 2.0);
        assert!((px - glam::DVec2::new(100.0, 50.0)).length() < 1e-12);
        // World +y is camera up in OpenGL, so image up (smaller pixel y).
        assert!(c.project(DVec3::new(0.0, 0.1, 0.0)).unwrap().0.y < 50.0);
        let d = &cams[1];
        assert_eq!((d.fx, d.cx), (7.0, 3.0));
        assert_eq!(
            d.model,
            CameraModel::Distorted {
                name: "OPENCV".into(),
                params: vec![0.1, 0.0, 0.0, 0.0]
            }
        );
        // Writing and reading back keeps distortion and per-frame intrinsics.
        let out = dir.path().join("t.json");
        write_transforms_json(&out, &cams).unwrap();
        let back = read_transforms_json(&out).unwrap();
        assert_eq!(back[1].model, d.model);
        assert_eq!((back[0].fx, back[1].fx), (c.fx, d.fx));
    }

    #[test]
    fn size_from_png_without_extension_in_file_path() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("train")).unwrap();
        let mut png = vec![0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a, 0, 0, 0, 13];
        png.extend_from_slice(b"IHDR");
        png.extend_from_slice(&640u32.to_be_bytes());
        png.extend_from_slice(&480u32.to_be_bytes());
        std::fs::write(dir.path().join("train/r_0.png"), &png).unwrap();
        let s = r#"{"camera_angle_x": 0.7, "frames": [
            {"file_path": "./train/r_0", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]},
            {"file_path": "./train/r_1", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}"#;
        let p = dir.path().join("transforms_train.json");
        std::fs::write(&p, s).unwrap();
        let cams = read_transforms_json(&p).unwrap();
        assert!(cams.iter().all(|c| (c.width, c.height) == (640, 480)));
        // Without the image, the error says why.
        std::fs::remove_file(dir.path().join("train/r_0.png")).unwrap();
        let e = read_transforms_json(&p).unwrap_err().to_string();
        assert!(
            e.contains("transforms_train.json") && e.contains("r_0"),
            "{e}"
        );
    }

    #[test]
    fn errors_name_frame_and_key() {
        let dir = Path::new(".");
        let m = "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]";
        let cases = [
            (format!(r#"{{"w": 4, "h": 4, "frames": [{{"file_path": "a", "transform_matrix": {m}}}]}}"#), "frame 0: missing key 'camera_angle_x'"),
            (format!(r#"{{"w": 4, "h": 4, "camera_angle_x": 1, "frames": [{{"transform_matrix": {m}}}]}}"#), "frame 0: missing key 'file_path'"),
            (r#"{"w": 4, "h": 4, "camera_angle_x": 1, "frames": [{"file_path": "a"}]}"#.to_string(), "missing key 'transform_matrix'"),
            (r#"{"w": 4, "h": 4, "camera_angle_x": 1}"#.to_string(), "missing key 'frames'"),
            (format!(r#"{{"w": 4, "h": 4, "camera_angle_x": "x", "frames": [{{"file_path": "a", "transform_matrix": {m}}}]}}"#), "'camera_angle_x' is not a number"),
            (r#"{"w": 4, "h": 4, "camera_angle_x": 1, "frames": [{"file_path": "a", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]]}]}"#.to_string(), "last row"),
            (r#"{"w": 4, "h": 4, "camera_angle_x": 1, "frames": [{"file_path": "a", "transform_matrix": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}"#.to_string(), "not orthonormal"),
            (format!(r#"{{"w": 4.5, "h": 4, "camera_angle_x": 1, "frames": [{{"file_path": "a", "transform_matrix": {m}}}]}}"#), "bad width"),
        ];
        for (s, msg) in cases {
            let e = parse_transforms_json("dir/t.json", s.as_bytes(), dir)
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with("dir/t.json: ") && e.contains(msg),
                "{msg}: {e}"
            );
        }
    }

    #[test]
    fn writer_rejects_unsupported_models() {
        let mut c = Camera::pinhole("a", 10, 10, 5.0, 5.0, 5.0, 5.0, rot(DVec3::Y), DVec3::ZERO);
        c.model = CameraModel::Distorted {
            name: "FOV".into(),
            params: vec![0.1],
        };
        assert!(
            transforms_json_value(&[c])
                .unwrap_err()
                .to_string()
                .contains("FOV")
        );
    }
}
