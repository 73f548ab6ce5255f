//! The two quick alternatives to level-set sampling for turning Gaussians
//! into oriented points (`splat2points --method centers | depth`).
//!
//! - [`centers`]: the centres of the Gaussians with opacity above a
//!   threshold; normal = the shortest axis, signed toward the majority of the
//!   cameras that see the Gaussian (at the pixel of its centre, the diamond
//!   z-buffer of the level-set method holds nothing nearer than its depth
//!   minus its own 2σ reach), or of all cameras with the centre in view when
//!   none sees it; colour = the DC colour C0·f_dc + 0.5.
//! - [`depth_points`]: per camera, the alpha-blended median depth map is
//!   back-projected through pixel centres; the normal at a pixel is the
//!   cross product of the central differences of the back-projected points
//!   (as 2DGS derives normals from depth), turned toward the camera; pixels
//!   without depth or on a depth edge (a neighbour missing) are skipped;
//!   colour from a DC-only render; a seeded random subset of at most
//!   ⌊max/N⌋ + 1 points per view.
//!
//! [`splat_to_points`] runs the method `splat2points` picks: one of these
//! or SuGaR's level-set sampling ([`crate::geom::surface_points::levelset`]).

use rand::RngExt;
use rayon::prelude::*;
use splatkit_render::gaussian::{self, Filter2d, Gaussians3, RasterSettings, RenderOutput};
use splatkit_render::sh::sh_to_rgb;

use crate::geom::surface_points::diamond_zbuffer::diamond_zbuffer;
use crate::geom::surface_points::levelset::{
    LevelPoints, LevelsetOptions, opaque_dc_subset, sample_levelset,
};
use crate::model::Camera;
use crate::model::rig::back_project;
use crate::model::rng;

/// How [`splat_to_points`] makes points; `near` is the near plane of the
/// renders (camera z, scene units).
#[derive(Clone, Debug)]
pub enum PointMethod {
    /// SuGaR's level-set sampling ([`sample_levelset`]) with these options.
    Levelset(LevelsetOptions),
    /// [`centers`] of the Gaussians with opacity above `min_opacity`.
    Centers { min_opacity: f32, near: f64 },
    /// [`depth_points`]: at most about `max_points`, chosen with `seed`,
    /// rendered with the 2-D filter `filter_2d`.
    Depth {
        max_points: usize,
        seed: u64,
        near: f64,
        filter_2d: Filter2d,
    },
}

/// Oriented, coloured points of `g` seen from `cams` by `method`;
/// `progress(i)` is called after each view the level-set and depth
/// methods sample. Errors only from the level-set sampling (no camera).
pub fn splat_to_points(
    g: &Gaussians3,
    cams: &[Camera],
    method: &PointMethod,
    progress: impl FnMut(usize),
) -> crate::Result<LevelPoints> {
    Ok(match method {
        PointMethod::Levelset(opts) => sample_levelset(g, cams, opts, progress)?,
        PointMethod::Centers { min_opacity, near } => centers(g, cams, *min_opacity, *near),
        PointMethod::Depth {
            max_points,
            seed,
            near,
            filter_2d,
        } => depth_points(g, cams, *max_points, *seed, *near, *filter_2d, progress),
    })
}

