//! Training data sets: a DATA folder of cameras, photos, optional masks and
//! optional initial points, loaded into [`View`]s for a training loop.
//!
//! # Layouts
//! The camera file is found by [`resolve_camera_source`], so when a folder
//! holds several, the first in this order wins: a COLMAP model in ROOT,
//! `ROOT/sparse/0`, `ROOT/sparse` (binary `.bin` before text `.txt`), then
//! `ROOT/cameras.json`, `ROOT/transforms_train.json`, `ROOT/transforms.json`,
//! `ROOT/cameras_sphere.npz`, `ROOT/cameras.npz`.
//!
//! | format ([`Dataset::format`]) | cameras | photos | masks (see [`MaskMode`]) | points |
//! |---|---|---|---|---|
//! | `"colmap"` | COLMAP model (cameras + images `.bin`/`.txt`) | `ROOT/images` | `ROOT/masks`, else `ROOT/mask` | `points3D.bin` / `.txt` beside the model (the model's own format; `points3D.ply` when neither exists): xyz + rgb |
//! | `"3dgs cameras.json"` | `ROOT/cameras.json` (3DGS output) | `ROOT/images` | `ROOT/masks`, else `ROOT/mask` | `ROOT/input.ply` (x y z, red green blue) when present |
//! | `"nerf transforms"` | `transforms_train.json`, else `transforms.json` | each frame's `file_path` relative to the JSON's folder, `.png` appended when it has no extension | none | none (the caller initialises randomly) |
//! | `"dtu npz"` | `cameras_sphere.npz` (else `cameras.npz`), in the normalised unit-sphere frame (`scale_mat` applied, as NeuS trains) | the first of `ROOT/image`, `ROOT/images`, `ROOT/image_full` (full size), `ROOT/image_half` (half size) that has an image for **every** camera | `ROOT/mask` (else `ROOT/masks`) | none |
//!
//! Photos are paired with cameras and decoded by [`load_views_from_files`]
//! (the pairing rules of [`crate::io::views`]: file named like the camera,
//! else the same number); extra photos without a camera are ignored, a camera
//! without a photo is an error naming it. Cameras and views keep the order of
//! the camera reader (see [`crate::io::cameras`]).
//!
//! # Units and pixels
//! Cameras follow [`crate::model::Camera`]: OpenCV axes, world-to-camera
//! pose, intrinsics in pixels with pixel centres at integer + 0.5, positions
//! in the format's world units (COLMAP / 3DGS: the reconstruction's
//! arbitrary scale; NeRF: Blender units; DTU: the unit sphere around the
//! object). Colours are linear values in [0, 1] (8- or 16-bit / max, no gamma
//! change). A photo with an alpha channel (NeRF-synthetic RGBA PNGs, or any
//! RGBA PNG) is composited onto [`DatasetOptions::background`] as
//! `rgb·a + bg·(1 − a)`, and its alpha is kept in [`View::alpha`].
//!
//! # Resolution
//! Views are loaded at an integer fraction 1/k of the cameras' size, by
//! the rule every command shares ([`crate::model::rig::downscale`]: sizes
//! rounded as 3DGS does, ties to even; intrinsics scaled by the same
//! factors; photos box-filtered k×k when k divides their size, otherwise
//! pixel-area resampled). k is [`DatasetOptions::downscale`], or, when
//! [`DatasetOptions::resolution`] gives a target width W, the smallest k with
//! `widest camera / k ≤ W` (3DGS's `-r WIDTH`, restricted to integers). DTU's `image_half` photos are half the size
//! of their cameras (the npz describes the 1600×1200 originals): k counts
//! from the cameras, so it must be even; downscale 1 ("as stored") means 2
//! there, an odd downscale above 1 is an error, and a target width picks the
//! smallest even k. A downscale of 4 on DTU is 400×300 from either folder.
//!
//! Loading reads files only: nothing is written.

use std::path::{Path, PathBuf};

use crate::io::cameras::colmap::{decode_points3d_bin, decode_points3d_txt};
use crate::io::cameras::{CameraFormat, read_cameras, resolve_camera_source};
use crate::io::ply::points::parse_points;
use crate::io::read_input;
use crate::io::views::{ViewOptions, load_views_from_files, pair_images};
use crate::model::{Camera, PointCloud, View};
use crate::{Error, Result};

