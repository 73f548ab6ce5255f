//! Tanks-and-Temples evaluation files: trajectory `.log`, `<Scene>_trans.txt`
//! alignment matrix and `<Scene>.json` crop volume (see `eval_tsdf.md` §2.1).
//!
//! - `.log` (Redwood / TnT trajectory): per frame one line of 3 integers
//!   (`k k 0`; `k -1 0` marks a frame COLMAP did not register, which the
//!   toolbox writes with an identity pose), then 4 lines of 4 numbers: the
//!   **camera-to-world** 4×4 matrix, row by row. The toolbox's
//!   `read_trajectory` keeps whatever matrix is stored, and so does
//!   [`parse_log`]; blank lines between frames are skipped.
//! - `_trans.txt`: a 4×4 matrix as whitespace-separated numbers, one row per
//!   line (what `np.loadtxt` reads; `#` starts a comment), mapping the
//!   reference COLMAP frame to the ground-truth frame.
//! - crop JSON: an Open3D `SelectionPolygonVolume` with keys
//!   `orthogonal_axis` ("X"/"Y"/"Z", lower case accepted), `axis_min`,
//!   `axis_max` and `bounding_polygon` (a list of `[x, y, z]`), plus
//!   `class_name` ("SelectionPolygonVolume"), `version_major` (1) and
//!   `version_minor` (0), which are checked when present.
//!
//! Matrices are glam [`DMat4`]s acting on column vectors; the files hold
//! them row by row (`m.row(r)`), while glam stores columns. Every parse
//! error names the file and the line (or JSON key).

use std::io::Write;
use std::path::Path;

use glam::{DMat4, DVec3};

use crate::io::source::{read_input, werr, write_output};
use crate::model::crop::{Axis, CropVolume};
use crate::{Error, Result};

/// One frame of a trajectory `.log` file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LogFrame {
    /// The three integers of the frame's header line (TnT: frame index,
    /// frame index or −1 when unregistered, 0).
    pub meta: [i64; 3],
    /// Camera-to-world pose.
    pub pose: DMat4,
}

impl LogFrame {
    /// False for the `k -1 0` frames the TnT converters write for images
    /// COLMAP did not register (their pose is the identity).
    pub fn is_registered(&self) -> bool {
        self.meta[1] != -1
    }

    /// The camera centre in world coordinates: the translation column of the
    /// camera-to-world pose (what the toolbox's
    /// `convert_trajectory_to_pointcloud` takes).
    pub fn centre(&self) -> DVec3 {
        self.pose.w_axis.truncate()
    }
}

/// Splits `bytes` into (1-based line number, line) after checking UTF-8.
fn text_lines<'a>(name: &str, bytes: &'a [u8]) -> Result<impl Iterator<Item = (usize, &'a str)>> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        Error::format(
            name,
            format!(
                "not UTF-8 text (invalid byte at offset {})",
                e.valid_up_to()
            ),
        )
    })?;
    Ok(text.lines().enumerate().map(|(i, l)| (i + 1, l)))
}

/// Parses numbers separated by whitespace; the message names the line and
/// the offending token.
fn parse_numbers(name: &str, line_no: usize, line: &str) -> Result<Vec<f64>> {
    line.split_whitespace()
        .map(|tok| match tok.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(Error::format(
                name,
                format!("line {line_no}: non-finite number {tok:?}"),
            )),
            Err(_) => Err(Error::format(
                name,
                format!("line {line_no}: {tok:?} is not a number"),
            )),
        })
        .collect()
}

