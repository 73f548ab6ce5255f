//! Camera-rig geometry: what every command derives from a set of cameras,
//! computed in one place so that two commands given the same cameras agree.
//!
//! - [`focus`]: the point the cameras look at (least-squares meeting point
//!   of their optical axes, 2DGS's `focus_point_fn`) with the smallest and
//!   mean camera distance to it (2DGS's fusion radius; the box of random
//!   initial points);
//! - [`nerfpp_radius`]: 3DGS's `getNerfppNorm` scene extent;
//! - [`downscaled_size`] / [`downscale`]: a camera at 1/k of its resolution
//!   by 3DGS's rule;
//! - [`back_project`]: a pixel and its camera depth to a world point;
//! - [`pick_file`]: which file of a folder belongs to a camera.
//!
//! Conventions (docs/ARCHITECTURE.md): OpenCV camera axes (x right, y down,
//! z forward), world-to-camera rotation `R` and translation `t` in f64,
//! pixel centres at integer + 0.5, depth = camera z in scene units.

use glam::{DMat3, DVec3};

use crate::model::Camera;

/// Below this determinant of the mean projector `(1/n) Σ (I − dᵢdᵢᵀ)` the
/// optical axes count as parallel and the focus point as undefined. The
/// mean projector's eigenvalues lie in [0, 1] and sum to 2; its smallest
/// grows with the square of the angular spread of the viewing directions,
/// so 1e-6 refuses rigs whose axes spread less than about 0.1°, where the
/// least-squares point runs off to thousands of rig sizes.
pub const PARALLEL_AXES_DET: f64 = 1e-6;

/// The point the cameras look at, and how far they are from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Focus {
    /// The least-squares meeting point of the optical axes.
    pub point: DVec3,
    /// The smallest distance of a camera centre from `point` (2DGS's
    /// `estimate_bounding_sphere` radius).
    pub min_distance: f64,
    /// The mean distance of the camera centres from `point`.
    pub mean_distance: f64,
}

/// The focus of `cams`: `(Σ Mᵢ / n)⁻¹ (Σ Mᵢ oᵢ / n)` with `Mᵢ = I − dᵢdᵢᵀ`
/// (dᵢ the unit viewing direction, the third row of R; oᵢ the centre).
/// `None` when there is no camera or the axes are (nearly) parallel
/// ([`PARALLEL_AXES_DET`]).
pub fn focus<'a>(cams: impl IntoIterator<Item = &'a Camera>) -> Option<Focus> {
    let mut m_sum = DMat3::ZERO;
    let mut mo_sum = DVec3::ZERO;
    let mut centres = Vec::new();
    for c in cams {
        let d = c.rotation.row(2).normalize();
        let o = c.center();
        let m = DMat3::IDENTITY - DMat3::from_cols(d * d.x, d * d.y, d * d.z);
        m_sum += m;
        mo_sum += m * o;
        centres.push(o);
    }
    if centres.is_empty() {
        return None;
    }
    let n = centres.len() as f64;
    let mean = m_sum * (1.0 / n);
    let det = mean.determinant();
    if det.is_nan() || det.abs() < PARALLEL_AXES_DET {
        return None;
    }
    let point = mean.inverse() * (mo_sum / n);
    let dist = || centres.iter().map(|o| (*o - point).length());
    Some(Focus {
        point,
        min_distance: dist().fold(f64::INFINITY, f64::min),
        mean_distance: dist().sum::<f64>() / n,
    })
}

