//! Niantic SPZ (`.spz`): quantised Gaussian splats, read in every released
//! version (1–4) and written as version 4, the version the official library
//! (nianticlabs/spz, `LATEST_SPZ_HEADER_VERSION`) writes by default.
//!
//! Layout (rules from the official `src/cc/load-spz.cc`, `splat-utils.h`,
//! `splat-types.h`):
//! - **Version 4**: a plaintext 32-byte header (`"NGSP"`, version, count,
//!   SH degree, fractional bits, flags, stream count, TOC offset, 12 reserved
//!   bytes), then extension records up to the TOC, then one TOC entry per
//!   non-empty stream (`u64` compressed size, `u64` uncompressed size), then
//!   the zstd-compressed streams in the order positions, alphas, colours,
//!   scales, rotations, SH. The streams end exactly at the end of the file.
//! - **Versions 1–3**: the whole file is one gzip stream holding a 16-byte
//!   header (`"NGSP"`, version, count, SH degree, fractional bits, flags, one
//!   reserved byte) and the same six blocks back to back, then any extension
//!   records.
//!
//! Per Gaussian: position as three signed 24-bit fixed-point numbers with
//! `fractionalBits` fractional bits (version 1: three float16); alpha as
//! `u8` of sigmoid(opacity)·255; colour as `u8` of `dc·0.15·255 + 127.5`
//! (SPZ's own colour scale, not the SH constant); log-scales as `u8` of
//! `(s + 10)·16`; rotation as 3 bytes `(xyz·127.5 + 127.5)` with `w ≥ 0`
//! (versions 1–2) or 4 bytes "smallest three" (versions 3–4: 2 bits naming
//! the largest component, three 10-bit signed magnitudes scaled by 1/√2);
//! SH rest as `u8` of `x·128 + 128`, coefficient-major with the channel
//! innermost (the layout of [`Gaussians::sh_rest`]), quantised on write to
//! 5 bits for band 1 and 4 bits for bands 2–3 (the official defaults).
//!
//! **Axes.** SPZ stores RUB (x right, y up, z back); the 3DGS PLY is RDF. As
//! the official loader does when asked for RDF, [`read`] flips y and z of the
//! positions, negates the quaternion's y and z and flips the sign of the SH
//! coefficients that are odd in y or z; [`write`] does the reverse. The
//! `SPZ_ADOBE_coordinate_system` extension (a stored axis system other than
//! RUB) is honoured for the eight axis-flip systems and refused for the
//! rotated ones. Note that `@playcanvas/splat-transform` reads and writes SPZ
//! without this conversion, so its SPZ files differ from Niantic's by a
//! 180° rotation about x.
//!
//! **Decoding departures**: alpha bytes 0 and 255 decode to logit(1e−6) and
//! logit(1 − 1e−6) (as splat-transform) instead of the official ±∞, so the
//! result stays finite. The antialiasing flag and other extensions are not
//! kept. SH degree 4 (which SPZ can hold) is refused: [`Gaussians`] holds up
//! to degree 3.
//!
//! **Writing departure**: the official writer always uses 12 fractional bits
//! (positions within ±2048, wrapping silently beyond); this writer uses 12
//! bits where they fit and otherwise the most bits that hold the largest
//! coordinate (the reader takes the count from the header), so large scenes
//! lose precision, not positions.

use std::io::Read;

use rayon::prelude::*;

use crate::io::budget;
use crate::model::Gaussians;
use crate::model::gaussians::sigmoid;
use crate::{Error, Result};

const MAGIC: &[u8; 4] = b"NGSP";
/// The version [`write`] writes.
pub const WRITE_VERSION: u32 = 4;
const COLOR_SCALE: f32 = 0.15;
const SQRT1_2: f32 = std::f32::consts::FRAC_1_SQRT_2;
const FLAG_HAS_EXTENSIONS: u8 = 0x2;
const EXT_COORDINATE_SYSTEM: u32 = 0xADBE_0003;
/// Official plausibility bound: at most `file size · 1024 / 9` Gaussians.
const MAX_RATIO: u64 = 1024;
const MIN_BYTES_PER_POINT: u64 = 9;
/// Fractional bits of the official writer.
const FRACTIONAL_BITS: u8 = 12;
/// SH quantisation bits of the official writer's defaults.
const SH1_BITS: u32 = 5;
const SH_REST_BITS: u32 = 4;
/// Logit of the clamp splat-transform applies to decoded alphas.
const ALPHA_EPS: f32 = 1e-6;
/// zstd level of the official writer.
const ZSTD_LEVEL: i32 = 12;