/// Parses a trajectory `.log` from memory; `name` is used in errors.
///
/// Errors (naming the line): a header that is not exactly 3 integers, a
/// frame cut short by the end of the file, a matrix row that is not exactly
/// 4 finite numbers, text that is not UTF-8. An empty file is an empty
/// trajectory.
pub fn parse_log(name: &str, bytes: &[u8]) -> Result<Vec<LogFrame>> {
    let mut lines = text_lines(name, bytes)?.filter(|(_, l)| !l.trim().is_empty());
    let mut frames = Vec::new();
    while let Some((hno, header)) = lines.next() {
        let toks: Vec<&str> = header.split_whitespace().collect();
        let mut meta = [0i64; 3];
        if toks.len() != 3 {
            return Err(Error::format(
                name,
                format!(
                    "line {hno}: frame {} header must be 3 integers, found {} fields",
                    frames.len(),
                    toks.len()
                ),
            ));
        }
        for (m, t) in meta.iter_mut().zip(&toks) {
            *m = t.parse().map_err(|_| {
                Error::format(
                    name,
                    format!(
                        "line {hno}: frame {} header field {t:?} is not an integer",
                        frames.len()
                    ),
                )
            })?;
        }
        let mut rows = [[0.0; 4]; 4];
        for (r, row) in rows.iter_mut().enumerate() {
            let Some((lno, line)) = lines.next() else {
                return Err(Error::format(
                    name,
                    format!(
                        "frame {} (header at line {hno}) is truncated: the file ends after {r} of its 4 matrix rows",
                        frames.len()
                    ),
                ));
            };
            let v = parse_numbers(name, lno, line)?;
            if v.len() != 4 {
                return Err(Error::format(
                    name,
                    format!(
                        "line {lno}: frame {} matrix row {r} must have 4 numbers, found {}",
                        frames.len(),
                        v.len()
                    ),
                ));
            }
            row.copy_from_slice(&v);
        }
        frames.push(LogFrame {
            meta,
            pose: from_rows(&rows),
        });
    }
    Ok(frames)
}

/// The matrix whose row r is `rows[r]`.
fn from_rows(rows: &[[f64; 4]; 4]) -> DMat4 {
    DMat4::from_cols_array_2d(rows).transpose()
}

/// Reads a trajectory `.log` file (`-` = stdin). See [`parse_log`].
pub fn read_log(path: &Path) -> Result<Vec<LogFrame>> {
    let input = read_input(path)?;
    parse_log(&input.name, &input)
}

/// Formats frames as the toolbox's `write_trajectory` does: the header
/// integers separated by spaces, then each matrix row as four numbers with
/// 12 decimals (`{:.12f}`), `\n` line ends.
pub fn format_log(frames: &[LogFrame]) -> String {
    let mut s = String::with_capacity(frames.len() * 240);
    for f in frames {
        s.push_str(&format!("{} {} {}\n", f.meta[0], f.meta[1], f.meta[2]));
        for row in (0..4).map(|r| f.pose.row(r)) {
            s.push_str(&format!(
                "{:.12} {:.12} {:.12} {:.12}\n",
                row[0], row[1], row[2], row[3]
            ));
        }
    }
    s
}

/// Writes frames to a `.log` file (`-` = stdout), atomically.
pub fn write_log(path: &Path, frames: &[LogFrame]) -> Result<()> {
    write_output(path, |w: &mut dyn Write| {
        w.write_all(format_log(frames).as_bytes()).map_err(werr)
    })
}

/// Parses a `_trans.txt` 4×4 matrix from memory (`np.loadtxt` layout: rows
/// on lines, numbers separated by whitespace, `#` comments and blank lines
/// ignored).
///
/// Errors (naming the line): a row without exactly 4 numbers, a token that is
/// not a finite number, more or fewer than 4 rows.
pub fn parse_trans(name: &str, bytes: &[u8]) -> Result<DMat4> {
    let mut m = [[0.0; 4]; 4];
    let mut rows = 0usize;
    for (lno, line) in text_lines(name, bytes)? {
        let data = line.split('#').next().unwrap_or("");
        if data.trim().is_empty() {
            continue;
        }
        let v = parse_numbers(name, lno, data)?;
        if v.len() != 4 {
            return Err(Error::format(
                name,
                format!(
                    "line {lno}: a 4×4 matrix row needs 4 numbers, found {}",
                    v.len()
                ),
            ));
        }
        if rows == 4 {
            return Err(Error::format(
                name,
                format!("line {lno}: more than 4 rows (expected a 4×4 matrix)"),
            ));
        }
        m[rows].copy_from_slice(&v);
        rows += 1;
    }
    if rows != 4 {
        return Err(Error::format(
            name,
            format!("expected a 4×4 matrix, found {rows} rows"),
        ));
    }
    check_transform(name, &m)?;
    Ok(from_rows(&m))
}

