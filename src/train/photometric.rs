//! The photometric loss of 3DGS / SuGaR and the held-out metrics.
//!
//! Loss = 0.8·L1 + 0.2·(1 − SSIM) (11×11 Gaussian window, σ 1.5, as
//! `render::loss`). With a mask, pixels outside it are replaced by the
//! ground truth before both terms (so they add nothing and pass no
//! gradient): the loss counts only the object, as DTU users train.
//! Metrics: PSNR over the mask's pixels (all pixels without a mask) and SSIM
//! of the same composited image.

use splatkit_render::loss::{l1_grad, psnr, ssim, ssim_grad};

use crate::model::View;

/// Weight of L1 (SuGaR / 3DGS: 0.8; D-SSIM gets 1 − this).
pub const L1_WEIGHT: f64 = 0.8;

fn composite(pred: &[[f32; 3]], view: &View) -> Vec<[f32; 3]> {
    match &view.mask {
        Some(m) => pred
            .iter()
            .zip(&view.image)
            .zip(m)
            .map(|((p, g), &inside)| if inside { *p } else { *g })
            .collect(),
        None => pred.to_vec(),
    }
}

/// The loss of `pred` against the view and its gradient per pixel.
pub fn loss_and_grad(pred: &[[f32; 3]], view: &View) -> (f64, Vec<[f32; 3]>) {
    loss_and_grad_weighted(pred, view, L1_WEIGHT)
}

/// [`loss_and_grad`] with L1 weight `l1_weight` and D-SSIM weight
/// 1 − `l1_weight` (Triangle Splatting's indoor preset: 0.6 / 0.4).
pub fn loss_and_grad_weighted(
    pred: &[[f32; 3]],
    view: &View,
    l1_weight: f64,
) -> (f64, Vec<[f32; 3]>) {
    let (w, h) = (view.camera.width as usize, view.camera.height as usize);
    let c = composite(pred, view);
    let (l1, g1) = l1_grad(&c, &view.image);
    let (s, gs) = ssim_grad(&c, &view.image, w, h);
    let a = l1_weight as f32;
    let mut grad: Vec<[f32; 3]> = g1
        .iter()
        .zip(&gs)
        .map(|(x, y)| std::array::from_fn(|k| a * x[k] - (1.0 - a) * y[k]))
        .collect();
    if let Some(m) = &view.mask {
        for (g, &inside) in grad.iter_mut().zip(m) {
            if !inside {
                *g = [0.0; 3];
            }
        }
    }
    (l1_weight * l1 + (1.0 - l1_weight) * (1.0 - s), grad)
}

/// PSNR of `pred` against the view, over the mask's pixels (all pixels
/// without a mask; NaN when the mask is empty).
pub fn psnr_of(pred: &[[f32; 3]], view: &View) -> f64 {
    match &view.mask {
        Some(m) => {
            let (a, b): (Vec<[f32; 3]>, Vec<[f32; 3]>) = pred
                .iter()
                .zip(&view.image)
                .zip(m)
                .filter(|(_, inside)| **inside)
                .map(|((a, b), _)| (*a, *b))
                .unzip();
            if a.is_empty() { f64::NAN } else { psnr(&a, &b) }
        }
        None => psnr(pred, &view.image),
    }
}

/// (PSNR, SSIM) of `pred` against the view (see the module docs for masks).
pub fn metrics(pred: &[[f32; 3]], view: &View) -> (f64, f64) {
    let (w, h) = (view.camera.width as usize, view.camera.height as usize);
    let c = composite(pred, view);
    (psnr_of(pred, view), ssim(&c, &view.image, w, h))
}

/// A held-out evaluation.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct Eval {
    pub iteration: u64,
    pub psnr: f64,
    pub ssim: f64,
    /// Per test view (its camera name, PSNR, SSIM).
    pub views: Vec<(String, f64, f64)>,
}

