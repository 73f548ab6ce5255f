//! Photos (and masks) for cameras: the views a training or refinement loop
//! fits, loaded once and in parallel.
//!
//! Pairing a camera with its file, in order:
//! 1. a file named like the camera (`name` as stored, then its stem with
//!    `.png`, `.jpg`, `.jpeg` in either case);
//! 2. a file whose stem is the same number (DTU: camera `007`, image
//!    `000007.png`, mask `007.png`).
//!
//! (Both rules are [`crate::model::rig::pick_file`], shared with every
//! command.) A camera without a file is an error naming the camera, the
//! folder and the names tried. Sizes: cameras are scaled to 1/`downscale`
//! by 3DGS's rule ([`crate::model::rig::downscale`]: sizes rounded, ties
//! to even); an image may be the camera's size at 1/j for any divisor j of
//! `downscale` (j = downscale: used as is; an exact multiple of the target:
//! box-filtered, so DTU's half-size images serve `--downscale 2` and `4`;
//! otherwise, when the size does not divide, pixel-area resampled);
//! anything else is an error naming the file and both sizes. PNG (8/16-bit, grey/RGB/RGBA; alpha dropped, or
//! composited onto [`ViewOptions::background`] and kept) and baseline
//! JPEG are read; values are scaled to [0, 1] without gamma change. A mask
//! pixel is object where its value (blue byte, as OpenCV's channel 0) is
//! non-zero, as the DTU tools read masks.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::io::cameras::image_dimensions;
use crate::io::image::{RgbImage, read_mask, read_png_rgb, read_png_rgb_alpha};
use crate::model::{Camera, Mask, View, rig};
use crate::{Error, Result};

const EXTS: [&str; 6] = rig::IMAGE_EXTENSIONS;

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

