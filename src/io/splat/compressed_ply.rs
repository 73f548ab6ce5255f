//! SuperSplat / PlayCanvas compressed PLY ↔ [`Gaussians`].
//!
//! Layout (binary little-endian PLY), as PlayCanvas's engine
//! (`gsplat-compressed-data.js`) reads it and `@playcanvas/splat-transform`
//! (`compressed-chunk.ts`, `write-compressed-ply.ts`, `decompress-ply.ts`)
//! writes it:
//! - `element chunk ⌈N/256⌉`: `float min_x min_y min_z max_x max_y max_z
//!   min_scale_x … max_scale_z` and, in the 18-float layout,
//!   `min_r min_g min_b max_r max_g max_b` (older files have 12 floats and
//!   store colour as a plain unorm);
//! - `element vertex N`: `uint packed_position packed_rotation packed_scale
//!   packed_color`; Gaussian i belongs to chunk ⌊i/256⌋;
//! - optional `element sh N`: `uchar f_rest_0 … f_rest_{3K−1}` (K = 3, 8 or
//!   15, channel-major as in a 3DGS PLY).
//!
//! Values: position and log scale are 11-10-11-bit unorms (x in the top
//! bits) lerped between the chunk's min and max; colour 0.5 + C0·f_dc is an
//! 8-bit unorm lerped between the chunk's colour bounds, opacity sigmoid(v)
//! a plain 8-bit unorm (bits 24..31 r, 16..23 g, 8..15 b, 0..7 α);
//! rotation: bits 30..31 index the largest-magnitude component of the
//! normalised (w, x, y, z) quaternion (made positive), bits 20..29, 10..19
//! and 0..9 the other three in order, each as v·√2/2 + 0.5 in 10 bits; SH
//! rest: byte b = trunc((v/8 + 0.5)·256) clamped to 0..255, read back as
//! (n − 0.5)·8 with n = 0 for b = 0, 1 for b = 255, else (b + 0.5)/256
//! (splat-transform's decoder; PlayCanvas's viewer uses b·8/255 − 4, at most
//! 0.016 away). Opacity is decoded as logit(α) with α = 0 → −40 and α = 1 →
//! +40, as the engine does (splat-transform gives ±∞). Unorms are packed
//! with ⌊x·(2ᵇ−1) + 0.5⌋; all arithmetic is in f64 as in the JavaScript.
//!
//! The writer sorts the Gaussians into Morton order first
//! ([`super::morton_order`]), as splat-transform does, so each chunk is a
//! small region of space; log-scale bounds are clamped to −20..20.
//! A zero quaternion is written as the identity (splat-transform's
//! normalisation turns it into (0, 0, 0, 1) in file order, a half turn).

use super::{Capacity, SH_C0, check_lossless, logit_unorm, morton_order, sigmoid64};
use crate::io::ply::PlyReader;
use crate::io::ply::header::{ElementDef, PropertyKind};
use crate::model::{Column, Element, Extras, Gaussians, ScalarData, ScalarType};
use crate::{Error, Result};

/// Gaussians per chunk.
pub const CHUNK: usize = 256;

/// What compressed PLY holds without clamping or dropping.
pub const CAPACITY: Capacity = Capacity {
    format: "compressed PLY",
    sh_degree: 3,
    colour: None,
    log_scale: Some((-20.0, 20.0)),
    sh_rest: Some((-4.0, 4.0)),
};

const CHUNK_PROPS: [&str; 18] = [
    "min_x",
    "min_y",
    "min_z",
    "max_x",
    "max_y",
    "max_z",
    "min_scale_x",
    "min_scale_y",
    "min_scale_z",
    "max_scale_x",
    "max_scale_y",
    "max_scale_z",
    "min_r",
    "min_g",
    "min_b",
    "max_r",
    "max_g",
    "max_b",
];
const VERTEX_PROPS: [&str; 4] = [
    "packed_position",
    "packed_rotation",
    "packed_scale",
    "packed_color",
];

