//! mkkellogg GaussianSplats3D `.ksplat` → [`Gaussians`] (read only).
//!
//! Layout (all little-endian), as GaussianSplats3D's `SplatBuffer.js` writes
//! and reads it (and splat-transform's `read-ksplat.ts` reads it):
//! - main header, 4096 bytes: `u8` version major (0) and minor (≥ 1); `u32`
//!   at 4 the section count, at 12 the largest splat count, at 16 the splat
//!   count; `u16` at 20 the compression level (0, 1 or 2); `f32` at 24..36
//!   the scene centre; `f32` at 36 and 40 the SH range of level 2 (0 means
//!   the default ±1.5);
//! - one 1024-byte header per section: `u32` at 0 the splat count, at 4 the
//!   capacity, at 8 the bucket size, at 12 the bucket count; `f32` at 16 the
//!   bucket block size; `u16` at 20 the bytes per bucket (12: three `f32`
//!   centre coordinates); `u32` at 24 the position quantisation range (0: the
//!   level's default, 32767), at 32 the full and at 36 the partially filled
//!   bucket counts; `u16` at 40 the SH degree;
//! - then per section: the partial buckets' sizes (`u32` each), the bucket
//!   centres, and `capacity` splat records.
//!
//! A record at level 0 is `f32` centre ×3, `f32` scale ×3 (linear),
//! `f32` rotation (w, x, y, z), `u8` r g b α, `f32` SH; at levels 1 and 2
//! the centre is `u16` ×3, decoded as (v − range)·(block/2)/range + the
//! bucket's centre, scale and rotation are half floats, and SH are half
//! floats (level 1) or bytes lerped over the header's SH range (level 2).
//! Colour is 0.5 + C0·f_dc and α = sigmoid(opacity), ×255. The SH of a
//! splat are stored band by band and, within a band, channel by channel
//! (band 1: r₀ r₁ r₂ g₀ g₁ g₂ b₀ b₁ b₂; band 2: r₃..r₇ g₃..g₇ b₃..b₇, …).
//!
//! Decoding follows splat-transform: scale ln(s), with s ≤ 0 read as
//! log scale −10; opacity logit(α/255) with α/255 clamped to
//! 1e−6..1−1e−6; colour (u/255 − 0.5)/C0. Splats come in file order
//! (bucketed by the writer, not the original order). The SH degree of the
//! result is the largest of the sections'; sections with fewer bands get
//! zeros.

use half::f16;

use super::SH_C0;
use crate::model::Gaussians;
use crate::{Error, Result};

const MAIN_HEADER: usize = 4096;
const SECTION_HEADER: usize = 1024;
const SH_COMPONENTS: [usize; 4] = [0, 9, 24, 45];

/// True when `bytes` start like a `.ksplat` main header: version 0.x with
/// x ≥ 1, compression level 0 to 2, at least one section, and room for
/// the headers. (A `.ksplat` has no magic; this is used with the extension.)
pub fn sniff(bytes: &[u8]) -> bool {
    bytes.len() >= MAIN_HEADER
        && bytes[0] == 0
        && bytes[1] >= 1
        && u16_at(bytes, 20) <= 2
        && u32_at(bytes, 4) >= 1
}

fn u16_at(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}
fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes(b[o..o + 4].try_into().expect("4 bytes"))
}
fn f32_at(b: &[u8], o: usize) -> f32 {
    f32::from_le_bytes(b[o..o + 4].try_into().expect("4 bytes"))
}
fn h_at(b: &[u8], o: usize) -> f32 {
    f16::from_bits(u16_at(b, o)).to_f32()
}

struct Section {
    count: usize,
    capacity: usize,
    bucket_size: usize,
    bucket_count: usize,
    block: f32,
    bucket_bytes: usize,
    range: u32,
    full: usize,
    partial: usize,
    degree: usize,
}