/// The file in `files` (from `dir`) for camera `cam`
/// ([`rig::pick_file`]).
fn find_file(dir: &Path, files: &[PathBuf], cam: &Camera, what: &str) -> Result<PathBuf> {
    let names: Vec<String> = files
        .iter()
        .filter_map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    if let Some(n) = rig::pick_file(&cam.name, &names) {
        return Ok(dir.join(n));
    }
    let tried = rig::file_candidates(&cam.name);
    Err(Error::invalid(format!(
        "no {what} for camera {:?} in {} (tried {}, and a file numbered {:?})",
        cam.name,
        dir.display(),
        tried[..4.min(tried.len())].join(", "),
        rig::camera_stem(&cam.name)
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

/// How a file is brought to its camera's downscaled size.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Resize {
    /// The file is the downscaled size already.
    AsIs,
    /// The file is exactly `f` times the downscaled size: `f` × `f` box
    /// average.
    Box(usize),
    /// Any other size the camera allows (the size does not divide):
    /// pixel-area average, each output pixel the mean of the source area it
    /// covers, fractional pixels weighted by their covered fraction.
    Area,
}

impl Resize {
    /// `px` (`src` = width × height) at `dst`; `avg` averages the values of
    /// one box (whole pixels, [`Resize::Box`]). [`Resize::Area`] averages
    /// through [`Pixel`].
    fn apply<T: Pixel>(
        self,
        px: Vec<T>,
        src: (usize, usize),
        dst: (usize, usize),
        avg: impl Fn(&[T]) -> T,
    ) -> Vec<T> {
        match self {
            Resize::AsIs => px,
            Resize::Box(f) => box_down(&px, src.0, f, dst.0, dst.1, avg),
            Resize::Area => {
                let planes = T::planes(&px);
                let out: Vec<Vec<f32>> =
                    planes.iter().map(|p| area_resample(p, src, dst)).collect();
                T::from_planes(&out)
            }
        }
    }
}

/// A pixel value the area resampler can split into f32 planes and put
/// back together.
trait Pixel: Copy {
    fn planes(px: &[Self]) -> Vec<Vec<f32>>;
    fn from_planes(planes: &[Vec<f32>]) -> Vec<Self>;
}

impl Pixel for [f32; 3] {
    fn planes(px: &[Self]) -> Vec<Vec<f32>> {
        (0..3).map(|c| px.iter().map(|p| p[c]).collect()).collect()
    }
    fn from_planes(planes: &[Vec<f32>]) -> Vec<Self> {
        (0..planes[0].len())
            .map(|i| std::array::from_fn(|c| planes[c][i]))
            .collect()
    }
}

impl Pixel for f32 {
    fn planes(px: &[Self]) -> Vec<Vec<f32>> {
        vec![px.to_vec()]
    }
    fn from_planes(planes: &[Vec<f32>]) -> Vec<Self> {
        planes[0].clone()
    }
}

/// Masks: the object fraction of the area, object where it is at least
/// one half (as the box rule's "most of the block").
impl Pixel for bool {
    fn planes(px: &[Self]) -> Vec<Vec<f32>> {
        vec![px.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect()]
    }
    fn from_planes(planes: &[Vec<f32>]) -> Vec<Self> {
        planes[0].iter().map(|&v| v >= 0.5).collect()
    }
}

/// For each output index along an axis of `n` source pixels resampled to
/// `m`: the first source pixel it covers and the covered fraction of each
/// source pixel, normalised to sum 1.
fn area_weights(n: usize, m: usize) -> Vec<(usize, Vec<f64>)> {
    let s = n as f64 / m as f64;
    (0..m)
        .map(|o| {
            let (a, b) = (o as f64 * s, ((o + 1) as f64 * s).min(n as f64));
            let first = a.floor() as usize;
            let last = (b.ceil() as usize).clamp(first + 1, n);
            let w: Vec<f64> = (first..last)
                .map(|i| (b.min(i as f64 + 1.0) - a.max(i as f64)).max(0.0) / (b - a))
                .collect();
            (first, w)
        })
        .collect()
}

/// Pixel-area resampling of one row-major plane from `src` to `dst`
/// (separable: rows, then columns; f64 sums).
fn area_resample(p: &[f32], src: (usize, usize), dst: (usize, usize)) -> Vec<f32> {
    let (wx, wy) = (area_weights(src.0, dst.0), area_weights(src.1, dst.1));
    let mut rows = vec![0.0f64; dst.0 * src.1];
    for y in 0..src.1 {
        for (x, (first, w)) in wx.iter().enumerate() {
            rows[y * dst.0 + x] = w
                .iter()
                .enumerate()
                .map(|(i, &wi)| wi * p[y * src.0 + first + i] as f64)
                .sum();
        }
    }
    let mut out = vec![0.0f32; dst.0 * dst.1];
    for (y, (first, w)) in wy.iter().enumerate() {
        for x in 0..dst.0 {
            out[y * dst.0 + x] = w
                .iter()
                .enumerate()
                .map(|(i, &wi)| wi * rows[(first + i) * dst.0 + x])
                .sum::<f64>() as f32;
        }
    }
    out
}

/// How a `w` × `h` file serves camera `cam` at 1/`k` (`target` its
/// downscaled size): the file must be the camera's size at 1/j for a
/// divisor j of k ([`rig::downscaled_size`]; j = k: the target itself, so
/// DTU's half-size images serve `--downscale 2` and `4`); anything else
/// is an error naming the file and both sizes.
fn fit(
    cam: &Camera,
    k: u32,
    target: (usize, usize),
    (w, h): (usize, usize),
    file: &Path,
) -> Result<Resize> {
    let (tw, th) = target;
    for j in (1..=k).rev().filter(|j| k.is_multiple_of(*j)) {
        let (sw, sh) = rig::downscaled_size(cam.width, cam.height, j);
        if (w, h) != (sw as usize, sh as usize) {
            continue;
        }
        return Ok(if (w, h) == (tw, th) {
            Resize::AsIs
        } else if w.is_multiple_of(tw) && h.is_multiple_of(th) && w / tw == h / th {
            Resize::Box(w / tw)
        } else {
            Resize::Area
        });
    }
    let (cw, ch) = (cam.width, cam.height);
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
            let target = rig::downscale(cam, k);
            let (tw, th) = (target.width as usize, target.height as usize);
            let fit = |w: usize, h: usize, file: &Path| fit(cam, k, (tw, th), (w, h), file);
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
            let src = (rgb.width, rgb.height);
            let image = f.apply(pixels, src, (tw, th), |b| {
                let n = b.len() as f32;
                std::array::from_fn(|c| b.iter().map(|p| p[c]).sum::<f32>() / n)
            });
            let alpha = alpha
                .map(|a| f.apply(a, src, (tw, th), |b| b.iter().sum::<f32>() / b.len() as f32));
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
                            format!(
                                "the header says {mw}x{mh} but {width}x{height} pixels were decoded"
                            ),
                        ));
                    }
                    // object where most of the block is object
                    Some(f.apply(bits, (width, height), (tw, th), |b| {
                        2 * b.iter().filter(|&&x| x).count() >= b.len()
                    }))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Pixel-area weights by hand: 3 pixels to 2, each output covers 1.5
    /// source pixels (1 + ½ and ½ + 1); 5 to 2 (2.5 each); a constant
    /// plane stays constant; a mask keeps object where at least half the
    /// area is object.
    #[test]
    fn area_resampling_weights_pixels_by_covered_area() {
        let out = area_resample(&[0.0, 3.0, 6.0], (3, 1), (2, 1));
        assert!(
            (out[0] - 1.0).abs() < 1e-6 && (out[1] - 5.0).abs() < 1e-6,
            "{out:?}"
        );
        let out = area_resample(&[1.0, 2.0, 3.0, 4.0, 5.0], (5, 1), (2, 1));
        assert!(
            (out[0] - 1.8).abs() < 1e-6 && (out[1] - 4.2).abs() < 1e-6,
            "{out:?}"
        );
        let c = area_resample(&[0.7; 35 * 27], (35, 27), (18, 14));
        assert!(c.iter().all(|v| (v - 0.7).abs() < 1e-6));
        let m = Resize::Area.apply(vec![true, true, false], (3, 1), (2, 1), |_| false);
        assert_eq!(m, vec![true, false], "2/3 object, then 1/3");
    }

    /// 3DGS's sizes: a 35-pixel camera at 1/2 is 18 pixels (ties to even),
    /// the file at full size is area-resampled, a 2× file box-filtered, the
    /// target size used as is; a floor-sized file (17) is refused.
    #[test]
    fn fit_follows_the_rig_rule() {
        let mut cam = crate::testing::cameras_around(1, 4.0, 35, 40.0).remove(0);
        cam.height = 35;
        let t = (18, 18);
        let f = |w, h| fit(&cam, 2, t, (w, h), Path::new("x.png"));
        assert_eq!(f(35, 35).unwrap(), Resize::Area);
        assert_eq!(f(18, 18).unwrap(), Resize::AsIs);
        assert!(f(17, 17).is_err());
        cam.width = 36;
        cam.height = 36;
        assert_eq!(
            fit(&cam, 2, (18, 18), (36, 36), Path::new("x.png")).unwrap(),
            Resize::Box(2)
        );
    }
}
