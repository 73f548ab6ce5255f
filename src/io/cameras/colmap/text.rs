//! COLMAP's text model files (`cameras.txt`, `images.txt`,
//! `points3D.txt`): reading and writing.

use std::path::Path;

use glam::DVec3;

use super::*;
use crate::io::source::{werr, write_output};
use crate::{Error, Result};

impl ColmapModel {
    /// (which must exist), in COLMAP's text layout. Floats are written with
    /// Rust's shortest round-trip formatting, so reading back is exact.
    pub fn write_text(&self, dir: &Path) -> Result<()> {
        write_output(&dir.join("cameras.txt"), |w| {
            let mut s = String::new();
            s.push_str("# Camera list with one line of data per camera:\n");
            s.push_str("#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n");
            s.push_str(&format!("# Number of cameras: {}\n", self.cameras.len()));
            for c in &self.cameras {
                s.push_str(&format!(
                    "{} {} {} {}",
                    c.id,
                    c.model_name(),
                    c.width,
                    c.height
                ));
                for p in &c.params {
                    s.push_str(&format!(" {p:?}"));
                }
                s.push('\n');
            }
            w.write_all(s.as_bytes()).map_err(werr)
        })?;
        write_output(&dir.join("images.txt"), |w| {
            let n_obs: usize = self.images.iter().map(|i| i.points2d.len()).sum();
            writeln!(w, "# Image list with two lines of data per image:").map_err(werr)?;
            writeln!(
                w,
                "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME"
            )
            .map_err(werr)?;
            writeln!(w, "#   POINTS2D[] as (X, Y, POINT3D_ID)").map_err(werr)?;
            writeln!(
                w,
                "# Number of images: {}, mean observations per image: {}",
                self.images.len(),
                n_obs as f64 / self.images.len().max(1) as f64
            )
            .map_err(werr)?;
            for im in &self.images {
                let [qw, qx, qy, qz] = im.qvec;
                let [tx, ty, tz] = im.tvec;
                writeln!(
                    w,
                    "{} {qw:?} {qx:?} {qy:?} {qz:?} {tx:?} {ty:?} {tz:?} {} {}",
                    im.id, im.camera_id, im.name
                )
                .map_err(werr)?;
                let mut line = String::new();
                for (k, p) in im.points2d.iter().enumerate() {
                    if k > 0 {
                        line.push(' ');
                    }
                    line.push_str(&format!("{:?} {:?} {}", p.x, p.y, p.point3d_id));
                }
                writeln!(w, "{line}").map_err(werr)?;
            }
            Ok(())
        })?;
        write_output(&dir.join("points3D.txt"), |w| {
            let n_track: usize = self.points3d.iter().map(|p| p.track.len()).sum();
            writeln!(w, "# 3D point list with one line of data per point:").map_err(werr)?;
            writeln!(
                w,
                "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)"
            )
            .map_err(werr)?;
            writeln!(
                w,
                "# Number of points: {}, mean track length: {}",
                self.points3d.len(),
                n_track as f64 / self.points3d.len().max(1) as f64
            )
            .map_err(werr)?;
            for p in &self.points3d {
                write!(
                    w,
                    "{} {:?} {:?} {:?} {} {} {} {:?}",
                    p.id, p.xyz.x, p.xyz.y, p.xyz.z, p.rgb[0], p.rgb[1], p.rgb[2], p.error
                )
                .map_err(werr)?;
                for t in &p.track {
                    write!(w, " {} {}", t.image_id, t.point2d_idx).map_err(werr)?;
                }
                writeln!(w).map_err(werr)?;
            }
            Ok(())
        })
    }
}

fn text(f: &Loaded) -> Result<&str> {
    std::str::from_utf8(&f.bytes).map_err(|e| {
        Error::format(
            &f.name,
            format!("not UTF-8 text (byte offset {})", e.valid_up_to()),
        )
    })
}

