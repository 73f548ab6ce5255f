//! Decoding of SOG versions 1 and 2 (layout in the module docs).

use rayon::prelude::*;

use super::webp;
use super::{Images, Meta};
use crate::io::budget;
use crate::model::Gaussians;
use crate::{Error, Result};

/// SH rest coefficients per channel for bands 1–3.
const SH_COEFFS: [usize; 4] = [0, 3, 8, 15];
const ALPHA_EPS: f64 = 1e-6;

// The decoding arithmetic is f64, rounded to f32 once at the end, as
// splat-transform's reader (JavaScript numbers into Float32Arrays) does: the
// two decodes of one file then agree to the last bit (f32 arithmetic differed
// by up to 12 ulps in positions after the exp of the log transform).

fn inv_log(v: f64) -> f32 {
    let e = v.abs().exp() - 1.0;
    (if v < 0.0 { -e } else { e }) as f32
}

fn sigmoid_inv(y: f64) -> f32 {
    let e = y.clamp(ALPHA_EPS, 1.0 - ALPHA_EPS);
    (e / (1.0 - e)).ln() as f32
}

/// Decodes a smallest-three quaternion texel to (w, x, y, z); an invalid tag
/// gives the identity.
fn unpack_quat(t: [u8; 4]) -> [f32; 4] {
    if t[3] < 252 {
        return [1.0, 0.0, 0.0, 0.0];
    }
    let largest = (t[3] - 252) as usize;
    let s = std::f32::consts::SQRT_2;
    let v = [t[0], t[1], t[2]].map(|b| (b as f32 / 255.0 * 2.0 - 1.0) / s);
    let mut q = [0f32; 4];
    let mut j = 0;
    for (i, c) in q.iter_mut().enumerate() {
        if i != largest {
            *c = v[j];
            j += 1;
        }
    }
    q[largest] = (1.0 - v.iter().map(|x| x * x).sum::<f32>()).max(0.0).sqrt();
    q
}

fn need<'m, T>(name: &str, v: &'m Option<T>, key: &str) -> Result<&'m T> {
    v.as_ref()
        .ok_or_else(|| Error::format(name, format!("meta.json: missing key {key:?}")))
}

fn need_len<T>(name: &str, v: &[T], n: usize, key: &str) -> Result<()> {
    if v.len() < n {
        return Err(Error::format(
            name,
            format!("meta.json: {key:?} has {} entries, expected {n}", v.len()),
        ));
    }
    Ok(())
}

fn file<'m>(name: &str, files: &'m [String], i: usize, key: &str) -> Result<&'m str> {
    files.get(i).map(String::as_str).ok_or_else(|| {
        Error::format(
            name,
            format!(
                "meta.json: {key:?}.files has {} names, expected {}",
                files.len(),
                i + 1
            ),
        )
    })
}