/// 3DGS's `getNerfppNorm` radius: 1.1 × the largest distance of a camera
/// centre from their mean (the mean summed, then divided, as numpy's
/// `mean` does for a few cameras). `None` when there is no centre, all
/// coincide, or the value is not finite; callers choose their fallback.
pub fn nerfpp_radius(centres: &[[f64; 3]]) -> Option<f64> {
    if centres.is_empty() {
        return None;
    }
    let n = centres.len() as f64;
    let c: [f64; 3] = std::array::from_fn(|k| centres.iter().map(|p| p[k]).sum::<f64>() / n);
    let r = centres
        .iter()
        .map(|p| (0..3).map(|k| (p[k] - c[k]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    (r > 0.0 && r.is_finite()).then_some(1.1 * r)
}

/// The size of a `w` × `h` camera at 1/`k` of its resolution, by 3DGS's
/// rule (`round(w / k)` with Python's `round`, ties to even), at least 1.
pub fn downscaled_size(w: u32, h: u32, k: u32) -> (u32, u32) {
    let r = |v: u32| ((v as f64 / k.max(1) as f64).round_ties_even() as u32).max(1);
    (r(w), r(h))
}

/// `cam` at 1/`k` of its resolution: the size of [`downscaled_size`], focal
/// lengths and principal point scaled by the same per-axis factors
/// (new / old size, as 3DGS's field-of-view round trip does), so pixel
/// centres stay at integer + 0.5 and the image covers the same view.
/// When `k` divides the size, the factors are exactly 1/k.
pub fn downscale(cam: &Camera, k: u32) -> Camera {
    let mut c = cam.clone();
    if k <= 1 {
        return c;
    }
    let (w, h) = downscaled_size(cam.width, cam.height, k);
    if (w as u64 * k as u64, h as u64 * k as u64) == (cam.width as u64, cam.height as u64) {
        let f = k as f64;
        c.fx /= f;
        c.fy /= f;
        c.cx /= f;
        c.cy /= f;
    } else {
        let (sx, sy) = (w as f64 / cam.width as f64, h as f64 / cam.height as f64);
        c.fx *= sx;
        c.cx *= sx;
        c.fy *= sy;
        c.cy *= sy;
    }
    c.width = w;
    c.height = h;
    c
}

/// The world point at camera depth `z` on the ray through the centre of
/// pixel (`x`, `y`).
pub fn back_project(cam: &Camera, x: usize, y: usize, z: f64) -> DVec3 {
    let pc = DVec3::new(
        (x as f64 + 0.5 - cam.cx) / cam.fx * z,
        (y as f64 + 0.5 - cam.cy) / cam.fy * z,
        z,
    );
    cam.c2w_rotation() * pc + cam.center()
}

/// Image extensions a camera's file may have, in the order tried.
pub const IMAGE_EXTENSIONS: [&str; 6] = ["png", "jpg", "jpeg", "PNG", "JPG", "JPEG"];

/// The names a camera's image or mask may have, in the order tried: its
/// own file name (folders dropped), then its stem with each of
/// [`IMAGE_EXTENSIONS`].
pub fn file_candidates(camera_name: &str) -> Vec<String> {
    let p = std::path::Path::new(camera_name);
    let own = p
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = camera_stem(camera_name);
    let mut v = Vec::with_capacity(1 + IMAGE_EXTENSIONS.len());
    if !own.is_empty() {
        v.push(own);
    }
    for e in IMAGE_EXTENSIONS {
        let n = format!("{stem}.{e}");
        if !stem.is_empty() && !v.contains(&n) {
            v.push(n);
        }
    }
    v
}

/// The stem a camera's files are named after: its image name without
/// folders or extension.
pub fn camera_stem(camera_name: &str) -> String {
    std::path::Path::new(camera_name)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| camera_name.to_string())
}

/// The file of `files` (names in one folder) that belongs to the camera
/// named `camera_name`: the first of [`file_candidates`] present, else the
/// only file whose stem is the same number as the camera's stem (DTU:
/// camera `007`, image `000007.png`, mask `007.png`). `None` when neither
/// rule finds exactly one.
pub fn pick_file<'a>(camera_name: &str, files: &'a [String]) -> Option<&'a str> {
    for c in file_candidates(camera_name) {
        if let Some(f) = files.iter().find(|f| **f == c) {
            return Some(f);
        }
    }
    let n: u64 = camera_stem(camera_name).parse().ok()?;
    let number = |f: &&String| camera_stem(f).parse::<u64>().ok() == Some(n);
    let mut hits = files.iter().filter(number);
    match (hits.next(), hits.next()) {
        (Some(one), None) => Some(one),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn looking_at(target: DVec3, pos: DVec3) -> Camera {
        let z = (target - pos).normalize();
        let x = z.cross(DVec3::Y).normalize();
        let y = z.cross(x);
        let (r, t) = Camera::pose_from_c2w(DMat3::from_cols(x, y, z), pos);
        Camera::pinhole("c", 64, 48, 50.0, 50.0, 32.0, 24.0, r, t)
    }

    /// Cameras on a circle of radius 3 around (1, 2, 0.5), each looking at
    /// it: the focus is the centre (to rounding, 1e-9), the smallest
    /// distance 2 (one camera moved in along its axis), the mean
    /// (7·3 + 2)/8; one camera or parallel axes give no focus.
    #[test]
    fn focus_of_a_ring() {
        let target = DVec3::new(1.0, 2.0, 0.5);
        let cams: Vec<Camera> = (0..8)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 8.0;
                let dist = if k == 3 { 2.0 } else { 3.0 };
                looking_at(
                    target,
                    target + DVec3::new(a.cos(), 0.3, a.sin()).normalize() * dist,
                )
            })
            .collect();
        let f = focus(&cams).unwrap();
        assert!((f.point - target).length() < 1e-9, "{:?}", f.point);
        assert!((f.min_distance - 2.0).abs() < 1e-9);
        assert!((f.mean_distance - 23.0 / 8.0).abs() < 1e-9);
        assert!(focus(&cams[..1]).is_none(), "one axis: no point");
        assert!(focus(std::iter::empty()).is_none());
        let parallel: Vec<Camera> = (0..4)
            .map(|k| {
                looking_at(
                    DVec3::new(k as f64, 0.0, 10.0),
                    DVec3::new(k as f64, 0.0, 0.0),
                )
            })
            .collect();
        assert!(focus(&parallel).is_none(), "parallel axes: no point");
    }

    /// NeRF++ radius: 1.1 × the farthest centre from the mean; coincident
    /// centres have none.
    #[test]
    fn nerfpp_radius_of_a_pair() {
        let r = nerfpp_radius(&[[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]).unwrap();
        assert!((r - 1.1).abs() < 1e-15);
        assert_eq!(nerfpp_radius(&[[2.0; 3], [2.0; 3]]), None);
        assert_eq!(nerfpp_radius(&[]), None);
    }

    /// 3DGS's rounding: ties to even (Python's `round`), so 1601 / 2 gives
    /// 800 and 1603 / 2 gives 802; a size that divides keeps the exact 1/k
    /// intrinsics; otherwise the principal point keeps its relative place.
    #[test]
    fn downscale_rounds_as_3dgs() {
        assert_eq!(downscaled_size(1601, 1203, 2), (800, 602));
        assert_eq!(downscaled_size(1600, 1200, 4), (400, 300));
        assert_eq!(downscaled_size(3, 3, 8), (1, 1));
        let mut c = looking_at(DVec3::Z, DVec3::ZERO);
        c.width = 1601;
        c.cx = 800.5;
        let d = downscale(&c, 2);
        assert_eq!(d.width, 800);
        assert!((d.cx / d.width as f64 - 800.5 / 1601.0).abs() < 1e-15);
        let e = downscale(&looking_at(DVec3::Z, DVec3::ZERO), 2);
        assert_eq!((e.width, e.height, e.fx, e.cx), (32, 24, 25.0, 16.0));
    }

    /// Back-projecting a projected point gives it back.
    #[test]
    fn back_project_inverts_projection() {
        let cam = looking_at(DVec3::new(0.3, -0.2, 0.1), DVec3::new(0.0, 0.5, -4.0));
        let p = back_project(&cam, 10, 37, 3.25);
        let pc = cam.rotation * p + cam.translation;
        assert!((pc.z - 3.25).abs() < 1e-12);
        assert!((cam.fx * pc.x / pc.z + cam.cx - 10.5).abs() < 1e-9);
        assert!((cam.fy * pc.y / pc.z + cam.cy - 37.5).abs() < 1e-9);
    }

    /// The camera's own name first, then its stem with an image extension,
    /// then a unique equal number; two numbered files are ambiguous.
    #[test]
    fn pick_file_order() {
        let f = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let files = f(&["a.jpg", "a.png", "000007.png"]);
        assert_eq!(pick_file("images/a.jpg", &files), Some("a.jpg"));
        assert_eq!(pick_file("a.tif", &files), Some("a.png"));
        assert_eq!(pick_file("007", &files), Some("000007.png"));
        assert_eq!(pick_file("7", &f(&["07.png", "007.png"])), None);
        assert_eq!(pick_file("b", &files), None);
    }
}