/// True when the header declares a compressed PLY (`packed_position` on the
/// vertex element).
pub fn sniff(bytes: &[u8]) -> bool {
    super::SplatFormat::sniff(bytes) == Some(super::SplatFormat::CompressedPly)
}

fn col<'a>(name: &str, e: &'a Element, prop: &str, ty: ScalarType) -> Result<&'a ScalarData> {
    let data = e
        .property(prop)
        .and_then(Column::as_scalar)
        .ok_or_else(|| {
            Error::format(
                name,
                format!("element '{}' has no scalar property '{prop}'", e.name),
            )
        })?;
    if data.scalar_type() != ty {
        return Err(Error::format(
            name,
            format!(
                "property '{prop}' of element '{}' is {}, expected {}",
                e.name,
                data.scalar_type().name(),
                ty.name()
            ),
        ));
    }
    Ok(data)
}

fn check_header(name: &str, elements: &[ElementDef]) -> Result<()> {
    for e in elements {
        if !matches!(e.name.as_str(), "chunk" | "vertex" | "sh") {
            return Err(Error::format(
                name,
                format!(
                    "a compressed PLY holds elements chunk, vertex and sh; this one also has '{}'",
                    e.name
                ),
            ));
        }
        if let Some(p) = e
            .properties
            .iter()
            .find(|p| matches!(p.kind, PropertyKind::List { .. }))
        {
            return Err(Error::format(
                name,
                format!(
                    "property '{}' of element '{}' is a list, expected a scalar",
                    p.name, e.name
                ),
            ));
        }
    }
    Ok(())
}

#[inline]
fn unorm(v: u32, bits: u32) -> f64 {
    let t = (1u32 << bits) - 1;
    (v & t) as f64 / t as f64
}

#[inline]
fn lerp(a: f32, b: f32, t: f64) -> f32 {
    (a as f64 * (1.0 - t) + b as f64 * t) as f32
}

fn unpack_111011(v: u32) -> [f64; 3] {
    [unorm(v >> 21, 11), unorm(v >> 11, 10), unorm(v, 11)]
}

/// (w, x, y, z) from the 2-10-10-10 smallest-three encoding.
fn unpack_rot(v: u32) -> [f32; 4] {
    let norm = std::f64::consts::SQRT_2;
    let a = (unorm(v >> 20, 10) - 0.5) * norm;
    let b = (unorm(v >> 10, 10) - 0.5) * norm;
    let c = (unorm(v, 10) - 0.5) * norm;
    let m = (1.0 - (a * a + b * b + c * c)).max(0.0).sqrt();
    let q = match v >> 30 {
        0 => [m, a, b, c],
        1 => [a, m, b, c],
        2 => [a, b, m, c],
        _ => [a, b, c, m],
    };
    q.map(|x| x as f32)
}

/// Decodes one SH byte (splat-transform's decoder).
#[inline]
pub fn sh_from_byte(b: u8) -> f32 {
    let n = match b {
        0 => 0.0,
        255 => 1.0,
        _ => (b as f64 + 0.5) / 256.0,
    };
    ((n - 0.5) * 8.0) as f32
}

/// Encodes one SH coefficient (splat-transform's encoder).
#[inline]
pub fn sh_to_byte(v: f32) -> u8 {
    let n = v as f64 / 8.0 + 0.5;
    (n * 256.0).trunc().clamp(0.0, 255.0) as u8
}