/// Per-coefficient signs that turn SH band 1–3 coefficients (index 0..15 of
/// the rest) from one axis system to another that differs by the flips
/// `(x, y, z)` (each ±1); the official `coordinateConverter` table.
fn sh_flips(x: f32, y: f32, z: f32) -> [f32; 15] {
    [
        y,
        z,
        x,
        x * y,
        y * z,
        1.0,
        x * z,
        1.0,
        y,
        x * y * z,
        y,
        z,
        x,
        z,
        x,
    ]
}

/// Axis flips between a stored standard-family axis system (the
/// `CoordinateSystem` enum value 1..=8 of the official code: bit 0 = right,
/// bit 1 = up, bit 2 = front of `value − 1`) and RDF, the PLY axes.
fn flips_to_rdf(system: u32) -> Option<[f32; 3]> {
    if !(1..=8).contains(&system) {
        return None;
    }
    let a = system - 1;
    let rdf = 6 - 1; // RDF = 6
    let f = |bit: u32| {
        if (a >> bit) & 1 == (rdf >> bit) & 1 {
            1.0
        } else {
            -1.0
        }
    };
    Some([f(0), f(1), f(2)])
}

/// RUB (enum value 4), the axis system SPZ stores by default.
const RUB: u32 = 4;

/// SH rest coefficients per channel for SPZ degree `d` (0..=4).
fn sh_dim(d: u8) -> usize {
    match d {
        1 => 3,
        2 => 8,
        3 => 15,
        4 => 24,
        _ => 0,
    }
}

/// True when `bytes` start like an SPZ file: the plaintext `NGSP` header of
/// version 4, or a gzip stream whose first decompressed bytes are `NGSP`.
pub fn sniff(bytes: &[u8]) -> bool {
    if bytes.starts_with(MAGIC) {
        return true;
    }
    if bytes.len() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b {
        let mut head = [0u8; 4];
        let mut d = flate2::read::GzDecoder::new(bytes);
        return d.read_exact(&mut head).is_ok() && &head == MAGIC;
    }
    false
}

/// The packed streams of one file, before dequantisation.
struct Packed {
    version: u32,
    n: usize,
    sh_degree: u8,
    fractional_bits: u8,
    /// Stored axis system (official `CoordinateSystem` value).
    axes: u32,
    positions: Vec<u8>,
    alphas: Vec<u8>,
    colors: Vec<u8>,
    scales: Vec<u8>,
    rotations: Vec<u8>,
    sh: Vec<u8>,
}

/// Byte sizes of the six streams for `n` Gaussians:
/// positions, alphas, colours, scales, rotations, SH.
fn stream_sizes(version: u32, n: usize, sh_degree: u8) -> [u64; 6] {
    let n = n as u64;
    let pos = if version == 1 { 6 } else { 9 };
    let rot = if version >= 3 { 4 } else { 3 };
    [
        n * pos,
        n,
        n * 3,
        n * 3,
        n * rot,
        n * sh_dim(sh_degree) as u64 * 3,
    ]
}

