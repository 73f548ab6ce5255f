//! Similarity transforms `p' = scale·R·p + t`, the plain value that point-set
//! registration ([`crate::geom::alignment::registration`]) estimates and the
//! Tanks-and-Temples evaluation composes.
//!
//! As everywhere in splatkit, matrices are glam's (column-major storage,
//! acting on column vectors); a 4×4 transform is a [`DMat4`] and composition
//! `a * b` applies `b` first.

use glam::{DMat3, DMat4, DVec3};

/// A similarity transform `p' = scale·rotation·p + translation`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    /// Proper rotation (det = +1).
    pub rotation: DMat3,
    /// Uniform scale (1 for a rigid transform).
    pub scale: f64,
    /// Translation.
    pub translation: DVec3,
}

impl Similarity {
    /// The 4×4 matrix `[[scale·R, t], [0, 0, 0, 1]]`, each entry of the
    /// upper-left block being exactly `scale·R[r][c]`.
    pub fn matrix(&self) -> DMat4 {
        let sr = self.rotation * self.scale;
        DMat4::from_cols(
            sr.x_axis.extend(0.0),
            sr.y_axis.extend(0.0),
            sr.z_axis.extend(0.0),
            self.translation.extend(1.0),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec4;

    #[test]
    fn matrix_layout() {
        let s = Similarity {
            rotation: DMat3::from_cols(
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::new(-1.0, 0.0, 0.0),
                DVec3::Z,
            ),
            scale: 2.0,
            translation: DVec3::new(1.0, 2.0, 3.0),
        };
        let m = s.matrix();
        assert_eq!(m.row(0), DVec4::new(0.0, -2.0, 0.0, 1.0));
        assert_eq!(m.row(1), DVec4::new(2.0, 0.0, 0.0, 2.0));
        assert_eq!(m.row(2), DVec4::new(0.0, 0.0, 2.0, 3.0));
        assert_eq!(m.row(3), DVec4::W);
        // x ↦ 2·(90° about z)·x + t
        assert_eq!(m.transform_point3(DVec3::X), DVec3::new(1.0, 4.0, 3.0));
    }
}