/// Parses a compressed PLY (`name` for errors). Normals are absent in the
/// result; header comments are kept.
pub fn read(name: &str, bytes: &[u8]) -> Result<Gaussians> {
    let reader = PlyReader::new(name, bytes)?;
    check_header(name, &reader.header.elements)?;
    let (mut ply, _) = reader.read()?;
    let vertex = ply
        .take_element("vertex")
        .ok_or_else(|| Error::format(name, "a compressed PLY needs a 'vertex' element"))?;
    let chunk = ply
        .take_element("chunk")
        .ok_or_else(|| Error::format(name, "a compressed PLY needs a 'chunk' element"))?;
    let n = vertex.count;
    let chunks = n.div_ceil(CHUNK);
    if chunk.count != chunks {
        return Err(Error::format(
            name,
            format!(
                "element 'chunk' has {} rows; {n} Gaussians in chunks of {CHUNK} need {chunks}",
                chunk.count
            ),
        ));
    }
    let with_colour = chunk.property("min_r").is_some();
    let nprops = if with_colour { 18 } else { 12 };
    if chunk.properties.len() != nprops {
        return Err(Error::format(
            name,
            format!(
                "element 'chunk' has {} properties; a compressed PLY has 12 (no colour bounds) \
                 or 18",
                chunk.properties.len()
            ),
        ));
    }
    let mut bounds: Vec<&[f32]> = Vec::with_capacity(18);
    for p in &CHUNK_PROPS[..nprops] {
        match col(name, &chunk, p, ScalarType::F32)? {
            ScalarData::F32(v) => bounds.push(v),
            _ => unreachable!("type checked"),
        }
    }
    let mut packed: Vec<&[u32]> = Vec::with_capacity(4);
    for p in VERTEX_PROPS {
        match col(name, &vertex, p, ScalarType::U32)? {
            ScalarData::U32(v) => packed.push(v),
            _ => unreachable!("type checked"),
        }
    }
    if vertex.properties.len() != 4 {
        return Err(Error::format(
            name,
            "element 'vertex' of a compressed PLY has exactly packed_position, packed_rotation, \
             packed_scale and packed_color",
        ));
    }
    // optional SH
    let sh = ply.take_element("sh");
    let (degree, sh_cols) = match &sh {
        None => (0, Vec::new()),
        Some(e) => {
            let degree = match e.properties.len() {
                9 => 1,
                24 => 2,
                45 => 3,
                m => {
                    return Err(Error::format(
                        name,
                        format!(
                            "element 'sh' has {m} properties; a compressed PLY has 9, 24 or 45 \
                             (SH degree 1, 2 or 3)"
                        ),
                    ));
                }
            };
            if e.count != n {
                return Err(Error::format(
                    name,
                    format!("element 'sh' has {} rows, element 'vertex' {n}", e.count),
                ));
            }
            let mut cols: Vec<&[u8]> = Vec::with_capacity(e.properties.len());
            for i in 0..e.properties.len() {
                match col(name, e, &format!("f_rest_{i}"), ScalarType::U8)? {
                    ScalarData::U8(v) => cols.push(v),
                    _ => unreachable!("type checked"),
                }
            }
            (degree, cols)
        }
    };
    let k = (degree + 1) * (degree + 1) - 1;
    let mut g = Gaussians {
        means: Vec::with_capacity(n),
        normals: None,
        sh_degree: degree,
        sh_dc: Vec::with_capacity(n),
        sh_rest: Vec::with_capacity(n * k * 3),
        opacity_logits: Vec::with_capacity(n),
        log_scales: Vec::with_capacity(n),
        rotations: Vec::with_capacity(n),
        extras: Extras {
            comments: ply.comments.clone(),
            obj_info: ply.obj_info.clone(),
            ..Default::default()
        },
    };
    for i in 0..n {
        let ci = i / CHUNK;
        let b = |j: usize| bounds[j][ci];
        let p = unpack_111011(packed[0][i]);
        g.means.push([0, 1, 2].map(|a| lerp(b(a), b(a + 3), p[a])));
        g.rotations.push(unpack_rot(packed[1][i]));
        let s = unpack_111011(packed[2][i]);
        g.log_scales
            .push([0, 1, 2].map(|a| lerp(b(6 + a), b(9 + a), s[a])));
        let c = packed[3][i];
        let rgb = [unorm(c >> 24, 8), unorm(c >> 16, 8), unorm(c >> 8, 8)];
        let rgb = if with_colour {
            [0, 1, 2].map(|a| b(12 + a) as f64 * (1.0 - rgb[a]) + b(15 + a) as f64 * rgb[a])
        } else {
            rgb
        };
        g.sh_dc.push(rgb.map(|v| ((v - 0.5) / SH_C0) as f32));
        g.opacity_logits.push(logit_unorm(unorm(c, 8)));
        for kk in 0..k {
            for ch in 0..3 {
                g.sh_rest.push(sh_from_byte(sh_cols[ch * k + kk][i]));
            }
        }
    }
    Ok(g)
}