/// Data lines (1-based line number, trimmed text), skipping blanks and `#` comments.
fn data_lines(s: &str) -> impl Iterator<Item = (usize, &str)> {
    s.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

fn field<T: std::str::FromStr>(
    name: &str,
    line: usize,
    tok: Option<&str>,
    what: &str,
) -> Result<T> {
    let tok = tok.ok_or_else(|| Error::format(name, format!("line {line}: missing {what}")))?;
    tok.parse()
        .map_err(|_| Error::format(name, format!("line {line}: bad {what} '{tok}'")))
}

pub(super) fn parse_cameras_txt(f: &Loaded) -> Result<Vec<ColmapCamera>> {
    decode_cameras_txt(&f.name, text(f)?)
}
pub(super) fn parse_images_txt(f: &Loaded) -> Result<Vec<ColmapImage>> {
    decode_images_txt(&f.name, text(f)?)
}
pub(super) fn parse_points3d_txt(f: &Loaded) -> Result<Vec<Point3D>> {
    decode_points3d_txt(&f.name, text(f)?)
}

/// Parses a `cameras.txt` (`CAMERA_ID MODEL WIDTH HEIGHT PARAMS…` per line);
/// `name` is used in errors, which give the line number.
pub fn decode_cameras_txt(name: &str, s: &str) -> Result<Vec<ColmapCamera>> {
    let mut out = Vec::new();
    for (ln, line) in data_lines(s) {
        let mut t = line.split_whitespace();
        let id = field(name, ln, t.next(), "CAMERA_ID")?;
        let model: String = field(name, ln, t.next(), "MODEL")?;
        let Some((model_id, np)) = model_by_name(&model) else {
            return Err(Error::format(
                name,
                format!("line {ln}: unknown camera model '{model}'"),
            ));
        };
        let width = field(name, ln, t.next(), "WIDTH")?;
        let height = field(name, ln, t.next(), "HEIGHT")?;
        let params = t
            .map(|p| field(name, ln, Some(p), "parameter"))
            .collect::<Result<Vec<f64>>>()?;
        if params.len() != np {
            return Err(Error::format(
                name,
                format!(
                    "line {ln}: model {model} takes {np} parameters, found {}",
                    params.len()
                ),
            ));
        }
        out.push(ColmapCamera {
            id,
            model_id,
            width,
            height,
            params,
        });
    }
    Ok(out)
}

/// Parses an `images.txt`: per image a line `IMAGE_ID QW QX QY QZ TX TY TZ
/// CAMERA_ID NAME`, then the line of its observations `X Y POINT3D_ID …`
/// (possibly empty). Errors give the line number.
pub fn decode_images_txt(name: &str, s: &str) -> Result<Vec<ColmapImage>> {
    let mut out = Vec::new();
    let mut lines = s.lines().enumerate().map(|(i, l)| (i + 1, l.trim()));
    while let Some((ln, line)) = lines.next() {
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut t = line.split_whitespace();
        let id = field(name, ln, t.next(), "IMAGE_ID")?;
        let mut qvec = [0.0; 4];
        for (q, w) in qvec.iter_mut().zip(["QW", "QX", "QY", "QZ"]) {
            *q = field(name, ln, t.next(), w)?;
        }
        let mut tvec = [0.0; 3];
        for (v, w) in tvec.iter_mut().zip(["TX", "TY", "TZ"]) {
            *v = field(name, ln, t.next(), w)?;
        }
        let camera_id = field(name, ln, t.next(), "CAMERA_ID")?;
        let rest: Vec<&str> = t.collect();
        if rest.is_empty() {
            return Err(Error::format(name, format!("line {ln}: missing NAME")));
        }
        // The observation line follows directly (it may be empty).
        let (pln, pline) = lines.next().unwrap_or((ln + 1, ""));
        let toks: Vec<&str> = pline.split_whitespace().collect();
        if !toks.len().is_multiple_of(3) {
            return Err(Error::format(
                name,
                format!(
                    "line {pln}: observations come in triples X Y POINT3D_ID, found {} values",
                    toks.len()
                ),
            ));
        }
        let points2d = toks
            .chunks_exact(3)
            .map(|c| {
                Ok(Point2D {
                    x: field(name, pln, Some(c[0]), "point2D X")?,
                    y: field(name, pln, Some(c[1]), "point2D Y")?,
                    point3d_id: field(name, pln, Some(c[2]), "POINT3D_ID")?,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        out.push(ColmapImage {
            id,
            qvec,
            tvec,
            camera_id,
            name: rest.join(" "),
            points2d,
        });
    }
    Ok(out)
}

/// Parses a `points3D.txt` (`POINT3D_ID X Y Z R G B ERROR TRACK…` per line);
/// errors give the line number.
pub fn decode_points3d_txt(name: &str, s: &str) -> Result<Vec<Point3D>> {
    let mut out = Vec::new();
    for (ln, line) in data_lines(s) {
        let mut t = line.split_whitespace();
        let id = field(name, ln, t.next(), "POINT3D_ID")?;
        let x = field(name, ln, t.next(), "X")?;
        let y = field(name, ln, t.next(), "Y")?;
        let z = field(name, ln, t.next(), "Z")?;
        let mut rgb = [0u8; 3];
        for (c, w) in rgb.iter_mut().zip(["R", "G", "B"]) {
            *c = field(name, ln, t.next(), w)?;
        }
        let error = field(name, ln, t.next(), "ERROR")?;
        let toks: Vec<&str> = t.collect();
        if !toks.len().is_multiple_of(2) {
            return Err(Error::format(
                name,
                format!(
                    "line {ln}: track comes in pairs IMAGE_ID POINT2D_IDX, found {} values",
                    toks.len()
                ),
            ));
        }
        let track = toks
            .chunks_exact(2)
            .map(|c| {
                Ok(TrackElement {
                    image_id: field(name, ln, Some(c[0]), "track IMAGE_ID")?,
                    point2d_idx: field(name, ln, Some(c[1]), "track POINT2D_IDX")?,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        out.push(Point3D {
            id,
            xyz: DVec3::new(x, y, z),
            rgb,
            error,
            track,
        });
    }
    Ok(out)
}
