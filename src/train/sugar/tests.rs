use glam::{DMat3, DVec3};
use rand::RngExt;

use super::*;
use crate::model::gaussians::logit;
use crate::model::rng::seeded;
use crate::model::{Camera, Gaussians};

/// Camera at the origin looking down +z (OpenCV axes), 32×24 pixels.
fn camera() -> Camera {
    Camera::pinhole(
        "t",
        32,
        24,
        30.0,
        30.0,
        16.0,
        12.0,
        DMat3::IDENTITY,
        DVec3::ZERO,
    )
}

/// `n` random flat-ish Gaussians in front of [`camera`]: centres in
/// [−0.6, 0.6]² × [3.4, 4.6], one short axis (0.04–0.1) and two long ones
/// (0.2–0.45), random unnormalised quaternions, opacities in `alpha`.
fn random_gaussians(n: usize, seed: u64, alpha: (f32, f32)) -> Gaussians {
    let mut r = seeded(seed);
    let mut u = |a: f32, b: f32| r.random_range(a..b);
    let mut g = Gaussians::default();
    for _ in 0..n {
        g.means.push([u(-0.6, 0.6), u(-0.6, 0.6), u(3.4, 4.6)]);
        let short = u(0.0, 3.0) as usize % 3;
        let ls: [f32; 3] = std::array::from_fn(|k| {
            if k == short {
                u(0.04, 0.1).ln()
            } else {
                u(0.2, 0.45).ln()
            }
        });
        g.log_scales.push(ls);
        g.rotations
            .push([u(0.3, 1.5), u(-1.0, 1.0), u(-1.0, 1.0), u(-1.0, 1.0)]);
        g.opacity_logits.push(logit(u(alpha.0, alpha.1)));
    }
    g.sh_dc = vec![[0.0; 3]; n];
    g
}

/// Checks `analytic` against central differences of `f` over the f32
/// parameters `base`, using the perturbation actually stored in f32 (so the
/// f32 rounding of the parameter does not enter). With h = 1e-4 against
/// length scales ≥ 0.04 the truncation error is ≤ (h/0.04)² ≈ 6e-6
/// relative; the losses are accumulated in f64 and the gradients returned
/// in f32 (6e-8 relative). Tolerance: 1e-3 relative or 1e-6 × the largest
/// gradient entry absolute. The losses have kinks (|·|, the clamps, the
/// nearest-pixel lookup) that a difference may straddle: at most 1% of the
/// entries may miss (none did when these tests were written).
fn fd_check(name: &str, analytic: &[f32], base: &[f32], f: impl Fn(&[f32]) -> f64) {
    let h = 1e-4f32;
    let scale = analytic
        .iter()
        .fold(0.0f64, |m, &v| m.max((v as f64).abs()));
    assert!(scale > 0.0, "{name}: all-zero gradient");
    let mut bad = Vec::new();
    for k in 0..base.len() {
        let mut p = base.to_vec();
        p[k] = base[k] + h;
        let hp = (p[k] - base[k]) as f64;
        let lp = f(&p);
        p[k] = base[k] - h;
        let hm = (p[k] - base[k]) as f64;
        let lm = f(&p);
        let fd = (lp - lm) / (hp - hm);
        let a = analytic[k] as f64;
        if (fd - a).abs() > 1e-3 * fd.abs().max(a.abs()) + 1e-6 * scale {
            bad.push((k, a, fd));
        }
    }
    assert!(
        bad.len() <= base.len() / 100,
        "{name}: {} of {} off: {:?}",
        bad.len(),
        base.len(),
        &bad[..bad.len().min(6)]
    );
}

fn flat3(v: &[[f32; 3]]) -> Vec<f32> {
    v.iter().flatten().copied().collect()
}

fn flat4(v: &[[f32; 4]]) -> Vec<f32> {
    v.iter().flatten().copied().collect()
}

/// FD-checks every raw parameter group of `loss(g)` against `grads`.
fn check_raw(name: &str, g: &Gaussians, grads: &RawGrads, loss: impl Fn(&Gaussians) -> f64) {
    fd_check(
        &format!("{name}/means"),
        &flat3(&grads.means),
        &flat3(&g.means),
        |v| {
            let mut h = g.clone();
            h.means = v.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
            loss(&h)
        },
    );
    fd_check(
        &format!("{name}/log_scales"),
        &flat3(&grads.log_scales),
        &flat3(&g.log_scales),
        |v| {
            let mut h = g.clone();
            h.log_scales = v.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
            loss(&h)
        },
    );
    fd_check(
        &format!("{name}/rotations"),
        &flat4(&grads.rotations),
        &flat4(&g.rotations),
        |v| {
            let mut h = g.clone();
            h.rotations = v.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();
            loss(&h)
        },
    );
    fd_check(
        &format!("{name}/opacity"),
        &grads.opacity_logits,
        &g.opacity_logits,
        |v| {
            let mut h = g.clone();
            h.opacity_logits = v.to_vec();
            loss(&h)
        },
    );
}