/// Checks the header's count and SH degree and the memory the decode needs.
fn check_count(name: &str, n: u32, sh_degree: u8, version: u32, file_len: usize) -> Result<()> {
    if n == 0 {
        return Err(Error::format(
            name,
            "header declares 0 Gaussians (SPZ files hold at least one)",
        ));
    }
    if n > i32::MAX as u32 || n as u64 > (file_len as u64 * MAX_RATIO) / MIN_BYTES_PER_POINT {
        return Err(Error::format(
            name,
            format!(
                "header declares {n} Gaussians, more than a {file_len}-byte SPZ file can hold \
                 (at most size·{MAX_RATIO}/{MIN_BYTES_PER_POINT})"
            ),
        ));
    }
    if sh_degree > 4 {
        return Err(Error::format(
            name,
            format!("header byte 12: SH degree {sh_degree} is above 4"),
        ));
    }
    if sh_degree == 4 {
        return Err(Error::format(
            name,
            "SH degree 4 is not supported (splatkit holds SH up to degree 3)",
        ));
    }
    let packed: u64 = stream_sizes(version, n as usize, sh_degree).iter().sum();
    let k = sh_dim(sh_degree) as u64;
    let decoded = n as u64 * (4 * (3 + 3 + 1 + 3 + 4) + 4 * 3 * k);
    budget::check(
        &format!("{name}: {n} SPZ Gaussians"),
        packed.saturating_add(decoded),
    )
}

fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

fn u64_at(b: &[u8], o: usize) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[o..o + 8]);
    u64::from_le_bytes(a)
}

/// Parses extension records in `ext` (`u32` type, `u32` length, payload) and
/// returns the stored axis system (RUB unless the coordinate-system extension
/// says otherwise). `at` is the byte offset of `ext` in the file (for errors).
fn parse_extensions(name: &str, ext: &[u8], at: usize) -> Result<u32> {
    let mut axes = RUB;
    let mut o = 0usize;
    while o < ext.len() {
        if ext.len() - o < 8 {
            return Err(Error::format(
                name,
                format!("byte {}: truncated extension record header", at + o),
            ));
        }
        let ty = u32_at(ext, o);
        let len = u32_at(ext, o + 4) as usize;
        if len > ext.len() - o - 8 {
            return Err(Error::format(
                name,
                format!(
                    "byte {}: extension 0x{ty:08X} declares {len} payload bytes, past its block",
                    at + o
                ),
            ));
        }
        if ty == EXT_COORDINATE_SYSTEM {
            if len != 4 {
                return Err(Error::format(
                    name,
                    format!(
                        "byte {}: coordinate-system extension has {len} payload bytes, expected 4",
                        at + o
                    ),
                ));
            }
            let v = u32_at(ext, o + 8);
            axes = match v {
                0 => RUB, // UNSPECIFIED: the official loader takes RUB
                1..=8 => v,
                _ => {
                    return Err(Error::format(
                        name,
                        format!(
                            "byte {}: coordinate-system extension names system {v}, a rotated \
                             (or unknown) axis system that is not supported",
                            at + o
                        ),
                    ));
                }
            };
        }
        o += 8 + len;
    }
    Ok(axes)
}

