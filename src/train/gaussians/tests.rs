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

/// The SuGaR phases run: after the 9,000 milestone every Gaussian has
/// α ≥ 0.5 at the prune, and each regulariser yields a finite loss.
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
        for _ in 0..1200 {
            last = t.step(&views, &train);
            if t.iteration() == t.params.at(9_000) {
                assert!(t.model.opacity_logits.iter().all(|&o| o >= 0.0));
                assert!(!t.model.is_empty());
            }
        }
        assert!(
            last.regularizer.is_finite() && last.regularizer > 0.0,
            "{mode:?}: {last:?}"
        );
        assert!(t.model.means.iter().flatten().all(|v| v.is_finite()));
    }
}
