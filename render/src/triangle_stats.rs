//! Per-triangle statistics of one forward pass that Triangle Splatting's
//! densification reads (triangle_splatting.md §2.1 step 9, §3.4):
//!
//! - `importance`: the largest blending weight α·T the triangle received at
//!   any pixel of the view (the kernel's `max_blending`, an atomic max over
//!   pixels; 0 when it blended nowhere);
//! - `inradius`: the projected triangle's inradius r in pixels (the
//!   kernel's `density_factor`; 0 when culled);
//! - `radius`: R = max distance of the projected vertices from the projected
//!   3-D centroid, in pixels (the kernel's `image_size`, which it stores as
//!   ceil(R); 0 when culled).
//!
//! Indexed by triangle (not by projected entry). The importance is the
//! forward pass's [`TriangleState::max_weight`] (weights of the
//! contributions it added, so > 0 exactly where it coloured some pixel).

use rayon::prelude::*;

use crate::Camera;
use crate::gaussian::RasterSettings;
use crate::triangle::{TriangleState, Triangles3};

/// See the module docs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleStats {
    pub importance: Vec<f32>,
    pub inradius: Vec<f32>,
    pub radius: Vec<f32>,
}

/// The statistics of the forward pass `state` of `t` seen from `cam`.
pub fn triangle_stats(
    t: &Triangles3,
    cam: &Camera,
    _s: &RasterSettings,
    state: &TriangleState,
) -> TriangleStats {
    let n = t.len();
    let proj = &state.proj;
    let importance = if state.max_weight.len() == n {
        state.max_weight.clone()
    } else {
        vec![0.0; n]
    };
    let mut inradius = vec![0.0f32; n];
    let mut radius = vec![0.0f32; n];
    let sizes: Vec<(usize, f32)> = proj
        .par_iter()
        .map(|p| {
            let v = &t.vertices[p.id as usize];
            let c: [f64; 3] = std::array::from_fn(|k| (v[0][k] + v[1][k] + v[2][k]) as f64 / 3.0);
            let r = cam
                .project(glam::DVec3::from_array(c))
                .map_or(0.0, |(c2, _)| {
                    v.iter()
                        .filter_map(|q| cam.project(glam::DVec3::from_array(q.map(f64::from))))
                        .map(|(q2, _)| (q2 - c2).length())
                        .fold(0.0f64, f64::max)
                });
            (p.id as usize, r as f32)
        })
        .collect();
    for (p, (id, r)) in proj.iter().zip(sizes) {
        inradius[id] = -p.phi_s;
        radius[id] = r;
    }
    TriangleStats {
        importance,
        inradius,
        radius,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::rgb_to_sh;
    use crate::testutil::test_camera;
    use crate::triangle::rasterize;

    fn tri(z: f32, half: f32) -> [[f32; 3]; 3] {
        [[-half, -half, z], [half, -half, z], [0.0, half, z]]
    }

    /// A hard opaque triangle in front has importance 0.99 (α is capped, T =
    /// 1); a half-opaque one of the same outline right behind gets 0.5·0.01; a triangle
    /// outside the view gets 0. Inradius and radius match the projection.
    #[test]
    fn importance_inradius_radius() {
        let cam = test_camera(64, 64, 64.0);
        let t = Triangles3 {
            vertices: vec![tri(2.0, 0.5), tri(2.5, 0.625), tri(-3.0, 0.5)],
            sigmas: vec![0.0; 3],
            opacities: vec![1.0, 0.5, 1.0],
            sh: vec![[rgb_to_sh(0.5); 3]; 3],
            sh_degree: 0,
        };
        let s = RasterSettings::default();
        let (_, st) = rasterize(&t, &cam, &s);
        let stats = triangle_stats(&t, &cam, &s, &st);
        assert!(
            (stats.importance[0] - 0.99).abs() < 1e-6,
            "{:?}",
            stats.importance
        );
        assert!((stats.importance[1] - 0.5 * 0.01).abs() < 1e-6);
        assert_eq!(stats.importance[2], 0.0);
        // the projected triangle: (±16, ±16) px about the centre, apex at +16
        // → vertices (16,16),(48,16),(32,48) relative; side a = b = √(16²+32²),
        // c = 32; area 512; inradius = 2·area/perimeter
        let a = (16.0f64 * 16.0 + 32.0 * 32.0).sqrt();
        let r = 2.0 * 512.0 / (2.0 * a + 32.0);
        assert!(
            (stats.inradius[0] as f64 - r).abs() < 1e-3,
            "{}",
            stats.inradius[0]
        );
        // 3-D centroid projects to y = −16/3 px from the centre: R = distance
        // to the apex, 16 + 16/3 (the lower corners are 19.2 px away)
        let big_r = 16.0 + 16.0 / 3.0f64;
        assert!(
            (stats.radius[0] as f64 - big_r).abs() < 1e-3,
            "{}",
            stats.radius[0]
        );
        assert_eq!(stats.radius[2], 0.0);
    }
}
