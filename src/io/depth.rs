//! Depth maps, colour images and masks for fusion, matched to cameras by
//! image name.
//!
//! Depth files hold camera z in scene units, 0 = no depth:
//! - `.npy`: float32 or float64, shape (H, W), (H, W, 1) or (1, H, W), as
//!   `render` and numpy write them;
//! - `.png`: 16-bit (or 8-bit) grey; depth = stored value / `png_scale`
//!   (`render` writes round(depth × 1000) by default), 0 stays 0.
//!
//! Names: for a camera whose image is `NAME.EXT` (stem `NAME`, with any
//! folder dropped), a depth folder is searched for `NAME_depth.npy`,
//! `NAME.npy`, `NAME_depth.png`, `NAME.png`, in that order (the first two
//! are what `render` writes, so its output folder fuses as it is); colour
//! and mask folders by the rule every command pairs cameras and images
//! with ([`crate::model::rig::pick_file`]).

use std::path::{Path, PathBuf};

use crate::io::cameras::npz::parse_npy;
use crate::io::image::decode_png;
use crate::io::source::read_input;
use crate::model::{Camera, rig};
use crate::{Error, Result};

/// A depth map, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    pub width: usize,
    pub height: usize,
    /// Camera z, scene units; 0 = missing.
    pub depth: Vec<f32>,
}

/// The stem a camera's files are named after: its image name without
/// folders or extension ([`rig::camera_stem`]).
pub fn camera_stem(cam: &Camera) -> String {
    rig::camera_stem(&cam.name)
}

/// The first of `names` that is a file in `dir`, or an error listing them.
fn find_in(dir: &Path, what: &str, cam: &Camera, names: &[String]) -> Result<PathBuf> {
    crate::io::transaction::note_input_dir(dir)?;
    names
        .iter()
        .map(|n| dir.join(n))
        .find(|p| p.is_file())
        .ok_or_else(|| {
            Error::invalid(format!(
                "camera {:?} has no {what} in {} (looked for {})",
                cam.name,
                dir.display(),
                names.join(", ")
            ))
        })
}

/// The depth file of `cam` in `dir` (see the module documentation).
pub fn find_depth(dir: &Path, cam: &Camera) -> Result<PathBuf> {
    let s = camera_stem(cam);
    find_in(
        dir,
        "depth map",
        cam,
        &[
            format!("{s}_depth.npy"),
            format!("{s}.npy"),
            format!("{s}_depth.png"),
            format!("{s}.png"),
        ],
    )
}

/// The colour image or mask of `cam` in `dir`, by the rule every command
/// pairs cameras and images with ([`rig::pick_file`]: the camera's own
/// file name, its stem with an image extension, a unique equal number).
pub fn find_image(dir: &Path, what: &str, cam: &Camera) -> Result<PathBuf> {
    crate::io::transaction::note_input_dir(dir)?;
    let name = dir.display().to_string();
    let names: Vec<String> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(&name, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    match rig::pick_file(&cam.name, &names) {
        Some(n) => Ok(dir.join(n)),
        None => Err(Error::invalid(format!(
            "camera {:?} has no {what} in {} (looked for {}, and a file numbered {:?})",
            cam.name,
            dir.display(),
            rig::file_candidates(&cam.name)[..].join(", "),
            rig::camera_stem(&cam.name)
        ))),
    }
}

/// Reads a depth map (`.npy` or `.png`, by extension); `png_scale` divides
/// PNG values. Errors name the file.
pub fn read_depth(path: &Path, png_scale: f64) -> Result<DepthImage> {
    let name = path.display().to_string();
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "npy" => {
            let input = read_input(path)?;
            let a = parse_npy(&name, &input)?;
            let (h, w) = match a.shape.as_slice() {
                [h, w] | [h, w, 1] | [1, h, w] => (*h, *w),
                s => {
                    return Err(Error::format(
                        &name,
                        format!("depth array has shape {s:?}; expected (H, W)"),
                    ));
                }
            };
            Ok(DepthImage {
                width: w,
                height: h,
                depth: a.data.iter().map(|&v| v as f32).collect(),
            })
        }
        "png" => {
            if !(png_scale.is_finite() && png_scale > 0.0) {
                return Err(Error::invalid(format!(
                    "depth PNG scale must be positive, got {png_scale}"
                )));
            }
            let (info, buf) = decode_png(path, png::Transformations::IDENTITY)?;
            if info.color_type != png::ColorType::Grayscale {
                return Err(Error::format(
                    &name,
                    format!(
                        "depth PNG must be single-channel grey, this one is {:?}",
                        info.color_type
                    ),
                ));
            }
            let (w, h) = (info.width as usize, info.height as usize);
            let depth = match info.bit_depth {
                png::BitDepth::Sixteen => buf
                    .chunks_exact(2)
                    .take(w * h)
                    .map(|b| (u16::from_be_bytes([b[0], b[1]]) as f64 / png_scale) as f32)
                    .collect(),
                png::BitDepth::Eight => buf
                    .iter()
                    .take(w * h)
                    .map(|&b| (b as f64 / png_scale) as f32)
                    .collect(),
                d => {
                    return Err(Error::format(
                        &name,
                        format!("depth PNG has {d:?} bits per sample; 8 or 16 are read"),
                    ));
                }
            };
            Ok(DepthImage {
                width: w,
                height: h,
                depth,
            })
        }
        _ => Err(Error::format(
            &name,
            "depth maps are read from .npy (float) or 16-bit grey .png files",
        )),
    }
}

