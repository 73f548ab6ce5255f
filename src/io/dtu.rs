//! The official DTU MVS evaluation data, laid out as the DTU download unpacks
//! it and as DTUeval-python's `eval.py --dataset_dir` reads it:
//!
//! ```text
//! <root>/Points/stl/stl{scan:03}_total.ply   structured-light reference points (mm)
//! <root>/ObsMask/ObsMask{scan}_10.mat        ObsMask (3-D logical), BB (2×3, mm), Res (mm)
//! <root>/ObsMask/Plane{scan}.mat             P (4 values, ground plane)
//! ```
//!
//! The readers fill [`ObsMask`] (a `model` type); the protocol's lookups in
//! it ([`ObsMask::contains`], the bounding-box filter) are the evaluation's
//! rules and live in [`crate::eval::dtu`].

use std::path::{Path, PathBuf};

use crate::io::mat::{self, MatArray, MatData};
pub use crate::model::ObsMask;
use crate::{Error, Result};

/// The 15 DTU scans of the IDR / NeuS / VolSDF / 2DGS evaluation subset
/// (the list hard-coded in 2DGS `scripts/dtu_eval.py`).
pub const DTU_SCANS: [u32; 15] = [
    24, 37, 40, 55, 63, 65, 69, 83, 97, 105, 106, 110, 114, 118, 122,
];

/// Reads an `ObsMask{scan}_10.mat`: variables `ObsMask` (3-D numeric or
/// logical array, any non-zero value = observed), `BB` (2×3, finite) and
/// `Res` (one finite positive value). A missing variable, a non-numeric one
/// or a wrong shape is an error naming the variable and the file.
pub fn read_obs_mask(path: &Path) -> Result<ObsMask> {
    let input = crate::io::read_input(path)?;
    let name = input.name.as_str();
    let mut arrays = mat::parse_mat(name, &input)?;

    let bb_var = mat::require_numeric(&arrays, "BB", name)?;
    if bb_var.dims != [2, 3] {
        return Err(wrong_shape(name, bb_var, "a 2×3 array ([min; max] rows)"));
    }
    let v = bb_var.to_f64();
    let bb = [[v[0], v[2], v[4]], [v[1], v[3], v[5]]];
    if v.iter().any(|x| !x.is_finite()) {
        return Err(Error::format(
            name,
            format!("variable 'BB' holds a non-finite value: {bb:?}"),
        ));
    }
    if (0..3).any(|i| bb[0][i] > bb[1][i]) {
        return Err(Error::format(
            name,
            format!(
                "variable 'BB' is an inverted bounding box: minimum {:?} exceeds maximum {:?} on some axis",
                bb[0], bb[1]
            ),
        ));
    }

    let res = scalar(&arrays, "Res", name)?;
    if !(res.is_finite() && res > 0.0) {
        return Err(Error::format(
            name,
            format!("variable 'Res' is {res}, expected a positive voxel size in mm"),
        ));
    }

    let m = mat::require_numeric(&arrays, "ObsMask", name)?;
    let [nx, ny, nz] = m.dims[..] else {
        return Err(wrong_shape(name, m, "a 3-D array"));
    };
    // Take the (possibly large) mask out of the parsed variables rather than
    // copy it; `find` semantics (last match wins) as in `require_numeric`.
    let at = arrays
        .iter()
        .rposition(|a| a.name == "ObsMask")
        .expect("require_numeric found ObsMask");
    let mask = match std::mem::replace(&mut arrays[at].data, MatData::Skipped) {
        MatData::U8(v) => v,
        // numpy's astype(bool): any non-zero value (NaN included) is true.
        MatData::F64(v) => v.iter().map(|&x| u8::from(x != 0.0)).collect(),
        MatData::Skipped => unreachable!("require_numeric returns decoded variables"),
    };
    Ok(ObsMask {
        mask,
        dims: [nx, ny, nz],
        bb,
        res,
    })
}

/// Reads a `Plane{scan}.mat`: variable `P`, 4 values in any 4×1 / 1×4 shape,
/// the plane `P·[x, y, z, 1] = 0` (the reference keeps STL points with
/// `P·[x, y, z, 1] > 0`).
pub fn read_plane(path: &Path) -> Result<[f64; 4]> {
    let input = crate::io::read_input(path)?;
    let name = input.name.as_str();
    let arrays = mat::parse_mat(name, &input)?;
    let p = mat::require_numeric(&arrays, "P", name)?;
    let non_unit = p.dims.iter().filter(|&&d| d != 1).count();
    if p.len() != 4 || non_unit != 1 {
        return Err(wrong_shape(name, p, "a 4-vector (4×1 or 1×4)"));
    }
    let v = p.to_f64();
    if v.iter().any(|x| !x.is_finite()) || v[..3].iter().all(|&x| x == 0.0) {
        return Err(Error::format(
            name,
            format!(
                "variable 'P' = {v:?} is not a plane (needs finite values and a non-zero normal)"
            ),
        ));
    }
    Ok([v[0], v[1], v[2], v[3]])
}

