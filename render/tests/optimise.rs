//! Optimisation tests (issue #5): from perturbed parameters, 300 Adam steps
//! on 0.8·L1 + 0.2·(1 − SSIM) must recover a 64×64 target rendered from the
//! true parameters to PSNR ≥ 35 dB, for Gaussians and for triangles.
//!
//! Parameters are optimised in the raw (pre-activation) form the reference
//! trainers use: log scales, opacity logits, σ = 0.01 + exp(raw) for
//! triangles, unnormalised quaternions, SH DC coefficients.

use glam::{DMat3, DVec3};
use splatkit_render::gaussian::{Gaussians3, RasterSettings, rasterize};
use splatkit_render::gaussian_grad::backward;
use splatkit_render::loss::{l1_grad, psnr, ssim_grad};
use splatkit_render::optim::{Adam, LrSchedule, ParamGroup};
use splatkit_render::sh::rgb_to_sh;
use splatkit_render::triangle::{self, Triangles3};
use splatkit_render::{Camera, triangle_grad};

const W: u32 = 64;
const STEPS: u64 = 300;

struct Lcg(u64);
impl Lcg {
    fn f(&mut self, a: f32, b: f32) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        a + (b - a) * ((self.0 >> 40) as f32 / (1u64 << 24) as f32)
    }
}

fn camera() -> Camera {
    Camera::pinhole(
        "opt",
        W,
        W,
        64.0,
        64.0,
        32.0,
        32.0,
        DMat3::IDENTITY,
        DVec3::ZERO,
    )
}

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

fn logit(p: f32) -> f32 {
    (p / (1.0 - p)).ln()
}

/// ∂L/∂image for L = 0.8·L1 + 0.2·(1 − SSIM); returns the loss too.
fn image_loss(img: &[[f32; 3]], target: &[[f32; 3]]) -> (f64, Vec<[f32; 3]>) {
    let (l1, g1) = l1_grad(img, target);
    let (s, gs) = ssim_grad(img, target, W as usize, W as usize);
    let g = g1
        .iter()
        .zip(&gs)
        .map(|(a, b)| std::array::from_fn(|k| 0.8 * a[k] - 0.2 * b[k]))
        .collect();
    (0.8 * l1 + 0.2 * (1.0 - s), g)
}

fn group(name: &str, range: std::ops::Range<usize>, init: f64, end: f64) -> ParamGroup {
    ParamGroup {
        name: name.into(),
        range,
        lr: LrSchedule::Exponential {
            init,
            end,
            steps: STEPS,
        },
    }
}

#[test]
fn gaussians_recover_a_target() {
    let cam = camera();
    let s = RasterSettings::default();
    let mut r = Lcg(11);
    let n = 40;
    let mut truth = Gaussians3 {
        sh_degree: 0,
        ..Default::default()
    };
    for _ in 0..n {
        truth
            .means
            .push([r.f(-1.6, 1.6), r.f(-1.6, 1.6), r.f(3.5, 4.5)]);
        truth
            .scales
            .push([r.f(0.15, 0.4), r.f(0.15, 0.4), r.f(0.05, 0.2)]);
        truth.rotations.push([
            r.f(0.5, 1.0),
            r.f(-0.5, 0.5),
            r.f(-0.5, 0.5),
            r.f(-0.5, 0.5),
        ]);
        truth.opacities.push(r.f(0.5, 0.9));
        truth
            .sh
            .push([r.f(0.1, 0.9), r.f(0.1, 0.9), r.f(0.1, 0.9)].map(rgb_to_sh));
    }
    let target = rasterize(&truth, &cam, &s).0.rgb;
    // raw layout: means 3n | log scales 3n | quats 4n | logits n | dc 3n
    let mut p: Vec<f32> = Vec::new();
    for i in 0..n {
        p.extend(truth.means[i].map(|v| v + r.f(-0.08, 0.08)));
    }
    for i in 0..n {
        p.extend(truth.scales[i].map(|v| v.ln() + r.f(-0.25, 0.25)));
    }
    for i in 0..n {
        p.extend(truth.rotations[i].map(|v| v + r.f(-0.1, 0.1)));
    }
    for i in 0..n {
        p.push(logit(truth.opacities[i]) + r.f(-0.5, 0.5));
    }
    for i in 0..n {
        p.extend(truth.sh[i].map(|v| v + r.f(-0.5, 0.5)));
    }
    let groups = vec![
        group("means", 0..3 * n, 4e-3, 4e-5),
        group("scales", 3 * n..6 * n, 1e-2, 1e-4),
        group("rotations", 6 * n..10 * n, 5e-3, 5e-5),
        group("opacity", 10 * n..11 * n, 3e-2, 3e-4),
        group("sh", 11 * n..14 * n, 2e-2, 2e-4),
    ];
    let mut adam = Adam::new(p.len(), groups);
    let decode = |p: &[f32]| Gaussians3 {
        means: (0..n)
            .map(|i| [p[3 * i], p[3 * i + 1], p[3 * i + 2]])
            .collect(),
        scales: (0..n)
            .map(|i| std::array::from_fn(|k| p[3 * n + 3 * i + k].exp()))
            .collect(),
        rotations: (0..n)
            .map(|i| std::array::from_fn(|k| p[6 * n + 4 * i + k]))
            .collect(),
        opacities: (0..n).map(|i| sigmoid(p[10 * n + i])).collect(),
        sh: (0..n)
            .map(|i| std::array::from_fn(|k| p[11 * n + 3 * i + k]))
            .collect(),
        sh_degree: 0,
    };
    let start = psnr(&rasterize(&decode(&p), &cam, &s).0.rgb, &target);
    for _ in 0..STEPS {
        let g = decode(&p);
        let (img, st) = rasterize(&g, &cam, &s);
        let (_, d_img) = image_loss(&img.rgb, &target);
        let gr = backward(&g, &cam, &s, &st, &d_img, None);
        let mut grad = vec![0.0f32; p.len()];
        for i in 0..n {
            for k in 0..3 {
                grad[3 * i + k] = gr.means[i][k];
                grad[3 * n + 3 * i + k] = gr.scales[i][k] * g.scales[i][k];
                grad[11 * n + 3 * i + k] = gr.sh[i][k];
            }
            for k in 0..4 {
                grad[6 * n + 4 * i + k] = gr.rotations[i][k];
            }
            let o = g.opacities[i];
            grad[10 * n + i] = gr.opacities[i] * o * (1.0 - o);
        }
        adam.step(&mut p, &grad);
    }
    let end = psnr(&rasterize(&decode(&p), &cam, &s).0.rgb, &target);
    println!("Gaussians: PSNR {start:.2} dB → {end:.2} dB after {STEPS} steps");
    assert!(end >= 35.0, "PSNR {end:.2} dB (start {start:.2})");
}