/// Whether views get masks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MaskMode {
    /// Use masks when the data set has a mask folder (see the module table).
    #[default]
    Auto,
    /// Use masks; a data set without a mask folder is an error.
    On,
    /// Never load masks.
    Off,
}

/// Options of [`load_dataset`].
#[derive(Clone, Debug, PartialEq)]
pub struct DatasetOptions {
    /// Integer downscale of the cameras: 1 = the cameras' size (the photos
    /// as stored, except DTU `image_half`: see the module docs). Must be ≥ 1.
    pub downscale: u32,
    /// Target width in pixels; overrides `downscale` with the smallest
    /// integer k that brings the widest camera to at most this width.
    pub resolution: Option<u32>,
    /// Whether to load masks.
    pub masks: MaskMode,
    /// Linear RGB in [0, 1] that photos with an alpha channel are composited
    /// onto.
    pub background: [f32; 3],
    /// Bytes per pixel the caller will need, beyond the loaded views, for
    /// the one view it works on at a time (a training step's buffers): added
    /// to the memory estimate [`views_bytes`] checked before any photo is
    /// decoded. 0 counts the loaded views only.
    pub work_bytes_per_pixel: u64,
}

impl Default for DatasetOptions {
    /// Downscale 1, no target width, masks [`MaskMode::Auto`], black background.
    fn default() -> Self {
        DatasetOptions {
            downscale: 1,
            resolution: None,
            masks: MaskMode::Auto,
            background: [0.0; 3],
            work_bytes_per_pixel: 0,
        }
    }
}

/// Bytes per pixel (at the loading size) every loaded [`View`] holds: the
/// linear RGB image (3 × f32 = 12), the mask (1 byte as `bool`) and the
/// alpha (f32, 4; counted whether or not the photos have one).
pub const VIEW_BYTES_PER_PIXEL: u64 = 12 + 1 + 4;

/// Bytes per pixel of a photo file (at its stored size, at most its
/// camera's) while it is decoded: 16-bit RGBA samples (8), linear RGB and
/// alpha in f32 before box filtering (12 + 4), and its mask decoded alike (8).
pub const DECODE_BYTES_PER_PIXEL: u64 = 8 + 16 + 8;

/// Bytes needed to load `cameras`' photos at integer downscale `k` and work
/// on them: Σ over views of (w/k)·(h/k) × [`VIEW_BYTES_PER_PIXEL`] (all
/// views are held) + the largest camera's w·h × [`DECODE_BYTES_PER_PIXEL`] ×
/// the photos decoded at once (`min(threads, views)`) + the largest view's
/// (w/k)·(h/k) × `work_bytes_per_pixel` (the caller's buffers for one view).
/// Saturating, so an overflow is refused as too large.
pub fn views_bytes(cameras: &[Camera], k: u32, threads: usize, work_bytes_per_pixel: u64) -> u64 {
    let k = u64::from(k.max(1));
    let full = |c: &Camera| u64::from(c.width).saturating_mul(u64::from(c.height));
    let scaled = |c: &Camera| (u64::from(c.width) / k).saturating_mul(u64::from(c.height) / k);
    let held = cameras
        .iter()
        .map(scaled)
        .fold(0u64, |a, p| a.saturating_add(p))
        .saturating_mul(VIEW_BYTES_PER_PIXEL);
    let at_once = threads.clamp(1, cameras.len().max(1)) as u64;
    let decode = cameras
        .iter()
        .map(full)
        .max()
        .unwrap_or(0)
        .saturating_mul(DECODE_BYTES_PER_PIXEL)
        .saturating_mul(at_once);
    let work = cameras
        .iter()
        .map(scaled)
        .max()
        .unwrap_or(0)
        .saturating_mul(work_bytes_per_pixel);
    held.saturating_add(decode).saturating_add(work)
}