/// Writes `mask` as an `ObsMask{scan}_10.mat` (zlib-compressed Level 5, as
/// MATLAB `save -v7`): `ObsMask` as a logical array (non-zero bytes become
/// 1), `BB` as a 2×3 double, `Res` as a 1×1 double. The file is written
/// atomically. Error if `mask.mask` does not hold `nx·ny·nz` bytes.
pub fn write_obs_mask(path: &Path, mask: &ObsMask) -> Result<()> {
    let [nx, ny, nz] = mask.dims;
    if nx.checked_mul(ny).and_then(|v| v.checked_mul(nz)) != Some(mask.mask.len()) {
        return Err(Error::invalid(format!(
            "ObsMask of {nx}×{ny}×{nz} voxels holds {} bytes",
            mask.mask.len()
        )));
    }
    let [min, max] = mask.bb;
    let arrays = [
        MatArray::logical(
            "ObsMask",
            vec![nx, ny, nz],
            mask.mask.iter().map(|&b| u8::from(b != 0)).collect(),
        ),
        MatArray::from_f64(
            "BB",
            vec![2, 3],
            vec![min[0], max[0], min[1], max[1], min[2], max[2]],
        ),
        MatArray::from_f64("Res", vec![1, 1], vec![mask.res]),
    ];
    crate::io::write_output(path, |w| mat::write_mat(w, &arrays, true))
}

/// Writes a `Plane{scan}.mat`: `P` as a 4×1 double (compressed Level 5).
pub fn write_plane(path: &Path, p: [f64; 4]) -> Result<()> {
    let arrays = [MatArray::from_f64("P", vec![4, 1], p.to_vec())];
    crate::io::write_output(path, |w| mat::write_mat(w, &arrays, true))
}

/// The root of the official DTU evaluation data (`--dataset_dir` of
/// `eval.py`, `DTU_Official` of 2DGS).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DtuOfficial {
    /// The folder holding `Points/` and `ObsMask/`.
    pub root: PathBuf,
}

impl DtuOfficial {
    /// The layout rooted at `root`.
    pub fn new(root: impl Into<PathBuf>) -> Self {
        DtuOfficial { root: root.into() }
    }

    /// `<root>/Points/stl/stl{scan:03}_total.ply`.
    pub fn stl_path(&self, scan: u32) -> PathBuf {
        self.root
            .join("Points")
            .join("stl")
            .join(format!("stl{scan:03}_total.ply"))
    }

    /// `<root>/ObsMask/ObsMask{scan}_10.mat` (scan number not zero-padded).
    pub fn obs_mask_path(&self, scan: u32) -> PathBuf {
        self.root
            .join("ObsMask")
            .join(format!("ObsMask{scan}_10.mat"))
    }

    /// `<root>/ObsMask/Plane{scan}.mat` (scan number not zero-padded).
    pub fn plane_path(&self, scan: u32) -> PathBuf {
        self.root.join("ObsMask").join(format!("Plane{scan}.mat"))
    }

    /// Checks that the three files of `scan` exist; the error lists every
    /// missing one.
    pub fn check(&self, scan: u32) -> Result<()> {
        let missing: Vec<String> = [
            self.stl_path(scan),
            self.obs_mask_path(scan),
            self.plane_path(scan),
        ]
        .iter()
        .filter(|p| !p.is_file())
        .map(|p| p.display().to_string())
        .collect();
        if missing.is_empty() {
            return Ok(());
        }
        Err(Error::invalid(format!(
            "DTU evaluation data in {} is incomplete for scan {scan}; missing: {}",
            self.root.display(),
            missing.join(", ")
        )))
    }
}

fn wrong_shape(file: &str, a: &MatArray, expected: &str) -> Error {
    Error::format(
        file,
        format!(
            "variable '{}' is {}, expected {expected}",
            a.name,
            a.describe()
        ),
    )
}