/// A `_trans.txt` must be an invertible, orientation-preserving affine
/// transform (last row 0 0 0 1, finite, 3×3 part with a positive and
/// well-conditioned determinant): an all-zero matrix, a projection or a
/// reflection would make the alignment and crop meaningless (an all-zero
/// matrix used to score precision = recall = 1), so it is refused rather
/// than scored. The toolbox's files are similarities; a non-uniform scale
/// is accepted since the toolbox would apply it as given.
fn check_transform(name: &str, m: &[[f64; 4]; 4]) -> Result<()> {
    let refuse = |why: &str| {
        Err(Error::format(
            name,
            format!("not a usable alignment transform ({why}): {m:?}"),
        ))
    };
    if m.iter().flatten().any(|v| !v.is_finite()) {
        return refuse("a value is not finite");
    }
    if m[3] != [0.0, 0.0, 0.0, 1.0] {
        return refuse("the last row must be 0 0 0 1");
    }
    let a = glam::DMat3::from_cols_array_2d(&[
        [m[0][0], m[1][0], m[2][0]],
        [m[0][1], m[1][1], m[2][1]],
        [m[0][2], m[1][2], m[2][2]],
    ]);
    let det = a.determinant();
    // Relative to the size of the entries: |det| ≤ 1e-12·‖A‖³ is singular.
    let norm = a.to_cols_array().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if det.is_nan() || det <= 1e-12 * norm.powi(3) {
        return refuse("its 3×3 part is singular or a reflection");
    }
    Ok(())
}

/// Reads a `_trans.txt` file (`-` = stdin). See [`parse_trans`].
pub fn read_trans(path: &Path) -> Result<DMat4> {
    let input = read_input(path)?;
    parse_trans(&input.name, &input)
}

/// Parses a crop volume JSON from memory.
///
/// Errors: invalid JSON (with line and column), a missing or mistyped key
/// (named), a `class_name` other than "SelectionPolygonVolume" or a version
/// other than 1.0 when present, an axis other than X/Y/Z (either case),
/// `axis_min > axis_max`, a polygon vertex that is not 3 numbers (named by
/// index), or a polygon with fewer than 3 vertices.
pub fn parse_crop_json(name: &str, bytes: &[u8]) -> Result<CropVolume> {
    let v: serde_json::Value = serde_json::from_slice(bytes).map_err(|e| {
        Error::format(
            name,
            format!(
                "invalid JSON at line {} column {}: {e}",
                e.line(),
                e.column()
            ),
        )
    })?;
    let obj = v
        .as_object()
        .ok_or_else(|| Error::format(name, "expected a JSON object at the top level"))?;
    let key = |k: &str| {
        obj.get(k)
            .ok_or_else(|| Error::format(name, format!("missing key \"{k}\"")))
    };
    let number = |k: &str| -> Result<f64> {
        key(k)?
            .as_f64()
            .ok_or_else(|| Error::format(name, format!("key \"{k}\" must be a number")))
    };
    if let Some(c) = obj.get("class_name")
        && c.as_str() != Some("SelectionPolygonVolume")
    {
        return Err(Error::format(
            name,
            format!("key \"class_name\" is {c}, expected \"SelectionPolygonVolume\""),
        ));
    }
    for (k, want) in [("version_major", 1u64), ("version_minor", 0)] {
        if let Some(c) = obj.get(k)
            && c.as_u64() != Some(want)
        {
            return Err(Error::format(
                name,
                format!("key \"{k}\" is {c}, expected {want}"),
            ));
        }
    }
    let axis = match key("orthogonal_axis")?.as_str() {
        Some("X" | "x") => Axis::X,
        Some("Y" | "y") => Axis::Y,
        Some("Z" | "z") => Axis::Z,
        _ => {
            return Err(Error::format(
                name,
                format!(
                    "key \"orthogonal_axis\" is {}, expected \"X\", \"Y\" or \"Z\"",
                    obj["orthogonal_axis"]
                ),
            ));
        }
    };
    let axis_min = number("axis_min")?;
    let axis_max = number("axis_max")?;
    if axis_min > axis_max {
        return Err(Error::format(
            name,
            format!("axis_min {axis_min} is greater than axis_max {axis_max}"),
        ));
    }
    let poly = key("bounding_polygon")?.as_array().ok_or_else(|| {
        Error::format(
            name,
            "key \"bounding_polygon\" must be an array of [x, y, z]",
        )
    })?;
    let mut bounding_polygon = Vec::with_capacity(poly.len());
    for (i, p) in poly.iter().enumerate() {
        let bad = || {
            Error::format(
                name,
                format!("bounding_polygon[{i}] must be an array of 3 numbers, got {p}"),
            )
        };
        let a = p.as_array().ok_or_else(bad)?;
        if a.len() != 3 {
            return Err(bad());
        }
        let mut q = [0.0; 3];
        for (qk, ak) in q.iter_mut().zip(a) {
            *qk = ak.as_f64().ok_or_else(bad)?;
        }
        bounding_polygon.push(q);
    }
    if bounding_polygon.len() < 3 {
        return Err(Error::format(
            name,
            format!(
                "bounding_polygon has {} vertices, a polygon needs at least 3",
                bounding_polygon.len()
            ),
        ));
    }
    Ok(CropVolume {
        orthogonal_axis: axis,
        axis_min,
        axis_max,
        bounding_polygon,
    })
}