/// Refuses to load `cameras`' photos at downscale `k` when [`views_bytes`]
/// (with the global thread pool's size) is beyond the memory budget
/// ([`crate::io::budget::check`]); `source` (the data folder or camera
/// file the sizes come from) is named in the message.
pub fn check_views_budget(
    source: &Path,
    cameras: &[Camera],
    k: u32,
    work_bytes_per_pixel: u64,
) -> Result<()> {
    let (w, h) = cameras
        .iter()
        .max_by_key(|c| u64::from(c.width) * u64::from(c.height))
        .map_or((0, 0), |c| (c.width / k.max(1), c.height / k.max(1)));
    crate::io::budget::check(
        &format!(
            "{}: the photos of {} views (largest {w}x{h} at downscale {k}) and their training buffers",
            source.display(),
            cameras.len()
        ),
        views_bytes(
            cameras,
            k,
            rayon::current_num_threads(),
            work_bytes_per_pixel,
        ),
    )
}

/// A loaded data set.
#[derive(Clone, Debug)]
pub struct Dataset {
    /// One view per camera, in the camera reader's order, at the chosen
    /// resolution (the cameras are the downscaled ones).
    pub views: Vec<View>,
    /// Initial points with colours, when the data set has them (COLMAP
    /// `points3D`, 3DGS `input.ply`); `None` otherwise or when the file holds
    /// no points.
    pub points: Option<PointCloud>,
    /// `"colmap"`, `"3dgs cameras.json"`, `"nerf transforms"` or `"dtu npz"`.
    pub format: &'static str,
    /// The DATA folder.
    pub root: PathBuf,
    /// The camera file read (for COLMAP, the model folder).
    pub cameras_file: PathBuf,
}

/// Loads the data set in folder `root` (see the module docs for the layouts,
/// which file wins and how the resolution is chosen).
///
/// Errors name the folder or file and what disagrees: `root` not a folder or
/// without camera data; a camera file without cameras, or with a non-pinhole
/// camera (undistort first); a missing or empty photo folder; a camera
/// without a photo; a photo (or mask) whose size is not its camera's at the
/// chosen downscale; [`MaskMode::On`] without masks.
pub fn load_dataset(root: &Path, opts: &DatasetOptions) -> Result<Dataset> {
    if !root.is_dir() {
        return Err(Error::invalid(format!(
            "{}: not a folder (expected a DATA folder with cameras and images)",
            root.display()
        )));
    }
    crate::io::transaction::note_input_dir(root)?;
    let Some((format, source)) = resolve_camera_source(root) else {
        return Err(Error::invalid(format!(
            "{}: no camera data found (expected a COLMAP model in the folder, sparse/0 or sparse; \
             cameras.json; transforms_train.json or transforms.json; cameras_sphere.npz)",
            root.display()
        )));
    };
    let cameras = read_cameras(&source)?;
    check_pinhole(&source, &cameras)?;
    let mut half = false;
    let (name, files, masks, points) = match format {
        CameraFormat::ColmapBinary | CameraFormat::ColmapText => {
            let images = images_folder(root, &source)?;
            let files = pair_images(&cameras, &images)?;
            let points = colmap_points(&source, format)?;
            (
                "colmap",
                files,
                mask_folder(root, &["masks", "mask"]),
                points,
            )
        }
        CameraFormat::GsJson => {
            let images = images_folder(root, &source)?;
            let files = pair_images(&cameras, &images)?;
            let ply = root.join("input.ply");
            let points = if ply.is_file() {
                let input = read_input(&ply)?;
                Some(parse_points(&input.name, &input)?)
            } else {
                None
            };
            (
                "3dgs cameras.json",
                files,
                mask_folder(root, &["masks", "mask"]),
                points,
            )
        }
        CameraFormat::NerfTransforms => {
            let files = transforms_files(&source, &cameras)?;
            ("nerf transforms", files, None, None)
        }
        CameraFormat::NeusNpz => {
            let (files, is_half) = dtu_images(root, &cameras)?;
            half = is_half;
            (
                "dtu npz",
                files,
                mask_folder(root, &["mask", "masks"]),
                None,
            )
        }
    };
    let masks = match opts.masks {
        MaskMode::Off => None,
        MaskMode::Auto => masks,
        MaskMode::On => Some(masks.ok_or_else(|| {
            Error::invalid(format!(
                "{}: masks were asked for but the {name} data set has no mask folder ({}){}",
                root.display(),
                match format {
                    CameraFormat::NeusNpz => "mask or masks",
                    CameraFormat::NerfTransforms => "this layout has none",
                    _ => "masks or mask",
                },
                if format == CameraFormat::NerfTransforms {
                    "; RGBA alpha is kept in View::alpha, not as a mask"
                } else {
                    ""
                }
            ))
        })?),
    };
    let downscale = choose_downscale(root, &cameras, opts, half)?;
    // every photo is held in memory: refused before any is decoded
    check_views_budget(root, &cameras, downscale, opts.work_bytes_per_pixel)?;
    let views = load_views_from_files(
        &cameras,
        &files,
        &ViewOptions {
            downscale,
            masks,
            background: Some(opts.background),
        },
    )?;
    Ok(Dataset {
        views,
        points: points.filter(|p| !p.is_empty()),
        format: name,
        root: root.to_path_buf(),
        cameras_file: source,
    })
}