/// One Gaussian at (0, 0, 4), axes = world axes, scales (0.3, 0.2, 0.05)
/// (shortest axis z, facing the camera), opacity `a`.
fn single(a: f32) -> Gaussians {
    Gaussians {
        means: vec![[0.0, 0.0, 4.0]],
        log_scales: vec![[0.3f32.ln(), 0.2f32.ln(), 0.05f32.ln()]],
        rotations: vec![[2.0, 0.0, 0.0, 0.0]], // unnormalised identity
        opacity_logits: vec![logit(a)],
        sh_dc: vec![[0.0; 3]],
        ..Default::default()
    }
}

fn one_sample(g: &Gaussians, owner: u32, eps: [f32; 3]) -> Samples {
    let geo = super::geometry::geometry(g);
    let p = super::density::sample_point(&geo[owner as usize], eps.map(f64::from));
    Samples {
        points: vec![p.map(|v| v as f32)],
        owner: vec![owner],
        eps: vec![eps],
    }
}

#[test]
fn entropy_values_and_gradient() {
    let (l, _) = entropy(&[0.0]);
    assert!((l - std::f64::consts::LN_2).abs() < 1e-12);
    let (l, g) = entropy(&[60.0, -60.0]);
    assert!(l < 1e-20 && g.iter().all(|v| v.abs() < 1e-20));
    assert_eq!(entropy(&[]), (0.0, vec![]));
    let mut r = seeded(3);
    let x: Vec<f32> = (0..50).map(|_| r.random_range(-6.0f32..6.0)).collect();
    let (_, grad) = entropy(&x);
    fd_check("entropy", &grad, &x, |v| entropy(v).0);
}

#[test]
fn neighbours_include_self_first() {
    let g = random_gaussians(30, 1, (0.5, 0.9));
    let nb = Neighbours::build(&g.means, SUGAR_K).unwrap();
    assert_eq!((nb.k, nb.len()), (16, 30));
    for i in 0..30 {
        assert_eq!(nb.of(i)[0] as usize, i);
    }
    let few = Neighbours::build(&g.means[..5], SUGAR_K).unwrap();
    assert_eq!((few.k, few.idx.len()), (5, 25));
}

#[test]
fn density_at_centre_is_opacity() {
    let g = single(0.7);
    let nb = Neighbours::build(&g.means, SUGAR_K).unwrap();
    let d = density_at(&g, &nb, 0, [0.0, 0.0, 4.0], 1.0);
    assert!((d - 0.7).abs() < 1e-6, "{d}");
    // one standard deviation along the short axis: α e^{−1/2}
    let d = density_at(&g, &nb, 0, [0.0, 0.0, 4.05], 1.0);
    assert!((d - 0.7 * (-0.5f64).exp()).abs() < 1e-6, "{d}");
    // two coincident Gaussians of α = 0.7 clamp at 1
    let mut two = single(0.7);
    two.means.push(two.means[0]);
    two.log_scales.push(two.log_scales[0]);
    two.rotations.push(two.rotations[0]);
    two.opacity_logits.push(two.opacity_logits[0]);
    let nb2 = Neighbours::build(&two.means, SUGAR_K).unwrap();
    assert_eq!(density_at(&two, &nb2, 0, [0.0, 0.0, 4.0], 1.0), 1.0);
    assert!((density_at(&two, &nb2, 0, [0.0, 0.0, 4.0], 1.0 / 16.0) - 1.4 / 16.0).abs() < 1e-6);
}

#[test]
fn density_regularizer_hand_value() {
    // flat Gaussian, sample at k·s along its normal: d = α e^{−k²/2},
    // target e^{−k²/2} (β = its own smallest scale, the only neighbour)
    for k in [0.5f64, 1.0, 2.0] {
        let g = single(0.6);
        let nb = Neighbours::build(&g.means, SUGAR_K).unwrap();
        let s = one_sample(&g, 0, [0.3, -0.2, (k / 1.5) as f32]);
        let (l, _) = density_regularizer(&g, &nb, &s);
        // the in-plane offsets lower d by exp(−½((1.5·0.3)² + (1.5·0.2)²))·... of
        // the in-plane coordinates: a = 1.5ε (in units of s) on axes x and y
        let inplane = (-0.5 * (1.5f64 * 0.3).powi(2) - 0.5 * (1.5f64 * -0.2).powi(2)).exp();
        let t = (-0.5 * k * k).exp();
        let kk = 1.5 * ((k / 1.5) as f32) as f64;
        let d = 0.6 * inplane * (-0.5 * kk * kk).exp();
        let t2 = (-0.5 * kk * kk).exp();
        assert!((t - t2).abs() < 1e-6);
        assert!(
            (l - (d - t2).abs()).abs() < 1e-6,
            "k={k}: {l} vs {}",
            (d - t2).abs()
        );
    }
}

