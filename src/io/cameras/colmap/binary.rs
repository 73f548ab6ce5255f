//! COLMAP's binary model files (`cameras.bin`, `images.bin`,
//! `points3D.bin`): reading and writing.

use std::path::Path;

use glam::DVec3;

use super::*;
use crate::io::source::{werr, write_output};
use crate::{Error, Result};

impl ColmapModel {
    /// Writes `cameras.bin`, `images.bin` and `points3D.bin` into `dir`
    /// (which must exist), byte-compatible with COLMAP's binary writer.
    pub fn write_binary(&self, dir: &Path) -> Result<()> {
        let files = [
            ("cameras.bin", encode_cameras_bin(&self.cameras)),
            ("images.bin", encode_images_bin(&self.images)),
            ("points3D.bin", encode_points3d_bin(&self.points3d)),
        ];
        for (name, bytes) in files {
            write_output(&dir.join(name), |w| w.write_all(&bytes).map_err(werr))?;
        }
        Ok(())
    }
}

/// A bounds-checked little-endian reader whose errors name the file, the
/// record being read and the byte offset.
struct Cursor<'a> {
    name: &'a str,
    data: &'a [u8],
    pos: usize,
    record: &'static str,
    index: usize,
}

impl<'a> Cursor<'a> {
    fn new(name: &'a str, data: &'a [u8]) -> Self {
        Cursor {
            name,
            data,
            pos: 0,
            record: "header",
            index: 0,
        }
    }

    fn at(&mut self, record: &'static str, index: usize) {
        self.record = record;
        self.index = index;
    }

    fn left(&self) -> usize {
        self.data.len() - self.pos
    }

    fn where_(&self) -> String {
        if self.record == "header" {
            "header".to_string()
        } else {
            format!("{} record {}", self.record, self.index)
        }
    }

    fn err(&self, msg: impl std::fmt::Display) -> Error {
        Error::format(
            self.name,
            format!("{} at byte offset {}: {msg}", self.where_(), self.pos),
        )
    }

    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8]> {
        if self.left() < n {
            return Err(self.err(format_args!(
                "truncated: {field} needs {n} bytes, only {} left",
                self.left()
            )));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn arr<const N: usize>(&mut self, field: &str) -> Result<[u8; N]> {
        Ok(self
            .take(N, field)?
            .try_into()
            .expect("take returns N bytes"))
    }
    fn u64(&mut self, field: &str) -> Result<u64> {
        Ok(u64::from_le_bytes(self.arr(field)?))
    }
    fn i64(&mut self, field: &str) -> Result<i64> {
        Ok(i64::from_le_bytes(self.arr(field)?))
    }
    fn u32(&mut self, field: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.arr(field)?))
    }
    fn i32(&mut self, field: &str) -> Result<i32> {
        Ok(i32::from_le_bytes(self.arr(field)?))
    }
    fn f64(&mut self, field: &str) -> Result<f64> {
        Ok(f64::from_le_bytes(self.arr(field)?))
    }

    /// A declared element count, checked against the bytes left given the
    /// smallest possible size of one element, before anything is allocated.
    fn count(&mut self, field: &str, min_each: usize) -> Result<usize> {
        let start = self.pos;
        let n = self.u64(field)?;
        let need = usize::try_from(n)
            .ok()
            .and_then(|n| n.checked_mul(min_each))
            .filter(|&need| need <= self.left());
        match need {
            Some(_) => Ok(n as usize),
            None => {
                self.pos = start;
                Err(self.err(format_args!(
                    "{field} = {n} needs at least {n} × {min_each} bytes, only {} left (truncated or corrupt file)",
                    self.left() - 8
                )))
            }
        }
    }

    /// A NUL-terminated string.
    fn cstring(&mut self, field: &str) -> Result<String> {
        let rest = &self.data[self.pos..];
        let Some(end) = rest.iter().position(|&b| b == 0) else {
            return Err(self.err(format_args!(
                "truncated: {field} has no terminating NUL byte"
            )));
        };
        let s = String::from_utf8_lossy(&rest[..end]).into_owned();
        self.pos += end + 1;
        Ok(s)
    }

    fn finish(&self) -> Result<()> {
        if self.left() != 0 {
            return Err(Error::format(
                self.name,
                format!(
                    "{} bytes of trailing data at byte offset {} after the last record",
                    self.left(),
                    self.pos
                ),
            ));
        }
        Ok(())
    }
}

pub(super) fn parse_cameras_bin(f: &Loaded) -> Result<Vec<ColmapCamera>> {
    decode_cameras_bin(&f.name, &f.bytes)
}
pub(super) fn parse_images_bin(f: &Loaded) -> Result<Vec<ColmapImage>> {
    decode_images_bin(&f.name, &f.bytes)
}
pub(super) fn parse_points3d_bin(f: &Loaded) -> Result<Vec<Point3D>> {
    decode_points3d_bin(&f.name, &f.bytes)
}