/// Every camera must be pinhole: training on the undistorted subset of a
/// data set would silently drop views.
fn check_pinhole(source: &Path, cameras: &[Camera]) -> Result<()> {
    let bad: Vec<&Camera> = cameras
        .iter()
        .filter(|c| c.require_pinhole().is_err())
        .collect();
    let Some(first) = bad.first() else {
        return Ok(());
    };
    let why = first.require_pinhole().unwrap_err();
    let msg = if bad.len() == cameras.len() {
        format!(
            "no usable view: none of the {} cameras is pinhole (camera {:?}: {why}); undistort \
             the images first (e.g. COLMAP image_undistorter), as 3DGS requires",
            cameras.len(),
            first.name
        )
    } else {
        format!(
            "{} of {} cameras are not pinhole (first: camera {:?}: {why}); undistort the images \
             first (e.g. COLMAP image_undistorter)",
            bad.len(),
            cameras.len(),
            first.name
        )
    };
    Err(Error::format(source.display(), msg))
}

/// `ROOT/images`, which must exist.
fn images_folder(root: &Path, source: &Path) -> Result<PathBuf> {
    let images = root.join("images");
    if !images.is_dir() {
        return Err(Error::invalid(format!(
            "{}: missing images folder {} (the photos for the cameras in {})",
            root.display(),
            images.display(),
            source.display()
        )));
    }
    Ok(images)
}

/// The first of `names` under `root` that is a folder.
fn mask_folder(root: &Path, names: &[&str]) -> Option<PathBuf> {
    names.iter().map(|n| root.join(n)).find(|p| p.is_dir())
}

/// The model's points: `points3D.bin` for a binary model, `points3D.txt` for
/// a text one (else the other), else `points3D.ply`; `None` when none exists.
fn colmap_points(dir: &Path, format: CameraFormat) -> Result<Option<PointCloud>> {
    let order: [&str; 2] = if format == CameraFormat::ColmapBinary {
        ["bin", "txt"]
    } else {
        ["txt", "bin"]
    };
    for ext in order {
        let p = dir.join(format!("points3D.{ext}"));
        if !p.is_file() {
            continue;
        }
        let input = read_input(&p)?;
        let pts = if ext == "bin" {
            decode_points3d_bin(&input.name, &input)?
        } else {
            let s = std::str::from_utf8(&input)
                .map_err(|e| Error::format(&input.name, format!("not UTF-8 text: {e}")))?;
            decode_points3d_txt(&input.name, s)?
        };
        return Ok(Some(PointCloud {
            positions: pts.iter().map(|p| p.xyz.as_vec3().to_array()).collect(),
            normals: None,
            colors: Some(pts.iter().map(|p| p.rgb).collect()),
            extras: Default::default(),
        }));
    }
    let ply = dir.join("points3D.ply");
    if ply.is_file() {
        let input = read_input(&ply)?;
        return parse_points(&input.name, &input).map(Some);
    }
    Ok(None)
}

