//! Image losses with gradients: L1, SSIM (the 3DGS definition) and PSNR.
//!
//! Images are row-major `width × height` RGB in [0, 1] (`[f32; 3]` per
//! pixel). Each loss is a mean over pixels and channels. SSIM uses an 11×11
//! Gaussian window of σ = 1.5 (normalised, separable), zero padding as
//! PyTorch's `conv2d(padding = 5)`, C1 = 0.01², C2 = 0.03², averaged over the
//! full image and the three channels — the 3DGS `ssim()` exactly.

use rayon::prelude::*;

/// Mean absolute error.
pub fn l1(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    assert_eq!(a.len(), b.len(), "images of different sizes");
    let s: f64 = a
        .iter()
        .zip(b)
        .map(|(p, q)| {
            (0..3)
                .map(|k| (p[k] as f64 - q[k] as f64).abs())
                .sum::<f64>()
        })
        .sum();
    s / (3 * a.len().max(1)) as f64
}

/// L1 and its gradient with respect to `a` (sign / 3N; 0 where equal).
pub fn l1_grad(a: &[[f32; 3]], b: &[[f32; 3]]) -> (f64, Vec<[f32; 3]>) {
    let inv = 1.0 / (3 * a.len().max(1)) as f32;
    let g = a
        .iter()
        .zip(b)
        .map(|(p, q)| {
            std::array::from_fn(|k| {
                let d = p[k] - q[k];
                if d > 0.0 {
                    inv
                } else if d < 0.0 {
                    -inv
                } else {
                    0.0
                }
            })
        })
        .collect();
    (l1(a, b), g)
}

/// Peak signal-to-noise ratio for a peak of 1: 10·log10(1 / MSE)
/// (∞ for identical images).
pub fn psnr(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    assert_eq!(a.len(), b.len(), "images of different sizes");
    let mse: f64 = a
        .iter()
        .zip(b)
        .map(|(p, q)| {
            (0..3)
                .map(|k| (p[k] as f64 - q[k] as f64).powi(2))
                .sum::<f64>()
        })
        .sum::<f64>()
        / (3 * a.len().max(1)) as f64;
    10.0 * (1.0 / mse).log10()
}

const C1: f64 = 0.01 * 0.01;
const C2: f64 = 0.03 * 0.03;

fn window() -> [f64; 11] {
    let mut g: [f64; 11] = std::array::from_fn(|i| {
        let x = i as f64 - 5.0;
        (-x * x / (2.0 * 1.5 * 1.5)).exp()
    });
    let s: f64 = g.iter().sum();
    g.iter_mut().for_each(|v| *v /= s);
    g
}

/// SSIM of `a` against `b` (mean of the SSIM map over pixels and channels).
pub fn ssim(a: &[[f32; 3]], b: &[[f32; 3]], w: usize, h: usize) -> f64 {
    ssim_impl(a, b, w, h, false).0
}

/// SSIM and its gradient with respect to `a`.
pub fn ssim_grad(a: &[[f32; 3]], b: &[[f32; 3]], w: usize, h: usize) -> (f64, Vec<[f32; 3]>) {
    let (s, g) = ssim_impl(a, b, w, h, true);
    (s, g.expect("asked for"))
}

/// Adds the horizontal 11-tap blur of `src` (one image row, zero padding)
/// to `dst` (zeroed by the caller). Tap-major: every output still adds its
/// taps in order k = 0..11 starting from 0, so the bits are those of a
/// per-pixel dot product, and the inner loop vectorises.
fn blur_row(src: &[f64], dst: &mut [f64], g: &[f64; 11]) {
    let w = src.len();
    for (k, gk) in g.iter().enumerate() {
        // outputs xx whose tap k reads inside the row: 0 ≤ xx + k − 5 < w
        let lo = 5usize.saturating_sub(k);
        let hi = (w + 5).saturating_sub(k).min(w);
        if lo >= hi {
            continue;
        }
        for (t, v) in dst[lo..hi].iter_mut().zip(&src[lo + k - 5..hi + k - 5]) {
            *t += gk * v;
        }
    }
}

