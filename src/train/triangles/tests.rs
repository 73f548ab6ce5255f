use glam::DVec3;

use super::init::{InitParams, init_triangles};
use super::*;
use crate::model::rng::seeded;
pub use crate::testing::sphere_points;
use crate::testing::{cameras_around, textured_photos, uv_sphere};
use crate::train::schedule::split;

/// λ / mean(area): value and vertex gradient against central differences
/// (f64 inside, f32 vertices: 1e-3 relative at h = 1e-3).
#[test]
fn size_loss_gradient() {
    let tris = vec![
        [[0.0, 0.0, 0.0], [1.0, 0.2, 0.0], [0.1, 0.8, 0.3]],
        [[0.5, 0.5, 0.5], [0.9, 0.1, 0.4], [0.2, 0.7, 1.0]],
    ];
    let lambda = 0.3;
    let mut g = vec![[[0.0f32; 3]; 3]; 2];
    let v = size_loss(&tris, lambda, &mut g);
    let area = |t: &[[f32; 3]; 3]| {
        let p = t.map(|x| DVec3::from_array(x.map(f64::from)));
        0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
    };
    let mean = (area(&tris[0]) + area(&tris[1])) / 2.0;
    assert!((v - lambda / mean).abs() < 1e-9);
    let h = 1e-3;
    for t in 0..2 {
        for k in 0..3 {
            for j in 0..3 {
                let mut a = tris.clone();
                let mut b = tris.clone();
                a[t][k][j] += h as f32;
                b[t][k][j] -= h as f32;
                let mut sink = vec![[[0.0f32; 3]; 3]; 2];
                let fd = (size_loss(&a, lambda, &mut sink) - size_loss(&b, lambda, &mut sink))
                    / (2.0 * h);
                let an = g[t][k][j] as f64;
                assert!(
                    (fd - an).abs() < 1e-3 * an.abs().max(1e-2),
                    "{t} {k} {j}: {fd} vs {an}"
                );
            }
        }
    }
}

/// Training on the generated sphere at 64² from 24 cameras raises the
/// held-out PSNR well above the initial one, densification grows the
/// soup, and the result depends only on the seed.
#[test]
fn trains_on_a_generated_sphere() {
    let truth = uv_sphere(48, 1.0);
    let cams = cameras_around(24, 3.5, 64, 80.0);
    let views = textured_photos(&truth, &cams);
    let (train, test) = split(views.len(), 8);
    let soup = init_triangles(
        &sphere_points(800, 3),
        &InitParams::default(),
        &mut seeded(1),
    )
    .unwrap();
    let mut p = TriangleParams::preset(Preset::Outdoor, 1500);
    p.seed = 5;
    p.mcmc.max_shapes = 4000;
    let mut t = TriangleTrainer::new(soup, p);
    let e0 = t.evaluate(&views, &test);
    let n0 = t.soup.len();
    let start = std::time::Instant::now();
    for _ in 0..1500 {
        t.step(&views, &train);
    }
    let e1 = t.evaluate(&views, &test);
    eprintln!(
        "triangles: PSNR {:.2} -> {:.2} dB, count {n0} -> {}, {:.1} s",
        e0.psnr,
        e1.psnr,
        t.soup.len(),
        start.elapsed().as_secs_f64()
    );
    assert!(e1.psnr > e0.psnr + 8.0, "{} -> {}", e0.psnr, e1.psnr);
    assert!(t.soup.len() > n0);
}

/// `sh_degree` caps the trained SH bands: past the iterations where the
/// default run has turned on bands 1–3, a run capped at 0 renders at degree
/// 0 and its higher bands are still exactly zero (their gradients are never
/// taken), while the uncapped run has trained them.
#[test]
fn sh_degree_caps_the_trained_bands() {
    let truth = uv_sphere(24, 1.0);
    let cams = cameras_around(8, 3.5, 24, 30.0);
    let views = textured_photos(&truth, &cams);
    let train: Vec<usize> = (0..views.len()).collect();
    let soup = init_triangles(
        &sphere_points(60, 3),
        &InitParams::default(),
        &mut seeded(1),
    )
    .unwrap();
    // 300 iterations: one band per at(1000) = 10 iterations
    for (cap, want) in [(0, 0), (3, 3)] {
        let mut p = TriangleParams::preset(Preset::Outdoor, 300);
        p.sh_degree = cap;
        let mut t = TriangleTrainer::new(soup.clone(), p);
        for _ in 0..40 {
            t.step(&views, &train);
        }
        assert_eq!(t.active_degree(), want);
        assert_eq!(t.model().active_sh_degree, want);
        let zero = t.soup.sh_rest.iter().all(|&v| v == 0.0);
        assert_eq!(zero, cap == 0, "cap {cap}: rest bands all zero: {zero}");
    }
}
