//! Colours for freshly bound Gaussians taken from another scene.

use rayon::prelude::*;

use crate::geom::sampling::knn::NnIndex;
use crate::model::Gaussians;
use crate::{Error, Result};

/// Neighbours searched for the highest-weight source Gaussian.
pub const NEIGHBOURS: usize = 16;

/// For each point of `at`, the SH DC coefficients of the source Gaussian
/// that contributes most density there: among the [`NEIGHBOURS`] nearest
/// source centres, the one maximising α·exp(−½ dᵀΣ⁻¹d) (the nearest one
/// when every weight underflows). Source values are activated as 3DGS does
/// (sigmoid opacity, exp scales, normalised quaternion).
pub fn dc_from_gaussians(at: &[[f64; 3]], src: &Gaussians) -> Result<Vec<[f32; 3]>> {
    if src.is_empty() {
        return Err(Error::invalid("the colour source holds no Gaussians"));
    }
    let centres: Vec<[f64; 3]> = src.means.iter().map(|m| m.map(f64::from)).collect();
    let index = NnIndex::new(&centres)?;
    Ok(at
        .par_iter()
        .map(|p| {
            let near = index.k_nearest(p, NEIGHBOURS);
            let mut best = (f64::NEG_INFINITY, near[0]);
            for &j in &near {
                let q = src.quat(j).as_dquat();
                let s = src.scales(j).map(|v| (v as f64).max(1e-12));
                let d = glam::DVec3::from_array(std::array::from_fn(|k| p[k] - centres[j][k]));
                let local = q.inverse() * d;
                let m =
                    (local.x / s[0]).powi(2) + (local.y / s[1]).powi(2) + (local.z / s[2]).powi(2);
                let w = (src.opacity(j) as f64).ln() - 0.5 * m;
                if w > best.0 {
                    best = (w, j);
                }
            }
            src.sh_dc[best.1]
        })
        .collect())
}

/// The SH DC coefficients of `b` recoloured from the photos of `views`
/// ([`rgb_from_views`]; a Gaussian no view sees keeps the colour of its
/// current DC), and how many Gaussians no view saw.
pub fn dc_from_views(
    b: &crate::model::BoundGaussians,
    views: &[crate::model::View],
) -> (Vec<[f32; 3]>, usize) {
    let fallback: Vec<[f32; 3]> = b
        .sh_dc
        .iter()
        .map(|d| d.map(splatkit_render::sh::sh_to_rgb))
        .collect();
    let (rgb, seen) = rgb_from_views(b, views, &fallback);
    let dc = rgb
        .iter()
        .map(|c| c.map(splatkit_render::sh::rgb_to_sh))
        .collect();
    let unseen = seen.iter().filter(|&&s| s == 0).count();
    (dc, unseen)
}

/// For each bound Gaussian, the mean colour of the photos at the pixel its
/// mean projects to, over the views where it is visible: its face is the
/// one the mesh z-buffer (`splatkit_render::mesh`) sees at that pixel.
/// Returns linear RGB in [0, 1] and how many views saw each Gaussian;
/// Gaussians no view sees keep `fallback`.
pub fn rgb_from_views(
    b: &crate::model::BoundGaussians,
    views: &[crate::model::View],
    fallback: &[[f32; 3]],
) -> (Vec<[f32; 3]>, Vec<u32>) {
    let n = b.len();
    let means: Vec<glam::DVec3> = (0..n)
        .map(|i| glam::DVec3::from_array(super::mean_of(b, i)))
        .collect();
    let mut sum = vec![[0.0f64; 3]; n];
    let mut count = vec![0u32; n];
    for v in views {
        let z = splatkit_render::mesh::render(&b.mesh.vertices, &b.mesh.faces, &v.camera, 1e-6);
        let (w, h) = (z.width, z.height);
        let hits: Vec<Option<[f32; 3]>> = means
            .par_iter()
            .enumerate()
            .map(|(i, m)| {
                let (px, _) = v.camera.project(*m)?;
                if !(px.x >= 0.0 && px.y >= 0.0) {
                    return None;
                }
                let (x, y) = (px.x as usize, px.y as usize);
                if x >= w || y >= h {
                    return None;
                }
                let o = y * w + x;
                (z.face[o] as usize == b.face_of(i)).then(|| v.image[o])
            })
            .collect();
        for (i, hit) in hits.into_iter().enumerate() {
            if let Some(c) = hit {
                for k in 0..3 {
                    sum[i][k] += c[k] as f64;
                }
                count[i] += 1;
            }
        }
    }
    let rgb = (0..n)
        .map(|i| {
            if count[i] == 0 {
                fallback[i]
            } else {
                sum[i].map(|s| (s / count[i] as f64) as f32)
            }
        })
        .collect();
    (rgb, count)
}
