//! Gaussian-splat file formats other than the graphdeco 3DGS PLY, and the
//! one place that says which of them a file is.
//!
//! | [`SplatFormat`] | extension | detected by | read | write |
//! |---|---|---|---|---|
//! | `ply` (graphdeco 3DGS) | `.ply` | `ply` magic, 3DGS properties | yes | yes |
//! | `compressed-ply` (SuperSplat / PlayCanvas) | `.compressed.ply` | `ply` magic, `packed_position` | yes | yes |
//! | `splat` (antimatter15) | `.splat` | extension only (no header), size a multiple of 32 | yes | yes |
//! | `ksplat` (mkkellogg GaussianSplats3D) | `.ksplat` | extension and a header that parses | yes | no |
//! | `spz` (Niantic) | `.spz` | `NGSP` (v4) or gzip holding `NGSP` (v1–3) | yes | yes (v4) |
//! | `sog` (PlayCanvas) | `.sog`, `meta.json` | zip holding `meta.json`; JSON with `means` | yes | yes (bundled v2) |
//!
//! Every reader returns [`Gaussians`] with the 3DGS conventions of
//! [`crate::model::gaussians`] (raw values: log scales, opacity logits,
//! SH DC coefficients; quaternions (w, x, y, z)). Every writer takes a
//! `lossy` flag: `false` refuses, with an error naming the output, the first
//! Gaussian and the value, anything the format would clamp or drop
//! ([`check_lossless`]); quantisation to the format's step is not refused.

use std::path::Path;

use crate::io::detect::PlyKind;
use crate::io::ply::Header;
use crate::model::Gaussians;
use crate::{Error, Result};

pub mod compressed_ply;
pub mod dot_splat;
pub mod ksplat;
pub mod sog;
pub mod spz;

/// SH DC coefficient ↔ colour: colour = 0.5 + C0·dc (every format here).
pub const SH_C0: f64 = 0.282_094_791_773_878_14;

/// A Gaussian-splat file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SplatFormat {
    /// The graphdeco 3DGS PLY (float properties, [`crate::io::ply::gaussians`]).
    Ply,
    /// SuperSplat / PlayCanvas compressed PLY ([`compressed_ply`]).
    CompressedPly,
    /// antimatter15 `.splat`, 32-byte records ([`dot_splat`]).
    Splat,
    /// mkkellogg GaussianSplats3D `.ksplat` ([`ksplat`], read only).
    Ksplat,
    /// Niantic SPZ ([`spz`]; read: versions 1–4, written: version 4).
    Spz,
    /// PlayCanvas SOG ([`sog`]; read: bundled `.sog` or `meta.json`,
    /// versions 1–2; written: bundled version 2).
    Sog,
}

impl SplatFormat {
    /// Every format, in the order `--help` lists them.
    pub const ALL: [SplatFormat; 6] = [
        SplatFormat::Ply,
        SplatFormat::CompressedPly,
        SplatFormat::Spz,
        SplatFormat::Sog,
        SplatFormat::Splat,
        SplatFormat::Ksplat,
    ];

    /// Name as `--format` and `info` spell it.
    pub fn name(self) -> &'static str {
        match self {
            SplatFormat::Ply => "ply",
            SplatFormat::CompressedPly => "compressed-ply",
            SplatFormat::Splat => "splat",
            SplatFormat::Ksplat => "ksplat",
            SplatFormat::Spz => "spz",
            SplatFormat::Sog => "sog",
        }
    }

    /// The file extension, with its dot (`.compressed.ply` is a double one).
    pub fn extension(self) -> &'static str {
        match self {
            SplatFormat::Ply => ".ply",
            SplatFormat::CompressedPly => ".compressed.ply",
            SplatFormat::Splat => ".splat",
            SplatFormat::Ksplat => ".ksplat",
            SplatFormat::Spz => ".spz",
            SplatFormat::Sog => ".sog",
        }
    }

    /// Whether splatkit writes this format.
    pub fn writable(self) -> bool {
        !matches!(self, SplatFormat::Ksplat)
    }

    /// From a `--format` name (case-insensitive).
    pub fn from_name(s: &str) -> Option<SplatFormat> {
        let s = s.to_ascii_lowercase();
        Self::ALL.into_iter().find(|f| f.name() == s)
    }

    /// From the file name: the longest matching extension, case-insensitive
    /// (`a.compressed.ply` is compressed PLY, `a.ply` a 3DGS PLY).
    pub fn from_path(path: &Path) -> Option<SplatFormat> {
        let name = path.file_name()?.to_str()?.to_ascii_lowercase();
        let mut best: Option<SplatFormat> = None;
        for f in Self::ALL {
            if name.ends_with(f.extension())
                && name.len() > f.extension().len()
                && best.is_none_or(|b| f.extension().len() > b.extension().len())
            {
                best = Some(f);
            }
        }
        best
    }

    /// From the content alone: a PLY header tells 3DGS from compressed; SPZ
    /// has its magic ([`spz::sniff`]); `.splat` has no header and `.ksplat`
    /// no magic, so they are `None`.
    pub fn sniff(bytes: &[u8]) -> Option<SplatFormat> {
        if spz::sniff(bytes) {
            return Some(SplatFormat::Spz);
        }
        if sog::sniff_zip(bytes) || sog::sniff_meta(bytes) {
            return Some(SplatFormat::Sog);
        }
        if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
            let h = Header::parse("", bytes).ok()?;
            return match PlyKind::of(&h) {
                PlyKind::CompressedGaussians => Some(SplatFormat::CompressedPly),
                _ => Some(SplatFormat::Ply),
            };
        }
        None
    }

    /// Content first, then the extension; a `.splat` must also have a
    /// length that is a multiple of 32 bytes and a `.ksplat` a header that
    /// parses ([`ksplat::sniff`]).
    pub fn detect(path: &Path, bytes: &[u8]) -> Option<SplatFormat> {
        if let Some(f) = Self::sniff(bytes) {
            return Some(f);
        }
        match Self::from_path(path)? {
            SplatFormat::Splat if dot_splat::sniff(bytes) => Some(SplatFormat::Splat),
            SplatFormat::Ksplat if ksplat::sniff(bytes) => Some(SplatFormat::Ksplat),
            _ => None,
        }
    }
}