/// Reads an 8-bit (or 16-bit) colour image as RGB8 with its size; grey is
/// replicated, alpha dropped.
pub fn read_rgb8(path: &Path) -> Result<(usize, usize, Vec<[u8; 3]>)> {
    let img = crate::io::image::read_png_rgb(path)?;
    let px = img
        .pixels
        .iter()
        .map(|p| p.map(crate::io::image::to_u8))
        .collect();
    Ok((img.width, img.height, px))
}

/// Reads a mask as values in [0, 1]: the alpha channel of a grey+alpha or
/// RGBA PNG (2DGS's `gt_alpha_mask`), the grey value or the mean of R, G, B
/// otherwise.
pub fn read_mask_values(path: &Path) -> Result<(usize, usize, Vec<f32>)> {
    let (info, buf) = decode_png(path, png::Transformations::normalize_to_color8())?;
    let (w, h) = (info.width as usize, info.height as usize);
    let ch = info.color_type.samples();
    let v = (0..w * h)
        .map(|i| {
            let p = &buf[i * ch..(i + 1) * ch];
            let x = match info.color_type {
                png::ColorType::GrayscaleAlpha => p[1] as f32,
                png::ColorType::Rgba => p[3] as f32,
                png::ColorType::Rgb => (p[0] as f32 + p[1] as f32 + p[2] as f32) / 3.0,
                _ => p[0] as f32,
            };
            x / 255.0
        })
        .collect();
    Ok((w, h, v))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::cameras::npz::encode_npy_f32;
    use crate::io::image::write_png16;

    fn cam(name: &str) -> Camera {
        Camera::pinhole(
            name,
            3,
            2,
            1.0,
            1.0,
            1.5,
            1.0,
            glam::DMat3::IDENTITY,
            glam::DVec3::ZERO,
        )
    }

    /// `.npy` and 16-bit PNG depth read back what was written (PNG to the
    /// scale's resolution); names resolve in the documented order; a
    /// missing map names the camera and the names tried.
    #[test]
    fn depth_files_round_trip_and_resolve() {
        let dir = tempfile::tempdir().unwrap();
        let d = [0.0f32, 1.25, 2.5, 0.001, 3.0, 65.535];
        std::fs::write(dir.path().join("a_depth.npy"), encode_npy_f32(&[2, 3], &d)).unwrap();
        let q: Vec<u16> = d.iter().map(|v| (v * 1000.0).round() as u16).collect();
        let mut f = std::fs::File::create(dir.path().join("b.png")).unwrap();
        write_png16(&mut f, "b", 3, 2, &q).unwrap();
        drop(f);
        let a = read_depth(&find_depth(dir.path(), &cam("imgs/a.jpg")).unwrap(), 1000.0).unwrap();
        assert_eq!((a.width, a.height), (3, 2));
        assert_eq!(a.depth, d);
        let b = read_depth(&find_depth(dir.path(), &cam("b.png")).unwrap(), 1000.0).unwrap();
        for (x, y) in b.depth.iter().zip(d) {
            assert!((x - y).abs() <= 0.0005, "{x} vs {y}");
        }
        let e = find_depth(dir.path(), &cam("c.png"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("\"c.png\"") && e.contains("c_depth.npy"), "{e}");
        let e = read_depth(&dir.path().join("a_depth.npy"), 1000.0);
        assert!(e.is_ok());
        std::fs::write(
            dir.path().join("bad.npy"),
            encode_npy_f32(&[2, 3, 2], &[0.0; 12]),
        )
        .unwrap();
        let e = read_depth(&dir.path().join("bad.npy"), 1.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.npy") && e.contains("[2, 3, 2]"), "{e}");
    }
}