/// Parses a `.ksplat` (`name` for errors).
pub fn read(name: &str, bytes: &[u8]) -> Result<Gaussians> {
    let err = |m: String| Error::format(name, m);
    if bytes.len() < MAIN_HEADER {
        return Err(err(format!(
            "a .ksplat starts with a {MAIN_HEADER}-byte header; this file has {} bytes",
            bytes.len()
        )));
    }
    let (major, minor) = (bytes[0], bytes[1]);
    if major != 0 || minor < 1 {
        return Err(err(format!(
            "unsupported .ksplat version {major}.{minor} (splatkit reads 0.1 and later 0.x)"
        )));
    }
    let sections = u32_at(bytes, 4) as usize;
    let total = u32_at(bytes, 16) as usize;
    let level = u16_at(bytes, 20);
    if level > 2 {
        return Err(err(format!(
            "compression level {level} at byte 20: a .ksplat has 0, 1 or 2"
        )));
    }
    let sh_min = match f32_at(bytes, 36) {
        0.0 => -1.5,
        v => v,
    };
    let sh_max = match f32_at(bytes, 40) {
        0.0 => 1.5,
        v => v,
    };
    let headers_end = (sections as u64)
        .saturating_mul(SECTION_HEADER as u64)
        .saturating_add(MAIN_HEADER as u64);
    if headers_end > bytes.len() as u64 {
        return Err(err(format!(
            "the header declares {sections} sections ({headers_end} bytes of headers), more than \
             the file's {} bytes",
            bytes.len()
        )));
    }
    let mut secs = Vec::with_capacity(sections);
    for s in 0..sections {
        let h = &bytes[MAIN_HEADER + s * SECTION_HEADER..MAIN_HEADER + (s + 1) * SECTION_HEADER];
        let degree = u16_at(h, 40) as usize;
        if degree > 3 {
            return Err(err(format!("section {s}: SH degree {degree} (at most 3)")));
        }
        let sec = Section {
            count: u32_at(h, 0) as usize,
            capacity: u32_at(h, 4) as usize,
            bucket_size: u32_at(h, 8) as usize,
            bucket_count: u32_at(h, 12) as usize,
            block: f32_at(h, 16),
            bucket_bytes: u16_at(h, 20) as usize,
            range: match u32_at(h, 24) {
                0 if level == 0 => 1,
                0 => 32767,
                r => r,
            },
            full: u32_at(h, 32) as usize,
            partial: u32_at(h, 36) as usize,
            degree,
        };
        if sec.count > sec.capacity {
            return Err(err(format!(
                "section {s}: {} splats but room for {}",
                sec.count, sec.capacity
            )));
        }
        if level >= 1 && sec.count > 0 && sec.bucket_bytes < 12 {
            return Err(err(format!(
                "section {s}: {} bytes per bucket, expected 12 (three f32)",
                sec.bucket_bytes
            )));
        }
        secs.push(sec);
    }
    let count_sum: usize = secs.iter().map(|s| s.count).sum();
    if count_sum != total {
        return Err(err(format!(
            "the header declares {total} splats and its sections hold {count_sum}"
        )));
    }
    let degree = secs
        .iter()
        .filter(|s| s.count > 0)
        .map(|s| s.degree)
        .max()
        .unwrap_or(0);
    let k = (degree + 1) * (degree + 1) - 1;
    // every splat is at least 24 bytes in the file, so `total` is bounded
    // by the file length before this allocation
    if (total as u64).saturating_mul(24) > bytes.len() as u64 {
        return Err(err(format!(
            "{total} splats cannot fit in {} bytes",
            bytes.len()
        )));
    }
    crate::io::budget::check(
        &format!("{name}: {total} Gaussians"),
        (total as u64).saturating_mul(60 + 12 * k as u64),
    )?;
    let mut g = Gaussians {
        sh_degree: degree,
        means: Vec::with_capacity(total),
        sh_dc: Vec::with_capacity(total),
        sh_rest: Vec::with_capacity(total * 3 * k),
        opacity_logits: Vec::with_capacity(total),
        log_scales: Vec::with_capacity(total),
        rotations: Vec::with_capacity(total),
        ..Default::default()
    };
    let mut base = headers_end as usize;
    for (si, s) in secs.iter().enumerate() {
        let comps = SH_COMPONENTS[s.degree];
        let per_splat = match level {
            0 => 44 + comps * 4,
            1 => 24 + comps * 2,
            _ => 24 + comps,
        };
        let meta = s.partial as u64 * 4;
        let buckets = meta + (s.bucket_bytes as u64).saturating_mul(s.bucket_count as u64);
        let data = (per_splat as u64).saturating_mul(s.capacity as u64);
        let end = (base as u64).saturating_add(buckets).saturating_add(data);
        if end > bytes.len() as u64 {
            return Err(err(format!(
                "section {si} (at byte {base}) needs {} bytes, and the file ends at {}",
                buckets + data,
                bytes.len()
            )));
        }
        let partial_sizes: Vec<usize> = (0..s.partial)
            .map(|i| u32_at(bytes, base + 4 * i) as usize)
            .collect();
        let centres_at = base + meta as usize;
        let records = &bytes[base + buckets as usize..end as usize];
        let scale = s.block as f64 / 2.0 / s.range as f64;
        let (mut bucket, mut partial_base, mut partial_i) = (s.full, s.full * s.bucket_size, 0);
        for j in 0..s.count {
            let r = &records[j * per_splat..(j + 1) * per_splat];
            let pos = if level == 0 {
                [f32_at(r, 0), f32_at(r, 4), f32_at(r, 8)]
            } else {
                let b = if j < s.full * s.bucket_size {
                    j / s.bucket_size.max(1)
                } else {
                    while partial_i < partial_sizes.len()
                        && j >= partial_base + partial_sizes[partial_i]
                    {
                        partial_base += partial_sizes[partial_i];
                        partial_i += 1;
                        bucket += 1;
                    }
                    bucket
                };
                if b >= s.bucket_count {
                    return Err(err(format!(
                        "section {si}, splat {j}: bucket {b} of {}",
                        s.bucket_count
                    )));
                }
                let c = centres_at + b * s.bucket_bytes;
                [0, 1, 2].map(|a| {
                    let q = u16_at(r, 2 * a) as f64;
                    ((q - s.range as f64) * scale + f32_at(bytes, c + 4 * a) as f64) as f32
                })
            };
            let (scales, rot): ([f32; 3], [f32; 4]) = if level == 0 {
                (
                    [f32_at(r, 12), f32_at(r, 16), f32_at(r, 20)],
                    [f32_at(r, 24), f32_at(r, 28), f32_at(r, 32), f32_at(r, 36)],
                )
            } else {
                (
                    [h_at(r, 6), h_at(r, 8), h_at(r, 10)],
                    [h_at(r, 12), h_at(r, 14), h_at(r, 16), h_at(r, 18)],
                )
            };
            let c = if level == 0 { 40 } else { 20 };
            g.means.push(pos);
            g.log_scales.push(scales.map(|v| {
                if v > 0.0 {
                    (v as f64).ln() as f32
                } else {
                    -10.0
                }
            }));
            g.rotations.push(rot);
            g.sh_dc
                .push([0, 1, 2].map(|a| ((r[c + a] as f64 / 255.0 - 0.5) / SH_C0) as f32));
            let a = (r[c + 3] as f64 / 255.0).clamp(1e-6, 1.0 - 1e-6);
            g.opacity_logits.push((a / (1.0 - a)).ln() as f32);
            // SH: band by band, channel by channel within a band
            let sh_at = c + 4;
            let value = |i: usize| -> f32 {
                match level {
                    0 => f32_at(r, sh_at + 4 * i),
                    1 => h_at(r, sh_at + 2 * i),
                    _ => {
                        (sh_min as f64 + r[sh_at + i] as f64 / 255.0 * (sh_max - sh_min) as f64)
                            as f32
                    }
                }
            };
            let start = g.sh_rest.len();
            g.sh_rest.resize(start + 3 * k, 0.0);
            for i in 0..comps {
                let (ch, coeff) = if i < 9 {
                    (i / 3, i % 3)
                } else if i < 24 {
                    ((i - 9) / 5, (i - 9) % 5 + 3)
                } else {
                    ((i - 24) / 7, (i - 24) % 7 + 8)
                };
                g.sh_rest[start + coeff * 3 + ch] = value(i);
            }
        }
        base = end as usize;
    }
    Ok(g)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A level-1 file with one section, two buckets (one full of 2 splats,
    /// one partial of 1), SH degree 1, built by hand from the layout.
    fn level1() -> Vec<u8> {
        let mut b = vec![0u8; MAIN_HEADER + SECTION_HEADER];
        b[1] = 1;
        b[4..8].copy_from_slice(&1u32.to_le_bytes());
        b[8..12].copy_from_slice(&1u32.to_le_bytes());
        b[12..16].copy_from_slice(&3u32.to_le_bytes());
        b[16..20].copy_from_slice(&3u32.to_le_bytes());
        b[20..22].copy_from_slice(&1u16.to_le_bytes());
        let h = MAIN_HEADER;
        for (o, v) in [
            (0, 3u32),
            (4, 3),
            (8, 2),
            (12, 2),
            (24, 100),
            (32, 1),
            (36, 1),
        ] {
            b[h + o..h + o + 4].copy_from_slice(&v.to_le_bytes());
        }
        b[h + 16..h + 20].copy_from_slice(&2.0f32.to_le_bytes());
        b[h + 20..h + 22].copy_from_slice(&12u16.to_le_bytes());
        b[h + 40..h + 42].copy_from_slice(&1u16.to_le_bytes());
        b.extend_from_slice(&1u32.to_le_bytes()); // the partial bucket holds 1
        for c in [0.0f32, 0.0, 0.0, 10.0, 20.0, 30.0] {
            b.extend_from_slice(&c.to_le_bytes());
        }
        for j in 0..3u16 {
            // position: range + 50·j → +0.5·j units (block 2, range 100)
            for _ in 0..3 {
                b.extend_from_slice(&(100 + 50 * j).to_le_bytes());
            }
            for s in [1.0f32, 0.5, 2.0] {
                b.extend_from_slice(&f16::from_f32(s).to_bits().to_le_bytes());
            }
            for q in [1.0f32, 0.0, 0.0, 0.0] {
                b.extend_from_slice(&f16::from_f32(q).to_bits().to_le_bytes());
            }
            b.extend_from_slice(&[255, 0, 128, 255]);
            for i in 0..9 {
                b.extend_from_slice(&f16::from_f32(i as f32 * 0.125).to_bits().to_le_bytes());
            }
        }
        b
    }

    #[test]
    fn decodes_a_hand_made_level1_file() {
        let g = read("a.ksplat", &level1()).unwrap();
        assert_eq!((g.len(), g.sh_degree), (3, 1));
        assert_eq!(g.means[0], [0.0; 3]);
        assert_eq!(g.means[1], [0.5; 3]);
        // the third splat is in the partial bucket centred at (10, 20, 30)
        assert_eq!(g.means[2], [11.0, 21.0, 31.0]);
        assert_eq!(g.log_scales[0], [0.0, 0.5f32.ln(), 2.0f32.ln()]);
        assert_eq!(g.rotations[0], [1.0, 0.0, 0.0, 0.0]);
        assert!((g.sh_dc[0][0] as f64 - 0.5 / SH_C0).abs() < 1e-6);
        // band 1 is r0 r1 r2 g0 g1 g2 b0 b1 b2 in the file; memory is (k, c)
        let rest = &g.sh_rest[0..9];
        assert_eq!(rest[0], 0.0); // k0 r
        assert_eq!(rest[1], 0.375); // k0 g = file 3
        assert_eq!(rest[2], 0.75); // k0 b = file 6
        assert_eq!(rest[3], 0.125); // k1 r = file 1
        assert!(sniff(&level1()));
    }

    #[test]
    fn truncated_and_bad_headers_are_refused() {
        let b = level1();
        let e = read("a.ksplat", &b[..b.len() - 1]).unwrap_err().to_string();
        assert!(e.starts_with("a.ksplat: section 0"), "{e}");
        let mut c = b.clone();
        c[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = read("a.ksplat", &c).unwrap_err().to_string();
        assert!(e.contains("sections"), "{e}");
        let mut c = b.clone();
        c[20] = 7;
        assert!(read("a.ksplat", &c).is_err());
        let mut c = b;
        c[16..20].copy_from_slice(&9u32.to_le_bytes());
        let e = read("a.ksplat", &c).unwrap_err().to_string();
        assert!(e.contains("declares 9 splats"), "{e}");
        assert!(read("a.ksplat", b"short").is_err());
    }
}