/// Reads Gaussians in `format` from `bytes` (`name` for errors; `base` is
/// the folder side files are resolved in: the images of an unbundled SOG
/// `meta.json`).
pub fn read(format: SplatFormat, name: &str, bytes: &[u8], base: &Path) -> Result<Gaussians> {
    match format {
        SplatFormat::Ply => crate::io::ply::gaussians::parse_gaussians(name, bytes),
        SplatFormat::CompressedPly => compressed_ply::read(name, bytes),
        SplatFormat::Splat => dot_splat::read(name, bytes),
        SplatFormat::Ksplat => ksplat::read(name, bytes),
        SplatFormat::Spz => spz::read(name, bytes),
        SplatFormat::Sog => sog::read(name, bytes, base),
    }
}

/// Encodes `g` in `format` (`name` is the output, for errors). See the
/// module docs for `lossy`. A 3DGS PLY keeps everything (binary
/// little-endian).
pub fn write(format: SplatFormat, name: &str, g: &Gaussians, lossy: bool) -> Result<Vec<u8>> {
    match format {
        SplatFormat::Ply => {
            let mut out = Vec::new();
            crate::io::ply::gaussians::write_gaussians(
                &mut out,
                g,
                crate::io::ply::Format::BinaryLittleEndian,
            )?;
            Ok(out)
        }
        SplatFormat::CompressedPly => compressed_ply::write(name, g, lossy),
        SplatFormat::Splat => dot_splat::write(name, g, lossy),
        SplatFormat::Spz => {
            // spz::write refuses out-of-range values itself; what it drops
            // (normals, extra properties, extra elements) is refused here
            if !lossy {
                check_lossless(name, g, &SPZ_EXTRAS)?;
            }
            spz::write(name, g, lossy)
        }
        // sog::write refuses what SOG drops or clamps itself (normals,
        // extra properties, SH above degree 3, non-finite values)
        SplatFormat::Sog => sog::write(name, g, lossy),
        SplatFormat::Ksplat => Err(Error::usage(format!(
            "{name}: splatkit reads KSPLAT but does not write it (write .compressed.ply, .splat \
             or .ply)"
        ))),
    }
}

/// The order in which `format`'s writer stores the Gaussians of `g`:
/// entry `j` is the input index of the Gaussian written `j`-th (compressed
/// PLY and SOG sort into Morton order, as splat-transform does; the others
/// keep the input order).
pub fn write_order(format: SplatFormat, g: &Gaussians) -> Vec<usize> {
    match format {
        SplatFormat::CompressedPly => morton_order(&g.means),
        SplatFormat::Sog => sog::write_order(&g.means),
        _ => (0..g.len()).collect(),
    }
}

/// What SPZ drops besides the ranges `spz::write` checks: normals, extra
/// properties and elements (SH up to degree 3 are kept).
const SPZ_EXTRAS: Capacity = Capacity {
    format: "SPZ",
    sh_degree: 3,
    colour: None,
    log_scale: None,
    sh_rest: None,
};

/// What a format can hold, for [`check_lossless`].
#[derive(Clone, Copy, Debug)]
pub struct Capacity {
    /// The format's name, for messages.
    pub format: &'static str,
    /// Highest SH degree stored (higher coefficients are dropped).
    pub sh_degree: usize,
    /// Range of the DC colour 0.5 + C0·dc the format holds without clamping.
    pub colour: Option<(f64, f64)>,
    /// Range of the log scales (natural log of the standard deviation).
    pub log_scale: Option<(f32, f32)>,
    /// Range of the SH rest coefficients.
    pub sh_rest: Option<(f32, f32)>,
}

