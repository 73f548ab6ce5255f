//! Photos (and masks) for cameras: the views a training or refinement loop
//! fits, loaded once and in parallel.
//!
//! Pairing a camera with its file, in order:
//! 1. a file named like the camera (`name` as stored, then its stem with
//!    `.png`, `.jpg`, `.jpeg` in either case);
//! 2. a file whose stem is the same number (DTU: camera `007`, image
//!    `000007.png`, mask `007.png`).
//!
//! A camera without a file is an error naming the camera, the folder and the
//! names tried. Sizes: cameras are scaled to 1/`downscale`; an image may be
//! the camera's size divided by any divisor j of `downscale` (j = downscale:
//! used as is; otherwise box-filtered by downscale / j, so DTU's half-size
//! images serve `--downscale 2` and `4`); anything else is an error naming
//! the file and both sizes. PNG (8/16-bit, grey/RGB/RGBA; alpha dropped, or
//! composited onto [`ViewOptions::background`] and kept) and baseline
//! JPEG are read; values are scaled to [0, 1] without gamma change. A mask
//! pixel is object where its value (blue byte, as OpenCV's channel 0) is
//! non-zero, as the DTU tools read masks.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::io::cameras::image_dimensions;
use crate::io::image::{RgbImage, read_mask, read_png_rgb, read_png_rgb_alpha};
use crate::model::{Camera, Mask, View};
use crate::{Error, Result};

const EXTS: [&str; 6] = ["png", "jpg", "jpeg", "PNG", "JPG", "JPEG"];

/// The files of `dir` that look like images, sorted by name.
fn image_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let name = dir.display().to_string();
    crate::io::transaction::note_input_dir(dir)?;
    let rd = std::fs::read_dir(dir).map_err(|e| Error::io(&name, e))?;
    let mut v: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| EXTS.contains(&e))
        })
        .collect();
    v.sort();
    Ok(v)
}