/// The photo of each frame of a `transforms*.json`: `file_path` relative to
/// the JSON's folder, `.png` appended when it has no extension (NeRF
/// synthetic's `./train/r_0`). The camera reader keeps one camera per frame,
/// in frame order.
fn transforms_files(json: &Path, cameras: &[Camera]) -> Result<Vec<PathBuf>> {
    let name = json.display().to_string();
    let input = read_input(json)?;
    let v: serde_json::Value = serde_json::from_slice(&input)
        .map_err(|e| Error::format(&name, format!("invalid JSON: {e}")))?;
    let frames = v
        .get("frames")
        .and_then(|f| f.as_array())
        .ok_or_else(|| Error::format(&name, "missing list 'frames'"))?;
    if frames.len() != cameras.len() {
        return Err(Error::format(
            &name,
            format!(
                "{} frames but {} cameras were read",
                frames.len(),
                cameras.len()
            ),
        ));
    }
    let dir = json.parent().unwrap_or(Path::new("."));
    frames
        .iter()
        .zip(cameras)
        .enumerate()
        .map(|(i, (f, cam))| {
            let fp = f.get("file_path").and_then(|p| p.as_str()).ok_or_else(|| {
                Error::format(&name, format!("frame {i}: missing string 'file_path'"))
            })?;
            let mut p = dir.join(fp);
            if p.extension().is_none() {
                p.as_mut_os_string().push(".png");
            }
            let folder = p.parent().unwrap_or(dir);
            if !folder.is_dir() {
                return Err(Error::invalid(format!(
                    "{name}: missing images folder {} (frame {i}, camera {:?})",
                    folder.display(),
                    cam.name
                )));
            }
            if !p.is_file() {
                return Err(Error::invalid(format!(
                    "{name}: no image for camera {:?} (frame {i}): {} does not exist",
                    cam.name,
                    p.display()
                )));
            }
            Ok(p)
        })
        .collect()
}

/// DTU photo folders, preferred first, with whether they hold half-size photos.
const DTU_FOLDERS: [(&str, bool); 4] = [
    ("image", false),
    ("images", false),
    ("image_full", false),
    ("image_half", true),
];

/// The first DTU photo folder with a photo for every camera; when none is
/// complete, the pairing error of the first one that exists.
fn dtu_images(root: &Path, cameras: &[Camera]) -> Result<(Vec<PathBuf>, bool)> {
    let mut first_err = None;
    for (folder, half) in DTU_FOLDERS {
        let dir = root.join(folder);
        if !dir.is_dir() {
            continue;
        }
        match pair_images(cameras, &dir) {
            Ok(files) => return Ok((files, half)),
            Err(e) => {
                first_err.get_or_insert(e);
            }
        }
    }
    let tried = DTU_FOLDERS.map(|(f, _)| f).join(", ");
    Err(match first_err {
        Some(e) => Error::invalid(format!(
            "{e} (no folder of {tried} under {} has an image for every camera)",
            root.display()
        )),
        None => Error::invalid(format!(
            "{}: missing images folder (none of {tried})",
            root.display()
        )),
    })
}

/// The integer downscale (see the module docs): `half` when the photos are
/// half the cameras' size.
fn choose_downscale(
    root: &Path,
    cameras: &[Camera],
    opts: &DatasetOptions,
    half: bool,
) -> Result<u32> {
    let widest = cameras.iter().map(|c| c.width).max().unwrap_or(1);
    let k = match opts.resolution {
        Some(0) => {
            return Err(Error::invalid(format!(
                "{}: a target width of 0 pixels",
                root.display()
            )));
        }
        Some(w) => {
            let k = widest.div_ceil(w).max(1);
            if half && k % 2 == 1 { k + 1 } else { k }
        }
        None => match opts.downscale {
            0 => {
                return Err(Error::invalid(format!(
                    "{}: downscale 0 (must be 1 or more)",
                    root.display()
                )));
            }
            1 if half => 2,
            k if half && k % 2 == 1 => {
                return Err(Error::invalid(format!(
                    "{}: downscale {k} is odd but the photos (image_half) are half the cameras' \
                     size: use an even downscale (2 = the photos as stored)",
                    root.display()
                )));
            }
            k => k,
        },
    };
    if let Some(c) = cameras
        .iter()
        .find(|c| c.width / k == 0 || c.height / k == 0)
    {
        return Err(Error::invalid(format!(
            "{}: downscale {k} leaves camera {:?} ({}x{}) without pixels",
            root.display(),
            c.name,
            c.width,
            c.height
        )));
    }
    Ok(k)
}

#[cfg(test)]
mod tests;