fn parse_v4(name: &str, bytes: &[u8]) -> Result<Packed> {
    if bytes.len() < 32 {
        return Err(Error::format(
            name,
            format!(
                "file is {} bytes, shorter than the 32-byte SPZ header",
                bytes.len()
            ),
        ));
    }
    let version = u32_at(bytes, 4);
    if version != 4 {
        return Err(Error::format(
            name,
            format!(
                "header byte 4: SPZ version {version} with a plaintext header (only version 4 has one; \
                 versions 1–3 are gzip files)"
            ),
        ));
    }
    let n = u32_at(bytes, 8);
    let sh_degree = bytes[12];
    let fractional_bits = bytes[13];
    let flags = bytes[14];
    let num_streams = bytes[15] as usize;
    let toc = u32_at(bytes, 16) as usize;
    check_count(name, n, sh_degree, version, bytes.len())?;
    let n = n as usize;
    if toc < 32 || toc > bytes.len() {
        return Err(Error::format(
            name,
            format!(
                "header byte 16: TOC offset {toc} is outside 32..={}",
                bytes.len()
            ),
        ));
    }
    let axes = if flags & FLAG_HAS_EXTENSIONS != 0 {
        parse_extensions(name, &bytes[32..toc], 32)?
    } else {
        RUB
    };
    let sizes = stream_sizes(version, n, sh_degree);
    let wanted: Vec<(usize, u64)> = sizes
        .iter()
        .copied()
        .enumerate()
        .filter(|&(_, s)| s > 0)
        .collect();
    if num_streams != wanted.len() {
        return Err(Error::format(
            name,
            format!(
                "header byte 15: {num_streams} streams, expected {} for SH degree {sh_degree}",
                wanted.len()
            ),
        ));
    }
    let toc_end = toc + 16 * num_streams;
    if toc_end > bytes.len() {
        return Err(Error::format(
            name,
            format!(
                "TOC of {num_streams} entries at byte {toc} runs past the end ({} bytes)",
                bytes.len()
            ),
        ));
    }
    const NAMES: [&str; 6] = ["positions", "alphas", "colors", "scales", "rotations", "sh"];
    let mut ranges = Vec::with_capacity(num_streams);
    let mut off = toc_end;
    for (j, &(slot, want)) in wanted.iter().enumerate() {
        let e = toc + 16 * j;
        let comp = u64_at(bytes, e);
        let unc = u64_at(bytes, e + 8);
        if unc != want {
            return Err(Error::format(
                name,
                format!(
                    "TOC entry {j} (byte {e}): {} stream declares {unc} bytes, expected {want}",
                    NAMES[slot]
                ),
            ));
        }
        if comp > (bytes.len() - off) as u64 {
            return Err(Error::format(
                name,
                format!(
                    "TOC entry {j} (byte {e}): {} stream of {comp} bytes at byte {off} runs past the end",
                    NAMES[slot]
                ),
            ));
        }
        ranges.push((slot, off, off + comp as usize, want as usize));
        off += comp as usize;
    }
    if off != bytes.len() {
        return Err(Error::format(
            name,
            format!(
                "{} bytes after the last stream (streams end at byte {off})",
                bytes.len() - off
            ),
        ));
    }
    let decoded: Vec<Result<(usize, Vec<u8>)>> = ranges
        .par_iter()
        .map(|&(slot, a, b, want)| {
            let v = zstd::bulk::decompress(&bytes[a..b], want).map_err(|e| {
                Error::format(
                    name,
                    format!("{} stream at byte {a}: zstd: {e}", NAMES[slot]),
                )
            })?;
            if v.len() != want {
                return Err(Error::format(
                    name,
                    format!(
                        "{} stream at byte {a}: decompressed to {} bytes, expected {want}",
                        NAMES[slot],
                        v.len()
                    ),
                ));
            }
            Ok((slot, v))
        })
        .collect();
    let mut streams: [Vec<u8>; 6] = Default::default();
    for d in decoded {
        let (slot, v) = d?;
        streams[slot] = v;
    }
    let [positions, alphas, colors, scales, rotations, sh] = streams;
    Ok(Packed {
        version,
        n,
        sh_degree,
        fractional_bits,
        axes,
        positions,
        alphas,
        colors,
        scales,
        rotations,
        sh,
    })
}

