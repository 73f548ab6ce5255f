//! The SOG writer: version 2, bundled as one zip.

use std::io::{Cursor, Write};

use rayon::prelude::*;

use super::codebook::{palette, quantize_1d};
use super::webp::{self, MAX_SIDE};
use crate::model::Gaussians;
use crate::model::gaussians::sigmoid;
use crate::{Error, Result};

const SH_COEFFS: [usize; 4] = [0, 3, 8, 15];

fn log_transform(v: f32) -> f32 {
    v.signum() * (v.abs() + 1.0).ln()
}

/// Spreads the low 10 bits of `v` to every third bit.
fn part1by2(v: u32) -> u32 {
    let mut x = v & 0x3ff;
    x = (x | (x << 16)) & 0x0300_00ff;
    x = (x | (x << 8)) & 0x0300_f00f;
    x = (x | (x << 4)) & 0x030c_30c3;
    x = (x | (x << 2)) & 0x0924_9249;
    x
}

/// The order of the texels: Morton (Z-order) codes of the positions with 10
/// bits per axis over the bounding box, ties by index.
pub(super) fn morton_order(means: &[[f32; 3]]) -> Vec<u32> {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for m in means {
        for a in 0..3 {
            lo[a] = lo[a].min(m[a]);
            hi[a] = hi[a].max(m[a]);
        }
    }
    let code = |m: &[f32; 3]| {
        let mut c = 0u32;
        for a in 0..3 {
            let s = hi[a] - lo[a];
            let t = if s > 0.0 { (m[a] - lo[a]) / s } else { 0.0 };
            c |= part1by2((t * 1023.0).round().clamp(0.0, 1023.0) as u32) << a;
        }
        c
    };
    let mut keyed: Vec<(u32, u32)> = means
        .par_iter()
        .enumerate()
        .map(|(i, m)| (code(m), i as u32))
        .collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

fn refuse(name: &str, i: usize, what: &str, v: impl std::fmt::Display, why: &str) -> Error {
    Error::invalid(format!(
        "{name}: Gaussian {i}: {what} {v} {why}; SOG would change it (allow lossy conversion to \
         write it anyway)"
    ))
}

/// Refuses what SOG cannot hold: non-finite values, zero quaternions,
/// non-zero normals and extra per-Gaussian properties (dropped).
fn check_lossless(name: &str, g: &Gaussians) -> Result<()> {
    if let Some(p) = g.extras.item.first() {
        return Err(Error::invalid(format!(
            "{name}: SOG cannot store the extra property {:?} (allow lossy conversion to drop it)",
            p.name
        )));
    }
    if let Some(nrm) = &g.normals
        && let Some(i) = nrm.iter().position(|v| v.iter().any(|&c| c != 0.0))
    {
        return Err(refuse(
            name,
            i,
            "normal",
            format!("{:?}", nrm[i]),
            "is not zero and would be dropped",
        ));
    }
    let k3 = g.rest_per_channel() * 3;
    for i in 0..g.len() {
        let checks: [(&str, &[f32]); 6] = [
            ("position", &g.means[i]),
            ("log-scale", &g.log_scales[i]),
            ("SH DC", &g.sh_dc[i]),
            ("opacity logit", std::slice::from_ref(&g.opacity_logits[i])),
            ("rotation", &g.rotations[i]),
            ("SH rest", &g.sh_rest[i * k3..(i + 1) * k3]),
        ];
        for (what, vals) in checks {
            if let Some(v) = vals.iter().find(|v| !v.is_finite()) {
                return Err(refuse(name, i, what, v, "is not finite"));
            }
        }
        if g.rotations[i].iter().all(|&c| c == 0.0) {
            return Err(refuse(
                name,
                i,
                "rotation",
                "[0, 0, 0, 0]",
                "has no direction",
            ));
        }
    }
    Ok(())
}

/// Non-finite values made writable (lossy mode): NaN → 0; infinite positions
/// → ±1e30; infinite SH rest → ±1e6; log-scales, DC and opacity keep ±∞
/// (the codebook gives them end entries).
fn sanitised(g: &Gaussians) -> Gaussians {
    let fix = |v: f32, inf: f32| {
        if v.is_nan() {
            0.0
        } else if v.is_infinite() {
            inf.copysign(v)
        } else {
            v
        }
    };
    let mut h = g.clone();
    h.means
        .iter_mut()
        .flatten()
        .for_each(|v| *v = fix(*v, 1e30));
    h.sh_rest.iter_mut().for_each(|v| *v = fix(*v, 1e6));
    for v in h
        .log_scales
        .iter_mut()
        .flatten()
        .chain(h.sh_dc.iter_mut().flatten())
        .chain(h.opacity_logits.iter_mut())
    {
        if v.is_nan() {
            *v = 0.0;
        }
    }
    h
}

/// Packs a (w, x, y, z) quaternion as a SOG texel (smallest three).
fn pack_quat(q: [f32; 4]) -> [u8; 4] {
    let l = q.iter().map(|v| v * v).sum::<f32>().sqrt();
    let q = if l > 0.0 && l.is_finite() {
        q.map(|v| v / l)
    } else {
        [1.0, 0.0, 0.0, 0.0]
    };
    let mut m = 0;
    for i in 1..4 {
        if q[i].abs() > q[m].abs() {
            m = i;
        }
    }
    let s = if q[m] < 0.0 { -1.0 } else { 1.0 } * std::f32::consts::SQRT_2;
    let mut t = [0u8; 4];
    let mut j = 0;
    for (i, &c) in q.iter().enumerate() {
        if i != m {
            t[j] = (255.0 * (c * s * 0.5 + 0.5)).round().clamp(0.0, 255.0) as u8;
            j += 1;
        }
    }
    t[3] = 252 + m as u8;
    t
}

/// Writes Gaussians (PLY axes) as a bundled SOG (version 2): a zip holding
/// `means_l.webp`, `means_u.webp`, `quats.webp`, `scales.webp`, `sh0.webp`,
/// with SH `shN_centroids.webp` and `shN_labels.webp`, and `meta.json`.
///
/// Rules as splat-transform's writer, with these departures: positions,
/// quaternion components and opacity are rounded to the nearest code (it
/// truncates, doubling the worst error); the texel order is a Morton order of
/// our own (any order is valid); the SH palette is built by the deterministic
/// k-means of [`super::palette`] (splat-transform seeds at random). The
/// palette has min(64, 2^⌊log2(n/1024)⌋)·1024 entries, as splat-transform.
///
/// With `lossy == false` refuses (naming `name`, the Gaussian and the value)
/// non-finite values, zero quaternions, non-zero normals and extra
/// properties, all of which SOG would change or drop; with `lossy == true`
/// writes them (non-finite values as in `sanitised`, normals and extras
/// dropped). Empty input and more Gaussians than a 16383×16383 image holds
/// are always refused.
pub fn write(name: &str, g: &Gaussians, lossy: bool) -> Result<Vec<u8>> {
    g.validate().map_err(|e| e.in_file(name))?;
    let n = g.len();
    if n == 0 {
        return Err(Error::invalid(format!(
            "{name}: SOG cannot hold zero Gaussians"
        )));
    }
    let width = ((n as f64).sqrt() / 4.0).ceil() as usize * 4;
    let height = (n as f64 / width as f64 / 4.0).ceil() as usize * 4;
    if width > MAX_SIDE as usize || height > MAX_SIDE as usize {
        return Err(Error::invalid(format!(
            "{name}: {n} Gaussians need {width}x{height} images, above WebP's {MAX_SIDE} per side"
        )));
    }
    let owned;
    let g = if lossy {
        owned = sanitised(g);
        &owned
    } else {
        check_lossless(name, g)?;
        g
    };
    let order = morton_order(&g.means);
    let texels = width * height;
    let mut files: Vec<(&str, Vec<u8>)> = Vec::new();
    let encode = |f: &str, data: &[u8], w: usize, h: usize| {
        webp::encode(&format!("{name}: {f}"), data, w as u32, h as u32)
    };

    // means
    let mut mins = [f32::INFINITY; 3];
    let mut maxs = [f32::NEG_INFINITY; 3];
    for m in &g.means {
        for a in 0..3 {
            mins[a] = mins[a].min(m[a]);
            maxs[a] = maxs[a].max(m[a]);
        }
    }
    let (mins, maxs) = (mins.map(log_transform), maxs.map(log_transform));
    let mut lo = vec![0u8; texels * 4];
    let mut hi = vec![0u8; texels * 4];
    for (t, &gi) in order.iter().enumerate() {
        let m = g.means[gi as usize];
        for a in 0..3 {
            let span = maxs[a] - mins[a];
            let q = if span > 0.0 {
                (65535.0 * (log_transform(m[a]) - mins[a]) / span)
                    .round()
                    .clamp(0.0, 65535.0) as u32
            } else {
                0
            };
            lo[t * 4 + a] = q as u8;
            hi[t * 4 + a] = (q >> 8) as u8;
        }
        lo[t * 4 + 3] = 255;
        hi[t * 4 + 3] = 255;
    }

    // quaternions
    let mut quats = vec![0u8; texels * 4];
    quats
        .par_chunks_exact_mut(4)
        .zip(order.par_iter())
        .for_each(|(t, &gi)| t.copy_from_slice(&pack_quat(g.rotations[gi as usize])));

    // scales: one codebook for the three axes
    let cols: [Vec<f32>; 3] = std::array::from_fn(|a| g.log_scales.iter().map(|s| s[a]).collect());
    let sq = quantize_1d(&[&cols[0], &cols[1], &cols[2]], 256, 0.5);
    let mut scales = vec![0u8; texels * 4];
    for (t, &gi) in order.iter().enumerate() {
        for a in 0..3 {
            scales[t * 4 + a] = sq.labels[a][gi as usize];
        }
        scales[t * 4 + 3] = 255;
    }

    // DC colour + opacity
    let cols: [Vec<f32>; 3] = std::array::from_fn(|a| g.sh_dc.iter().map(|s| s[a]).collect());
    let cq = quantize_1d(&[&cols[0], &cols[1], &cols[2]], 256, 0.5);
    let mut sh0 = vec![0u8; texels * 4];
    for (t, &gi) in order.iter().enumerate() {
        let i = gi as usize;
        for a in 0..3 {
            sh0[t * 4 + a] = cq.labels[a][i];
        }
        sh0[t * 4 + 3] = (sigmoid(g.opacity_logits[i]) * 255.0)
            .round()
            .clamp(0.0, 255.0) as u8;
    }

    let ((lo_w, hi_w), (q_w, (s_w, c_w))) = rayon::join(
        || {
            rayon::join(
                || encode("means_l.webp", &lo, width, height),
                || encode("means_u.webp", &hi, width, height),
            )
        },
        || {
            rayon::join(
                || encode("quats.webp", &quats, width, height),
                || {
                    rayon::join(
                        || encode("scales.webp", &scales, width, height),
                        || encode("sh0.webp", &sh0, width, height),
                    )
                },
            )
        },
    );
    files.push(("means_l.webp", lo_w?));
    files.push(("means_u.webp", hi_w?));
    files.push(("quats.webp", q_w?));
    files.push(("scales.webp", s_w?));
    files.push(("sh0.webp", c_w?));

    let mut meta = serde_json::json!({
        "version": 2,
        "asset": { "generator": concat!("splatkit v", env!("CARGO_PKG_VERSION")) },
        "count": n,
        "means": { "mins": mins, "maxs": maxs, "files": ["means_l.webp", "means_u.webp"] },
        "scales": { "codebook": sq.centroids, "files": ["scales.webp"] },
        "quats": { "files": ["quats.webp"] },
        "sh0": { "codebook": cq.centroids, "files": ["sh0.webp"] },
    });

    let k = SH_COEFFS[g.sh_degree];
    if k > 0 {
        // rows in splat-transform's channel-major f_rest order: [c·k + j]
        let dim = 3 * k;
        let rows: Vec<f32> = (0..n)
            .flat_map(|i| {
                (0..dim).map(move |d| {
                    let (c, j) = (d / k, d % k);
                    g.sh_rest[(i * k + j) * 3 + c]
                })
            })
            .collect();
        let count = (1024.0 * ((n as f64 / 1024.0).log2().floor()).exp2()).min(65536.0) as usize;
        let (cent, labels) = palette(&rows, dim, count.max(1));
        let nc = cent.len() / dim;
        let cols: Vec<Vec<f32>> = (0..dim)
            .map(|d| (0..nc).map(|i| cent[i * dim + d]).collect())
            .collect();
        let col_refs: Vec<&[f32]> = cols.iter().map(Vec::as_slice).collect();
        let pq = quantize_1d(&col_refs, 256, 0.5);
        let (cw, ch) = (64 * k, nc.div_ceil(64));
        let mut cbuf = vec![0u8; cw * ch * 4];
        for i in 0..nc {
            for j in 0..k {
                let o = (i * k + j) * 4;
                for c in 0..3 {
                    cbuf[o + c] = pq.labels[c * k + j][i];
                }
                cbuf[o + 3] = 255;
            }
        }
        let mut lbuf = vec![0u8; texels * 4];
        for (t, &gi) in order.iter().enumerate() {
            let l = labels[gi as usize];
            lbuf[t * 4] = l as u8;
            lbuf[t * 4 + 1] = (l >> 8) as u8;
            lbuf[t * 4 + 3] = 255;
        }
        files.push((
            "shN_centroids.webp",
            encode("shN_centroids.webp", &cbuf, cw, ch)?,
        ));
        files.push((
            "shN_labels.webp",
            encode("shN_labels.webp", &lbuf, width, height)?,
        ));
        meta["shN"] = serde_json::json!({
            "count": count,
            "bands": g.sh_degree,
            "codebook": pq.centroids,
            "files": ["shN_centroids.webp", "shN_labels.webp"],
        });
    }
    let meta_bytes = serde_json::to_vec(&meta).expect("JSON of plain numbers");
    files.push(("meta.json", meta_bytes));

    let zerr = |e: zip::result::ZipError| Error::invalid(format!("{name}: writing the zip: {e}"));
    let mut z = zip::ZipWriter::new(Cursor::new(Vec::new()));
    for (f, data) in &files {
        let method = if f.ends_with(".json") {
            zip::CompressionMethod::Deflated
        } else {
            zip::CompressionMethod::Stored
        };
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(method)
            .last_modified_time(zip::DateTime::default());
        z.start_file(*f, opts).map_err(zerr)?;
        z.write_all(data).map_err(|e| Error::io(name, e))?;
    }
    Ok(z.finish().map_err(zerr)?.into_inner())
}
