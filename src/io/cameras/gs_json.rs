//! 3DGS `cameras.json` (written by 3DGS `scene/__init__.py` with
//! `utils/camera_utils.camera_to_JSON`, read by SuGaR and viewers).
//!
//! The file is a JSON array, one object per camera, with keys
//! `id` (int), `img_name` (image basename without extension), `width`,
//! `height` (pixels), `position` (camera centre in world coordinates),
//! `rotation` (3×3, a list of **rows**, the **camera-to-world** rotation whose
//! columns are the camera x, y, z axes in world coordinates, OpenCV axes:
//! x right, y down, z forward), `fx`, `fy` (pixels).
//!
//! The principal point is not stored: 3DGS assumes the image centre, so the
//! reader sets `cx = width / 2`, `cy = height / 2` (pixel centres at +0.5),
//! and the writer drops `cx`, `cy`. The pose becomes world-to-camera
//! `R = rotationᵀ`, `t = −R · position`.
//!
//! Order: the reader sorts cameras by `img_name` (stable), as 3DGS's scene
//! loader and SuGaR's `load_gs_cameras` do (the file itself lists test
//! cameras first); duplicates are kept. The writer keeps the given order and
//! numbers `id` from 0.

use std::path::Path;

use glam::{DMat3, DVec3};
use serde_json::{Map, Value, json};

use super::{check_rotation, json_error};
use crate::io::source::{read_input, werr, write_output};
use crate::model::{Camera, CameraModel};
use crate::{Error, Result};

/// Tolerance on `|RᵀR − I|` for a stored rotation: files written from
/// float32 data are orthonormal to ~1e-7; 1e-4 still rejects scaled or
/// sheared matrices, which would silently distort every projection.
pub(crate) const ROTATION_TOL: f64 = 1e-4;

/// Reads a 3DGS `cameras.json` (see the module docs for the conventions).
/// Errors name the file, the camera index and the key.
pub fn read_gs_json(path: &Path) -> Result<Vec<Camera>> {
    let input = read_input(path)?;
    parse_gs_json(&input.name, &input)
}

/// Parses the bytes of a 3DGS `cameras.json`; `name` is used in errors.
pub fn parse_gs_json(name: &str, bytes: &[u8]) -> Result<Vec<Camera>> {
    let v: Value = serde_json::from_slice(bytes).map_err(|e| json_error(name, e))?;
    let Value::Array(list) = v else {
        return Err(Error::format(
            name,
            "expected a JSON array of cameras (3DGS cameras.json)",
        ));
    };
    let mut cams = list
        .iter()
        .enumerate()
        .map(|(i, v)| camera_from_json(name, i, v))
        .collect::<Result<Vec<_>>>()?;
    cams.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(cams)
}

fn camera_from_json(file: &str, i: usize, v: &Value) -> Result<Camera> {
    let err = |msg: String| Error::format(file, format!("camera {i}: {msg}"));
    let Value::Object(o) = v else {
        return Err(err("expected a JSON object".into()));
    };
    let get = |key: &str| {
        o.get(key)
            .ok_or_else(|| err(format!("missing key '{key}'")))
    };
    let name = get("img_name")?
        .as_str()
        .ok_or_else(|| err("key 'img_name' is not a string".into()))?
        .to_string();
    let size = |key: &str| -> Result<u32> {
        get(key)?
            .as_u64()
            .and_then(|s| u32::try_from(s).ok())
            .filter(|&s| s > 0)
            .ok_or_else(|| err(format!("key '{key}' is not a positive integer")))
    };
    let (width, height) = (size("width")?, size("height")?);
    let focal = |key: &str| -> Result<f64> {
        get(key)?
            .as_f64()
            .filter(|f| f.is_finite() && *f > 0.0)
            .ok_or_else(|| err(format!("key '{key}' is not a positive number")))
    };
    let (fx, fy) = (focal("fx")?, focal("fy")?);
    let position = DVec3::from_array(
        numbers::<3>(get("position")?)
            .ok_or_else(|| err("key 'position' is not a list of 3 numbers".into()))?,
    );
    let rows = get("rotation")?
        .as_array()
        .filter(|r| r.len() == 3)
        .and_then(|r| {
            Some([
                numbers::<3>(&r[0])?,
                numbers::<3>(&r[1])?,
                numbers::<3>(&r[2])?,
            ])
        })
        .ok_or_else(|| err("key 'rotation' is not a 3×3 list of rows of numbers".into()))?;
    let c2w = DMat3::from_cols_array_2d(&rows).transpose();
    check_rotation(c2w, ROTATION_TOL).map_err(|e| err(format!("key 'rotation' {e}")))?;
    let (rotation, translation) = Camera::pose_from_c2w(c2w, position);
    Ok(Camera::pinhole(
        name,
        width,
        height,
        fx,
        fy,
        width as f64 / 2.0,
        height as f64 / 2.0,
        rotation,
        translation,
    ))
}

