use super::init::init_gaussians;
use super::*;
use crate::testing::{cameras_around, textured_photos, uv_sphere};
use crate::train::schedule::split;
use crate::train::triangles::tests::sphere_points;

fn scene(n_cams: usize, size: u32) -> Vec<View> {
    let truth = uv_sphere(48, 1.0);
    let cams = cameras_around(n_cams, 3.5, size, size as f64 * 1.25);
    textured_photos(&truth, &cams)
}

/// 3DGS on the generated sphere at 64²: the held-out PSNR rises by more
/// than 8 dB in 600 iterations and density control adds Gaussians.
#[test]
fn trains_on_a_generated_sphere() {
    let views = scene(24, 64);
    let (train, test) = split(views.len(), 8);
    let g = init_gaussians(&sphere_points(800, 3), 3).unwrap();
    let mut p = GaussianParams::new(600, None, 3.85);
    p.seed = 2;
    let mut t = GaussianTrainer::new(g, p);
    let e0 = t.evaluate(&views, &test);
    for _ in 0..600 {
        t.step(&views, &train);
    }
    let e1 = t.evaluate(&views, &test);
    eprintln!(
        "gaussians: PSNR {:.2} -> {:.2} dB, {} Gaussians",
        e0.psnr,
        e1.psnr,
        t.model.len()
    );
    assert!(e1.psnr > e0.psnr + 8.0, "{} -> {}", e0.psnr, e1.psnr);
    assert!(t.model.len() > 800);
}

/// The SuGaR phases run: the prune due after the 9,000 milestone (made at
/// the start of the next iteration, so the model evaluated at 9,000 is the
/// one before it) keeps exactly the Gaussians of α ≥ 0.5 at that moment
/// (logit ≥ 0; all of them if none is), and each regulariser yields a
/// finite loss.
#[test]
fn sugar_phases_prune_and_regularize() {
    let views = scene(16, 32);
    let (train, _) = split(views.len(), 8);
    for mode in [
        Regularize::Density,
        Regularize::Sdf,
        Regularize::DnConsistency,
    ] {
        let g = init_gaussians(&sphere_points(300, 3), 3).unwrap();
        let mut p = GaussianParams::new(1200, Some(mode), 3.85);
        p.samples = 2000;
        let mut t = GaussianTrainer::new(g, p);
        let mut last = StepStats::default();
        let at = t.params.at(9_000);
        let mut due = None;
        for _ in 0..1200 {
            last = t.step(&views, &train);
            if t.iteration() == at {
                let o = &t.model.opacity_logits;
                let kept = o.iter().filter(|&&v| v >= 0.0).count();
                due = Some((o.len(), if kept > 0 { kept } else { o.len() }));
            }
        }
        let (before, after) = due.expect("the run passes the 9,000 milestone");
        let prune: Vec<_> = t.edits.iter().filter(|e| e.strategy == "sugar").collect();
        assert_eq!(prune.len(), 1, "{mode:?}");
        assert_eq!(
            (prune[0].iteration, prune[0].before, prune[0].after),
            (at, before, after),
            "{mode:?}"
        );
        assert!(after > 0);
        assert!(
            last.regularizer.is_finite() && last.regularizer > 0.0,
            "{mode:?}: {last:?}"
        );
        assert!(t.model.means.iter().flatten().all(|v| v.is_finite()));
    }
}

/// `sh_degree` caps the trained SH bands: past the iterations where the
/// default run has turned on bands 1–3, a run capped at 0 renders at degree
/// 0 and its higher bands are still exactly zero, while the uncapped run
/// has trained them.
#[test]
fn sh_degree_caps_the_trained_bands() {
    let views = scene(8, 24);
    let train: Vec<usize> = (0..views.len()).collect();
    let g = init_gaussians(&sphere_points(60, 3), 3).unwrap();
    // 300 iterations: one band per at(1000) = 10 iterations
    for (cap, want) in [(0, 0), (3, 3)] {
        let mut p = GaussianParams::new(300, None, 3.85);
        p.sh_degree = cap;
        let mut t = GaussianTrainer::new(g.clone(), p);
        for _ in 0..40 {
            t.step(&views, &train);
        }
        assert_eq!(t.active_degree(), want);
        let zero = t.model.sh_rest.iter().all(|&v| v == 0.0);
        assert_eq!(zero, cap == 0, "cap {cap}: rest bands all zero: {zero}");
    }
}