fn stem_of(p: &str) -> String {
    Path::new(p)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// The file in `files` (from `dir`) for camera `cam`.
fn find_file(dir: &Path, files: &[PathBuf], cam: &Camera, what: &str) -> Result<PathBuf> {
    let base = Path::new(&cam.name)
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = stem_of(&cam.name);
    let mut tried = vec![base.clone()];
    tried.extend(EXTS.iter().map(|e| format!("{stem}.{e}")));
    for t in &tried {
        let p = dir.join(t);
        if !t.is_empty() && p.is_file() {
            return Ok(p);
        }
    }
    if let Ok(n) = stem.parse::<u64>() {
        let hits: Vec<&PathBuf> = files
            .iter()
            .filter(|f| {
                f.file_stem()
                    .and_then(|s| s.to_str())
                    .and_then(|s| s.parse::<u64>().ok())
                    == Some(n)
            })
            .collect();
        if let [one] = hits.as_slice() {
            return Ok((*one).clone());
        }
    }
    Err(Error::invalid(format!(
        "no {what} for camera {:?} in {} (tried {}, and a file numbered {:?})",
        cam.name,
        dir.display(),
        tried[..4.min(tried.len())].join(", "),
        stem
    )))
}

fn is_jpeg(path: &Path) -> bool {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    ext == "jpg" || ext == "jpeg"
}

/// Like [`read_rgb`], also returning a PNG's alpha channel when it has one
/// (see [`read_png_rgb_alpha`]); a JPEG has none.
pub fn read_rgb_alpha(path: &Path) -> Result<(RgbImage, Option<Vec<f32>>)> {
    if is_jpeg(path) {
        return Ok((read_rgb(path)?, None));
    }
    read_png_rgb_alpha(path)
}

/// Decodes a PNG or JPEG as RGB in [0, 1]; errors name the file.
pub fn read_rgb(path: &Path) -> Result<RgbImage> {
    if !is_jpeg(path) {
        return read_png_rgb(path);
    }
    let name = path.display().to_string();
    let bytes = crate::io::source::read_file(path)?;
    let mut d = jpeg_decoder::Decoder::new(std::io::Cursor::new(&bytes));
    d.read_info()
        .map_err(|e| Error::format(&name, format!("JPEG: {e}")))?;
    let info = d
        .info()
        .ok_or_else(|| Error::format(&name, "JPEG: no frame header"))?;
    let (w, h) = (info.width as usize, info.height as usize);
    if (w as u64) * (h as u64) > 1 << 28 {
        return Err(Error::format(
            &name,
            format!("JPEG declares {w}x{h} pixels, more than the 2^28 limit"),
        ));
    }
    let px = d
        .decode()
        .map_err(|e| Error::format(&name, format!("JPEG: {e}")))?;
    let ch = match info.pixel_format {
        jpeg_decoder::PixelFormat::L8 => 1,
        jpeg_decoder::PixelFormat::RGB24 => 3,
        other => {
            return Err(Error::format(
                &name,
                format!("JPEG pixel format {other:?} is not supported (use 8-bit grey or RGB)"),
            ));
        }
    };
    let pixels = (0..w * h)
        .map(|i| {
            if ch == 3 {
                std::array::from_fn(|k| px[3 * i + k] as f32 / 255.0)
            } else {
                [px[i] as f32 / 255.0; 3]
            }
        })
        .collect();
    Ok(RgbImage {
        width: w,
        height: h,
        pixels,
    })
}

/// `cam` at 1/`k` of its resolution: size ⌊W/k⌋ × ⌊H/k⌋, intrinsics divided
/// by k (pixel centres stay at integer + 0.5).
pub fn downscale_camera(cam: &Camera, k: u32) -> Camera {
    let mut c = cam.clone();
    let f = k as f64;
    c.width = cam.width / k;
    c.height = cam.height / k;
    c.fx /= f;
    c.fy /= f;
    c.cx /= f;
    c.cy /= f;
    c
}

fn box_down<T: Copy>(
    px: &[T],
    w: usize,
    k: usize,
    ow: usize,
    oh: usize,
    avg: impl Fn(&[T]) -> T,
) -> Vec<T> {
    let mut out = Vec::with_capacity(ow * oh);
    let mut buf = Vec::with_capacity(k * k);
    for y in 0..oh {
        for x in 0..ow {
            buf.clear();
            for dy in 0..k {
                for dx in 0..k {
                    buf.push(px[(y * k + dy) * w + x * k + dx]);
                }
            }
            out.push(avg(&buf));
        }
    }
    out
}

/// Options of [`load_views`] and [`load_views_from_files`].
#[derive(Clone, Debug, Default)]
pub struct ViewOptions {
    /// Integer downscale of the cameras (1 = as stored).
    pub downscale: u32,
    /// Folder of masks (object = non-zero), paired like the images.
    pub masks: Option<PathBuf>,
    /// `None`: a PNG's alpha channel is dropped (the colours are used as
    /// stored) and [`View::alpha`] is `None`. `Some(bg)`: a photo with an
    /// alpha channel is composited onto `bg` (linear RGB in [0, 1]) as
    /// `rgb·a + bg·(1 − a)`, as 3DGS's NeRF-synthetic reader does, and its
    /// alpha is kept in [`View::alpha`] (box-filtered like the colours when
    /// downscaled); photos without alpha are unchanged (`alpha` `None`).
    pub background: Option<[f32; 3]>,
}

/// The image in `dir` of every camera, in camera order, by the pairing rules
/// of the module docs (no file is decoded). Errors: `dir` unreadable or
/// without PNG/JPEG files, or a camera without a file (naming the camera,
/// the folder and the names tried).
pub fn pair_images(cameras: &[Camera], dir: &Path) -> Result<Vec<PathBuf>> {
    let files = image_files(dir)?;
    if files.is_empty() {
        return Err(Error::invalid(format!(
            "{} holds no PNG or JPEG images",
            dir.display()
        )));
    }
    cameras
        .iter()
        .map(|cam| find_file(dir, &files, cam, "image"))
        .collect()
}

/// Loads the photo (and mask) of every camera from `images`, in parallel;
/// the views come back in camera order.
pub fn load_views(cameras: &[Camera], images: &Path, opts: &ViewOptions) -> Result<Vec<View>> {
    // pinhole first: a distorted camera is the error, not its missing file
    for cam in cameras {
        require_pinhole(cam)?;
    }
    let files = pair_images(cameras, images)?;
    load_views_from_files(cameras, &files, opts)
}

fn require_pinhole(cam: &Camera) -> Result<()> {
    cam.require_pinhole()
        .map_err(|m| Error::invalid(format!("camera {:?}: {m}", cam.name)))
}

/// [`load_views`] with the image of each camera given (`files[i]` for
/// `cameras[i]`, e.g. the `file_path`s of a `transforms.json`); masks are
/// still paired in [`ViewOptions::masks`]. Every file's size is read from
/// its header and checked against its camera before any pixel is decoded.
pub fn load_views_from_files(
    cameras: &[Camera],
    files: &[PathBuf],
    opts: &ViewOptions,
) -> Result<Vec<View>> {
    if files.len() != cameras.len() {
        return Err(Error::invalid(format!(
            "{} image files for {} cameras",
            files.len(),
            cameras.len()
        )));
    }
    let k = opts.downscale.max(1);
    let mask_files = match &opts.masks {
        Some(m) => image_files(m)?,
        None => Vec::new(),
    };
    // pair first (cheap, sequential, first error wins in camera order)
    let mut pairs = Vec::with_capacity(cameras.len());
    for (cam, img) in cameras.iter().zip(files) {
        require_pinhole(cam)?;
        let mask = match &opts.masks {
            Some(m) => Some(find_file(m, &mask_files, cam, "mask")?),
            None => None,
        };
        pairs.push((cam, img, mask));
    }
    pairs
        .par_iter()
        .map(|(cam, img, mask)| {
            let target = downscale_camera(cam, k);
            let (tw, th) = (target.width as usize, target.height as usize);
            // the factor the file still has to be divided by: the file is the
            // camera's size divided by some j that divides k (j = k: as is)
            let fit = |w: usize, h: usize, file: &Path| -> Result<usize> {
                let (cw, ch) = (cam.width as usize, cam.height as usize);
                for j in (1..=k as usize).rev().filter(|j| (k as usize).is_multiple_of(*j)) {
                    if (w, h) == (cw / j, ch / j) && (w / (k as usize / j), h / (k as usize / j)) == (tw, th) {
                        return Ok(k as usize / j);
                    }
                }
                Err(Error::invalid(format!(
                    "{}: the image is {w}x{h} but camera {:?} is {cw}x{ch}{} (expected {tw}x{th}, or the \
                     camera's size divided by a divisor of the downscale)",
                    file.display(),
                    cam.name,
                    if k > 1 {
                        format!(" at --downscale {k}")
                    } else {
                        String::new()
                    }
                )))
            };
            // sizes from the headers, before anything is decoded
            let (hw, hh) = image_dimensions(img)?;
            let f = fit(hw as usize, hh as usize, img)?;
            let mask_fit = match mask {
                Some(mp) => {
                    let (mw, mh) = image_dimensions(mp)?;
                    Some((mw as usize, mh as usize, fit(mw as usize, mh as usize, mp)?))
                }
                None => None,
            };
            let (rgb, alpha) = if opts.background.is_some() {
                read_rgb_alpha(img)?
            } else {
                (read_rgb(img)?, None)
            };
            if (rgb.width, rgb.height) != (hw as usize, hh as usize) {
                return Err(Error::format(
                    img.display(),
                    format!(
                        "the header says {hw}x{hh} but {}x{} pixels were decoded",
                        rgb.width, rgb.height
                    ),
                ));
            }
            let mut pixels = rgb.pixels;
            if let (Some(bg), Some(a)) = (opts.background, &alpha) {
                for (p, &a) in pixels.iter_mut().zip(a) {
                    *p = std::array::from_fn(|c| p[c] * a + bg[c] * (1.0 - a));
                }
            }
            let image = if f > 1 {
                box_down(&pixels, rgb.width, f, tw, th, |b| {
                    let n = b.len() as f32;
                    std::array::from_fn(|c| b.iter().map(|p| p[c]).sum::<f32>() / n)
                })
            } else {
                pixels
            };
            let alpha = alpha.map(|a| {
                if f > 1 {
                    box_down(&a, rgb.width, f, tw, th, |b| b.iter().sum::<f32>() / b.len() as f32)
                } else {
                    a
                }
            });
            let mask = match (mask, mask_fit) {
                (Some(mp), Some((mw, mh, f))) => {
                    let Mask {
                        width,
                        height,
                        bits,
                        ..
                    } = read_mask(mp)?;
                    if (width, height) != (mw, mh) {
                        return Err(Error::format(
                            mp.display(),
                            format!("the header says {mw}x{mh} but {width}x{height} pixels were decoded"),
                        ));
                    }
                    Some(if f > 1 {
                        // object where most of the block is object
                        box_down(&bits, width, f, tw, th, |b| {
                            2 * b.iter().filter(|&&x| x).count() >= b.len()
                        })
                    } else {
                        bits
                    })
                }
                _ => None,
            };
            Ok(View {
                camera: target,
                image,
                mask,
                alpha,
                source: img.display().to_string(),
            })
        })
        .collect()
}