fn parse_gzip(name: &str, bytes: &[u8]) -> Result<Packed> {
    let mut d = flate2::read::GzDecoder::new(bytes);
    let gz =
        |e: std::io::Error, what: &str| Error::format(name, format!("gzip stream: {what}: {e}"));
    let mut h = [0u8; 16];
    d.read_exact(&mut h)
        .map_err(|e| gz(e, "reading the 16-byte header"))?;
    if &h[0..4] != MAGIC {
        return Err(Error::format(
            name,
            "gzip stream does not start with the SPZ magic \"NGSP\"",
        ));
    }
    let version = u32_at(&h, 4);
    if !(1..=3).contains(&version) {
        return Err(Error::format(
            name,
            format!("header byte 4: gzip SPZ version {version} (versions 1–3 are gzip files)"),
        ));
    }
    let n = u32_at(&h, 8);
    let sh_degree = h[12];
    let fractional_bits = h[13];
    let flags = h[14];
    // Deflate expands at most ~1032:1; the official bound is looser still.
    check_count(name, n, sh_degree, version, bytes.len())?;
    let n = n as usize;
    let sizes = stream_sizes(version, n, sh_degree);
    let total: u64 = sizes.iter().sum();
    if total > bytes.len() as u64 * 1032 + 64 {
        return Err(Error::format(
            name,
            format!(
                "header declares {n} Gaussians ({total} bytes), more than a {}-byte gzip stream can hold",
                bytes.len()
            ),
        ));
    }
    let mut streams: [Vec<u8>; 6] = Default::default();
    const NAMES: [&str; 6] = ["positions", "alphas", "colors", "scales", "rotations", "sh"];
    for (slot, &s) in sizes.iter().enumerate() {
        let mut v = vec![0u8; s as usize];
        d.read_exact(&mut v).map_err(|e| {
            gz(
                e,
                &format!(
                    "reading the {} block ({s} bytes) of {n} Gaussians",
                    NAMES[slot]
                ),
            )
        })?;
        streams[slot] = v;
    }
    let axes = if flags & FLAG_HAS_EXTENSIONS != 0 {
        let mut ext = Vec::new();
        (&mut d)
            .take(1 << 20)
            .read_to_end(&mut ext)
            .map_err(|e| gz(e, "reading the extensions"))?;
        parse_extensions(name, &ext, 16 + total as usize)?
    } else {
        RUB
    };
    let [positions, alphas, colors, scales, rotations, sh] = streams;
    Ok(Packed {
        version,
        n,
        sh_degree,
        fractional_bits,
        axes,
        positions,
        alphas,
        colors,
        scales,
        rotations,
        sh,
    })
}

/// Decodes a "smallest three" quaternion to (x, y, z, w).
fn unpack_smallest_three(r: &[u8]) -> [f32; 4] {
    let mut comp = u32::from_le_bytes([r[0], r[1], r[2], r[3]]);
    let mask = (1u32 << 9) - 1;
    let largest = (comp >> 30) as usize;
    let mut q = [0f32; 4];
    let mut sum = 0f32;
    for i in (0..4).rev() {
        if i != largest {
            let mag = comp & mask;
            let neg = (comp >> 9) & 1;
            comp >>= 10;
            let v = SQRT1_2 * mag as f32 / mask as f32;
            q[i] = if neg == 1 { -v } else { v };
            sum += q[i] * q[i];
        }
    }
    q[largest] = (1.0 - sum).max(0.0).sqrt();
    q
}

/// Decodes a "first three" quaternion (versions 1–2) to (x, y, z, w).
fn unpack_first_three(r: &[u8]) -> [f32; 4] {
    let x = r[0] as f32 / 127.5 - 1.0;
    let y = r[1] as f32 / 127.5 - 1.0;
    let z = r[2] as f32 / 127.5 - 1.0;
    [x, y, z, (1.0 - (x * x + y * y + z * z)).max(0.0).sqrt()]
}

/// Reads an SPZ file (any version 1–4) into Gaussians in PLY (RDF) axes.
/// `name` is used in errors. Quaternions come out normalised (w, x, y, z),
/// log-scales and opacity logits as raw 3DGS parameters.
pub fn read(name: &str, bytes: &[u8]) -> Result<Gaussians> {
    let p = if bytes.starts_with(MAGIC) {
        parse_v4(name, bytes)?
    } else if bytes.len() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b {
        parse_gzip(name, bytes)?
    } else {
        return Err(Error::format(
            name,
            "not an SPZ file (neither the \"NGSP\" header nor a gzip stream)",
        ));
    };
    Ok(decode(&p))
}

