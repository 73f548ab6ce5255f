//! PlayCanvas SOG ("spatially ordered Gaussians"): a `meta.json` and
//! lossless WebP images, either loose in a folder or bundled in one zip
//! (`.sog`). Rules from `@playcanvas/splat-transform` (`writers/write-sog.ts`,
//! `readers/read-sog.ts`, `readers/read-sog-v1.ts`, `spatial/quantize-1d-core.ts`)
//! and the PlayCanvas engine's `gsplat-sog-data.js`.
//!
//! Every image holds one Gaussian per texel, row-major, in the same order
//! (the writer's Morton order). Version 2 (`"version": 2`, written by
//! splat-transform ≥ 1.x and by [`write`]):
//! - `means_l.webp`, `means_u.webp`: the low and high bytes of 16-bit
//!   coordinates; `x = sign(v)·(e^|v| − 1)` with `v = min + (max − min)·q/65535`
//!   per axis (`means.mins`/`maxs` are of the log-transformed values);
//! - `quats.webp`: smallest three of the normalised (w, x, y, z) with the
//!   largest made positive, each `255·(c·√2·0.5 + 0.5)` in R, G, B (in index
//!   order, skipping the largest), A = 252 + index of the largest;
//! - `scales.webp`: per axis an index into `scales.codebook` (256 log-scales);
//! - `sh0.webp`: per channel an index into `sh0.codebook` (256 DC values),
//!   A = `sigmoid(opacity)·255`;
//! - `shN_centroids.webp`, `shN_labels.webp` (optional, `shN.bands` 1–3): a
//!   palette of SH-rest vectors (centroid `i` in row `i/64`, texels
//!   `(i mod 64)·K + j` for coefficient `j`, R/G/B = channel indices into
//!   `shN.codebook`), and per Gaussian a 16-bit palette index (R low, G high);
//!   a label ≥ `shN.count` means zero SH.
//!
//! Version 1 (no `version` key) stores linear ranges instead of codebooks:
//! `scales.mins`/`maxs`, `sh0.mins`/`maxs` (4 entries, the 4th for the opacity
//! logit in A), SH palette bytes mapped through `shN.mins`/`maxs`; the palette
//! size comes from the centroid image (width 192, 512 or 960 for bands 1–3).
//!
//! **Axes**: SOG holds the PLY's (RDF) axes, as the 3DGS PLY; nothing is
//! converted. **Decoding**: an opacity byte decodes to logit(clamp(b/255,
//! 1e−6, 1 − 1e−6)) (splat-transform's rule); an invalid quaternion tag
//! decodes to the identity.
//!
//! **What is lossy** (see [`write`]): positions to 16 bits of the
//! log-transformed range per axis, rotations to 8 bits per component,
//! log-scales and DC colours through 256-entry codebooks, opacity to 8 bits,
//! SH rest through a palette of up to 64 Ki vectors whose entries go through a
//! 256-entry codebook. Normals and extra properties are not stored.

mod codebook;
mod read;
pub mod webp;
mod write;

use std::io::Read;
use std::path::Path;

use serde::Deserialize;

use crate::model::Gaussians;
use crate::{Error, Result};

pub use codebook::{Quantized, palette, quantize_1d};
pub use write::write;

/// The `meta.json` of either version (fields of both, optional where one
/// version lacks them).
#[derive(Debug, Deserialize)]
struct Meta {
    version: Option<u32>,
    count: Option<u64>,
    means: Means,
    scales: Table,
    quats: Files,
    sh0: Table,
    #[serde(rename = "shN")]
    sh_n: Option<ShN>,
}

#[derive(Debug, Deserialize)]
struct Means {
    shape: Option<Vec<u64>>,
    mins: Vec<f64>,
    maxs: Vec<f64>,
    files: Vec<String>,
}

#[derive(Debug, Deserialize)]
struct Table {
    codebook: Option<Vec<f32>>,
    mins: Option<Vec<f64>>,
    maxs: Option<Vec<f64>>,
    files: Vec<String>,
}

#[derive(Debug, Deserialize)]
struct Files {
    files: Vec<String>,
}

#[derive(Debug, Deserialize)]
struct ShN {
    count: Option<u64>,
    bands: Option<u32>,
    codebook: Option<Vec<f32>>,
    mins: Option<f64>,
    maxs: Option<f64>,
    files: Vec<String>,
}

/// The order the writer stores Gaussians in: entry `j` is the input index
/// of the `j`-th texel (Morton order of the positions, ties by index).
pub fn write_order(means: &[[f32; 3]]) -> Vec<usize> {
    write::morton_order(means)
        .into_iter()
        .map(|i| i as usize)
        .collect()
}

