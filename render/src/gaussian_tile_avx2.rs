//! The Gaussian forward blend of one tile, 8 pixels of a row at a time
//! (AVX2), chosen at run time where the CPU has AVX2.
//!
//! Same order as the scalar [`super::render_tile_scalar`]: the tile's list front to
//! back, each Gaussian visiting the rows of its pixel box; a row's 16 pixels
//! are two groups of 8 lanes, and a group is skipped when the box misses it.
//! Every lane does the scalar loop's f32 operations in the same order (power,
//! the skip tests, α with [`crate::exp_approx::exp8`], the early stop at
//! T < 1e-4, the accumulations and the 2DGS median rule), each rounded once,
//! and a lane that the scalar loop would skip is left unchanged by masks; so
//! the output is bit for bit the scalar one (the test
//! `avx2_tile_equals_the_scalar_tile` checks it on random scenes).

use std::arch::x86_64::*;

use super::{PixelOut, Projected, RasterSettings, pixel_span};
use crate::exp_approx::exp8;
use crate::tiles::{PREFETCH_DISTANCE, TILE, prefetch_ahead, tile_pixels};

const N: usize = TILE * TILE;

/// The tile's per-pixel accumulators, one array per quantity (row-major,
/// 16 per row), so 8 neighbouring pixels load as one vector.
struct Soa {
    t: [f32; N],
    c: [[f32; N]; 3],
    nsum: [[f32; N]; 3],
    dsum: [f32; N],
    wsum: [f32; N],
    median: [f32; N],
    n: [i32; N],
    last: [i32; N],
    /// All bits set once the pixel stopped (T would fall below 1e-4).
    done: [i32; N],
}

