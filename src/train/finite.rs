//! Finiteness guards of the optimisation loops (`train triangles`,
//! `train gaussians`, `refine`): a run whose loss or parameters become NaN
//! or infinite stops with an error instead of writing NaN models.
//!
//! What is checked when (the ops drive it through
//! [`super::trainer::Trainer::step_checked`] / `check_finite` and
//! [`super::refine::Refiner::step_checked`] / `check_finite`):
//! - **every iteration**: the step's loss (one comparison). A step whose
//!   loss is not finite applies no update, so the parameters are still
//!   those that made it non-finite; they are then scanned to name the first
//!   non-finite one (an infinite colour, say). The rasterisers clamp a NaN
//!   colour or opacity to a finite value, so a NaN parameter often leaves
//!   the loss finite, hence:
//! - **before every held-out evaluation and once at the end** (before
//!   anything is written): every parameter, in one branch-free pass over the
//!   model (O(parameters), far cheaper than the evaluation's renders). This
//!   catches a NaN the loss did not show, and a primitive that went NaN
//!   where no training view sees it.
//!
//! The error names the iteration (1-based: the step that failed, as in
//! `point_cloud/iteration_N`) and the value, and says that nothing was
//! written: the op returns it as an error, so the output transaction
//! commits nothing and the output folder, with any earlier checkpoint (the
//! one `--resume` started from), is left as it was.

/// One parameter array of a model, for [`first_non_finite`].
pub struct Param<'a> {
    /// Optimiser group name (`means`, `sh_dc`, `vertices`, …).
    pub name: &'a str,
    /// What one row is (`Gaussian`, `triangle`, `vertex`).
    pub unit: &'a str,
    /// Values per row (≥ 1).
    pub width: usize,
    /// The values, row-major.
    pub values: &'a [f32],
}

use crate::model::finite::first_non_finite as first_bad;

/// The first non-finite value among `params`, described as
/// `sh_dc of Gaussian 5 (value 1 of 3) is NaN`; `None` when all are finite.
pub fn first_non_finite(params: &[Param]) -> Option<String> {
    params.iter().find_map(|p| {
        let t = first_bad(p.values)?;
        let w = p.width.max(1);
        Some(format!(
            "{} of {} {} (value {} of {w}) is {}",
            p.name,
            p.unit,
            t / w,
            t % w + 1,
            p.values[t]
        ))
    })
}

/// The tail every finiteness error ends with.
pub const NOTHING_WRITTEN: &str =
    "stopped without writing: the output folder and any earlier checkpoint are left as they were";

/// `Err` when `loss` (of the step that made `done` steps in all) is not
/// finite; `scan` names the first non-finite parameter, if any.
pub fn check_loss(
    done: u64,
    loss: f64,
    scan: impl FnOnce() -> Option<String>,
) -> crate::Result<()> {
    if loss.is_finite() {
        return Ok(());
    }
    let why = match scan() {
        Some(p) => format!(" ({p})"),
        None => String::new(),
    };
    Err(crate::Error::invalid(format!(
        "iteration {done}: the loss became {loss}{why}; {NOTHING_WRITTEN}"
    )))
}

