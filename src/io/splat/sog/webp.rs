//! The WebP images of SOG: lossless RGBA decode (dimensions checked against
//! the memory budget and the Gaussian count before decoding) and lossless
//! encode, both through the `image-webp` crate.

use std::io::Cursor;

use image_webp::{ColorType, WebPDecoder, WebPEncoder};

use crate::io::budget;
use crate::{Error, Result};

/// WebP's largest side.
pub const MAX_SIDE: u32 = 16383;

/// A decoded image, RGBA8, row-major.
#[derive(Debug)]
pub struct Rgba {
    pub width: u32,
    pub height: u32,
    pub data: Vec<u8>,
}

impl Rgba {
    /// The 4 bytes of texel `i` (row-major).
    pub fn texel(&self, i: usize) -> [u8; 4] {
        let o = 4 * i;
        [
            self.data[o],
            self.data[o + 1],
            self.data[o + 2],
            self.data[o + 3],
        ]
    }
}

/// Decodes a WebP image to RGBA. `what` names the image in errors
/// (`"scene.sog: means_l.webp"`); the image must hold between `min_texels`
/// (what the caller will read) and `max_texels` texels, checked from its
/// header before any pixel is allocated. Lossy WebP is refused: SOG images
/// must be lossless to hold codebook labels.
pub fn decode(what: &str, bytes: &[u8], min_texels: u64, max_texels: u64) -> Result<Rgba> {
    let fail = |e: image_webp::DecodingError| Error::format(what, format!("WebP: {e}"));
    let mut d = WebPDecoder::new(Cursor::new(bytes)).map_err(fail)?;
    let (width, height) = d.dimensions();
    let texels = width as u64 * height as u64;
    if texels < min_texels {
        return Err(Error::format(
            what,
            format!("image is {width}x{height}, fewer than the {min_texels} texels it must hold"),
        ));
    }
    // A few-KB lossless WebP may declare 16383x16383 (found by fuzzing).
    if texels > max_texels {
        return Err(Error::format(
            what,
            format!(
                "image is {width}x{height}, more than the {max_texels} texels a SOG image \
                 of this kind holds"
            ),
        ));
    }
    budget::check(
        &format!("{what}: a {width}x{height} image"),
        texels.saturating_mul(8),
    )?;
    if d.is_lossy() {
        return Err(Error::format(
            what,
            "image is lossy WebP; SOG images are lossless (codebook indices would be corrupted)",
        ));
    }
    let size = d
        .output_buffer_size()
        .ok_or_else(|| Error::format(what, "image too large"))?;
    let mut buf = vec![0u8; size];
    d.read_image(&mut buf).map_err(fail)?;
    let data = if d.has_alpha() {
        buf
    } else {
        let mut out = Vec::with_capacity(texels as usize * 4);
        for p in buf.chunks_exact(3) {
            out.extend_from_slice(&[p[0], p[1], p[2], 255]);
        }
        out
    };
    Ok(Rgba {
        width,
        height,
        data,
    })
}

/// Encodes RGBA8 texels (`width·height·4` bytes) as lossless WebP.
pub fn encode(name: &str, data: &[u8], width: u32, height: u32) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    WebPEncoder::new(&mut out)
        .encode(data, width, height, ColorType::Rgba8)
        .map_err(|e| Error::invalid(format!("{name}: WebP encoding failed: {e}")))?;
    Ok(out)
}