/// True when `bytes` are a zip archive (local-file header `PK\x03\x04`)
/// that holds a `meta.json`: a bundled SOG.
pub fn sniff_zip(bytes: &[u8]) -> bool {
    if !bytes.starts_with(b"PK\x03\x04") {
        return false;
    }
    match zip::ZipArchive::new(std::io::Cursor::new(bytes)) {
        Ok(z) => z.file_names().flatten().any(|n| is_meta_name(&n)),
        Err(_) => false,
    }
}

fn is_meta_name(n: &str) -> bool {
    n == "meta.json" || n.ends_with("/meta.json")
}

/// True when `bytes` look like a SOG `meta.json`: a JSON object with
/// `means`, `quats`, `scales` and `sh0` entries.
pub fn sniff_meta(bytes: &[u8]) -> bool {
    let t = bytes.trim_ascii_start();
    if !t.starts_with(b"{") {
        return false;
    }
    match serde_json::from_slice::<serde_json::Value>(bytes) {
        Ok(serde_json::Value::Object(m)) => ["means", "quats", "scales", "sh0"]
            .iter()
            .all(|k| m.get(*k).is_some_and(|v| v.is_object())),
        _ => false,
    }
}

/// Where the images come from: a zip (with the folder of its `meta.json`)
/// or a folder on disk.
enum Images<'a> {
    Zip(zip::ZipArchive<std::io::Cursor<&'a [u8]>>, String),
    Dir(&'a Path),
}

impl Images<'_> {
    /// The bytes of image `file` (a name from `meta.json`).
    fn load(&mut self, name: &str, file: &str) -> Result<Vec<u8>> {
        if file.is_empty()
            || file.starts_with('/')
            || file.contains('\\')
            || file.split('/').any(|c| c == "..")
        {
            return Err(Error::format(
                name,
                format!("meta.json names image {file:?}, which is not a plain relative file name"),
            ));
        }
        match self {
            Images::Zip(z, dir) => {
                let path = format!("{dir}{file}");
                let mut f = z.by_name(&path).map_err(|e| {
                    Error::format(
                        name,
                        format!("zip entry {path:?} (named in meta.json): {e}"),
                    )
                })?;
                let size = f.size();
                crate::io::budget::check(&format!("{name}: zip entry {path}"), size)?;
                // The header's size is a claim: memory follows the bytes that
                // actually inflate (a few-KB zip may declare a 1 GiB entry;
                // found by fuzzing), so only the first 16 MiB are reserved.
                let mut v = Vec::with_capacity(size.min(1 << 24) as usize);
                (&mut f)
                    .take(size + 1)
                    .read_to_end(&mut v)
                    .map_err(|e| Error::format(name, format!("zip entry {path:?}: {e}")))?;
                if v.len() as u64 != size {
                    return Err(Error::format(
                        name,
                        format!(
                            "zip entry {path:?}: {} bytes, its header says {size}",
                            v.len()
                        ),
                    ));
                }
                Ok(v)
            }
            Images::Dir(base) => {
                let p = base.join(file);
                std::fs::read(&p).map_err(|e| Error::io(p.display(), e))
            }
        }
    }
}

/// Reads a SOG scene: `bytes` are a bundled `.sog` zip, or a `meta.json`
/// whose images lie in folder `base`. `name` is used in errors. Returns
/// Gaussians in PLY (RDF) axes with (w, x, y, z) quaternions, log-scales
/// and opacity logits; SH degree from `shN.bands` (0 without `shN`).
pub fn read(name: &str, bytes: &[u8], base: &Path) -> Result<Gaussians> {
    if bytes.starts_with(b"PK") {
        let z = zip::ZipArchive::new(std::io::Cursor::new(bytes))
            .map_err(|e| Error::format(name, format!("zip: {e}")))?;
        let meta_path = z
            .file_names()
            .flatten()
            .filter(|n| is_meta_name(n))
            .min_by_key(|n| (n.matches('/').count(), n.to_string()))
            .ok_or_else(|| Error::format(name, "zip archive has no meta.json (not a SOG bundle)"))?
            .to_string();
        let dir = meta_path[..meta_path.len() - "meta.json".len()].to_string();
        let mut images = Images::Zip(z, dir);
        let meta_bytes = images.load(name, &meta_path[meta_path.len() - "meta.json".len()..])?;
        let meta = parse_meta(&format!("{name}: {meta_path}"), &meta_bytes)?;
        read::decode(name, &meta, &mut images)
    } else {
        let meta = parse_meta(name, bytes)?;
        read::decode(name, &meta, &mut Images::Dir(base))
    }
}

fn parse_meta(name: &str, bytes: &[u8]) -> Result<Meta> {
    serde_json::from_slice(bytes).map_err(|e| Error::format(name, format!("meta.json: {e}")))
}

#[cfg(test)]
mod tests;