/// Gaussian centres with opacity > `min_opacity` (see the module docs).
pub fn centers(g: &Gaussians3, cams: &[Camera], min_opacity: f32, near: f64) -> LevelPoints {
    let nc = (g.sh_degree + 1) * (g.sh_degree + 1);
    let (keep, kept) = opaque_dc_subset(g, min_opacity);
    // the shortest axis of each kept Gaussian
    let axes: Vec<glam::DVec3> = (0..kept.len())
        .into_par_iter()
        .map(|i| {
            let s = kept.scales[i];
            let k = (0..3)
                .min_by(|&a, &b| s[a].total_cmp(&s[b]))
                .expect("3 axes");
            let r = kept.rotations[i].map(f64::from);
            let q = glam::DQuat::from_xyzw(r[1], r[2], r[3], r[0]);
            let q = if q.length() > 0.0 {
                q.normalize()
            } else {
                glam::DQuat::IDENTITY
            };
            q * [glam::DVec3::X, glam::DVec3::Y, glam::DVec3::Z][k]
        })
        .collect();
    // votes (seen, in view) per Gaussian: +1 when the axis faces the camera
    let mut votes = CenterVotes::new(kept.len());
    for cam in cams {
        let z = diamond_zbuffer(&kept, cam, near);
        let w = cam.width as usize;
        votes.add(
            (0..kept.len())
                .into_par_iter()
                .map(|i| {
                    let mu = glam::DVec3::from(kept.means[i].map(f64::from));
                    let Some((px, d)) = project_in_frame(cam, mu, near) else {
                        return (0.0, 0.0);
                    };
                    let sign = if axes[i].dot(cam.center() - mu) >= 0.0 {
                        1.0
                    } else {
                        -1.0
                    };
                    let o = px.y as usize * w + px.x as usize;
                    // nothing in front of it beyond its own diamond's reach
                    let reach =
                        2.0 * kept.scales[i].iter().fold(0.0f32, |m, v| m.max(v.abs())) as f64;
                    let visible = z[o].is_some_and(|(depth, _)| depth as f64 >= d - reach);
                    (if visible { sign } else { 0.0 }, sign)
                })
                .collect(),
        );
    }
    votes.points(&keep, &axes, &g.means, &g.sh, nc)
}

/// Pixel and depth of `mu` in `cam` when its centre lies in the image and
/// beyond the near plane.
pub(super) fn project_in_frame(
    cam: &Camera,
    mu: glam::DVec3,
    near: f64,
) -> Option<(glam::DVec2, f64)> {
    let (px, d) = cam.project(mu)?;
    let inside = d > near
        && px.x >= 0.0
        && px.y >= 0.0
        && px.x < cam.width as f64
        && px.y < cam.height as f64;
    inside.then_some((px, d))
}

/// The orientation votes of the centre methods: per kept splat, the sum of
/// its votes over the views that see it and over all views with its centre
/// in the image. Integer votes (±1) are exact in f64.
pub(super) struct CenterVotes {
    seen: Vec<f64>,
    in_view: Vec<f64>,
}

impl CenterVotes {
    pub(super) fn new(n: usize) -> Self {
        CenterVotes {
            seen: vec![0.0; n],
            in_view: vec![0.0; n],
        }
    }

    /// Adds one view's (seen, in view) vote per kept splat.
    pub(super) fn add(&mut self, votes: Vec<(f64, f64)>) {
        for (k, (a, b)) in votes.into_iter().enumerate() {
            self.seen[k] += a;
            self.in_view[k] += b;
        }
    }

    /// The points: kept splat `keep[k]`'s centre, its axis `axes[k]` turned
    /// to the side its votes chose (the seen votes, or the in-view votes
    /// when no view sees it), its DC colour (`sh` holds `nc` coefficients
    /// per splat).
    pub(super) fn points(
        &self,
        keep: &[usize],
        axes: &[glam::DVec3],
        means: &[[f32; 3]],
        sh: &[[f32; 3]],
        nc: usize,
    ) -> LevelPoints {
        let mut out = LevelPoints::default();
        for (k, &i) in keep.iter().enumerate() {
            let vote = if self.seen[k] != 0.0 {
                self.seen[k]
            } else {
                self.in_view[k]
            };
            let n = if vote < 0.0 { -axes[k] } else { axes[k] };
            out.positions.push(means[i]);
            out.normals.push([n.x as f32, n.y as f32, n.z as f32]);
            out.colors
                .push(sh[i * nc].map(|v| (sh_to_rgb(v).clamp(0.0, 1.0) * 255.0).round() as u8));
            out.level.push(0.0);
            out.camera.push(u32::MAX);
        }
        out
    }
}