#[inline]
fn pack_unorm(v: f64, bits: u32) -> u32 {
    let t = ((1u32 << bits) - 1) as f64;
    (v * t + 0.5).floor().clamp(0.0, t) as u32
}

fn pack_111011(v: [f64; 3]) -> u32 {
    (pack_unorm(v[0], 11) << 21) | (pack_unorm(v[1], 10) << 11) | pack_unorm(v[2], 11)
}

/// splat-transform's `normalize`: 0 at or below min, 1 at or above max,
/// 0 for a range under 1e-5.
#[inline]
fn normalize(x: f64, min: f64, max: f64) -> f64 {
    if x <= min {
        0.0
    } else if x >= max {
        1.0
    } else if max - min < 0.00001 {
        0.0
    } else {
        (x - min) / (max - min)
    }
}

/// The 2-10-10-10 rotation word of a (w, x, y, z) quaternion.
fn pack_rot(q: [f32; 4]) -> u32 {
    let q = q.map(|v| v as f64);
    let len = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let mut a = if len == 0.0 || !len.is_finite() {
        [1.0, 0.0, 0.0, 0.0]
    } else {
        let inv = 1.0 / len;
        q.map(|v| v * inv)
    };
    let mut largest = 0;
    for i in 1..4 {
        if a[i].abs() > a[largest].abs() {
            largest = i;
        }
    }
    if a[largest] < 0.0 {
        a = a.map(|v| -v);
    }
    let norm = std::f64::consts::SQRT_2 * 0.5;
    let mut r = largest as u32;
    for (i, v) in a.iter().enumerate() {
        if i != largest {
            r = (r << 10) | pack_unorm(v * norm + 0.5, 10);
        }
    }
    r
}

fn min_max(v: impl Iterator<Item = f64>) -> (f64, f64) {
    v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    })
}