/// Adds the vertical 11-tap blur at row `y` of `planes` planes stored
/// row-interleaved in `hbuf` (row r holds `planes` runs of `w` values) to
/// `acc` (`planes · w`, zeroed by the caller), taps in order k = 0..11.
fn blur_column(
    hbuf: &[f64],
    (y, h, w): (usize, usize, usize),
    planes: usize,
    g: &[f64; 11],
    acc: &mut [f64],
) {
    let stride = 5 * w;
    for (k, gk) in g.iter().enumerate() {
        let sy = y as isize + k as isize - 5;
        if sy < 0 || sy as usize >= h {
            continue;
        }
        let row = &hbuf[sy as usize * stride..sy as usize * stride + planes * w];
        for (o, v) in acc.iter_mut().zip(row) {
            *o += gk * v;
        }
    }
}

thread_local! {
    /// Scratch of [`ssim_impl`] kept between calls on the calling thread (a
    /// trainer calls it every step at the same size; fresh 10-MB buffers
    /// would be page-faulted in each time): 9 f64 per pixel.
    static SSIM_SCRATCH: std::cell::RefCell<Vec<f64>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// SSIM (and its gradient with respect to `a` when `grad`), one channel
/// after the other, image rows in parallel. Per channel: the horizontal
/// blurs of x, y, x², y², xy (five planes per row), then per row their
/// vertical blurs and the SSIM map with its partial derivatives (∂S/∂μx,
/// ∂S/∂σx², ∂S/∂σxy), then those three blurred again (the window is its
/// own adjoint) and combined into the gradient. Every value is the same
/// fixed-order sum whatever the thread count; the map's total is summed in
/// pixel order.
fn ssim_impl(
    a: &[[f32; 3]],
    b: &[[f32; 3]],
    w: usize,
    h: usize,
    grad: bool,
) -> (f64, Option<Vec<[f32; 3]>>) {
    assert_eq!(a.len(), w * h, "image a is not {w}×{h}");
    assert_eq!(b.len(), w * h, "image b is not {w}×{h}");
    let wh = w * h;
    if wh == 0 {
        return (0.0, grad.then(Vec::new));
    }
    let g = window();
    let n = (wh * 3) as f64;
    let mut out = grad.then(|| vec![[0.0f32; 3]; wh]);
    let mut scratch = SSIM_SCRATCH.with(|s| std::mem::take(&mut *s.borrow_mut()));
    scratch.clear();
    scratch.resize(9 * wh, 0.0);
    let (hbuf, rest) = scratch.split_at_mut(5 * wh);
    let (dbuf, smap) = rest.split_at_mut(3 * wh);
    let mut total = 0.0;
    for ch in 0..3 {
        // horizontal blurs of x, y, x², y², xy
        hbuf.par_chunks_mut(5 * w)
            .enumerate()
            .for_each(|(y, planes)| {
                planes.fill(0.0);
                let (pa, pb) = (&a[y * w..(y + 1) * w], &b[y * w..(y + 1) * w]);
                let mut src = vec![0.0f64; w];
                for q in 0..5 {
                    for ((s, p), r) in src.iter_mut().zip(pa).zip(pb) {
                        let (x, y) = (p[ch] as f64, r[ch] as f64);
                        *s = match q {
                            0 => x,
                            1 => y,
                            2 => x * x,
                            3 => y * y,
                            _ => x * y,
                        };
                    }
                    blur_row(&src, &mut planes[q * w..(q + 1) * w], &g);
                }
            });
        // vertical blurs, the SSIM map and its partial derivatives
        let hb: &[f64] = hbuf;
        smap.par_chunks_mut(w)
            .zip(dbuf.par_chunks_mut(3 * w))
            .enumerate()
            .for_each(|(y, (srow, drow))| {
                let mut v = vec![0.0f64; 5 * w];
                blur_column(hb, (y, h, w), 5, &g, &mut v);
                for xx in 0..w {
                    let (ux, uy) = (v[xx], v[w + xx]);
                    let vx = v[2 * w + xx] - ux * ux;
                    let vy = v[3 * w + xx] - uy * uy;
                    let cxy = v[4 * w + xx] - ux * uy;
                    let n1 = 2.0 * ux * uy + C1;
                    let n2 = 2.0 * cxy + C2;
                    let d1 = ux * ux + uy * uy + C1;
                    let d2 = vx + vy + C2;
                    let s = n1 * n2 / (d1 * d2);
                    srow[xx] = s;
                    if grad {
                        // S as a function of μx, Sxx = blur(x²), Sxy = blur(xy)
                        let ds_dvx = -s / d2;
                        let ds_dcxy = 2.0 * n1 / (d1 * d2);
                        drow[xx] = 2.0 * uy * n2 / (d1 * d2)
                            - 2.0 * ux * s / d1
                            - 2.0 * ux * ds_dvx
                            - uy * ds_dcxy;
                        drow[w + xx] = ds_dvx;
                        drow[2 * w + xx] = ds_dcxy;
                    }
                }
            });
        total += smap.iter().sum::<f64>();
        let Some(out) = out.as_mut() else { continue };
        // the adjoint: blur the three partial derivatives, then chain
        let db: &[f64] = dbuf;
        hbuf.par_chunks_mut(5 * w)
            .enumerate()
            .for_each(|(y, planes)| {
                planes[..3 * w].fill(0.0);
                for q in 0..3 {
                    let src = &db[y * 3 * w + q * w..y * 3 * w + (q + 1) * w];
                    blur_row(src, &mut planes[q * w..(q + 1) * w], &g);
                }
            });
        let hb: &[f64] = hbuf;
        out.par_chunks_mut(w).enumerate().for_each(|(y, orow)| {
            let mut v = vec![0.0f64; 3 * w];
            blur_column(hb, (y, h, w), 3, &g, &mut v);
            for (xx, o) in orow.iter_mut().enumerate() {
                let i = y * w + xx;
                let (x, yv) = (a[i][ch] as f64, b[i][ch] as f64);
                o[ch] = ((v[xx] + 2.0 * x * v[w + xx] + yv * v[2 * w + xx]) / n) as f32;
            }
        });
    }
    SSIM_SCRATCH.with(|s| *s.borrow_mut() = scratch);
    (total / n, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::Lcg;

    // The straightforward form the fused `ssim_impl` replaced: one full-image
    // buffer per blurred quantity, each blur a full-image pass. Kept as the
    // reference the fused form must equal bit for bit.
    /// Separable 11×11 Gaussian filter with zero padding (symmetric, so it is
    /// also its own adjoint). Rows of each pass run in parallel; every output
    /// value is the same fixed-order sum, so the result does not depend on the
    /// thread count.
    fn blur(x: &[f64], w: usize, h: usize, g: &[f64; 11]) -> Vec<f64> {
        let mut tmp = vec![0.0; w * h];
        tmp.par_chunks_mut(w.max(1))
            .enumerate()
            .for_each(|(y, row)| {
                let src = &x[y * w..(y + 1) * w];
                for (xx, t) in row.iter_mut().enumerate() {
                    let mut acc = 0.0;
                    if xx >= 5 && xx + 5 < w {
                        // interior: all 11 taps, the same order as below
                        for (gk, v) in g.iter().zip(&src[xx - 5..xx + 6]) {
                            acc += gk * v;
                        }
                    } else {
                        for (k, gk) in g.iter().enumerate() {
                            let sx = xx as isize + k as isize - 5;
                            if sx >= 0 && (sx as usize) < w {
                                acc += gk * src[sx as usize];
                            }
                        }
                    }
                    *t = acc;
                }
            });
        let mut out = vec![0.0; w * h];
        out.par_chunks_mut(w.max(1))
            .enumerate()
            .for_each(|(y, row)| {
                for (k, gk) in g.iter().enumerate() {
                    let sy = y as isize + k as isize - 5;
                    if sy >= 0 && (sy as usize) < h {
                        let src = &tmp[sy as usize * w..(sy as usize + 1) * w];
                        for (o, v) in row.iter_mut().zip(src) {
                            *o += gk * v;
                        }
                    }
                }
            });
        out
    }

    fn ssim_reference(
        a: &[[f32; 3]],
        b: &[[f32; 3]],
        w: usize,
        h: usize,
        grad: bool,
    ) -> (f64, Option<Vec<[f32; 3]>>) {
        assert_eq!(a.len(), w * h, "image a is not {w}×{h}");
        assert_eq!(b.len(), w * h, "image b is not {w}×{h}");
        let g = window();
        let n = (w * h * 3).max(1) as f64;
        // the three channels in parallel; totals summed in channel order
        let per: Vec<(f64, Option<Vec<f64>>)> = (0..3)
            .into_par_iter()
            .map(|ch| {
                let mut total = 0.0;
                let x: Vec<f64> = a.iter().map(|p| p[ch] as f64).collect();
                let y: Vec<f64> = b.iter().map(|p| p[ch] as f64).collect();
                let sq =
                    |v: &[f64], u: &[f64]| v.iter().zip(u).map(|(p, q)| p * q).collect::<Vec<_>>();
                let mx = blur(&x, w, h, &g);
                let my = blur(&y, w, h, &g);
                let sxx = blur(&sq(&x, &x), w, h, &g);
                let syy = blur(&sq(&y, &y), w, h, &g);
                let sxy = blur(&sq(&x, &y), w, h, &g);
                let mut da = vec![0.0; if grad { w * h } else { 0 }];
                let mut db = da.clone();
                let mut dd = da.clone();
                for i in 0..w * h {
                    let (ux, uy) = (mx[i], my[i]);
                    let vx = sxx[i] - ux * ux;
                    let vy = syy[i] - uy * uy;
                    let cxy = sxy[i] - ux * uy;
                    let n1 = 2.0 * ux * uy + C1;
                    let n2 = 2.0 * cxy + C2;
                    let d1 = ux * ux + uy * uy + C1;
                    let d2 = vx + vy + C2;
                    let s = n1 * n2 / (d1 * d2);
                    total += s;
                    if grad {
                        // S as a function of μx, Sxx = blur(x²), Sxy = blur(xy)
                        let ds_dvx = -s / d2;
                        let ds_dcxy = 2.0 * n1 / (d1 * d2);
                        da[i] = 2.0 * uy * n2 / (d1 * d2)
                            - 2.0 * ux * s / d1
                            - 2.0 * ux * ds_dvx
                            - uy * ds_dcxy;
                        db[i] = ds_dvx;
                        dd[i] = ds_dcxy;
                    }
                }
                let gch = grad.then(|| {
                    let ba = blur(&da, w, h, &g);
                    let bb = blur(&db, w, h, &g);
                    let bd = blur(&dd, w, h, &g);
                    (0..w * h)
                        .map(|i| (ba[i] + 2.0 * x[i] * bb[i] + y[i] * bd[i]) / n)
                        .collect()
                });
                (total, gch)
            })
            .collect();
        let total = per[0].0 + per[1].0 + per[2].0;
        let out = grad.then(|| {
            let c: Vec<&Vec<f64>> = per.iter().map(|p| p.1.as_ref().expect("grad")).collect();
            (0..w * h)
                .map(|i| [c[0][i] as f32, c[1][i] as f32, c[2][i] as f32])
                .collect()
        });
        (total / n, out)
    }

    fn random_image(w: usize, h: usize, seed: u64) -> Vec<[f32; 3]> {
        let mut r = Lcg(seed);
        (0..w * h)
            .map(|_| [r.range(0.0, 1.0), r.range(0.0, 1.0), r.range(0.0, 1.0)])
            .collect()
    }

    /// The tap-major row blur gives the bits of the plain per-pixel 11-tap
    /// sums (zero padding, taps in order), on widths below, at and above the
    /// window's; any change of order or padding makes it fail.
    #[test]
    fn row_blur_equals_the_per_pixel_sums() {
        let g = window();
        for w in [1, 3, 5, 6, 10, 11, 12, 37] {
            let mut r = Lcg(w as u64);
            let x: Vec<f64> = (0..w).map(|_| r.range(-1.0, 1.0) as f64).collect();
            let want: Vec<f64> = (0..w)
                .map(|xx| {
                    let mut acc = 0.0;
                    for (k, gk) in g.iter().enumerate() {
                        let sx = xx as isize + k as isize - 5;
                        if (0..w as isize).contains(&sx) {
                            acc += gk * x[sx as usize];
                        }
                    }
                    acc
                })
                .collect();
            let mut got = vec![0.0; w];
            blur_row(&x, &mut got, &g);
            assert!(
                want.iter()
                    .zip(&got)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "w = {w}"
            );
        }
    }

    /// The fused SSIM (rows in parallel, scratch reused between calls) gives
    /// the bits of the straightforward full-image form, value and gradient,
    /// on images narrower, shorter and larger than the window, twice in a
    /// row (the second call runs on the kept scratch).
    #[test]
    fn fused_ssim_equals_the_reference_bits() {
        for (w, h) in [(1, 1), (4, 3), (11, 11), (12, 7), (40, 23), (23, 40)] {
            let a = random_image(w, h, w as u64 * 7 + h as u64);
            let b = random_image(w, h, w as u64 * 5 + h as u64 + 1);
            let (rv, rg) = ssim_reference(&a, &b, w, h, true);
            let rg = rg.expect("grad");
            for _ in 0..2 {
                let (v, gr) = ssim_grad(&a, &b, w, h);
                assert_eq!(v.to_bits(), rv.to_bits(), "{w}×{h}: {v} vs {rv}");
                assert!(
                    gr.iter()
                        .flatten()
                        .zip(rg.iter().flatten())
                        .all(|(p, q)| p.to_bits() == q.to_bits()),
                    "{w}×{h}: gradient bits differ"
                );
                assert_eq!(ssim(&a, &b, w, h).to_bits(), rv.to_bits());
            }
        }
    }

    /// SSIM(x, x) = 1; PSNR of a constant offset d is −20·log10(d).
    #[test]
    fn identities() {
        let a = random_image(20, 15, 1);
        assert!((ssim(&a, &a, 20, 15) - 1.0).abs() < 1e-12);
        let b: Vec<[f32; 3]> = a.iter().map(|p| p.map(|v| v + 0.01)).collect();
        assert!((psnr(&a, &b) - 40.0).abs() < 1e-3);
        assert!((l1(&a, &b) - 0.01).abs() < 1e-6);
    }

    /// The SSIM gradient against central differences (f64 inside, step 1e-3
    /// on pixel values ~0.5: truncation O(h²) ≈ 1e-6 relative), every entry
    /// within 1e-3 relative or 1e-9 absolute.
    #[test]
    fn ssim_gradient_matches_finite_differences() {
        let (w, h) = (17, 13);
        let a = random_image(w, h, 2);
        let b = random_image(w, h, 3);
        let (_, g) = ssim_grad(&a, &b, w, h);
        for i in 0..w * h {
            for ch in 0..3 {
                let mut p = a.clone();
                let mut m = a.clone();
                p[i][ch] += 1e-3;
                m[i][ch] -= 1e-3;
                let fd = (ssim(&p, &b, w, h) - ssim(&m, &b, w, h)) / 2e-3;
                let an = g[i][ch] as f64;
                assert!(
                    (an - fd).abs() <= 1e-3 * fd.abs() + 1e-9,
                    "pixel {i} ch {ch}: {an} vs {fd}"
                );
            }
        }
    }
}