/// Refuses Gaussians that writing to a format of capacity `cap` would
/// clamp or drop: a non-finite value; SH rest coefficients above the
/// format's degree that are not zero; values outside the format's ranges;
/// normals that are not all zero; extra per-Gaussian properties (such as a
/// bound PLY's `face_index` and barycentrics, or `filter_3D`); extra PLY
/// elements. `out` names the output. Checked in that order; the error names
/// the first Gaussian (0-based) and its value.
pub fn check_lossless(out: &str, g: &Gaussians, cap: &Capacity) -> Result<()> {
    let f = cap.format;
    let hint = "(give --lossy to write it anyway)";
    crate::io::ply::gaussians::check_finite(out, g).map_err(|e| {
        Error::format(
            out,
            format!(
                "{}; {f} cannot store it {hint}",
                e.to_string().trim_start_matches(&format!("{out}: "))
            ),
        )
    })?;
    let k = g.rest_per_channel();
    let keep = (cap.sh_degree + 1).pow(2) - 1;
    if k > keep {
        for i in 0..g.len() {
            let rest = &g.sh_rest[i * k * 3..(i + 1) * k * 3];
            if let Some(j) = (keep * 3..k * 3).find(|&j| rest[j] != 0.0) {
                let file = (j % 3) * k + j / 3;
                return Err(Error::format(
                    out,
                    format!(
                        "Gaussian {i} has f_rest_{file} = {}: SH degree {} is above the {} that \
                         {f} holds, so it would be dropped {hint}",
                        rest[j], g.sh_degree, cap.sh_degree
                    ),
                ));
            }
        }
    }
    if let Some((lo, hi)) = cap.colour {
        for (i, dc) in g.sh_dc.iter().enumerate() {
            for (c, &d) in dc.iter().enumerate() {
                let col = 0.5 + SH_C0 * d as f64;
                if !(lo..=hi).contains(&col) {
                    return Err(Error::format(
                        out,
                        format!(
                            "Gaussian {i} has f_dc_{c} = {d} (colour 0.5 + C0·dc = {col:.4}), \
                             outside the {lo}..{hi} that {f} holds {hint}"
                        ),
                    ));
                }
            }
        }
    }
    if let Some((lo, hi)) = cap.log_scale {
        for (i, s) in g.log_scales.iter().enumerate() {
            for (c, &v) in s.iter().enumerate() {
                if !(lo..=hi).contains(&v) {
                    return Err(Error::format(
                        out,
                        format!(
                            "Gaussian {i} has scale_{c} = {v} (log scale), outside the {lo}..{hi} \
                             that {f} holds {hint}"
                        ),
                    ));
                }
            }
        }
    }
    if let Some((lo, hi)) = cap.sh_rest {
        for i in 0..g.len() {
            for j in 0..k.min(keep) * 3 {
                let v = g.sh_rest[i * k * 3 + j];
                if !(lo..=hi).contains(&v) {
                    let file = (j % 3) * k + j / 3;
                    return Err(Error::format(
                        out,
                        format!(
                            "Gaussian {i} has f_rest_{file} = {v}, outside the {lo}..{hi} that \
                             {f} holds {hint}"
                        ),
                    ));
                }
            }
        }
    }
    if let Some(n) = &g.normals
        && let Some(i) = n.iter().position(|v| v.iter().any(|&x| x != 0.0))
    {
        return Err(Error::format(
            out,
            format!(
                "Gaussian {i} has normal {:?}: {f} stores no normals, so they would be dropped \
                 {hint}",
                n[i]
            ),
        ));
    }
    if !g.extras.item.is_empty() {
        let names: Vec<&str> = g.extras.item.iter().map(|p| p.name.as_str()).collect();
        return Err(Error::format(
            out,
            format!(
                "the Gaussians carry extra properties {} (Gaussian 0 has {} = {}): {f} stores \
                 none, so they would be dropped {hint}",
                names.join(", "),
                names[0],
                g.extras.item[0]
                    .data
                    .as_scalar()
                    .filter(|d| !d.is_empty())
                    .map_or("a list".to_string(), |d| d.get_f64(0).to_string())
            ),
        ));
    }
    if let Some(e) = g.extras.elements.first() {
        return Err(Error::format(
            out,
            format!(
                "the input has a PLY element '{}' ({} rows) besides the Gaussians: {f} stores \
                 none, so it would be dropped {hint}",
                e.name, e.count
            ),
        ));
    }
    Ok(())
}