/// Encodes `g` as a compressed PLY (SH kept up to degree 3 as `sh` bytes),
/// Gaussians in Morton order ([`super::write_order`]). Unless `lossy`,
/// refuses what the format would clamp or drop ([`CAPACITY`]); `name` is
/// the output, for errors.
pub fn write(name: &str, g: &Gaussians, lossy: bool) -> Result<Vec<u8>> {
    g.validate()
        .map_err(|e| Error::invalid(format!("{name}: cannot write Gaussians: {e}")))?;
    if !lossy {
        check_lossless(name, g, &CAPACITY)?;
    }
    let n = g.len();
    let chunks = n.div_ceil(CHUNK);
    let k = g.rest_per_channel();
    crate::io::budget::check(
        &format!("{name}: the compressed PLY"),
        (n as u64).saturating_mul(16 + 3 * k as u64 + 8),
    )?;
    let order = morton_order(&g.means);
    let mut head = String::from("ply\nformat binary_little_endian 1.0\n");
    head.push_str(&format!(
        "comment Generated by splatkit {}\n",
        env!("CARGO_PKG_VERSION")
    ));
    head.push_str(&format!("element chunk {chunks}\n"));
    for p in CHUNK_PROPS {
        head.push_str(&format!("property float {p}\n"));
    }
    head.push_str(&format!("element vertex {n}\n"));
    for p in VERTEX_PROPS {
        head.push_str(&format!("property uint {p}\n"));
    }
    if k > 0 {
        head.push_str(&format!("element sh {n}\n"));
        for i in 0..3 * k {
            head.push_str(&format!("property uchar f_rest_{i}\n"));
        }
    }
    head.push_str("end_header\n");
    let mut chunk_bytes = Vec::with_capacity(chunks * 18 * 4);
    let mut vertex_bytes = Vec::with_capacity(n * 16);
    let mut sh_bytes = Vec::with_capacity(n * 3 * k);
    let f = |x: f32| x as f64;
    for c in 0..chunks {
        let rows = &order[c * CHUNK..((c + 1) * CHUNK).min(n)];
        let pos: [(f64, f64); 3] =
            [0, 1, 2].map(|a| min_max(rows.iter().map(|&i| f(g.means[i][a]))));
        let scl: [(f64, f64); 3] = [0, 1, 2].map(|a| {
            let (lo, hi) = min_max(rows.iter().map(|&i| f(g.log_scales[i][a])));
            (lo.clamp(-20.0, 20.0), hi.clamp(-20.0, 20.0))
        });
        // colours are rounded to f32 before their bounds are taken, as the
        // reference stores them back into its Float32Array
        let colour = |i: usize, a: usize| (g.sh_dc[i][a] as f64 * SH_C0 + 0.5) as f32 as f64;
        let col: [(f64, f64); 3] = [0, 1, 2].map(|a| min_max(rows.iter().map(|&i| colour(i, a))));
        let mut bounds = [0f32; 18];
        for a in 0..3 {
            bounds[a] = pos[a].0 as f32;
            bounds[3 + a] = pos[a].1 as f32;
            bounds[6 + a] = scl[a].0 as f32;
            bounds[9 + a] = scl[a].1 as f32;
            bounds[12 + a] = col[a].0 as f32;
            bounds[15 + a] = col[a].1 as f32;
        }
        for b in bounds {
            chunk_bytes.extend_from_slice(&b.to_le_bytes());
        }
        for &i in rows {
            let words = [
                pack_111011([0, 1, 2].map(|a| normalize(f(g.means[i][a]), pos[a].0, pos[a].1))),
                pack_rot(g.rotations[i]),
                pack_111011(
                    [0, 1, 2].map(|a| normalize(f(g.log_scales[i][a]), scl[a].0, scl[a].1)),
                ),
                {
                    let rgb = [0, 1, 2].map(|a| normalize(colour(i, a), col[a].0, col[a].1));
                    (pack_unorm(rgb[0], 8) << 24)
                        | (pack_unorm(rgb[1], 8) << 16)
                        | (pack_unorm(rgb[2], 8) << 8)
                        | pack_unorm(sigmoid64(g.opacity_logits[i]), 8)
                },
            ];
            for w in words {
                vertex_bytes.extend_from_slice(&w.to_le_bytes());
            }
            let rest = &g.sh_rest[i * k * 3..(i + 1) * k * 3];
            for ch in 0..3 {
                for kk in 0..k {
                    sh_bytes.push(sh_to_byte(rest[kk * 3 + ch]));
                }
            }
        }
    }
    let mut out = head.into_bytes();
    out.extend_from_slice(&chunk_bytes);
    out.extend_from_slice(&vertex_bytes);
    out.extend_from_slice(&sh_bytes);
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::RngExt;

    pub(crate) fn random_gaussians(n: usize, degree: usize, seed: u64) -> Gaussians {
        let mut r = crate::model::rng::seeded(seed);
        let k = (degree + 1) * (degree + 1) - 1;
        let mut u = |lo: f32, hi: f32| lo + (hi - lo) * r.random::<f32>();
        let mut g = Gaussians {
            sh_degree: degree,
            ..Default::default()
        };
        for _ in 0..n {
            g.means.push([u(-2.0, 2.0), u(-1.0, 1.0), u(0.0, 3.0)]);
            g.sh_dc.push([u(-1.5, 1.5), u(-1.5, 1.5), u(-1.5, 1.5)]);
            for _ in 0..3 * k {
                g.sh_rest.push(u(-0.5, 0.5));
            }
            g.opacity_logits.push(u(-4.0, 4.0));
            g.log_scales
                .push([u(-6.0, -1.0), u(-6.0, -1.0), u(-6.0, -1.0)]);
            g.rotations
                .push([u(-1.0, 1.0), u(-1.0, 1.0), u(-1.0, 1.0), u(-1.0, 1.0)]);
        }
        g
    }

    /// Bit layout of one word, independently worked out: 11-10-11 with x on
    /// top; unorms rounded to nearest.
    #[test]
    fn packing_matches_the_layout() {
        assert_eq!(pack_111011([1.0, 0.0, 0.0]), 0x7ff << 21);
        assert_eq!(pack_111011([0.0, 1.0, 0.0]), 0x3ff << 11);
        assert_eq!(pack_111011([0.0, 0.0, 1.0]), 0x7ff);
        assert_eq!(pack_unorm(0.5, 8), 128); // 127.5 + 0.5 floors to 128
        // identity: largest is w (index 0), the others encode 0 → 512
        assert_eq!(
            pack_rot([1.0, 0.0, 0.0, 0.0]),
            (512 << 20) | (512 << 10) | 512
        );
        // a negative largest component flips the sign of the whole quaternion
        assert_eq!(
            pack_rot([0.0, 0.0, -1.0, 0.0]),
            pack_rot([0.0, 0.0, 1.0, 0.0])
        );
        assert_eq!(pack_rot([0.0, 0.0, 1.0, 0.0]) >> 30, 2);
        let q = unpack_rot(pack_rot([0.0, 0.0, 1.0, 0.0]));
        assert!((q[2] - 1.0).abs() < 1e-6 && q[0].abs() < 2e-3, "{q:?}");
        for b in 0..=255u8 {
            assert_eq!(sh_to_byte(sh_from_byte(b)), b, "byte {b}");
        }
    }

    /// A round trip stays within half a quantisation step of each value
    /// (in the chunk's own range), and the rotation within the 10-bit step.
    #[test]
    fn round_trip_within_the_step() {
        let g = random_gaussians(700, 3, 5);
        let bytes = write("t.compressed.ply", &g, false).unwrap();
        let back = read("t.compressed.ply", &bytes).unwrap();
        assert_eq!(back.len(), g.len());
        assert_eq!(back.sh_degree, 3);
        let order = morton_order(&g.means);
        let k = g.rest_per_channel();
        for (j, &i) in order.iter().enumerate() {
            let c = j / CHUNK;
            let rows = &order[c * CHUNK..((c + 1) * CHUNK).min(g.len())];
            for a in 0..3 {
                let (lo, hi) = min_max(rows.iter().map(|&r| g.means[r][a] as f64));
                let step = (hi - lo) / if a == 1 { 1023.0 } else { 2047.0 };
                let d = (back.means[j][a] as f64 - g.means[i][a] as f64).abs();
                assert!(d <= step * 0.5 + 1e-6, "pos {i} {a}: {d} > {step}/2");
                let (lo, hi) = min_max(rows.iter().map(|&r| g.log_scales[r][a] as f64));
                let step = (hi - lo) / if a == 1 { 1023.0 } else { 2047.0 };
                let d = (back.log_scales[j][a] - g.log_scales[i][a]).abs() as f64;
                assert!(d <= step * 0.5 + 1e-5, "scale {i} {a}");
                let (lo, hi) = min_max(rows.iter().map(|&r| g.sh_dc[r][a] as f64));
                let step = (hi - lo) / 255.0;
                let d = (back.sh_dc[j][a] - g.sh_dc[i][a]).abs() as f64;
                assert!(d <= step * 0.5 + 1e-5, "dc {i} {a}: {d} vs {step}");
            }
            let da = (g.opacity(i) - back.opacity(j)).abs();
            assert!(da <= 0.5 / 255.0 + 1e-6, "opacity {i}: {da}");
            let dot = g.quat(i).dot(back.quat(j)).abs().min(1.0);
            let angle = 2.0 * dot.acos().to_degrees();
            assert!(angle < 0.2, "rotation {i}: {angle}°");
            for t in 0..3 * k {
                let d = (g.sh_rest[i * 3 * k + t] - back.sh_rest[j * 3 * k + t]).abs();
                assert!(d <= 8.0 / 256.0 * 0.5 + 1e-6, "sh {i} {t}: {d}");
            }
        }
    }

    #[test]
    fn refuses_what_it_would_clamp_unless_lossy() {
        let mut g = random_gaussians(10, 3, 1);
        g.sh_rest[5 * 45 + 7] = 6.5;
        let e = write("o.compressed.ply", &g, false)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("o.compressed.ply: Gaussian 5 has f_rest_"),
            "{e}"
        );
        assert!(e.contains("6.5") && e.contains("--lossy"), "{e}");
        assert!(write("o.compressed.ply", &g, true).is_ok());
        let mut g = random_gaussians(10, 0, 1);
        g.log_scales[3][1] = -25.0;
        let e = write("o", &g, false).unwrap_err().to_string();
        assert!(e.contains("Gaussian 3 has scale_1 = -25"), "{e}");
        let mut g = random_gaussians(10, 0, 1);
        g.means[2][0] = f32::NAN;
        let e = write("o", &g, false).unwrap_err().to_string();
        assert!(e.contains("Gaussian 2 has x = NaN"), "{e}");
        let mut g = random_gaussians(4, 0, 1);
        g.normals = Some(vec![[0.0; 3], [0.0, 1.0, 0.0], [0.0; 3], [0.0; 3]]);
        let e = write("o", &g, false).unwrap_err().to_string();
        assert!(e.contains("Gaussian 1 has normal"), "{e}");
        g.normals = Some(vec![[0.0; 3]; 4]);
        assert!(write("o", &g, false).is_ok());
    }

    /// The 12-float chunk layout (no colour bounds) decodes colour as a
    /// plain unorm.
    #[test]
    fn reads_the_older_12_float_layout() {
        let mut b = b"ply\nformat binary_little_endian 1.0\nelement chunk 1\n".to_vec();
        for p in &CHUNK_PROPS[..12] {
            b.extend_from_slice(format!("property float {p}\n").as_bytes());
        }
        b.extend_from_slice(b"element vertex 1\n");
        for p in VERTEX_PROPS {
            b.extend_from_slice(format!("property uint {p}\n").as_bytes());
        }
        b.extend_from_slice(b"end_header\n");
        for v in [0f32, 0., 0., 2., 4., 8., -1., -1., -1., 1., 1., 1.] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        let words = [
            (2047u32 << 21) | (1023 << 11),
            (512 << 20) | (512 << 10) | 512,
            0,
            (255 << 24) | 255,
        ];
        for w in words {
            b.extend_from_slice(&w.to_le_bytes());
        }
        let g = read("old.ply", &b).unwrap();
        assert_eq!(g.means[0], [2.0, 4.0, 0.0]);
        assert_eq!(g.log_scales[0], [-1.0; 3]);
        assert!((g.sh_dc[0][0] as f64 - 0.5 / SH_C0).abs() < 1e-6);
        assert!((g.sh_dc[0][1] as f64 + 0.5 / SH_C0).abs() < 1e-6);
        assert_eq!(g.opacity_logits[0], 40.0);
        assert!((g.rotations[0][0] - 1.0).abs() < 1e-5);
        // a chunk count that does not match is refused
        let bad = String::from_utf8_lossy(&b).replace("element chunk 1", "element chunk 2");
        let e = read("old.ply", bad.as_bytes()).unwrap_err().to_string();
        assert!(e.contains("old.ply"), "{e}");
    }
}