/// Reads a crop volume JSON file (`-` = stdin). See [`parse_crop_json`].
pub fn read_crop_json(path: &Path) -> Result<CropVolume> {
    let input = read_input(path)?;
    parse_crop_json(&input.name, &input)
}

/// A `<Scene>_mapping_reference.txt` (also the toolbox's `mapping.txt`):
/// line 1 the number of sampled frames n, line 2 the number of frames of the
/// full video, then n lines of two integers, the second being the 1-based
/// video frame of each sampled image.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameMapping {
    /// Frames of the full video (line 2).
    pub total_frames: usize,
    /// Per sampled image, its 1-based video frame (second column).
    pub frames: Vec<usize>,
}

impl FrameMapping {
    /// The toolbox's `gen_sparse_trajectory`: for each sampled image, the
    /// frame `frames[i] − 1` of `full`. Errors when a frame is past the end
    /// of `full` (the toolbox would raise an IndexError).
    pub fn sparse<T: Copy>(&self, name: &str, full: &[T]) -> Result<Vec<T>> {
        self.frames
            .iter()
            .enumerate()
            .map(|(i, &f)| {
                full.get(f.wrapping_sub(1)).copied().ok_or_else(|| {
                    Error::format(
                        name,
                        format!(
                            "line {}: video frame {f} is not in the {}-frame trajectory",
                            i + 3,
                            full.len()
                        ),
                    )
                })
            })
            .collect()
    }
}

/// Parses a frame mapping from memory; `name` is used in errors, which name
/// the line: counts that are not non-negative integers, a row that is not two
/// integers, a frame of 0, fewer rows than the first line says.
pub fn parse_mapping(name: &str, bytes: &[u8]) -> Result<FrameMapping> {
    let mut lines = text_lines(name, bytes)?.filter(|(_, l)| !l.trim().is_empty());
    let mut count = |what: &str| -> Result<usize> {
        let (no, l) = lines
            .next()
            .ok_or_else(|| Error::format(name, format!("missing the {what} line")))?;
        l.trim().parse::<usize>().map_err(|_| {
            Error::format(
                name,
                format!(
                    "line {no}: the {what} must be a non-negative integer, got {:?}",
                    l.trim()
                ),
            )
        })
    };
    let n = count("number of sampled frames")?;
    let total_frames = count("number of video frames")?;
    let mut frames = Vec::with_capacity(n.min(1 << 20));
    for k in 0..n {
        let (no, l) = lines.next().ok_or_else(|| {
            Error::format(
                name,
                format!("the first line declares {n} sampled frames, the file ends after {k}"),
            )
        })?;
        let toks: Vec<&str> = l.split_whitespace().collect();
        let frame = match toks.as_slice() {
            [a, b] if a.parse::<i64>().is_ok() => b.parse::<usize>().ok(),
            _ => None,
        };
        match frame {
            Some(f) if f >= 1 => frames.push(f),
            _ => {
                return Err(Error::format(
                    name,
                    format!("line {no}: expected two integers (image, video frame ≥ 1), got {l:?}"),
                ));
            }
        }
    }
    Ok(FrameMapping {
        total_frames,
        frames,
    })
}

/// Reads a frame mapping file.
pub fn read_mapping(path: &Path) -> Result<FrameMapping> {
    let input = read_input(path)?;
    parse_mapping(&input.name, &input)
}