/// The Morton (Z-order) permutation of `means` used by splat-transform's
/// compressed-PLY and SOG writers: 10 bits per axis over the points'
/// bounding box, a stable sort by code, and buckets of more than 256 equal
/// codes re-sorted over their own box. Entry `j` is the index of the
/// point sorted to place `j`. Non-finite extents leave the order as is.
pub fn morton_order(means: &[[f32; 3]]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..means.len()).collect();
    morton_refine(means, &mut idx);
    idx
}

fn morton_refine(means: &[[f32; 3]], idx: &mut [usize]) {
    if idx.is_empty() {
        return;
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in idx.iter() {
        for a in 0..3 {
            let v = means[i][a] as f64;
            // NaN compares false, as in the reference
            if v < lo[a] {
                lo[a] = v;
            }
            if v > hi[a] {
                hi[a] = v;
            }
        }
    }
    let len = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    if len.iter().any(|l| !l.is_finite()) || len.iter().all(|&l| l == 0.0) {
        return;
    }
    let mul = len.map(|l| if l == 0.0 { 0.0 } else { 1024.0 / l });
    let part = |v: u32| -> u32 {
        let mut v = v & 0x3ff;
        v = (v ^ (v << 16)) & 0xff00_00ff;
        v = (v ^ (v << 8)) & 0x0300_f00f;
        v = (v ^ (v << 4)) & 0x030c_30c3;
        (v ^ (v << 2)) & 0x0924_9249
    };
    let code = |i: usize| -> u32 {
        let q = |a: usize| {
            let t = ((means[i][a] as f64 - lo[a]) * mul[a]).min(1023.0);
            // ToUint32 of a non-negative value below 1024: truncation
            if t.is_nan() { 0 } else { t as u32 }
        };
        (part(q(2)) << 2) + (part(q(1)) << 1) + part(q(0))
    };
    let mut keyed: Vec<(u32, usize)> = idx.iter().map(|&i| (code(i), i)).collect();
    keyed.sort_by_key(|&(c, _)| c);
    for (slot, &(_, i)) in idx.iter_mut().zip(&keyed) {
        *slot = i;
    }
    let mut start = 0;
    while start < keyed.len() {
        let mut end = start + 1;
        while end < keyed.len() && keyed[end].0 == keyed[start].0 {
            end += 1;
        }
        if end - start > 256 {
            morton_refine(means, &mut idx[start..end]);
        }
        start = end;
    }
}

/// Activated opacity in f64 (the references compute in double precision).
pub(crate) fn sigmoid64(x: f32) -> f64 {
    1.0 / (1.0 + (-(x as f64)).exp())
}

/// Opacity logit of an 8-bit or unorm alpha `a` in [0, 1], as the PlayCanvas
/// engine decodes it: ±40 at the ends instead of ±∞.
pub(crate) fn logit_unorm(a: f64) -> f32 {
    if a <= 0.0 {
        -40.0
    } else if a >= 1.0 {
        40.0
    } else {
        (-(1.0 / a - 1.0).ln()) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_extensions() {
        for f in SplatFormat::ALL {
            assert_eq!(SplatFormat::from_name(f.name()), Some(f));
            let p = format!("scene{}", f.extension());
            assert_eq!(SplatFormat::from_path(Path::new(&p)), Some(f), "{p}");
        }
        assert_eq!(
            SplatFormat::from_path(Path::new("A.COMPRESSED.PLY")),
            Some(SplatFormat::CompressedPly)
        );
        assert_eq!(SplatFormat::from_path(Path::new(".ply")), None);
        assert_eq!(SplatFormat::from_path(Path::new("x.obj")), None);
    }

    /// The Morton order puts points of one octant together, and a bucket of
    /// equal codes is refined.
    #[test]
    fn morton_order_groups_octants() {
        let pts: Vec<[f32; 3]> = (0..8)
            .map(|i| [(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32])
            .rev()
            .collect();
        let o = morton_order(&pts);
        let sorted: Vec<[f32; 3]> = o.iter().map(|&i| pts[i]).collect();
        // x is the lowest bit of the code, z the highest
        assert_eq!(sorted[0], [0.0, 0.0, 0.0]);
        assert_eq!(sorted[1], [1.0, 0.0, 0.0]);
        assert_eq!(sorted[2], [0.0, 1.0, 0.0]);
        assert_eq!(sorted[7], [1.0, 1.0, 1.0]);
        // 300 points in one cell of the coarse grid, one far away: the
        // cluster is re-sorted by its own box
        let mut pts: Vec<[f32; 3]> = (0..300)
            .map(|i| [1e-6 * (299 - i) as f32, 0.0, 0.0])
            .collect();
        pts.push([1000.0, 0.0, 0.0]);
        let o = morton_order(&pts);
        assert_eq!(o[0], 299);
        assert_eq!(o[299], 0);
        assert_eq!(o[300], 300);
    }
}