fn decode(p: &Packed) -> Gaussians {
    let n = p.n;
    let [fx, fy, fz] = flips_to_rdf(p.axes).unwrap_or([1.0, -1.0, -1.0]);
    let flip_p = [fx, fy, fz];
    let flip_q = [fy * fz, fx * fz, fx * fy];
    let flip_sh = sh_flips(fx, fy, fz);
    let step = (-(p.fractional_bits as f32)).exp2();
    let means: Vec<[f32; 3]> = if p.version == 1 {
        p.positions
            .par_chunks_exact(6)
            .map(|c| {
                std::array::from_fn(|j| {
                    half::f16::from_le_bytes([c[2 * j], c[2 * j + 1]]).to_f32() * flip_p[j]
                })
            })
            .collect()
    } else {
        p.positions
            .par_chunks_exact(9)
            .map(|c| {
                std::array::from_fn(|j| {
                    let v = i32::from_le_bytes([c[3 * j], c[3 * j + 1], c[3 * j + 2], 0]) << 8 >> 8;
                    v as f32 * step * flip_p[j]
                })
            })
            .collect()
    };
    let lo = (ALPHA_EPS / (1.0 - ALPHA_EPS)).ln();
    let opacity_logits = p
        .alphas
        .iter()
        .map(|&a| {
            let x = a as f32 / 255.0;
            (x / (1.0 - x)).ln().clamp(lo, -lo)
        })
        .collect();
    let sh_dc = p
        .colors
        .chunks_exact(3)
        .map(|c| std::array::from_fn(|j| (c[j] as f32 / 255.0 - 0.5) / COLOR_SCALE))
        .collect();
    let log_scales = p
        .scales
        .chunks_exact(3)
        .map(|c| std::array::from_fn(|j| c[j] as f32 / 16.0 - 10.0))
        .collect();
    let rot_bytes = if p.version >= 3 { 4 } else { 3 };
    let rotations = p
        .rotations
        .par_chunks_exact(rot_bytes)
        .map(|r| {
            let q = if rot_bytes == 4 {
                unpack_smallest_three(r)
            } else {
                unpack_first_three(r)
            };
            [q[3], q[0] * flip_q[0], q[1] * flip_q[1], q[2] * flip_q[2]]
        })
        .collect();
    let k = sh_dim(p.sh_degree);
    let sh_rest = if k == 0 {
        Vec::new()
    } else {
        p.sh.par_chunks_exact(3 * k)
            .flat_map_iter(|row| {
                row.iter()
                    .enumerate()
                    .map(|(j, &b)| (b as f32 - 128.0) / 128.0 * flip_sh[j / 3])
            })
            .collect()
    };
    debug_assert_eq!(means.len(), n);
    Gaussians {
        means,
        normals: None,
        sh_degree: p.sh_degree as usize,
        sh_dc,
        sh_rest,
        opacity_logits,
        log_scales,
        rotations,
        extras: Default::default(),
    }
}

/// The official `toUint8`: round, clamp to 0..=255 (NaN → 0).
fn to_u8(x: f32) -> u8 {
    if x.is_nan() {
        0
    } else {
        x.round().clamp(0.0, 255.0) as u8
    }
}

/// The official `quantizeSH`: 8-bit value rounded to the centre of a
/// bucket of `bucket` codes.
fn quantize_sh(x: f32, bucket: i32) -> u8 {
    if x.is_nan() {
        return 128;
    }
    let q = ((x * 128.0).round() + 128.0).clamp(-1e6, 1e6) as i32;
    let q = (q + bucket / 2) / bucket * bucket;
    q.clamp(0, 255) as u8
}

/// A value the format would clamp or drop, found by [`check_lossless`].
fn refuse(name: &str, i: usize, what: &str, v: impl std::fmt::Display, why: &str) -> Error {
    Error::invalid(format!(
        "{name}: Gaussian {i}: {what} {v} {why}; SPZ would change it (allow lossy conversion to \
         clamp such values)"
    ))
}

/// Largest fixed-point magnitude of a signed 24-bit number.
const FIXED_MAX: f32 = 8_388_607.0;

/// Picks the fractional bits: 12 (the official choice) if the largest
/// |coordinate| fits, otherwise the most that fit (0 at worst).
fn fractional_bits_for(max_abs: f32) -> u8 {
    let mut fb = FRACTIONAL_BITS;
    while fb > 0 && (max_abs * (fb as f32).exp2()).round() > FIXED_MAX {
        fb -= 1;
    }
    fb
}

