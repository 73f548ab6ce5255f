//! Oriented, coloured points of 2DGS surfels (`splat2points` on a 2DGS
//! PLY), the counterparts of [`crate::geom::surface_points::splat_points`]'s
//! two quick methods. SuGaR's level-set sampling does not apply: a surfel
//! is flat, so its density has no level set around a surface (it is a disc
//! of zero thickness), and 2DGS's own surface is its rendered depth.
//!
//! - [`surfel_depth_points`] (`--method depth`, the default for surfels):
//!   per camera, the surfels are rendered with 2DGS's rasteriser
//!   ([`splatkit_render::surfel`], DC colour, black background) and the
//!   median depth where the alpha reaches 0.5 is back-projected through the
//!   pixel centres as for Gaussians ([`depth_points_of`]), but with the
//!   rendered normal (the alpha-blended disc normals, 2DGS's `rend_normal`,
//!   taken to world axes and turned toward the camera) instead of the
//!   depth gradient, which jumps where the front disc changes. The points
//!   lie on the surface 2DGS's TSDF fusion meshes (its `surf_depth` at depth
//!   ratio 1).
//! - [`surfel_centers`] (`--method centers`): the centre of each surfel with
//!   opacity above a threshold, its normal the disc normal (the rotation's
//!   third column, 2DGS's `R[:, 2]`) signed by the sum, over the cameras
//!   that see the centre (at the pixel of the centre, the rendered median
//!   depth is 0 or not nearer than its depth minus 3 × its larger scale,
//!   the rasteriser's cutoff), of the cosine between the normal and the
//!   direction to the camera (so grazing views weigh little), or over all
//!   cameras with the centre in view when none sees it; colour = the DC
//!   colour C0·f_dc + 0.5.

use rayon::prelude::*;
use splatkit_render::surfel::{self, SurfelSettings, Surfels2};

use crate::geom::surface_points::levelset::LevelPoints;
use crate::geom::surface_points::splat_points::{
    CenterVotes, PointMethod, depth_points_of, project_in_frame,
};
use crate::model::Camera;
use crate::{Error, Result};

/// Oriented, coloured points of `s` (activated values) seen from `cams` by
/// `method`; `progress(i)` is called after each view the depth method
/// renders. [`PointMethod::Levelset`] is refused (see the module docs).
pub fn surfels_to_points(
    s: &Surfels2,
    cams: &[Camera],
    method: &PointMethod,
    progress: impl FnMut(usize),
) -> Result<LevelPoints> {
    Ok(match method {
        PointMethod::Levelset(_) => {
            return Err(Error::invalid(
                "SuGaR's level-set sampling needs 3D Gaussians; 2DGS surfels are flat discs \
                 with no density level set: use --method depth (their rendered surface) or \
                 --method centers",
            ));
        }
        PointMethod::Centers { min_opacity, near } => surfel_centers(s, cams, *min_opacity, *near),
        PointMethod::Depth {
            max_points,
            seed,
            near,
            ..
        } => surfel_depth_points(s, cams, *max_points, *seed, *near, progress),
    })
}

fn settings(near: f64) -> SurfelSettings {
    SurfelSettings {
        background: [0.0; 3],
        near,
        ..SurfelSettings::default()
    }
}

/// Back-projected surfel depth (see the module docs): at most about
/// `max_points` in all (⌊max/N⌋ + 1 per view), chosen with `seed`.
pub fn surfel_depth_points(
    s: &Surfels2,
    cams: &[Camera],
    max_points: usize,
    seed: u64,
    near: f64,
    progress: impl FnMut(usize),
) -> LevelPoints {
    let dc = s.dc_only();
    let st = settings(near);
    depth_points_of(
        |cam| surfel::render(&dc, cam, &st),
        cams,
        max_points,
        seed,
        true,
        progress,
    )
}

/// Unit disc normal of surfel `i`: the third column of its normalised
/// rotation (identity for a zero or non-finite quaternion).
fn disc_normal(s: &Surfels2, i: usize) -> glam::DVec3 {
    let r = s.rotations[i].map(f64::from);
    let q = glam::DQuat::from_xyzw(r[1], r[2], r[3], r[0]);
    let len = q.length();
    let q = if len > 0.0 && len.is_finite() {
        q / len
    } else {
        glam::DQuat::IDENTITY
    };
    q * glam::DVec3::Z
}

/// Surfel centres with opacity > `min_opacity` (see the module docs).
pub fn surfel_centers(s: &Surfels2, cams: &[Camera], min_opacity: f32, near: f64) -> LevelPoints {
    let keep: Vec<usize> = (0..s.len())
        .filter(|&i| s.opacities[i] > min_opacity && s.means[i].iter().all(|v| v.is_finite()))
        .collect();
    let axes: Vec<glam::DVec3> = keep.par_iter().map(|&i| disc_normal(s, i)).collect();
    let dc = s.dc_only();
    let st = settings(near);
    // votes (seen, in view) per kept surfel: the cosine between the normal
    // and the direction to the camera (a grazing view, which cannot tell the
    // disc's sides apart, weighs little)
    let mut votes = CenterVotes::new(keep.len());
    for cam in cams {
        let depth = surfel::render(&dc, cam, &st).opaque_median_depth();
        let w = cam.width as usize;
        votes.add(
            keep.par_iter()
                .zip(&axes)
                .map(|(&i, axis)| {
                    let mu = glam::DVec3::from(s.means[i].map(f64::from));
                    let Some((px, d)) = project_in_frame(cam, mu, near) else {
                        return (0.0, 0.0);
                    };
                    let cos = axis.dot((cam.center() - mu).normalize_or_zero());
                    let z = depth[px.y as usize * w + px.x as usize] as f64;
                    let reach =
                        surfel::CUTOFF * s.scales[i][0].abs().max(s.scales[i][1].abs()) as f64;
                    let visible = z <= 0.0 || z >= d - reach;
                    (if visible { cos } else { 0.0 }, cos)
                })
                .collect(),
        );
    }
    let nc = (s.sh_degree + 1) * (s.sh_degree + 1);
    votes.points(&keep, &axes, &s.means, &s.sh, nc)
}