/// Back-projected median-depth maps (see the module docs).
pub fn depth_points(
    g: &Gaussians3,
    cams: &[Camera],
    max_points: usize,
    seed: u64,
    near: f64,
    filter_2d: Filter2d,
    progress: impl FnMut(usize),
) -> LevelPoints {
    let dc = g.dc_only();
    let s = RasterSettings {
        background: [0.0; 3],
        near,
        filter_2d,
        ..Default::default()
    };
    depth_points_of(
        |cam| gaussian::render(&dc, cam, &s),
        cams,
        max_points,
        seed,
        false,
        progress,
    )
}

/// The core of [`depth_points`] for any splat renderer: `render(cam)` gives
/// a view (colour on black, median depth, alpha), whose opaque median depth
/// (alpha ≥ 0.5) is back-projected with depth-gradient normals (or, with
/// `rendered_normals`, the render's own blended normal taken to world axes)
/// and subsampled as the module docs say. Normals are turned toward the
/// camera.
pub fn depth_points_of(
    render: impl Fn(&Camera) -> RenderOutput,
    cams: &[Camera],
    max_points: usize,
    seed: u64,
    rendered_normals: bool,
    mut progress: impl FnMut(usize),
) -> LevelPoints {
    let per_view = max_points / cams.len().max(1) + 1;
    let mut out = LevelPoints::default();
    for (ci, cam) in cams.iter().enumerate() {
        let img = render(cam);
        let (w, h) = (img.width, img.height);
        let d = &img.opaque_median_depth();
        let eye = cam.center();
        let pts: Vec<Option<([f64; 3], [f64; 3])>> = (0..w * h)
            .into_par_iter()
            .map(|o| {
                let (x, y) = (o % w, o / w);
                if x == 0 || y == 0 || x + 1 == w || y + 1 == h || d[o] <= 0.0 {
                    return None;
                }
                let nb = [o - 1, o + 1, o - w, o + w];
                if nb.iter().any(|&k| d[k] <= 0.0) {
                    return None;
                }
                let p = |k: usize| back_project(cam, k % w, k / w, d[k] as f64).to_array();
                let (l, r, u, b) = (p(o - 1), p(o + 1), p(o - w), p(o + w));
                let dx = [r[0] - l[0], r[1] - l[1], r[2] - l[2]];
                let dy = [b[0] - u[0], b[1] - u[1], b[2] - u[2]];
                let mut n = if rendered_normals {
                    // camera to world axes: Rᵀ·n
                    let c = glam::DVec3::from(img.normal[o].map(f64::from));
                    (cam.rotation.transpose() * c).to_array()
                } else {
                    [
                        dx[1] * dy[2] - dx[2] * dy[1],
                        dx[2] * dy[0] - dx[0] * dy[2],
                        dx[0] * dy[1] - dx[1] * dy[0],
                    ]
                };
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                if !(len > 0.0 && len.is_finite()) {
                    return None;
                }
                n = n.map(|c| c / len);
                let x3 = p(o);
                let to = [eye.x - x3[0], eye.y - x3[1], eye.z - x3[2]];
                if n[0] * to[0] + n[1] * to[1] + n[2] * to[2] < 0.0 {
                    n = n.map(|c| -c);
                }
                Some((x3, n))
            })
            .collect();
        let mut valid: Vec<usize> = (0..pts.len()).filter(|&o| pts[o].is_some()).collect();
        let mut rng = rng::golden_stream(seed, ci as u64);
        let take = per_view.min(valid.len());
        for k in 0..take {
            let j = rng.random_range(k..valid.len());
            valid.swap(k, j);
        }
        for &o in &valid[..take] {
            let (x, n) = pts[o].expect("valid");
            out.positions.push(x.map(|v| v as f32));
            out.normals.push(n.map(|v| v as f32));
            out.colors
                .push(img.rgb[o].map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8));
            out.level.push(0.0);
            out.camera.push(ci as u32);
        }
        progress(ci);
    }
    out
}