/// Decodes the scene `meta` describes, loading its images from `images`.
pub(super) fn decode(name: &str, meta: &Meta, images: &mut Images) -> Result<Gaussians> {
    let v2 = match meta.version {
        None => false,
        Some(2) => true,
        Some(v) => {
            return Err(Error::format(
                name,
                format!("meta.json: SOG version {v} is not supported (versions 1 and 2 are)"),
            ));
        }
    };
    let count = if v2 {
        *need(name, &meta.count, "count")?
    } else {
        *need(name, &meta.means.shape, "means.shape")?
            .first()
            .ok_or_else(|| Error::format(name, "meta.json: \"means.shape\" is empty"))?
    };
    let side = webp::MAX_SIDE as u64;
    if count > side * side {
        return Err(Error::format(
            name,
            format!("meta.json: count {count} is more than a {side}x{side} image holds"),
        ));
    }
    let n = count as usize;
    let (bands, k) = match &meta.sh_n {
        Some(s) if v2 => {
            let b = *need(name, &s.bands, "shN.bands")?;
            if !(1..=3).contains(&b) {
                return Err(Error::format(
                    name,
                    format!("meta.json: shN.bands {b} is not 1, 2 or 3"),
                ));
            }
            (b as usize, SH_COEFFS[b as usize])
        }
        _ => (0, 0),
    };
    // decoded model plus the (up to six) images
    budget::check(
        &format!("{name}: {n} SOG Gaussians"),
        (n as u64).saturating_mul(4 * (3 + 3 + 3 + 1 + 4 + 45) + 6 * 4),
    )?;
    need_len(name, &meta.means.mins, 3, "means.mins")?;
    need_len(name, &meta.means.maxs, 3, "means.maxs")?;
    // A per-Gaussian image is one texel per Gaussian in whole rows: a SOG
    // writer makes it just large enough (at most a few rows larger), so one
    // of more than twice the texels (+65,536) is refused.
    let per_gaussian = (count, count.saturating_mul(2).saturating_add(1 << 16));
    let mut img = |key: &str, files: &[String], i: usize, (min, max): (u64, u64)| {
        let f = file(name, files, i, key)?.to_string();
        let bytes = images.load(name, &f)?;
        webp::decode(&format!("{name}: {f}"), &bytes, min, max)
    };
    let lo = img("means", &meta.means.files, 0, per_gaussian)?;
    let hi = img("means", &meta.means.files, 1, per_gaussian)?;
    let quats = img("quats", &meta.quats.files, 0, per_gaussian)?;
    let scales = img("scales", &meta.scales.files, 0, per_gaussian)?;
    let sh0 = img("sh0", &meta.sh0.files, 0, per_gaussian)?;

    let mins = &meta.means.mins;
    let maxs = &meta.means.maxs;
    let span: [f64; 3] = std::array::from_fn(|a| {
        let s = maxs[a] - mins[a];
        if s == 0.0 { 1.0 } else { s }
    });
    let means: Vec<[f32; 3]> = (0..n)
        .into_par_iter()
        .map(|i| {
            let (l, h) = (lo.texel(i), hi.texel(i));
            std::array::from_fn(|a| {
                let q = l[a] as u32 | (h[a] as u32) << 8;
                inv_log(mins[a] + span[a] * (q as f64 / 65535.0))
            })
        })
        .collect();
    let rotations: Vec<[f32; 4]> = (0..n)
        .into_par_iter()
        .map(|i| unpack_quat(quats.texel(i)))
        .collect();

    let (log_scales, sh_dc, opacity_logits): (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<f32>) = if v2 {
        let sc = need(name, &meta.scales.codebook, "scales.codebook")?;
        let cc = need(name, &meta.sh0.codebook, "sh0.codebook")?;
        need_len(name, sc, 256, "scales.codebook")?;
        need_len(name, cc, 256, "sh0.codebook")?;
        (
            (0..n)
                .map(|i| {
                    let t = scales.texel(i);
                    [sc[t[0] as usize], sc[t[1] as usize], sc[t[2] as usize]]
                })
                .collect(),
            (0..n)
                .map(|i| {
                    let t = sh0.texel(i);
                    [cc[t[0] as usize], cc[t[1] as usize], cc[t[2] as usize]]
                })
                .collect(),
            (0..n)
                .map(|i| sigmoid_inv(sh0.texel(i)[3] as f64 / 255.0))
                .collect(),
        )
    } else {
        let smin = need(name, &meta.scales.mins, "scales.mins")?;
        let smax = need(name, &meta.scales.maxs, "scales.maxs")?;
        let cmin = need(name, &meta.sh0.mins, "sh0.mins")?;
        let cmax = need(name, &meta.sh0.maxs, "sh0.maxs")?;
        need_len(name, smin, 3, "scales.mins")?;
        need_len(name, smax, 3, "scales.maxs")?;
        need_len(name, cmin, 4, "sh0.mins")?;
        need_len(name, cmax, 4, "sh0.maxs")?;
        let lin = |lo: f64, hi: f64, b: u8| (lo + (hi - lo) * (b as f64 / 255.0)) as f32;
        (
            (0..n)
                .map(|i| {
                    let t = scales.texel(i);
                    std::array::from_fn(|a| lin(smin[a], smax[a], t[a]))
                })
                .collect(),
            (0..n)
                .map(|i| {
                    let t = sh0.texel(i);
                    std::array::from_fn(|a| lin(cmin[a], cmax[a], t[a]))
                })
                .collect(),
            (0..n)
                .map(|i| lin(cmin[3], cmax[3], sh0.texel(i)[3]))
                .collect(),
        )
    };

    let (sh_degree, sh_rest) = match &meta.sh_n {
        None => (0, Vec::new()),
        Some(s) => {
            // 16-bit labels address at most 65,536 palette entries, 64 to a
            // row of at most 15 coefficients: 960 × 1024 texels.
            let cent = img("shN", &s.files, 0, (0, 960 * 1024))?;
            let labels = img("shN", &s.files, 1, per_gaussian)?;
            let (bands, k) = if v2 {
                (bands, k)
            } else {
                let b = match cent.width {
                    192 => 1,
                    512 => 2,
                    960 => 3,
                    w => {
                        return Err(Error::format(
                            name,
                            format!(
                                "{}: SH centroid image is {w} wide, expected 192, 512 or 960",
                                s.files[0]
                            ),
                        ));
                    }
                };
                (b, SH_COEFFS[b])
            };
            if v2 && cent.width as usize != 64 * k {
                return Err(Error::format(
                    name,
                    format!(
                        "{}: SH centroid image is {} wide, expected {} for {bands} bands",
                        s.files[0],
                        cent.width,
                        64 * k
                    ),
                ));
            }
            // the palette entries → value of a centroid byte
            let table: Vec<f32> = if v2 {
                let cb = need(name, &s.codebook, "shN.codebook")?;
                need_len(name, cb, 256, "shN.codebook")?;
                cb[..256].to_vec()
            } else {
                let lo = *need(name, &s.mins, "shN.mins")?;
                let hi = *need(name, &s.maxs, "shN.maxs")?;
                (0..256)
                    .map(|b| (lo + (hi - lo) * (b as f64 / 255.0)) as f32)
                    .collect()
            };
            let palette_count = if v2 {
                *need(name, &s.count, "shN.count")?
            } else {
                (cent.width as u64 / k as u64) * cent.height as u64
            };
            let (cw, ch) = (cent.width as usize, cent.height as usize);
            let rest: Vec<f32> = (0..n)
                .into_par_iter()
                .flat_map_iter(|i| {
                    let t = labels.texel(i);
                    let label = t[0] as usize | (t[1] as usize) << 8;
                    let ok = (label as u64) < palette_count;
                    let (cy, cx0) = (label / 64, (label % 64) * k);
                    let cent = &cent;
                    let table = &table;
                    (0..k * 3).map(move |idx| {
                        let (j, c) = (idx / 3, idx % 3);
                        let cx = cx0 + j;
                        if ok && cy < ch && cx < cw {
                            table[cent.data[(cy * cw + cx) * 4 + c] as usize]
                        } else {
                            0.0
                        }
                    })
                })
                .collect();
            (bands, rest)
        }
    };
    let g = Gaussians {
        means,
        normals: None,
        sh_degree,
        sh_dc,
        sh_rest,
        opacity_logits,
        log_scales,
        rotations,
        extras: Default::default(),
    };
    g.validate().map_err(|e| e.in_file(name))?;
    Ok(g)
}