/// `Err` when `scan` (the parameters after `done` steps) found a
/// non-finite value.
pub fn check_params(done: u64, scan: Option<String>) -> crate::Result<()> {
    match scan {
        Some(p) => Err(crate::Error::invalid(format!(
            "after iteration {done}, a parameter is not finite: {p}; {NOTHING_WRITTEN}"
        ))),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scan finds the first bad value in any block and describes its
    /// row and position; finite models pass.
    #[test]
    fn scan_names_the_first_bad_value() {
        let mut a = vec![0.5f32; 3 * 2000];
        let b = vec![1.0f32; 10];
        let params = |a: &[f32]| {
            first_non_finite(&[
                Param {
                    name: "means",
                    unit: "Gaussian",
                    width: 3,
                    values: a,
                },
                Param {
                    name: "opacity",
                    unit: "Gaussian",
                    width: 1,
                    values: &b,
                },
            ])
        };
        assert_eq!(params(&a), None);
        a[3 * 1500 + 2] = f32::NEG_INFINITY;
        a[3 * 1700] = f32::NAN;
        assert_eq!(
            params(&a).as_deref(),
            Some("means of Gaussian 1500 (value 3 of 3) is -inf")
        );
        let e = check_params(7, params(&a)).unwrap_err().to_string();
        assert!(
            e.starts_with("after iteration 7, a parameter is not finite: means of Gaussian 1500")
        );
        assert!(e.ends_with(NOTHING_WRITTEN), "{e}");
        // a loss check passes finite losses without scanning
        assert!(check_loss(3, 0.25, || panic!("no scan for a finite loss")).is_ok());
        let e = check_loss(3, f64::NAN, || None).unwrap_err().to_string();
        assert!(
            e.starts_with("iteration 3: the loss became NaN; stopped"),
            "{e}"
        );
    }

    use crate::geom::binding::{BindOptions, bind};
    use crate::model::View;
    use crate::testing::{cameras_around, sphere_points, textured_photos, uv_sphere};
    use crate::train::gaussians::init::init_gaussians;
    use crate::train::gaussians::{GaussianParams, GaussianTrainer};
    use crate::train::refine::{LearningRates, RefineParams, Refiner};
    use crate::train::schedule::{split, view_at};
    use crate::train::trainer::Trainer;
    use crate::train::triangles::init::{InitParams, init_triangles};
    use crate::train::triangles::{Preset, TriangleParams, TriangleTrainer};

    /// Photos of a textured unit sphere from 8 cameras at 32², the train
    /// split, and the camera centre of the view the first step uses
    /// (seed 0).
    fn scene() -> (Vec<View>, Vec<usize>, [f64; 3]) {
        let cams = cameras_around(8, 3.5, 32, 40.0);
        let views = textured_photos(&uv_sphere(24, 1.0), &cams);
        let (train, _) = split(views.len(), 8);
        let first = view_at(&train, 0, 0);
        let eye = views[first].camera.center().to_array();
        (views, train, eye)
    }

    /// The primitive whose centre is nearest the first view's camera: in
    /// front of everything else on the sphere, so that view renders it.
    fn front(centres: impl Iterator<Item = [f64; 3]>, eye: [f64; 3]) -> usize {
        let d = |c: [f64; 3]| (0..3).map(|k| (c[k] - eye[k]).powi(2)).sum::<f64>();
        centres
            .enumerate()
            .min_by(|a, b| d(a.1).total_cmp(&d(b.1)))
            .expect("a primitive")
            .0
    }

    /// An infinite colour on a Gaussian the first view sees makes that
    /// step's loss non-finite: `step_checked` stops at iteration 1 and
    /// names the parameter; the same trainer without it steps on. (A NaN
    /// colour would not do: the rasteriser's `max(colour, 0)` turns it into
    /// 0, which is why the parameter guard exists.) An infinite mean is
    /// found by the parameter guard.
    #[test]
    fn gaussian_training_stops_on_a_nan_parameter() {
        let (views, train, eye) = scene();
        let g = init_gaussians(&sphere_points(300, 3), 1).unwrap();
        let i = front(g.means.iter().map(|m| m.map(f64::from)), eye);
        let fresh = || GaussianTrainer::new(g.clone(), GaussianParams::new(100, None, 3.85));
        let mut ok = fresh();
        assert!(ok.step_checked(&views, &train).is_ok());
        assert!(ok.check_finite().is_ok());
        let mut t = fresh();
        t.model.sh_dc[i][1] = f32::INFINITY;
        let e = t.step_checked(&views, &train).unwrap_err().to_string();
        assert!(e.starts_with("iteration 1: the loss became "), "{e}");
        assert!(
            e.contains(&format!("sh_dc of Gaussian {i} (value 2 of 3) is inf")),
            "{e}"
        );
        assert!(e.ends_with(NOTHING_WRITTEN), "{e}");
        let mut t = fresh();
        t.model.means[7][0] = f32::INFINITY;
        let e = t.check_finite().unwrap_err().to_string();
        assert!(e.starts_with("after iteration 0, a parameter is not finite: means of Gaussian 7 (value 1 of 3) is inf"), "{e}");
    }

    /// The same for Triangle Splatting: an infinite colour on a front
    /// triangle stops the first step; a NaN vertex is found by the
    /// parameter guard.
    #[test]
    fn triangle_training_stops_on_a_non_finite_parameter() {
        let (views, train, eye) = scene();
        let soup = init_triangles(
            &sphere_points(200, 3),
            &InitParams::default(),
            &mut crate::model::rng::seeded(0),
        )
        .unwrap();
        let centre =
            |t: &[[f32; 3]; 3]| std::array::from_fn(|k| (t[0][k] + t[1][k] + t[2][k]) as f64 / 3.0);
        let i = front(soup.triangles.iter().map(centre), eye);
        let params = TriangleParams::preset(Preset::Outdoor, 100);
        let mut t = TriangleTrainer::new(soup.clone(), params.clone());
        t.soup.sh_dc[i] = [f32::INFINITY; 3];
        let e = t.step_checked(&views, &train).unwrap_err().to_string();
        assert!(e.starts_with("iteration 1: the loss became "), "{e}");
        assert!(e.contains(&format!("of triangle {i}")), "{e}");
        let mut t = TriangleTrainer::new(soup, params);
        t.soup.triangles[3][1][2] = f32::NAN;
        let e = t.check_finite().unwrap_err().to_string();
        assert!(
            e.contains("vertices of triangle 3 (value 6 of 9) is NaN"),
            "{e}"
        );
    }

    /// Refinement: an infinite colour on a front Gaussian stops the first
    /// step; a
    /// NaN complex rotation (read as (1, 0), so the render stays finite)
    /// is found by the parameter guard. And an honest blow-up from finite
    /// state: a restored first moment of −3e38 (finite, so the checkpoint
    /// reader takes it) throws the SH DC to +∞ in one Adam step, and
    /// the next step's loss is not finite.
    #[test]
    fn refinement_stops_on_a_non_finite_parameter() {
        let (views, train, eye) = scene();
        let opts = BindOptions {
            per_face: 1,
            thickness: 1e-4,
            sh_degree: 0,
        };
        let b = bind(&uv_sphere(8, 1.0), &opts, None).unwrap();
        let params = RefineParams {
            background: [0.0; 3],
            normal_consistency: 0.1,
            sh_warmup: 1000,
            lr: LearningRates::default(),
            spatial_lr_scale: 1.0,
            seed: 0,
        };
        let means: Vec<[f64; 3]> = (0..b.len())
            .map(|i| crate::geom::binding::mean_of(&b, i))
            .collect();
        let i = front(means.into_iter(), eye);
        let mut r = Refiner::new(b.clone(), params.clone());
        r.model.sh_dc[i][0] = f32::INFINITY;
        let e = r.step_checked(&views, &train).unwrap_err().to_string();
        assert!(e.starts_with("iteration 1: the loss became "), "{e}");
        assert!(e.contains(&format!("sh_dc of Gaussian {i}")), "{e}");
        let mut r = Refiner::new(b.clone(), params.clone());
        r.model.complex[2][1] = f32::NAN;
        assert!(
            r.step_checked(&views, &train).is_ok(),
            "the render ignores it"
        );
        let e = r.check_finite().unwrap_err().to_string();
        assert!(e.starts_with("after iteration 1, a parameter is not finite: complex of Gaussian 2 (value 2 of 2) is NaN"), "{e}");
        // finite but absurd optimiser state, as a checkpoint could hold it
        let mut r = Refiner::new(b, params);
        let (_, mut groups) = r.optimizer_state();
        let dc = groups.iter_mut().find(|g| g.name == "sh_dc").unwrap();
        dc.m.fill(-3e38);
        r.restore(5, groups).unwrap();
        let mut err = None;
        for _ in 0..3 {
            if let Err(e) = r.step_checked(&views, &train) {
                err = Some(e.to_string());
                break;
            }
        }
        let e = err.expect("the blow-up is caught within 3 steps");
        assert!(e.contains("the loss became"), "{e}");
        assert!(e.contains("sh_dc of Gaussian"), "{e}");
    }
}