#[test]
fn density_clamp_is_straight_through() {
    // two coincident α = 0.9 Gaussians, sample one s_min along the normal:
    // d_raw = 1.8 e^{−1/2} ≈ 1.09 → d = 1, target e^{−1/2}; loss 1 − e^{−1/2};
    // straight-through: ∂/∂logit_g = sign(d − t)·e^{−1/2}·α(1−α) for each g
    let mut g = single(0.9);
    g.means.push(g.means[0]);
    g.log_scales.push(g.log_scales[0]);
    g.rotations.push(g.rotations[0]);
    g.opacity_logits.push(g.opacity_logits[0]);
    let nb = Neighbours::build(&g.means, SUGAR_K).unwrap();
    let s = one_sample(&g, 0, [0.0, 0.0, (1.0 / 1.5) as f32]);
    let (l, gr) = density_regularizer(&g, &nb, &s);
    let e = (-0.5f64).exp();
    assert!((l - (1.0 - e)).abs() < 1e-6, "{l}");
    for i in 0..2 {
        let want = e * 0.9 * 0.1;
        assert!(
            (gr.opacity_logits[i] as f64 - want).abs() < 1e-5,
            "{:?}",
            gr.opacity_logits
        );
    }
}

#[test]
fn sdf_regularizer_hand_value_and_clamp() {
    // flat Gaussian at z = 4 facing the camera, sample k·s in front of it
    // along its normal (−z): d = α/16 · e^{−k²/2}, f = s·sqrt(−2 ln d),
    // z(p) = 4 − k·s, depth map 3.9 everywhere: f̂ = |3.9 − z(p)|; ∇d ∥ n, so
    // the normal term is 0.
    let cam = camera();
    let g = single(0.8);
    let nb = Neighbours::build(&g.means, SUGAR_K).unwrap();
    let k = 1.2f64;
    let ez = (-k / 1.5) as f32;
    let kk = -1.5 * ez as f64;
    let s = one_sample(&g, 0, [0.0, 0.0, ez]);
    let depth = vec![3.9f32; 32 * 24];
    let params = SdfParams::sugar(20.0);
    let (l, gr, gd) = sdf_regularizer(&g, &nb, &s, &cam, &depth, &params);
    let sm = 0.05f32 as f64;
    let d = 0.8f32 as f64 / 16.0 * (-0.5 * kk * kk).exp();
    let f = sm * (-2.0 * d.ln()).sqrt();
    let z = 4.0 - kk * sm;
    let fh = (3.9f32 as f64 - z).abs();
    let want = (f - fh).abs() / 2.0;
    assert!((l - want).abs() < 1e-6, "{l} vs {want}");
    assert!(gd.iter().filter(|v| **v != 0.0).count() == 1);
    assert!(gr.opacity_logits[0] != 0.0);
    // a tiny extent clamps the SDF term at 1: no gradient left from it
    let params = SdfParams {
        normal_weight: 0.0,
        ..SdfParams::sugar(1e-3)
    };
    let (l, gr, gd) = sdf_regularizer(&g, &nb, &s, &cam, &depth, &params);
    assert_eq!(l, 1.0);
    assert!(gd.iter().all(|&v| v == 0.0));
    assert!(flat3(&gr.means).iter().all(|&v| v == 0.0));
    assert!(gr.opacity_logits.iter().all(|&v| v == 0.0));
    // samples projecting on zero depth are dropped
    let (l, _, _) = sdf_regularizer(&g, &nb, &s, &cam, &vec![0.0; 32 * 24], &params);
    assert_eq!(l, 0.0);
}

fn random_samples(g: &Gaussians, n: usize, seed: u64) -> Samples {
    let cand: Vec<u32> = (0..g.len() as u32).collect();
    sample_points(g, &cand, n, &mut seeded(seed))
}

#[test]
fn density_regularizer_gradients() {
    for seed in [11u64, 12] {
        // α ≤ 0.19 over 6 neighbours keeps d < 1 (the clamp's straight-through
        // gradient is not the derivative of the clamped value)
        let g = random_gaussians(12, seed, (0.05, 0.19));
        let nb = Neighbours::build(&g.means, 6).unwrap();
        let s = random_samples(&g, 40, seed + 1);
        let (_, gr) = density_regularizer(&g, &nb, &s);
        check_raw("density", &g, &gr, |h| density_regularizer(h, &nb, &s).0);
    }
}