/// Parses the bytes of a `cameras.bin`; `name` is used in errors.
pub fn decode_cameras_bin(name: &str, data: &[u8]) -> Result<Vec<ColmapCamera>> {
    let mut c = Cursor::new(name, data);
    // Smallest camera record: ids, size and 3 parameters.
    let n = c.count("num_cameras", 4 + 4 + 8 + 8 + 3 * 8)?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        c.at("camera", i);
        let id = c.u32("camera_id")?;
        let model_id = c.i32("model_id")?;
        let Some((model, np)) = model_by_id(model_id) else {
            c.pos -= 4;
            return Err(c.err(format_args!(
                "unknown camera model id {model_id} (known: 0..={})",
                CAMERA_MODELS.len() - 1
            )));
        };
        let width = c.u64("width")?;
        let height = c.u64("height")?;
        let mut params = Vec::with_capacity(np);
        for _ in 0..np {
            params.push(c.f64(model)?);
        }
        out.push(ColmapCamera {
            id,
            model_id,
            width,
            height,
            params,
        });
    }
    c.finish()?;
    Ok(out)
}

/// Parses the bytes of an `images.bin`; `name` is used in errors. Images are
/// returned in file order.
pub fn decode_images_bin(name: &str, data: &[u8]) -> Result<Vec<ColmapImage>> {
    let mut c = Cursor::new(name, data);
    // Smallest image record: id, 7 doubles, camera id, empty name + NUL, point count.
    let n = c.count("num_reg_images", 4 + 7 * 8 + 4 + 1 + 8)?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        c.at("image", i);
        let id = c.u32("image_id")?;
        let mut qvec = [0.0; 4];
        for q in &mut qvec {
            *q = c.f64("qvec")?;
        }
        let mut tvec = [0.0; 3];
        for t in &mut tvec {
            *t = c.f64("tvec")?;
        }
        let camera_id = c.u32("camera_id")?;
        let name = c.cstring("name")?;
        let np = c.count("num_points2D", 24)?;
        let mut points2d = Vec::with_capacity(np);
        for _ in 0..np {
            let x = c.f64("point2D x")?;
            let y = c.f64("point2D y")?;
            let point3d_id = c.i64("point3D_id")?;
            points2d.push(Point2D { x, y, point3d_id });
        }
        out.push(ColmapImage {
            id,
            qvec,
            tvec,
            camera_id,
            name,
            points2d,
        });
    }
    c.finish()?;
    Ok(out)
}

/// Parses the bytes of a `points3D.bin`; `name` is used in errors.
pub fn decode_points3d_bin(name: &str, data: &[u8]) -> Result<Vec<Point3D>> {
    let mut c = Cursor::new(name, data);
    // Smallest point record: id, xyz, rgb, error, empty track.
    let n = c.count("num_points", 8 + 24 + 3 + 8 + 8)?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        c.at("point", i);
        let id = c.u64("point3D_id")?;
        let x = c.f64("xyz")?;
        let y = c.f64("xyz")?;
        let z = c.f64("xyz")?;
        let rgb = c.arr::<3>("rgb")?;
        let error = c.f64("error")?;
        let nt = c.count("track_length", 8)?;
        let mut track = Vec::with_capacity(nt);
        for _ in 0..nt {
            let image_id = c.u32("track image_id")?;
            let point2d_idx = c.u32("track point2D_idx")?;
            track.push(TrackElement {
                image_id,
                point2d_idx,
            });
        }
        out.push(Point3D {
            id,
            xyz: DVec3::new(x, y, z),
            rgb,
            error,
            track,
        });
    }
    c.finish()?;
    Ok(out)
}

/// The bytes of a `cameras.bin` holding `cameras`.
pub fn encode_cameras_bin(cameras: &[ColmapCamera]) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&(cameras.len() as u64).to_le_bytes());
    for c in cameras {
        b.extend_from_slice(&c.id.to_le_bytes());
        b.extend_from_slice(&c.model_id.to_le_bytes());
        b.extend_from_slice(&c.width.to_le_bytes());
        b.extend_from_slice(&c.height.to_le_bytes());
        for p in &c.params {
            b.extend_from_slice(&p.to_le_bytes());
        }
    }
    b
}

/// The bytes of an `images.bin` holding `images` (in the given order).
pub fn encode_images_bin(images: &[ColmapImage]) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&(images.len() as u64).to_le_bytes());
    for im in images {
        b.extend_from_slice(&im.id.to_le_bytes());
        for v in im.qvec.iter().chain(&im.tvec) {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&im.camera_id.to_le_bytes());
        b.extend_from_slice(im.name.as_bytes());
        b.push(0);
        b.extend_from_slice(&(im.points2d.len() as u64).to_le_bytes());
        for p in &im.points2d {
            b.extend_from_slice(&p.x.to_le_bytes());
            b.extend_from_slice(&p.y.to_le_bytes());
            b.extend_from_slice(&p.point3d_id.to_le_bytes());
        }
    }
    b
}

/// The bytes of a `points3D.bin` holding `points`.
pub fn encode_points3d_bin(points: &[Point3D]) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(&(points.len() as u64).to_le_bytes());
    for p in points {
        b.extend_from_slice(&p.id.to_le_bytes());
        for v in p.xyz.to_array() {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&p.rgb);
        b.extend_from_slice(&p.error.to_le_bytes());
        b.extend_from_slice(&(p.track.len() as u64).to_le_bytes());
        for t in &p.track {
            b.extend_from_slice(&t.image_id.to_le_bytes());
            b.extend_from_slice(&t.point2d_idx.to_le_bytes());
        }
    }
    b
}
