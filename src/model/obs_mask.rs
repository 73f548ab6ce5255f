//! The observability mask of a DTU scan, as `ObsMask{scan}_10.mat` stores
//! it (read and written by [`crate::io::dtu`]). The protocol's lookups in it
//! (which voxel a point falls in, whether it is observed, the bounding-box
//! filter) reproduce the reference's float32 and rounding rules and are
//! implemented with the evaluation, in `crate::eval::dtu`.

/// The observability mask of one DTU scan (`ObsMask{scan}_10.mat`).
#[derive(Debug, Clone, PartialEq)]
pub struct ObsMask {
    /// One byte per voxel, non-zero = observed; column-major as MATLAB stores
    /// it: voxel (x, y, z) is at `x + nx*(y + ny*z)`.
    pub mask: Vec<u8>,
    /// Voxel counts `[nx, ny, nz]`.
    pub dims: [usize; 3],
    /// The `BB` variable: `bb[0]` is its first row (minimum corner), `bb[1]`
    /// its second row (maximum corner), x y z in millimetres, f64 as stored.
    pub bb: [[f64; 3]; 2],
    /// The `Res` variable: voxel size in millimetres.
    pub res: f64,
}

/// Test support: a 5×4×3 mask with the voxels `set` observed, minimum
/// corner `bb_min`, voxel size `res`.
#[cfg(test)]
pub(crate) fn mask_with(set: &[[usize; 3]], bb_min: [f64; 3], res: f64) -> ObsMask {
    let mut mask = vec![0u8; 60];
    for &[x, y, z] in set {
        mask[x + 5 * (y + 4 * z)] = 1;
    }
    ObsMask {
        mask,
        dims: [5, 4, 3],
        bb: [bb_min, [bb_min[0] + 2.0, bb_min[1] + 1.5, bb_min[2] + 1.0]],
        res,
    }
}