/// [`super::render_tile_scalar`] for AVX2 CPUs ([`super::render_tile`] picks).
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn render_tile(
    proj: &[Projected],
    list: &[u32],
    tx: usize,
    ty: usize,
    w: usize,
    h: usize,
    s: &RasterSettings,
) -> Vec<PixelOut> {
    let (x0, y0) = (tx * TILE, ty * TILE);
    let mut a = Box::new(Soa {
        t: [1.0; N],
        c: [[0.0; N]; 3],
        nsum: [[0.0; N]; 3],
        dsum: [0.0; N],
        wsum: [0.0; N],
        median: [0.0; N],
        n: [0; N],
        last: [0; N],
        done: [0; N],
    });
    let pixels = (((tx + 1) * TILE).min(w) - x0) * (((ty + 1) * TILE).min(h) - y0);
    let mut active = pixels as u32;
    let iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let (zero, half, one) = (
        _mm256_setzero_ps(),
        _mm256_set1_ps(0.5),
        _mm256_set1_ps(1.0),
    );
    let (cap, min_alpha, t_stop) = (
        _mm256_set1_ps(0.99),
        _mm256_set1_ps(1.0 / 255.0),
        _mm256_set1_ps(1e-4),
    );
    for (li, &pi) in list.iter().enumerate() {
        if active == 0 {
            break;
        }
        prefetch_ahead(proj, list, li + PREFETCH_DISTANCE);
        let p = &proj[pi as usize];
        let Some((xa, xb, ya, yb)) = pixel_span(p, tx, ty, w, h) else {
            continue;
        };
        let (c0, c1) = (_mm256_set1_ps(p.conic[0]), _mm256_set1_ps(p.conic[1]));
        let (mx, cut, op) = (
            _mm256_set1_ps(p.xy[0]),
            _mm256_set1_ps(p.power_cut),
            _mm256_set1_ps(p.opacity),
        );
        let rgb = [0, 1, 2].map(|k| _mm256_set1_ps(p.rgb[k]));
        let nrm = [0, 1, 2].map(|k| _mm256_set1_ps(p.normal[k]));
        let depth = _mm256_set1_ps(p.depth);
        let last_v = _mm256_set1_epi32(li as i32 + 1);
        let (lo, hi) = (
            _mm256_set1_epi32(xa as i32 - 1),
            _mm256_set1_epi32(xb as i32 + 1),
        );
        for y in ya..=yb {
            let dy = p.xy[1] - (y as f32 + 0.5);
            // the scalar loop's conic[2]·dy·dy, the same for the whole row
            let cyy = _mm256_set1_ps(p.conic[2] * dy * dy);
            let dyv = _mm256_set1_ps(dy);
            for g in 0..2 {
                let gx = x0 + 8 * g;
                if gx > xb || gx + 7 < xa {
                    continue;
                }
                let o = (y - y0) * TILE + 8 * g;
                // SAFETY: every load and store of the block reads or writes
                // [o, o + 8) of an N-array, and o + 8 ≤ N as the group's 8
                // pixels lie in the tile's 16 × 16.
                unsafe {
                    let xs = _mm256_add_epi32(_mm256_set1_epi32(gx as i32), iota);
                    let in_box =
                        _mm256_and_si256(_mm256_cmpgt_epi32(xs, lo), _mm256_cmpgt_epi32(hi, xs));
                    let done = _mm256_loadu_si256(a.done.as_ptr().add(o) as *const __m256i);
                    let lanes = _mm256_andnot_si256(done, in_box);
                    if _mm256_testz_si256(lanes, lanes) != 0 {
                        continue;
                    }
                    let dx = _mm256_sub_ps(mx, _mm256_add_ps(_mm256_cvtepi32_ps(xs), half));
                    // −0.5·(c0·dx·dx + c2·dy·dy) − c1·dx·dy, as the scalar loop
                    let q = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(c0, dx), dx), cyy);
                    let power = _mm256_sub_ps(
                        _mm256_mul_ps(_mm256_set1_ps(-0.5), q),
                        _mm256_mul_ps(_mm256_mul_ps(c1, dx), dyv),
                    );
                    let in_range = _mm256_and_ps(
                        _mm256_cmp_ps::<_CMP_LE_OQ>(power, zero),
                        _mm256_cmp_ps::<_CMP_GE_OQ>(power, cut),
                    );
                    let in_range = _mm256_and_ps(in_range, _mm256_castsi256_ps(lanes));
                    if _mm256_testz_ps(in_range, in_range) != 0 {
                        continue;
                    }
                    let alpha = _mm256_min_ps(_mm256_mul_ps(op, exp8(power)), cap);
                    let valid =
                        _mm256_and_ps(in_range, _mm256_cmp_ps::<_CMP_GE_OQ>(alpha, min_alpha));
                    if _mm256_testz_ps(valid, valid) != 0 {
                        continue;
                    }
                    let t = _mm256_loadu_ps(a.t.as_ptr().add(o));
                    let next = _mm256_mul_ps(t, _mm256_sub_ps(one, alpha));
                    let stop = _mm256_and_ps(valid, _mm256_cmp_ps::<_CMP_LT_OQ>(next, t_stop));
                    let upd = _mm256_andnot_ps(stop, valid);
                    let stops = _mm256_movemask_ps(stop);
                    if stops != 0 {
                        active -= stops.count_ones();
                        let d = _mm256_or_si256(done, _mm256_castps_si256(stop));
                        _mm256_storeu_si256(a.done.as_mut_ptr().add(o) as *mut __m256i, d);
                    }
                    if _mm256_testz_ps(upd, upd) != 0 {
                        continue;
                    }
                    let wgt = _mm256_mul_ps(alpha, t);
                    // acc[o..o + 8] += v·wgt on the updated lanes
                    macro_rules! add {
                        ($acc:expr, $v:expr) => {{
                            let ptr = $acc.as_mut_ptr().add(o);
                            let old = _mm256_loadu_ps(ptr);
                            let new = _mm256_add_ps(old, _mm256_mul_ps($v, wgt));
                            _mm256_storeu_ps(ptr, _mm256_blendv_ps(old, new, upd));
                        }};
                    }
                    for k in 0..3 {
                        add!(a.c[k], rgb[k]);
                        add!(a.nsum[k], nrm[k]);
                    }
                    add!(a.dsum, depth);
                    // 1·wgt is exactly wgt: the scalar loop's wsum += wgt
                    add!(a.wsum, one);
                    // 2DGS: the last contribution made while T before it > 0.5
                    let med = _mm256_and_ps(upd, _mm256_cmp_ps::<_CMP_GT_OQ>(t, half));
                    let mp = a.median.as_mut_ptr().add(o);
                    _mm256_storeu_ps(mp, _mm256_blendv_ps(_mm256_loadu_ps(mp), depth, med));
                    _mm256_storeu_ps(a.t.as_mut_ptr().add(o), _mm256_blendv_ps(t, next, upd));
                    let updi = _mm256_castps_si256(upd);
                    let np = a.n.as_mut_ptr().add(o) as *mut __m256i;
                    // upd lanes are −1: n − (−1) = n + 1
                    _mm256_storeu_si256(np, _mm256_sub_epi32(_mm256_loadu_si256(np), updi));
                    let lp = a.last.as_mut_ptr().add(o) as *mut __m256i;
                    let l = _mm256_blendv_epi8(_mm256_loadu_si256(lp), last_v, updi);
                    _mm256_storeu_si256(lp, l);
                }
            }
        }
    }
    let mut res = Vec::with_capacity(pixels);
    for (x, y) in tile_pixels(ty * w.div_ceil(TILE) + tx, w.div_ceil(TILE), w, h) {
        let i = (y - y0) * TILE + (x - x0);
        res.push(super::pixel_out(
            a.t[i],
            [a.c[0][i], a.c[1][i], a.c[2][i]],
            [a.nsum[0][i], a.nsum[1][i], a.nsum[2][i]],
            a.dsum[i],
            a.wsum[i],
            a.median[i],
            a.n[i] as u32,
            a.last[i] as u32,
            s,
        ));
    }
    res
}