/// `N` finite numbers from a JSON list of exactly `N` numbers.
pub(crate) fn numbers<const N: usize>(v: &Value) -> Option<[f64; N]> {
    let a = v.as_array().filter(|a| a.len() == N)?;
    let mut out = [0.0; N];
    for (o, x) in out.iter_mut().zip(a) {
        *o = x.as_f64().filter(|f| f.is_finite())?;
    }
    Some(out)
}

/// The `cameras.json` value for `cameras`: ids from 0 in the given order,
/// `img_name` = the camera name without its extension, `position` = centre,
/// `rotation` = camera-to-world rows. Fails for non-pinhole cameras and
/// non-rotation matrices; the principal point is dropped (3DGS assumes the
/// image centre).
pub fn gs_json_value(cameras: &[Camera]) -> Result<Value> {
    super::colmap::check_camera_rotations(cameras)?;
    let list = cameras
        .iter()
        .enumerate()
        .map(|(i, c)| {
            if let CameraModel::Distorted { name, .. } = &c.model {
                return Err(Error::invalid(format!(
                    "camera '{}' uses the {name} model; cameras.json holds only undistorted \
                     pinhole cameras",
                    c.name
                )));
            }
            let r = c.c2w_rotation().transpose().to_cols_array_2d(); // rows of c2w
            let mut o = Map::new();
            o.insert("id".into(), json!(i));
            o.insert("img_name".into(), json!(strip_extension(&c.name)));
            o.insert("width".into(), json!(c.width));
            o.insert("height".into(), json!(c.height));
            o.insert("position".into(), json!(c.center().to_array()));
            o.insert("rotation".into(), json!(r));
            o.insert("fy".into(), json!(c.fy));
            o.insert("fx".into(), json!(c.fx));
            Ok(Value::Object(o))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Value::Array(list))
}

/// Writes `cameras` as a 3DGS `cameras.json` to `path` (`-` = stdout),
/// atomically; see [`gs_json_value`] for the content.
pub fn write_gs_json(path: &Path, cameras: &[Camera]) -> Result<()> {
    let v = gs_json_value(cameras)?;
    write_output(path, |w| {
        serde_json::to_writer(&mut *w, &v).map_err(|e| werr(e.into()))?;
        w.write_all(b"\n").map_err(werr)
    })
}

/// The name without its last extension (`0001.jpg` → `0001`, `a/b.png` → `a/b`).
fn strip_extension(name: &str) -> &str {
    match name.rfind('.') {
        Some(i) if i > 0 && !name[i..].contains('/') => &name[..i],
        _ => name,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::cameras::colmap::ColmapModel;
    use crate::io::cameras::test_util::{assert_same_projections, rot};
    use crate::testing::shared_data;

    #[test]
    fn colmap_to_cameras_json_and_back() {
        let Some(p) = shared_data("colmap-kunkun-figurine/sparse/0") else {
            return;
        };
        let m = ColmapModel::read(&p).unwrap();
        let cams = m.to_cameras().unwrap();
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("cameras.json");
        write_gs_json(&out, &cams).unwrap();
        let back = read_gs_json(&out).unwrap();
        assert_eq!(back.len(), 64);
        assert_eq!(back[0].name, "0001");
        let pts: Vec<DVec3> = m.points3d.iter().map(|p| p.xyz).collect();
        // JSON floats round-trip exactly (shortest repr); only the inversion
        // R -> Rᵀ, t -> −Rᵀt -> −R(−Rᵀt) adds a few ulps, i.e. ~1e-13 of the
        // pixel coordinates (~2e3 px): 1e-6 px is a generous bound that any
        // convention error (a transpose, a sign) exceeds by orders of magnitude.
        // kunkun's principal point is the image centre, so it survives.
        assert_same_projections(&cams, &back, &pts, 1e-6, 1e-9);
    }

    #[test]
    fn reader_conventions_on_a_hand_written_camera() {
        // A camera at (0, 0, -5) looking along world +z, camera-to-world = I.
        let s = r#"[{"id": 3, "img_name": "b", "width": 100, "height": 80,
                    "position": [0, 0, -5], "rotation": [[1,0,0],[0,1,0],[0,0,1]],
                    "fx": 50.0, "fy": 60.0},
                   {"id": 0, "img_name": "a", "width": 100, "height": 80,
                    "position": [1, 2, 3], "rotation": [[0,-1,0],[1,0,0],[0,0,1]],
                    "fx": 50.0, "fy": 60.0}]"#;
        let cams = parse_gs_json("cameras.json", s.as_bytes()).unwrap();
        assert_eq!(cams[0].name, "a");
        let b = &cams[1];
        assert_eq!((b.cx, b.cy), (50.0, 40.0));
        let (px, z) = b.project(DVec3::new(1.0, 1.0, 0.0)).unwrap();
        assert_eq!(z, 5.0);
        assert!((px - glam::DVec2::new(60.0, 52.0)).length() < 1e-12);
        // Second camera: its x axis (first column of the rotation) is world +y.
        let a = &cams[0];
        assert!((a.c2w_rotation().x_axis - DVec3::Y).length() < 1e-15);
        assert!((a.center() - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-15);
    }

    #[test]
    fn errors_name_camera_and_key() {
        let good = r#"{"id": 0, "img_name": "a", "width": 10, "height": 10,
                      "position": [0, 0, 0], "rotation": [[1,0,0],[0,1,0],[0,0,1]], "fx": 5, "fy": 5}"#;
        let cases = [
            ("fx", r#""fx": 5, "#, "", "missing key 'fx'"),
            (
                "rotation",
                "[[1,0,0],[0,1,0],[0,0,1]]",
                "[[2,0,0],[0,1,0],[0,0,1]]",
                "not orthonormal",
            ),
            (
                "rotation",
                "[[1,0,0],[0,1,0],[0,0,1]]",
                "[[1,0,0],[0,1,0],[0,0,-1]]",
                "reflection",
            ),
            (
                "rotation",
                "[[1,0,0],[0,1,0],[0,0,1]]",
                "[[1,0,0],[0,1,0]]",
                "3×3",
            ),
            ("position", "[0, 0, 0]", "[0, \"x\", 0]", "'position'"),
            ("width", r#""width": 10"#, r#""width": -1"#, "'width'"),
        ];
        for (key, from, to, msg) in cases {
            let bad = good.replacen(from, to, 1);
            let s = format!("[{good}, {bad}]");
            let e = parse_gs_json("x/cameras.json", s.as_bytes())
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("x/cameras.json: camera 1: "), "{key}: {e}");
            assert!(e.contains(msg), "{key}: {e}");
        }
        let e = parse_gs_json("c.json", b"{}").unwrap_err().to_string();
        assert!(e.contains("array"), "{e}");
        let e = parse_gs_json("c.json", b"[{").unwrap_err().to_string();
        assert!(
            e.contains("c.json: invalid JSON") && e.contains("line 1"),
            "{e}"
        );
    }

    #[test]
    fn writer_rejects_distorted_cameras() {
        let mut c = Camera::pinhole(
            "a.png",
            10,
            10,
            5.0,
            5.0,
            5.0,
            5.0,
            rot(DVec3::X),
            DVec3::ZERO,
        );
        c.model = CameraModel::Distorted {
            name: "OPENCV".into(),
            params: vec![0.0; 4],
        };
        let e = gs_json_value(&[c]).unwrap_err().to_string();
        assert!(e.contains("OPENCV"), "{e}");
        assert_eq!(strip_extension("a.b/c"), "a.b/c");
        assert_eq!(strip_extension(".hidden"), ".hidden");
        assert_eq!(strip_extension("r_0.png"), "r_0");
    }
}
