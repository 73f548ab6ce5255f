//! In-memory scene types, and the plain value types shared by the layers
//! (similarity transform, crop volume, seeded generator). Storage is f32 (as
//! in the files); algorithms accumulate in f64 where precision matters.

pub mod attributes;
pub mod bound;
pub mod camera;
pub mod crop;
pub mod filter3d;
pub mod finite;
pub mod gaussians;
pub mod mask;
pub mod mesh;
pub mod obs_mask;
pub mod optim_state;
pub mod orbit;
pub mod point_cloud;
pub mod rig;
pub mod rng;
pub mod scene;
pub mod surfels;
pub mod texture;
pub mod transform;
pub mod triangle_soup;
pub mod view;

/// SH coefficients of item `i`, coefficient-major with the DC term at k = 0,
/// from a DC array and a coefficient-major `rest` array with `k` higher-order
/// coefficients per channel (the layout of [`Gaussians`], [`Surfels`] and
/// [`TriangleSoup`]).
pub fn sh_coeffs_of(dc: &[[f32; 3]], rest: &[f32], k: usize, i: usize) -> Vec<[f32; 3]> {
    let mut out = Vec::with_capacity(k + 1);
    out.push(dc[i]);
    out.extend(
        rest[i * k * 3..(i + 1) * k * 3]
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]]),
    );
    out
}

/// Every item's SH coefficients truncated to the first `keep` (DC, then
/// the rest in order; `keep` at most k + 1), coefficient-major as the
/// rasterisers take them (`keep` rows per item), built in parallel.
pub fn sh_rows(dc: &[[f32; 3]], rest: &[f32], k: usize, keep: usize) -> Vec<[f32; 3]> {
    use rayon::prelude::*;
    let keep = keep.clamp(1, k + 1);
    let mut sh = vec![[0.0f32; 3]; dc.len() * keep];
    sh.par_chunks_mut(keep).enumerate().for_each(|(i, c)| {
        c[0] = dc[i];
        for (kk, ck) in c.iter_mut().enumerate().skip(1) {
            let o = (i * k + kk - 1) * 3;
            *ck = [rest[o], rest[o + 1], rest[o + 2]];
        }
    });
    sh
}

pub use attributes::{Column, Element, Extras, Property, ScalarData, ScalarType};
pub use bound::BoundGaussians;
pub use camera::{Camera, CameraModel};
pub use crop::{Axis, CropVolume};
pub use gaussians::Gaussians;
pub use mask::Mask;
pub use mesh::Mesh;
pub use obs_mask::ObsMask;
pub use orbit::OrbitSpec;
pub use point_cloud::PointCloud;
pub use scene::{Scene, SceneKind};
pub use surfels::Surfels;
pub use texture::Texture;
pub use transform::Similarity;
pub use triangle_soup::TriangleSoup;
pub use view::View;