/// A variable holding exactly one value.
fn scalar(arrays: &[MatArray], var: &str, file: &str) -> Result<f64> {
    let a = mat::require_numeric(arrays, var, file)?;
    if a.len() != 1 {
        return Err(wrong_shape(file, a, "a scalar"));
    }
    Ok(a.to_f64()[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::model::obs_mask::mask_with;

    /// Round half to even written out independently of `round_ties_even`:
    /// the integer within 0.5, the even one on an exact tie.
    fn nearest_even(g: f64) -> i64 {
        let f = g.floor();
        let d = g - f;
        let k = f as i64;
        if d < 0.5 || (d == 0.5 && k % 2 == 0) {
            k
        } else {
            k + 1
        }
    }

    #[test]
    fn obs_mask_round_trip_and_lookup() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ObsMask1_10.mat");
        // Voxel (3, 1, 2) plus two corners so that the grid edges are probed.
        // BB_min and Res are exact in f32 and binary, so every probe point
        // below and its grid coordinate are exact.
        let m = mask_with(&[[3, 1, 2], [0, 0, 0], [4, 3, 2]], [-10.0, 4.0, 100.0], 0.5);
        write_obs_mask(&path, &m).unwrap();
        let back = read_obs_mask(&path).unwrap();
        assert_eq!(back, m);

        // Raw MAT contents: column-major, x fastest.
        let arrays = mat::read_mat(&path).unwrap();
        let om = mat::find(&arrays, "ObsMask").unwrap();
        assert!(om.logical);
        assert_eq!(om.get(&[3, 1, 2]), 1.0);
        assert_eq!(om.get(&[2, 1, 2]), 0.0);

        // Probe grid coordinates from −1 to n + 1 in quarter steps on every
        // axis: contains must be true exactly where every coordinate rounds
        // (half to even) to a set voxel.
        let set = [[3i64, 1, 2], [0, 0, 0], [4, 3, 2]];
        let steps: Vec<f64> = (-4..=24).map(|k| f64::from(k) * 0.25).collect();
        let mut hits = 0;
        for &gx in &steps {
            for &gy in &steps {
                for &gz in &steps {
                    let p = [-10.0 + 0.5 * gx, 4.0 + 0.5 * gy, 100.0 + 0.5 * gz];
                    let k = [nearest_even(gx), nearest_even(gy), nearest_even(gz)];
                    let want = set.contains(&k);
                    assert_eq!(back.contains(p), want, "g = {gx} {gy} {gz}");
                    hits += usize::from(want);
                }
            }
        }
        assert!(hits > 0);

        // Named cases. Half-way points: g = 2.5 rounds to 2 (half away from
        // zero would give 3), 3.5 to 4.
        let at = |g: [f64; 3]| [-10.0 + 0.5 * g[0], 4.0 + 0.5 * g[1], 100.0 + 0.5 * g[2]];
        assert!(back.contains(at([3.0, 1.0, 2.0])));
        assert!(back.contains(at([3.0, 1.0, 2.5])));
        assert!(back.contains(at([3.0, 1.0, 1.5])));
        assert!(back.contains(at([3.0, 1.4, 2.0])));
        assert!(!back.contains(at([2.5, 1.0, 2.0])));
        assert!(!back.contains(at([3.5, 1.0, 2.0])));
        assert!(!back.contains(at([3.0, 0.5, 2.0])));
        // BB edge: p = BB_min is voxel 0; g = −0.5 rounds to −0 = 0 (kept,
        // as numpy's around gives −0.0 and int32(−0.0) = 0); g = −0.75 is out.
        assert!(back.contains([-10.0, 4.0, 100.0]));
        assert!(back.contains(at([-0.5, -0.5, -0.5])));
        assert!(!back.contains(at([-0.75, 0.0, 0.0])));
        // Far side: g = 4.5 rounds to 4 (last voxel), 5.5 to 6 (out).
        assert!(back.contains(at([4.5, 3.0, 2.0])));
        assert!(!back.contains(at([5.5, 3.0, 2.0])));
        assert!(!back.contains([f64::NAN, 4.0, 100.0]));
        assert_eq!(back.voxel(at([3.2, 0.8, 2.1])), Some([3, 1, 2]));
    }

    fn write_arrays(path: &Path, arrays: &[MatArray]) {
        crate::io::write_output(path, |w| mat::write_mat(w, arrays, false)).unwrap();
    }

    #[test]
    fn obs_mask_errors_name_variable_and_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.mat");
        let name = path.display().to_string();
        let mask = MatArray::logical("ObsMask", vec![2, 2, 2], vec![1; 8]);
        let bb = MatArray::from_f64("BB", vec![2, 3], vec![0.0; 6]);
        let res = MatArray::from_f64("Res", vec![1, 1], vec![0.5]);

        let cases: Vec<(Vec<MatArray>, &str)> = vec![
            (
                vec![bb.clone(), res.clone()],
                "no variable 'ObsMask' in this MAT-file (it has 'BB', 'Res')",
            ),
            (
                vec![
                    mask.clone(),
                    MatArray::from_f64("BB", vec![3, 2], vec![0.0; 6]),
                    res.clone(),
                ],
                "variable 'BB' is a 3×2 double array, expected a 2×3 array",
            ),
            (
                vec![
                    MatArray::logical("ObsMask", vec![2, 4], vec![1; 8]),
                    bb.clone(),
                    res.clone(),
                ],
                "variable 'ObsMask' is a 2×4 logical array, expected a 3-D array",
            ),
            (
                vec![mask.clone(), bb.clone()],
                "no variable 'Res' in this MAT-file",
            ),
            (
                vec![
                    mask.clone(),
                    bb.clone(),
                    MatArray::from_f64("Res", vec![1, 2], vec![0.5, 1.0]),
                ],
                "variable 'Res' is a 1×2 double array, expected a scalar",
            ),
            (
                vec![
                    mask.clone(),
                    bb.clone(),
                    MatArray::from_f64("Res", vec![1, 1], vec![0.0]),
                ],
                "variable 'Res' is 0, expected a positive voxel size",
            ),
        ];
        for (arrays, want) in cases {
            write_arrays(&path, &arrays);
            let e = read_obs_mask(&path).unwrap_err().to_string();
            assert!(e.starts_with(&format!("{name}: ")), "{e}");
            assert!(e.contains(want), "{e} (wanted {want})");
        }
        // A double-valued ObsMask is accepted, non-zero meaning observed.
        write_arrays(
            &path,
            &[
                MatArray::from_f64("ObsMask", vec![1, 1, 3], vec![0.0, 2.5, f64::NAN]),
                bb,
                res,
            ],
        );
        assert_eq!(read_obs_mask(&path).unwrap().mask, [0, 1, 1]);
    }

    #[test]
    fn plane_shapes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("Plane1.mat");
        let p = [0.25, -1.0, 3.0, -700.5];
        write_plane(&path, p).unwrap();
        assert_eq!(read_plane(&path).unwrap(), p);
        write_arrays(&path, &[MatArray::from_f64("P", vec![1, 4], p.to_vec())]);
        assert_eq!(read_plane(&path).unwrap(), p);
        write_arrays(&path, &[MatArray::from_f64("P", vec![2, 2], p.to_vec())]);
        let e = read_plane(&path).unwrap_err().to_string();
        assert!(
            e.contains("variable 'P' is a 2×2 double array, expected a 4-vector"),
            "{e}"
        );
        write_arrays(&path, &[MatArray::from_f64("Q", vec![4, 1], p.to_vec())]);
        let e = read_plane(&path).unwrap_err().to_string();
        assert!(e.contains("no variable 'P'"), "{e}");
    }

    #[test]
    fn official_layout_paths_and_check() {
        let dir = tempfile::tempdir().unwrap();
        let d = DtuOfficial::new(dir.path());
        assert_eq!(
            d.stl_path(24),
            dir.path().join("Points/stl/stl024_total.ply")
        );
        assert_eq!(
            d.obs_mask_path(24),
            dir.path().join("ObsMask/ObsMask24_10.mat")
        );
        assert_eq!(d.plane_path(105), dir.path().join("ObsMask/Plane105.mat"));

        let e = d.check(24).unwrap_err().to_string();
        for p in [d.stl_path(24), d.obs_mask_path(24), d.plane_path(24)] {
            assert!(e.contains(&p.display().to_string()), "{e}");
        }
        std::fs::create_dir_all(dir.path().join("ObsMask")).unwrap();
        write_plane(&d.plane_path(24), [0.0, 0.0, 1.0, 0.0]).unwrap();
        let e = d.check(24).unwrap_err().to_string();
        assert!(!e.contains("Plane24"), "{e}");
        assert!(
            e.contains("ObsMask24_10.mat") && e.contains("stl024_total.ply"),
            "{e}"
        );
        write_obs_mask(&d.obs_mask_path(24), &mask_with(&[], [0.0; 3], 1.0)).unwrap();
        std::fs::create_dir_all(dir.path().join("Points/stl")).unwrap();
        std::fs::write(d.stl_path(24), b"ply\n").unwrap();
        d.check(24).unwrap();
        assert!(d.check(37).is_err());
    }
}
