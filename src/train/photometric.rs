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
    let (w, h) = (view.camera.width as usize, view.camera.height as usize);
    let c = composite(pred, view);
    let (l1, g1) = l1_grad(&c, &view.image);
    let (s, gs) = ssim_grad(&c, &view.image, w, h);
    let a = L1_WEIGHT as f32;
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
    (L1_WEIGHT * l1 + (1.0 - L1_WEIGHT) * (1.0 - s), grad)
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