#[test]
fn sdf_regularizer_gradients() {
    let cam = camera();
    for seed in [21u64, 22] {
        let g = random_gaussians(12, seed, (0.2, 0.95));
        let nb = Neighbours::build(&g.means, 6).unwrap();
        let s = random_samples(&g, 40, seed + 1);
        let params = SdfParams::sugar(30.0);
        // constant depth for the parameter gradients: the nearest-pixel
        // lookup then has no jumps a difference could straddle
        let flat = vec![3.8f32; 32 * 24];
        let (l, gr, _) = sdf_regularizer(&g, &nb, &s, &cam, &flat, &params);
        assert!(l > 0.0);
        check_raw("sdf", &g, &gr, |h| {
            sdf_regularizer(h, &nb, &s, &cam, &flat, &params).0
        });
        // a random depth map for the depth gradient
        let mut r = seeded(seed + 7);
        let depth: Vec<f32> = (0..32 * 24).map(|_| r.random_range(3.0f32..5.0)).collect();
        let (_, _, gd) = sdf_regularizer(&g, &nb, &s, &cam, &depth, &params);
        fd_check("sdf/depth", &gd, &depth, |d| {
            sdf_regularizer(&g, &nb, &s, &cam, d, &params).0
        });
    }
}

#[test]
fn results_do_not_depend_on_thread_count() {
    let cam = camera();
    let g = random_gaussians(40, 5, (0.2, 0.95));
    let nb = Neighbours::build(&g.means, SUGAR_K).unwrap();
    let s = random_samples(&g, 3 * CHUNK + 17, 6);
    let depth = vec![4.0f32; 32 * 24];
    let params = SdfParams::sugar(10.0);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            (
                density_regularizer(&g, &nb, &s),
                sdf_regularizer(&g, &nb, &s, &cam, &depth, &params),
            )
        })
    };
    assert_eq!(run(1), run(3));
}

#[test]
fn sample_points_follow_the_owner() {
    let g = random_gaussians(5, 9, (0.5, 0.9));
    let s = sample_points(&g, &[1, 3], 4000, &mut seeded(4));
    assert_eq!(s, sample_points(&g, &[1, 3], 4000, &mut seeded(4)));
    assert!(s.owner.iter().all(|&o| o == 1 || o == 3));
    let ones = s.owner.iter().filter(|&&o| o == 1).count();
    assert!((1800..2200).contains(&ones), "{ones}");
    // ε ~ N(0, I): mean ≈ 0, variance ≈ 1 (4000 draws: σ_mean ≈ 0.016)
    for k in 0..3 {
        let m: f64 = s.eps.iter().map(|e| e[k] as f64).sum::<f64>() / 4000.0;
        let v: f64 = s.eps.iter().map(|e| (e[k] as f64 - m).powi(2)).sum::<f64>() / 4000.0;
        assert!(m.abs() < 0.07 && (v - 1.0).abs() < 0.1, "{k}: {m} {v}");
    }
    // p = μ + R(1.5 s ⊙ ε)
    let i = 7;
    let o = s.owner[i] as usize;
    let q = g.quat(o).as_dquat();
    let sc = g.scales(o);
    let e = s.eps[i];
    let local = DVec3::new(
        1.5 * sc[0] as f64 * e[0] as f64,
        1.5 * sc[1] as f64 * e[1] as f64,
        1.5 * sc[2] as f64 * e[2] as f64,
    );
    let want = DVec3::from_array(g.means[o].map(f64::from)) + q * local;
    let got = DVec3::from_array(s.points[i].map(f64::from));
    assert!((want - got).length() < 1e-5, "{want} vs {got}");
    assert!(sample_points(&g, &[], 10, &mut seeded(1)).is_empty());
}

#[test]
fn visible_candidates_near_the_depth() {
    let cam = camera();
    let mut g = single(0.8); // σ along the view ray = 0.05 (short axis z)
    g.means.push([0.0, 0.0, -4.0]); // behind the camera
    g.log_scales.push(g.log_scales[0]);
    g.rotations.push(g.rotations[0]);
    g.opacity_logits.push(g.opacity_logits[0]);
    let at = |d: f32| visible_candidates(&g, &cam, &vec![d; 32 * 24], 2.0);
    assert_eq!(at(4.09), vec![0]);
    assert_eq!(at(3.91), vec![0]);
    assert!(at(4.11).is_empty() && at(3.89).is_empty() && at(0.0).is_empty());
}

#[test]
fn raw_grads_add_to() {
    let mut a = RawGrads::zeros(2);
    let mut b = RawGrads::zeros(2);
    b.means[1] = [1.0, 2.0, 3.0];
    b.rotations[0] = [1.0, 0.0, 0.0, -1.0];
    b.opacity_logits[1] = 4.0;
    b.add_to(&mut a, 0.5);
    b.add_to(&mut a, 0.5);
    assert_eq!(a, b);
}
