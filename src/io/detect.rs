//! What a file is: format from content first (magic bytes), extension second.

use std::path::Path;

use crate::io::ply::Header;

/// A file format splatkit knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileFormat {
    Ply,
    Obj,
    Off,
    Glb,
    Gltf,
    /// A PyTorch checkpoint (zip container).
    TorchPt,
    /// A NumPy `.npz` archive (zip container).
    Npz,
    /// A JSON file (cameras.json / transforms.json).
    Json,
    /// antimatter15 `.splat` Gaussians (no header: told by extension).
    Splat,
    /// mkkellogg GaussianSplats3D `.ksplat` Gaussians (told by extension).
    Ksplat,
    /// Niantic SPZ Gaussians (magic `NGSP`, or gzip holding it).
    Spz,
    /// PlayCanvas SOG Gaussians: a zip holding `meta.json` and WebP images,
    /// or the `meta.json` itself (images beside it).
    Sog,
}

impl FileFormat {
    /// Lower-case name as used by `--format` and `info`.
    pub fn name(self) -> &'static str {
        match self {
            FileFormat::Ply => "ply",
            FileFormat::Obj => "obj",
            FileFormat::Off => "off",
            FileFormat::Glb => "glb",
            FileFormat::Gltf => "gltf",
            FileFormat::TorchPt => "pt",
            FileFormat::Npz => "npz",
            FileFormat::Json => "json",
            FileFormat::Splat => "splat",
            FileFormat::Ksplat => "ksplat",
            FileFormat::Spz => "spz",
            FileFormat::Sog => "sog",
        }
    }

    /// From a file extension (case-insensitive).
    pub fn from_extension(path: &Path) -> Option<FileFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "ply" => FileFormat::Ply,
            "obj" => FileFormat::Obj,
            "off" | "coff" | "noff" => FileFormat::Off,
            "glb" => FileFormat::Glb,
            "gltf" => FileFormat::Gltf,
            "pt" | "pth" => FileFormat::TorchPt,
            "npz" => FileFormat::Npz,
            "json" => FileFormat::Json,
            "splat" => FileFormat::Splat,
            "ksplat" => FileFormat::Ksplat,
            "spz" => FileFormat::Spz,
            "sog" => FileFormat::Sog,
            _ => return None,
        })
    }

    /// From the first bytes; `None` when the content does not tell.
    pub fn sniff(bytes: &[u8]) -> Option<FileFormat> {
        if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
            return Some(FileFormat::Ply);
        }
        if bytes.starts_with(b"glTF") {
            return Some(FileFormat::Glb);
        }
        if crate::io::splat::spz::sniff(bytes) {
            return Some(FileFormat::Spz);
        }
        if crate::io::splat::sog::sniff_zip(bytes) || crate::io::splat::sog::sniff_meta(bytes) {
            return Some(FileFormat::Sog);
        }
        let text = std::str::from_utf8(&bytes[..bytes.len().min(512)]).unwrap_or("");
        let first = text
            .lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && !l.starts_with('#'));
        if let Some(l) = first
            && matches!(
                l.split_whitespace().next(),
                Some("OFF" | "COFF" | "NOFF" | "CNOFF" | "NCOFF")
            )
        {
            return Some(FileFormat::Off);
        }
        // OBJ: its first statement is one of the OBJ keywords (so a mesh
        // piped through stdin, with no extension to go by, is still found).
        if let Some(l) = first
            && matches!(
                l.split_whitespace().next(),
                Some("v" | "vn" | "vt" | "f" | "o" | "g" | "s" | "mtllib" | "usemtl")
            )
        {
            return Some(FileFormat::Obj);
        }
        None
    }

    /// Content first, then extension. Zip archives are told apart by
    /// extension (`.npz` vs `.pt`), defaulting to a torch checkpoint.
    ///
    /// Binary formats without magic bytes (`.splat`, `.ksplat`) are taken from the
    /// extension before the text sniffers run, so a record that happens to
    /// look like an OBJ statement is not misread; a PLY or glTF magic still
    /// wins.
    pub fn detect(path: &Path, bytes: &[u8]) -> Option<FileFormat> {
        let by_ext = Self::from_extension(path);
        let strong = bytes.starts_with(b"ply\n")
            || bytes.starts_with(b"ply\r\n")
            || bytes.starts_with(b"glTF");
        if matches!(by_ext, Some(FileFormat::Splat | FileFormat::Ksplat)) && !strong {
            return by_ext;
        }
        if let Some(f) = Self::sniff(bytes) {
            return Some(f);
        }
        if bytes.starts_with(b"PK\x03\x04") {
            return Some(match by_ext {
                Some(FileFormat::Npz) => FileFormat::Npz,
                _ => FileFormat::TorchPt,
            });
        }
        by_ext
    }
}

/// What a PLY holds, from its header alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlyKind {
    /// A standard 3DGS Gaussian splat file.
    Gaussians,
    /// A 2DGS surfel file (the 3DGS layout with two scales).
    Surfels,
    /// A SuperSplat compressed splat file (packed chunks).
    CompressedGaussians,
    /// A triangle-splat soup (faces carry opacity and sigma).
    TriangleSoup,
    /// A triangle / polygon mesh.
    Mesh,
    /// Points only (no faces, or an empty face element).
    PointCloud,
    /// Something else.
    Other,
}

impl PlyKind {
    /// Classifies a header.
    pub fn of(h: &Header) -> PlyKind {
        let Some(v) = h.element("vertex") else {
            return PlyKind::Other;
        };
        let has = |n: &str| v.index_of(n).is_some();
        if has("packed_position") {
            return PlyKind::CompressedGaussians;
        }
        if has("f_dc_0") && has("opacity") && has("scale_0") && has("rot_0") {
            // 2DGS writes the 3DGS layout with two scales
            if has("scale_1") && !has("scale_2") {
                return PlyKind::Surfels;
            }
            return PlyKind::Gaussians;
        }
        match h.element("face") {
            Some(f) if f.index_of("opacity").is_some() && f.index_of("sigma").is_some() => {
                PlyKind::TriangleSoup
            }
            Some(f) if f.count > 0 => PlyKind::Mesh,
            _ if has("x") => PlyKind::PointCloud,
            _ => PlyKind::Other,
        }
    }

    /// Lower-case name used by `info`.
    pub fn name(self) -> &'static str {
        match self {
            PlyKind::Gaussians => "gaussians",
            PlyKind::Surfels => "surfels",
            PlyKind::CompressedGaussians => "gaussians-compressed",
            PlyKind::TriangleSoup => "triangle-soup",
            PlyKind::Mesh => "mesh",
            PlyKind::PointCloud => "point-cloud",
            PlyKind::Other => "other",
        }
    }
}
