//! Cameras placed on an orbit around a scene (for scenes that come without
//! a camera file): OpenCV axes, pinhole, principal point at the image centre.

use glam::{DMat3, DVec3};

use crate::model::{Camera, OrbitSpec};
use crate::{Error, Result};

/// One ring of orbit cameras: `views` cameras evenly spaced in azimuth,
/// `elevation_deg` degrees above the horizon (the plane orthogonal to
/// `up`), looking at the centre of the scene's central 96% box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitRing {
    /// Cameras on the ring.
    pub views: usize,
    /// Image size in pixels.
    pub width: u32,
    pub height: u32,
    /// Horizontal field of view, degrees, in (0, 180).
    pub fov_deg: f64,
    /// Elevation above the horizon, degrees.
    pub elevation_deg: f64,
    /// Distance from the centre (`None`: the central box fills the view).
    pub radius: Option<f64>,
    /// World up direction (non-zero).
    pub up: DVec3,
}

impl OrbitRing {
    /// The ring of `spec` at `elevation_deg`.
    pub fn of(spec: &OrbitSpec, elevation_deg: f64) -> Self {
        OrbitRing {
            views: spec.views_per_ring,
            width: spec.width,
            height: spec.height,
            fov_deg: spec.fov_deg,
            elevation_deg,
            radius: spec.radius,
            up: spec.up,
        }
    }
}

/// The cameras of `ring` around the central 96% box of `points`, named
/// `orbit_{i:03}`.
pub fn orbit_cameras(points: &[[f32; 3]], ring: &OrbitRing) -> Result<Vec<Camera>> {
    let OrbitRing {
        views: n,
        width,
        height,
        fov_deg,
        elevation_deg,
        radius,
        up,
    } = *ring;
    let finite: Vec<&[f32; 3]> = points
        .iter()
        .filter(|p| p.iter().all(|v| v.is_finite()))
        .collect();
    if finite.is_empty() {
        return Err(Error::invalid("the scene has no finite points to orbit"));
    }
    let mut lo = [0.0f64; 3];
    let mut hi = [0.0f64; 3];
    for k in 0..3 {
        let mut v: Vec<f64> = finite.iter().map(|p| p[k] as f64).collect();
        v.sort_by(f64::total_cmp);
        lo[k] = v[(v.len() as f64 * 0.02) as usize];
        hi[k] = v[((v.len() as f64 * 0.98) as usize).min(v.len() - 1)];
    }
    let centre = DVec3::new(lo[0] + hi[0], lo[1] + hi[1], lo[2] + hi[2]) * 0.5;
    let half = (DVec3::from(hi) - DVec3::from(lo)).length() * 0.5;
    let up = up
        .try_normalize()
        .ok_or_else(|| Error::invalid("--up must be a non-zero vector"))?;
    let fov = fov_deg.to_radians();
    if !(fov > 0.0 && fov < std::f64::consts::PI) {
        return Err(Error::invalid("--fov must lie in (0, 180) degrees"));
    }
    let dist = radius.unwrap_or(1.3 * half.max(1e-6) / (0.5 * fov).tan());
    // two directions spanning the horizon plane
    let any = if up.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let h0 = (any - up * any.dot(up)).normalize();
    let h1 = up.cross(h0);
    let el = elevation_deg.to_radians();
    let f = 0.5 * width as f64 / (0.5 * fov).tan();
    if !(dist.is_finite() && dist > 0.0) {
        return Err(Error::invalid(format!(
            "the orbit radius {dist} is not a positive finite distance"
        )));
    }
    (0..n)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            let dir = (h0 * a.cos() + h1 * a.sin()) * el.cos() + up * el.sin();
            let eye = centre + dir * dist;
            // A radius below the rounding step of the centre's coordinates
            // puts the eye on the centre; looking straight along `up` leaves
            // no horizon: both leave no camera frame.
            let frame = (centre - eye).try_normalize().and_then(|fwd| {
                let right = (-up).cross(fwd).try_normalize()?;
                Some((fwd, right))
            });
            let Some((fwd, right)) = frame else {
                return Err(Error::invalid(format!(
                    "camera {i} of the orbit has no viewing direction: radius {dist:.4e} around \
                     the centre ({:.4e}, {:.4e}, {:.4e}) at elevation {elevation_deg}° (the radius is \
                     below the coordinates' rounding step, or the camera looks along --up)",
                    centre.x, centre.y, centre.z
                )));
            };
            let down = fwd.cross(right);
            let (r, t) = Camera::pose_from_c2w(DMat3::from_cols(right, down, fwd), eye);
            Ok(Camera::pinhole(
                format!("orbit_{i:03}"),
                width,
                height,
                f,
                f,
                width as f64 / 2.0,
                height as f64 / 2.0,
                r,
                t,
            ))
        })
        .collect()
}

/// The cameras of `spec` around `points`: one ring per elevation; rings
/// after the first get names `orbit_r{ring}_{i}` so names stay unique.
pub fn orbit_rings(points: &[[f32; 3]], spec: &OrbitSpec) -> Result<Vec<Camera>> {
    let mut cams = Vec::with_capacity(spec.views_per_ring * spec.elevations_deg.len());
    for (ring, &el) in spec.elevations_deg.iter().enumerate() {
        let mut ring_cams = orbit_cameras(points, &OrbitRing::of(spec, el))?;
        if ring > 0 {
            for (i, c) in ring_cams.iter_mut().enumerate() {
                c.name = format!("orbit_r{ring}_{i:03}");
            }
        }
        cams.extend(ring_cams);
    }
    Ok(cams)
}