/// Checks that every value survives SPZ up to quantisation: finite values,
/// positions within the 24-bit range, log-scales, colours and SH inside the
/// byte ranges, non-zero quaternions.
fn check_lossless(name: &str, g: &Gaussians, fb: u8) -> Result<()> {
    let scale = (fb as f32).exp2();
    for i in 0..g.len() {
        for (j, &v) in g.means[i].iter().enumerate() {
            if !v.is_finite() || (v * scale).round().abs() > FIXED_MAX {
                return Err(refuse(
                    name,
                    i,
                    &format!("position[{j}]"),
                    v,
                    "is not finite or outside SPZ's 24-bit range",
                ));
            }
        }
        for (j, &s) in g.log_scales[i].iter().enumerate() {
            let code = ((s + 10.0) * 16.0).round();
            if !(0.0..=255.0).contains(&code) {
                return Err(refuse(
                    name,
                    i,
                    &format!("log-scale[{j}]"),
                    s,
                    "is outside SPZ's range [-10, 5.9375] (or not finite)",
                ));
            }
        }
        let o = g.opacity_logits[i];
        if o.is_nan() {
            return Err(refuse(name, i, "opacity logit", o, "is NaN"));
        }
        for (j, &c) in g.sh_dc[i].iter().enumerate() {
            let code = (c * (COLOR_SCALE * 255.0) + 127.5).round();
            if !(0.0..=255.0).contains(&code) {
                return Err(refuse(
                    name,
                    i,
                    &format!("SH DC[{j}]"),
                    c,
                    "is outside SPZ's colour range [-3.33, 3.33] (or not finite)",
                ));
            }
        }
        let q = g.rotations[i];
        let n2: f32 = q.iter().map(|v| v * v).sum();
        if !(n2.is_finite() && n2 > 0.0) {
            return Err(refuse(
                name,
                i,
                "rotation",
                format!("{q:?}"),
                "has no direction (zero or not finite)",
            ));
        }
    }
    let k = g.rest_per_channel();
    if k > 0 {
        // the writer flips signs (RDF → RUB), so check the flipped value
        let flip = sh_flips(1.0, -1.0, -1.0);
        for (idx, &v) in g.sh_rest.iter().enumerate() {
            let x = v * flip[(idx / 3) % k];
            let code = (x * 128.0).round() + 128.0;
            if !(0.0..=255.0).contains(&code) {
                return Err(refuse(
                    name,
                    idx / (3 * k),
                    &format!("SH rest coefficient {} channel {}", (idx / 3) % k, idx % 3),
                    v,
                    "is outside SPZ's range [-1, 0.99] (after the axis flip) or not finite",
                ));
            }
        }
    }
    Ok(())
}

/// Encodes (x, y, z, w) (already in SPZ axes) as "smallest three".
fn pack_smallest_three(q: [f32; 4]) -> [u8; 4] {
    let n = q.iter().map(|v| v * v).sum::<f32>().sqrt();
    let q = if n > 0.0 && n.is_finite() {
        q.map(|v| v / n)
    } else {
        [0.0, 0.0, 0.0, 1.0]
    };
    let mut largest = 0;
    for i in 1..4 {
        if q[i].abs() > q[largest].abs() {
            largest = i;
        }
    }
    let negate = (q[largest] < 0.0) as u32;
    let mut comp = largest as u32;
    for (i, &v) in q.iter().enumerate() {
        if i != largest {
            let negbit = ((v < 0.0) as u32) ^ negate;
            let mag = (511.0 * (v.abs() / SQRT1_2) + 0.5) as u32;
            comp = (comp << 10) | (negbit << 9) | mag.min(511);
        }
    }
    comp.to_le_bytes()
}