/// The crop volume as Open3D writes it: keys `axis_max`, `axis_min`,
/// `bounding_polygon`, `class_name`, `orthogonal_axis`, `version_major`,
/// `version_minor` (sorted, as jsoncpp does), pretty-printed; numbers are
/// written in shortest round-trip form.
pub fn crop_to_json(crop: &CropVolume) -> String {
    let v = serde_json::json!({
        "class_name": "SelectionPolygonVolume",
        "version_major": 1,
        "version_minor": 0,
        "orthogonal_axis": crop.orthogonal_axis.letter(),
        "axis_min": crop.axis_min,
        "axis_max": crop.axis_max,
        "bounding_polygon": crop.bounding_polygon,
    });
    let mut s = serde_json::to_string_pretty(&v).unwrap_or_default();
    s.push('\n');
    s
}

/// Writes a crop volume JSON file (`-` = stdout), atomically. Errors on
/// non-finite numbers, which JSON cannot hold.
pub fn write_crop_json(path: &Path, crop: &CropVolume) -> Result<()> {
    let finite = crop.axis_min.is_finite()
        && crop.axis_max.is_finite()
        && crop
            .bounding_polygon
            .iter()
            .flatten()
            .all(|c| c.is_finite());
    if !finite {
        return Err(Error::invalid(format!(
            "{}: crop volume has a non-finite number, which JSON cannot represent",
            path.display()
        )));
    }
    write_output(path, |w: &mut dyn Write| {
        w.write_all(crop_to_json(crop).as_bytes()).map_err(werr)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `_trans.txt` that cannot align anything (all zeros, singular, a
    /// reflection, a bad last row, NaN) is refused, naming the file.
    #[test]
    fn trans_must_be_usable() {
        let ok = "2 0 0 1\n0 0 -2 2\n0 2 0 3\n0 0 0 1\n";
        assert!(parse_trans("t.txt", ok.as_bytes()).is_ok());
        for bad in [
            "0 0 0 0\n0 0 0 0\n0 0 0 0\n0 0 0 0\n",
            "1 1 0 0\n1 1 0 0\n0 0 1 0\n0 0 0 1\n",
            "-1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n",
            "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n",
            "1 0 0 nan\n0 1 0 0\n0 0 1 0\n0 0 0 1\n",
        ] {
            let e = parse_trans("t.txt", bad.as_bytes())
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("t.txt"), "{e}");
            assert!(
                e.contains("not a usable alignment") || e.contains("non-finite"),
                "{e}"
            );
        }
    }
    use crate::testing::shared_data;

    /// The toolbox's own test trajectory: 151 frames, each a rigid
    /// camera-to-world pose; writing it back in the toolbox format gives the
    /// same bytes.
    #[test]
    fn reads_and_rewrites_toolbox_log() {
        let Some(p) = shared_data("tnt-toolbox-testdata/test.log") else {
            return;
        };
        let frames = read_log(&p).unwrap();
        assert_eq!(frames.len(), 151);
        for (k, f) in frames.iter().enumerate() {
            assert_eq!(f.meta, [k as i64, k as i64, 0]);
            assert!(f.is_registered());
            assert_eq!(f.pose.row(3).to_array(), [0.0, 0.0, 0.0, 1.0]);
            // Rotation block orthonormal: the file's matrices deviate by up to
            // 3.7e-6 (measured with numpy), so 1e-5 checks a rotation was read
            // without demanding more than the data holds (the last-row check
            // above pins the row-major layout).
            for i in 0..3 {
                for j in 0..3 {
                    let dot: f64 = (0..3).map(|r| f.pose.row(r)[i] * f.pose.row(r)[j]).sum();
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((dot - want).abs() < 1e-5, "frame {k}");
                }
            }
        }
        // Values of the first frame, as printed in the file.
        assert_eq!(
            frames[0].pose.row(0).to_array(),
            [
                0.753603734645,
                -0.022161615602,
                -0.656955193301,
                2.377286677636
            ]
        );
        assert_eq!(
            frames[0].centre().to_array(),
            [2.377286677636, -0.005093510202, -2.085496122745]
        );
        let original = std::fs::read(&p).unwrap();
        assert_eq!(format_log(&frames).as_bytes(), &original[..]);
    }

    #[test]
    fn log_round_trip_through_file_and_unregistered_frames() {
        let frames = vec![
            LogFrame {
                meta: [0, 0, 0],
                pose: from_rows(&[
                    [0.0, -1.0, 0.0, 1.25],
                    [1.0, 0.0, 0.0, -2.5],
                    [0.0, 0.0, 1.0, 0.125],
                    [0.0, 0.0, 0.0, 1.0],
                ]),
            },
            LogFrame {
                meta: [1, -1, 0],
                pose: DMat4::IDENTITY,
            },
        ];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.log");
        write_log(&path, &frames).unwrap();
        // Values chosen exactly representable with 12 decimals.
        let back = read_log(&path).unwrap();
        assert_eq!(back, frames);
        assert!(!back[1].is_registered());
        // Blank lines between frames are tolerated.
        let spaced = format_log(&frames).replace("\n1 -1 0", "\n\n\n1 -1 0");
        assert_eq!(parse_log("s.log", spaced.as_bytes()).unwrap(), frames);
        assert!(parse_log("e.log", b"").unwrap().is_empty());
    }

    #[test]
    fn malformed_logs_are_errors_naming_file_and_line() {
        let good = "0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
        assert_eq!(parse_log("g.log", good.as_bytes()).unwrap().len(), 1);
        let cases: [(&str, &str); 6] = [
            // Truncated frame: header and 2 of 4 rows.
            ("0 0 0\n1 0 0 0\n0 1 0 0\n", "truncated"),
            // Non-numeric matrix entry on line 3.
            ("0 0 0\n1 0 0 0\n0 x 0 0\n0 0 1 0\n0 0 0 1\n", "line 3"),
            // Row with 3 numbers.
            ("0 0 0\n1 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", "line 2"),
            // Header not integers.
            ("0 a 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", "line 1"),
            // Header with 2 fields.
            ("0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", "line 1"),
            // Non-finite value.
            ("0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 nan\n0 0 0 1\n", "line 4"),
        ];
        for (text, want) in cases {
            let e = parse_log("bad.log", text.as_bytes())
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("bad.log: "), "{e}");
            assert!(e.contains(want), "{e} lacks {want}");
        }
        let e = parse_log("bin.log", &[0xff, 0xfe]).unwrap_err().to_string();
        assert!(e.contains("UTF-8"), "{e}");
        let e = read_log(Path::new("/nonexistent/x.log"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/x.log"), "{e}");
    }

    #[test]
    fn trans_matrix_parsing() {
        let text = "# alignment\n1 0 0 0.5\n0 1 0 -1e-3\n\n0 0 2 3 # scaled\n0 0 0 1\n";
        let m = parse_trans("a_trans.txt", text.as_bytes()).unwrap();
        assert_eq!(m.row(0).to_array(), [1.0, 0.0, 0.0, 0.5]);
        assert_eq!(m.row(1)[3], -1e-3);
        assert_eq!(m.row(2).to_array(), [0.0, 0.0, 2.0, 3.0]);
        assert_eq!(m.row(3).to_array(), [0.0, 0.0, 0.0, 1.0]);
        // Tabs and trailing spaces, as np.loadtxt accepts.
        let tabs = "1\t0\t0\t0 \n0\t1\t0\t0\n0\t0\t1\t0\n0\t0\t0\t1\n";
        assert!(parse_trans("t.txt", tabs.as_bytes()).is_ok());
        // 15 numbers: the last row is short.
        let e = parse_trans("b_trans.txt", b"1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("b_trans.txt: line 4"), "{e}");
        // 15 numbers on 3 full rows plus nothing: too few rows.
        let e = parse_trans("c.txt", b"1 0 0 0\n0 1 0 0\n0 0 1 0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("found 3 rows"), "{e}");
        let e = parse_trans("d.txt", b"1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n0 0 0 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 5"), "{e}");
        let e = parse_trans("e.txt", b"1 0 0 0\n0 1 0 0\n0 0 one 0\n0 0 0 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("\"one\""), "{e}");
    }

    const CROP: &str = r#"{
        "axis_max" : 4.5,
        "axis_min" : -1.25,
        "bounding_polygon" : [
            [ 2.0, -1.0, 0.0 ],
            [ 3.5, 2.0, 0.0 ],
            [ -1.0, 1.0, 0.0 ]
        ],
        "class_name" : "SelectionPolygonVolume",
        "orthogonal_axis" : "Z",
        "version_major" : 1,
        "version_minor" : 0
    }"#;

    #[test]
    fn crop_json_round_trip() {
        let c = parse_crop_json("c.json", CROP.as_bytes()).unwrap();
        assert_eq!(c.orthogonal_axis, Axis::Z);
        assert_eq!((c.axis_min, c.axis_max), (-1.25, 4.5));
        assert_eq!(c.bounding_polygon.len(), 3);
        assert_eq!(c.bounding_polygon[1], [3.5, 2.0, 0.0]);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.json");
        write_crop_json(&path, &c).unwrap();
        assert_eq!(read_crop_json(&path).unwrap(), c);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("\"class_name\": \"SelectionPolygonVolume\""));
        // Lower-case axis names are accepted (Open3D compares both cases).
        let lower = CROP.replace("\"Z\"", "\"y\"");
        assert_eq!(
            parse_crop_json("l.json", lower.as_bytes())
                .unwrap()
                .orthogonal_axis,
            Axis::Y
        );
    }

    #[test]
    fn malformed_crop_json_names_the_key() {
        for k in [
            "orthogonal_axis",
            "axis_min",
            "axis_max",
            "bounding_polygon",
        ] {
            let mut v: serde_json::Value = serde_json::from_str(CROP).unwrap();
            v.as_object_mut().unwrap().remove(k);
            let e = parse_crop_json("m.json", v.to_string().as_bytes())
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with("m.json: ") && e.contains(&format!("\"{k}\"")),
                "{e}"
            );
        }
        let cases: [(String, &str); 7] = [
            (CROP.replace("\"Z\"", "\"W\""), "orthogonal_axis"),
            (CROP.replace("4.5", "\"4.5\""), "axis_max"),
            (
                CROP.replace("[ 3.5, 2.0, 0.0 ]", "[ 3.5, 2.0 ]"),
                "bounding_polygon[1]",
            ),
            (
                CROP.replace("SelectionPolygonVolume", "Other"),
                "class_name",
            ),
            (
                CROP.replace("\"version_major\" : 1", "\"version_major\" : 2"),
                "version_major",
            ),
            (CROP.replace("4.5", "-2.0"), "greater than"),
            (
                CROP.replace(",\n        \"class_name\"", "\n        \"class_name\""),
                "line 9 column 9",
            ),
        ];
        for (text, want) in cases {
            let e = parse_crop_json("m.json", text.as_bytes())
                .unwrap_err()
                .to_string();
            assert!(e.contains(want), "{e} lacks {want}");
        }
        let two = CROP.replace(",\n            [ -1.0, 1.0, 0.0 ]", "");
        let e = parse_crop_json("m.json", two.as_bytes())
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least 3"), "{e}");
        assert!(parse_crop_json("m.json", b"[1, 2]").is_err());
    }

    /// The toolbox's own mapping files: 151 sampled frames of a 6015-frame
    /// video, every 40th from frame 1 (the second column), and 263 of 7845
    /// for Ignatius; the sparse trajectory picks those frames.
    #[test]
    fn reads_toolbox_mappings() {
        let Some(p) = shared_data("tnt-toolbox-testdata/mapping.txt") else {
            return;
        };
        let m = read_mapping(&p).unwrap();
        assert_eq!((m.frames.len(), m.total_frames), (151, 6015));
        assert!(m.frames.iter().enumerate().all(|(i, &f)| f == 40 * i + 1));
        let full: Vec<usize> = (0..6015).collect();
        let sparse = m.sparse("mapping.txt", &full).unwrap();
        assert_eq!(sparse[..3], [0, 40, 80]);
        assert!(m.sparse("mapping.txt", &full[..100]).is_err());
        let Some(p) = shared_data("tnt-toolbox-testdata/Ignatius_mapping.txt") else {
            return;
        };
        let m = read_mapping(&p).unwrap();
        assert_eq!((m.frames.len(), m.total_frames), (263, 7845));
    }

    #[test]
    fn malformed_mappings_name_the_line() {
        let e = |t: &str| {
            parse_mapping("m.txt", t.as_bytes())
                .unwrap_err()
                .to_string()
        };
        assert!(e("").contains("missing the number of sampled frames"));
        assert!(e("2\nx\n").contains("line 2"));
        assert!(e("2\n10\n0 1\n").contains("ends after 1"));
        assert!(e("1\n10\n0 0\n").contains("line 3"));
        assert!(e("1\n10\n0 1 2\n").contains("line 3"));
        let ok = parse_mapping("m.txt", b"2\n10\n0 3\n1 7\n").unwrap();
        assert_eq!(ok.frames, vec![3, 7]);
    }
}
