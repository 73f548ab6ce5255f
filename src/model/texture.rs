//! Texture images for textured meshes, and how they are sampled.
//!
//! Conventions (OBJ / OpenGL texture coordinates):
//! - `u` runs left to right across the image, `v` runs **bottom to top**:
//!   (u, v) = (0, 0) is the lower-left corner of the image and (1, 1) the
//!   upper-right, so row 0 of the stored image (the first PNG row, the top)
//!   is at v = 1.
//! - Texel (col, row) covers u ∈ [col/W, (col+1)/W] and
//!   v ∈ [1 − (row+1)/H, 1 − row/H]; its centre is at
//!   ((col + 0.5)/W, 1 − (row + 0.5)/H).
//! - Sampling is bilinear between the four nearest texel centres, clamped at
//!   the image border (no wrap across the edge, so an atlas never bleeds
//!   from its opposite side). Coordinates outside [0, 1] repeat (u − ⌊u⌋), as
//!   OBJ viewers' default "repeat" mode does.

/// An 8-bit RGB texture image, row-major with row 0 at the top (v = 1).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Texture {
    /// The image file name as the material named it (for messages and for
    /// writing the material again).
    pub name: String,
    pub width: usize,
    pub height: usize,
    /// `width × height` RGB texels, row 0 first.
    pub pixels: Vec<[u8; 3]>,
}

impl Texture {
    /// Checks that the pixel count matches the size.
    pub fn validate(&self) -> crate::Result<()> {
        if self.pixels.len() != self.width * self.height {
            return Err(crate::Error::invalid(format!(
                "texture {} has {} texels, expected {}x{}",
                self.name,
                self.pixels.len(),
                self.width,
                self.height
            )));
        }
        Ok(())
    }

    /// The colour at texture coordinates (u, v) in [0, 1]³, bilinear (see
    /// the module docs for the axes). An empty image or a non-finite
    /// coordinate gives black.
    pub fn sample(&self, u: f32, v: f32) -> [f32; 3] {
        if self.width == 0 || self.height == 0 || !u.is_finite() || !v.is_finite() {
            return [0.0; 3];
        }
        let wrap = |t: f32| {
            if (0.0..=1.0).contains(&t) {
                t
            } else {
                t - t.floor()
            }
        };
        let (u, v) = (wrap(u), wrap(v));
        // continuous texel coordinates with texel centres at integers
        let x = u * self.width as f32 - 0.5;
        let y = (1.0 - v) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let clamp_x = |i: f32| (i.max(0.0) as usize).min(self.width - 1);
        let clamp_y = |i: f32| (i.max(0.0) as usize).min(self.height - 1);
        let (xa, xb) = (clamp_x(x0), clamp_x(x0 + 1.0));
        let (ya, yb) = (clamp_y(y0), clamp_y(y0 + 1.0));
        let at = |c: usize, r: usize| self.pixels[r * self.width + c];
        let (p00, p10, p01, p11) = (at(xa, ya), at(xb, ya), at(xa, yb), at(xb, yb));
        std::array::from_fn(|k| {
            let top = p00[k] as f32 * (1.0 - fx) + p10[k] as f32 * fx;
            let bottom = p01[k] as f32 * (1.0 - fx) + p11[k] as f32 * fx;
            (top * (1.0 - fy) + bottom * fy) / 255.0
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_by_two() -> Texture {
        // row 0 (top, v = 1): red, green; row 1 (bottom, v = 0): blue, white
        Texture {
            name: "t.png".into(),
            width: 2,
            height: 2,
            pixels: vec![[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255]],
        }
    }

    #[test]
    fn texel_centres_give_their_texel_and_v_points_up() {
        let t = two_by_two();
        assert_eq!(t.sample(0.25, 0.75), [1.0, 0.0, 0.0]);
        assert_eq!(t.sample(0.75, 0.75), [0.0, 1.0, 0.0]);
        assert_eq!(t.sample(0.25, 0.25), [0.0, 0.0, 1.0]);
        assert_eq!(t.sample(0.75, 0.25), [1.0, 1.0, 1.0]);
        // corners clamp to the corner texel
        assert_eq!(t.sample(0.0, 1.0), [1.0, 0.0, 0.0]);
        assert_eq!(t.sample(1.0, 0.0), [1.0, 1.0, 1.0]);
    }

    #[test]
    fn bilinear_between_centres_and_repeat_outside() {
        let t = two_by_two();
        let c = t.sample(0.5, 0.5);
        assert_eq!(c, [0.5, 0.5, 0.5]);
        let half = t.sample(0.5, 0.75); // between red and green
        assert_eq!(half, [0.5, 0.5, 0.0]);
        assert_eq!(t.sample(1.25, -0.25), t.sample(0.25, 0.75));
        assert_eq!(t.sample(f32::NAN, 0.5), [0.0; 3]);
    }
}