#[test]
fn triangles_recover_a_target() {
    let cam = camera();
    let s = RasterSettings::default();
    let mut r = Lcg(5);
    let n = 40;
    let mut truth = Triangles3 {
        sh_degree: 0,
        ..Default::default()
    };
    for _ in 0..n {
        let c = [r.f(-1.6, 1.6), r.f(-1.6, 1.6), r.f(3.5, 4.5)];
        let rad = r.f(0.3, 0.6);
        let a0 = r.f(0.0, std::f32::consts::TAU);
        let v: [[f32; 3]; 3] = std::array::from_fn(|k| {
            let a = a0 + k as f32 * 2.1 + r.f(-0.3, 0.3);
            [
                c[0] + rad * a.cos(),
                c[1] + rad * a.sin(),
                c[2] + r.f(-0.2, 0.2),
            ]
        });
        truth.vertices.push(v);
        truth.sigmas.push(r.f(0.3, 1.5));
        truth.opacities.push(r.f(0.5, 0.9));
        truth
            .sh
            .push([r.f(0.1, 0.9), r.f(0.1, 0.9), r.f(0.1, 0.9)].map(rgb_to_sh));
    }
    let target = triangle::rasterize(&truth, &cam, &s).0.rgb;
    // raw layout: vertices 9n | σ raw n | logits n | dc 3n
    let mut p: Vec<f32> = Vec::new();
    for i in 0..n {
        for v in truth.vertices[i] {
            p.extend(v.map(|x| x + r.f(-0.08, 0.08)));
        }
    }
    for i in 0..n {
        p.push((truth.sigmas[i] - 0.01).ln() + r.f(-0.3, 0.3));
    }
    for i in 0..n {
        p.push(logit(truth.opacities[i]) + r.f(-0.5, 0.5));
    }
    for i in 0..n {
        p.extend(truth.sh[i].map(|v| v + r.f(-0.5, 0.5)));
    }
    let groups = vec![
        group("vertices", 0..9 * n, 3e-3, 3e-5),
        group("sigma", 9 * n..10 * n, 1e-2, 1e-4),
        group("opacity", 10 * n..11 * n, 3e-2, 3e-4),
        group("sh", 11 * n..14 * n, 2e-2, 2e-4),
    ];
    let mut adam = Adam::new(p.len(), groups);
    let decode = |p: &[f32]| Triangles3 {
        vertices: (0..n)
            .map(|i| std::array::from_fn(|v| std::array::from_fn(|k| p[9 * i + 3 * v + k])))
            .collect(),
        sigmas: (0..n).map(|i| 0.01 + p[9 * n + i].exp()).collect(),
        opacities: (0..n).map(|i| sigmoid(p[10 * n + i])).collect(),
        sh: (0..n)
            .map(|i| std::array::from_fn(|k| p[11 * n + 3 * i + k]))
            .collect(),
        sh_degree: 0,
    };
    let start = psnr(&triangle::rasterize(&decode(&p), &cam, &s).0.rgb, &target);
    for _ in 0..STEPS {
        let t = decode(&p);
        let (img, st) = triangle::rasterize(&t, &cam, &s);
        let (_, d_img) = image_loss(&img.rgb, &target);
        let gr = triangle_grad::backward(&t, &cam, &s, &st, &d_img, None);
        let mut grad = vec![0.0f32; p.len()];
        for i in 0..n {
            for v in 0..3 {
                for k in 0..3 {
                    grad[9 * i + 3 * v + k] = gr.vertices[i][v][k];
                }
            }
            grad[9 * n + i] = gr.sigmas[i] * (t.sigmas[i] - 0.01);
            let o = t.opacities[i];
            grad[10 * n + i] = gr.opacities[i] * o * (1.0 - o);
            for k in 0..3 {
                grad[11 * n + 3 * i + k] = gr.sh[i][k];
            }
        }
        adam.step(&mut p, &grad);
    }
    let end = psnr(&triangle::rasterize(&decode(&p), &cam, &s).0.rgb, &target);
    println!("triangles: PSNR {start:.2} dB → {end:.2} dB after {STEPS} steps");
    assert!(end >= 35.0, "PSNR {end:.2} dB (start {start:.2})");
}