/// Writes Gaussians (PLY / RDF axes) as an SPZ version 4 file.
///
/// With `lossy == false`, refuses (an error naming `name`, the first
/// Gaussian and the value) anything SPZ would clamp or drop: non-finite
/// values, positions beyond the 24-bit range, log-scales outside
/// [−10, 5.94], DC colours outside ±3.33, SH rest outside [−1, 0.99],
/// zero quaternions, and empty input (SPZ cannot hold zero Gaussians). With
/// `lossy == true`, clamps as the official writer does (NaN → the code of 0;
/// a zero quaternion → identity). Quantisation itself is always applied
/// (see the module docs).
pub fn write(name: &str, g: &Gaussians, lossy: bool) -> Result<Vec<u8>> {
    g.validate().map_err(|e| e.in_file(name))?;
    let n = g.len();
    if n == 0 {
        return Err(Error::invalid(format!(
            "{name}: SPZ cannot hold zero Gaussians (the official loader refuses a count of 0)"
        )));
    }
    if n > i32::MAX as usize {
        return Err(Error::invalid(format!(
            "{name}: {n} Gaussians are more than SPZ's count field holds"
        )));
    }
    let max_abs = g
        .means
        .iter()
        .flatten()
        .filter(|v| v.is_finite())
        .fold(0f32, |m, v| m.max(v.abs()));
    let fb = fractional_bits_for(max_abs);
    if !lossy {
        check_lossless(name, g, fb)?;
    }
    let scale = (fb as f32).exp2();
    let flip_p = [1.0f32, -1.0, -1.0];
    let positions: Vec<u8> = g
        .means
        .par_iter()
        .flat_map_iter(|m| {
            (0..3).flat_map(move |j| {
                let v = m[j] * flip_p[j] * scale;
                let v = if v.is_nan() {
                    0
                } else {
                    v.round().clamp(-FIXED_MAX - 1.0, FIXED_MAX) as i32
                };
                let b = v.to_le_bytes();
                [b[0], b[1], b[2]]
            })
        })
        .collect();
    let alphas: Vec<u8> = g
        .opacity_logits
        .iter()
        .map(|&o| to_u8(sigmoid(o) * 255.0))
        .collect();
    let colors: Vec<u8> = g
        .sh_dc
        .iter()
        .flat_map(|c| c.map(|v| to_u8(v * (COLOR_SCALE * 255.0) + 0.5 * 255.0)))
        .collect();
    let scales: Vec<u8> = g
        .log_scales
        .iter()
        .flat_map(|s| s.map(|v| to_u8((v + 10.0) * 16.0)))
        .collect();
    let rotations: Vec<u8> = g
        .rotations
        .par_iter()
        .flat_map_iter(|&[w, x, y, z]| pack_smallest_three([x, -y, -z, w]))
        .collect();
    let k = g.rest_per_channel();
    let flip_sh = sh_flips(1.0, -1.0, -1.0);
    let b1 = 1 << (8 - SH1_BITS);
    let brest = 1 << (8 - SH_REST_BITS);
    let sh: Vec<u8> = g
        .sh_rest
        .iter()
        .enumerate()
        .map(|(idx, &v)| {
            let kk = (idx / 3) % k.max(1);
            quantize_sh(v * flip_sh[kk], if kk < 3 { b1 } else { brest })
        })
        .collect();
    let streams = [positions, alphas, colors, scales, rotations, sh];
    let chunks: Vec<Result<(u64, Vec<u8>)>> = streams
        .par_iter()
        .filter(|s| !s.is_empty())
        .map(|s| {
            zstd::bulk::compress(s, ZSTD_LEVEL)
                .map(|c| (s.len() as u64, c))
                .map_err(|e| Error::io(name, e))
        })
        .collect();
    let chunks: Vec<(u64, Vec<u8>)> = chunks.into_iter().collect::<Result<_>>()?;
    let mut out = Vec::with_capacity(
        32 + 16 * chunks.len() + chunks.iter().map(|c| c.1.len()).sum::<usize>(),
    );
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&WRITE_VERSION.to_le_bytes());
    out.extend_from_slice(&(n as u32).to_le_bytes());
    out.push(g.sh_degree as u8);
    out.push(fb);
    out.push(0); // flags: not antialiased, no extensions
    out.push(chunks.len() as u8);
    out.extend_from_slice(&32u32.to_le_bytes());
    out.extend_from_slice(&[0u8; 12]);
    for (unc, c) in &chunks {
        out.extend_from_slice(&(c.len() as u64).to_le_bytes());
        out.extend_from_slice(&unc.to_le_bytes());
    }
    for (_, c) in &chunks {
        out.extend_from_slice(c);
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests;