/// Renders each view of `test` with `render` and averages PSNR / SSIM
/// ([`metrics`]) over them.
pub fn evaluate(
    views: &[View],
    test: &[usize],
    iteration: u64,
    render: impl Fn(&View) -> Vec<[f32; 3]>,
) -> Eval {
    let per: Vec<(String, f64, f64)> = test
        .iter()
        .map(|&i| {
            let img = render(&views[i]);
            let (p, q) = metrics(&img, &views[i]);
            (views[i].camera.name.clone(), p, q)
        })
        .collect();
    let n = per.len().max(1) as f64;
    Eval {
        iteration,
        psnr: per.iter().map(|v| v.1).sum::<f64>() / n,
        ssim: per.iter().map(|v| v.2).sum::<f64>() / n,
        views: per,
    }
}

/// The view training iteration `iteration` uses and the background it
/// renders with: `view` as loaded (composited on `bg0`) with `bg0`, or, when
/// `random` (`--random-background`), the view recomposited on that
/// iteration's [`random_background`] with that colour.
pub fn view_for_step(
    view: &View,
    bg0: [f32; 3],
    random: bool,
    seed: u64,
    iteration: u64,
) -> (std::borrow::Cow<'_, View>, [f32; 3]) {
    if random {
        let bg = random_background(seed, iteration);
        (std::borrow::Cow::Owned(recomposite(view, bg0, bg)), bg)
    } else {
        (std::borrow::Cow::Borrowed(view), bg0)
    }
}

/// The background of training iteration `iteration` with `--random-background`:
/// a uniformly random colour from the seeded stream of that iteration
/// (3DGS's `random_background`), so a resumed run draws the same colours.
pub fn random_background(seed: u64, iteration: u64) -> [f32; 3] {
    use rand::RngExt;
    let mut r = crate::model::rng::stream(seed ^ 0x0062_6163_6b67, iteration);
    std::array::from_fn(|_| r.random::<f32>())
}

/// `view` with its photo put on `bg` instead of `bg0`, the background it was
/// composited on when loaded: image + (bg − bg0)·(1 − alpha) where the view
/// kept its alpha; the view unchanged (cloned) otherwise.
pub fn recomposite(view: &View, bg0: [f32; 3], bg: [f32; 3]) -> View {
    let mut v = view.clone();
    if let Some(a) = &view.alpha {
        for (p, &al) in v.image.iter_mut().zip(a) {
            for k in 0..3 {
                p[k] += (bg[k] - bg0[k]) * (1.0 - al);
            }
        }
    }
    v
}

#[cfg(test)]
mod background_tests {
    use super::*;
    use crate::model::Camera;

    /// A half-transparent pixel loaded on black moves halfway to the new
    /// background; an opaque one stays; a view without alpha is unchanged;
    /// the random colours depend only on (seed, iteration).
    #[test]
    fn recomposite_and_random_colours() {
        let cam = Camera::pinhole(
            "c",
            2,
            1,
            1.0,
            1.0,
            1.0,
            0.5,
            Default::default(),
            Default::default(),
        );
        let v = View {
            camera: cam,
            image: vec![[0.2, 0.1, 0.0], [0.3, 0.3, 0.3]],
            mask: None,
            alpha: Some(vec![0.5, 1.0]),
            source: "x".into(),
        };
        let w = recomposite(&v, [0.0; 3], [1.0, 0.5, 0.0]);
        assert_eq!(w.image, vec![[0.7, 0.35, 0.0], [0.3, 0.3, 0.3]]);
        let mut no = v.clone();
        no.alpha = None;
        assert_eq!(recomposite(&no, [0.0; 3], [1.0; 3]).image, no.image);
        assert_eq!(random_background(3, 7), random_background(3, 7));
        assert_ne!(random_background(3, 7), random_background(3, 8));
        assert!(
            random_background(3, 7)
                .iter()
                .all(|c| (0.0..1.0).contains(c))
        );
    }
}
