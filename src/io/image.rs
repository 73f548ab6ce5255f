//! PNG images for the renderer: 8-bit RGB and grey, 16-bit grey (depth),
//! and reading RGB(A)/grey PNGs of any bit depth as floats in [0, 1].

use std::io::Write;
use std::path::Path;

use crate::io::cameras::MAX_PIXELS;
use crate::model::Mask;
use crate::{Error, Result};

fn encode_err(name: &str, e: png::EncodingError) -> Error {
    match e {
        png::EncodingError::IoError(e) => Error::io(name, e),
        other => Error::format(name, format!("PNG encoding: {other}")),
    }
}

/// Writes an 8-bit PNG; `channels` 1 (grey), 3 (RGB) or 4 (RGBA).
pub fn write_png8(
    w: &mut dyn Write,
    name: &str,
    width: usize,
    height: usize,
    channels: usize,
    data: &[u8],
) -> Result<()> {
    let color = match channels {
        1 => png::ColorType::Grayscale,
        3 => png::ColorType::Rgb,
        4 => png::ColorType::Rgba,
        _ => return Err(Error::format(name, format!("{channels} channels"))),
    };
    let mut enc = png::Encoder::new(w, width as u32, height as u32);
    enc.set_color(color);
    enc.set_depth(png::BitDepth::Eight);
    let mut wr = enc.write_header().map_err(|e| encode_err(name, e))?;
    wr.write_image_data(data).map_err(|e| encode_err(name, e))?;
    wr.finish().map_err(|e| encode_err(name, e))
}

/// Writes a 16-bit grey PNG (big-endian samples, as PNG stores them).
pub fn write_png16(
    w: &mut dyn Write,
    name: &str,
    width: usize,
    height: usize,
    data: &[u16],
) -> Result<()> {
    let mut enc = png::Encoder::new(w, width as u32, height as u32);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Sixteen);
    let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_be_bytes()).collect();
    let mut wr = enc.write_header().map_err(|e| encode_err(name, e))?;
    wr.write_image_data(&bytes)
        .map_err(|e| encode_err(name, e))?;
    wr.finish().map_err(|e| encode_err(name, e))
}

/// An RGB image as floats in [0, 1], row-major.
#[derive(Clone, Debug)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<[f32; 3]>,
}

/// Decodes the first frame of a PNG file with the given transformations:
/// its frame info and samples. Errors name the file.
pub fn decode_png(path: &Path, t: png::Transformations) -> Result<(png::OutputInfo, Vec<u8>)> {
    let name = path.display().to_string();
    let bytes = crate::io::source::read_file(path)?;
    decode_png_bytes(&name, &bytes, t)
}

/// [`decode_png`] over bytes already in memory; `name` is used in errors.
/// The frame buffer is allocated only after the header's size passed the
/// png crate's default memory limit (64 MiB of decoded samples), so a
/// few-byte header declaring a huge image is an error, not an allocation.
pub fn decode_png_bytes(
    name: &str,
    bytes: &[u8],
    t: png::Transformations,
) -> Result<(png::OutputInfo, Vec<u8>)> {
    let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
    dec.set_transformations(t);
    let mut reader = dec
        .read_info()
        .map_err(|e| Error::format(name, format!("PNG: {e}")))?;
    let info = reader.info();
    let (w, h) = (info.width as u64, info.height as u64);
    if w * h > MAX_PIXELS {
        return Err(Error::format(
            name,
            format!("PNG header declares {w}x{h} pixels, more than the {MAX_PIXELS} (2^28) limit"),
        ));
    }
    // Deflate expands at most ~1032:1, so image data larger than about a
    // thousand times the file cannot be in it: refuse before allocating.
    let raw = info.raw_bytes() as u64;
    if raw > 1100 * bytes.len() as u64 + (1 << 16) {
        return Err(Error::format(
            name,
            format!(
                "PNG header declares {w}x{h} pixels ({raw} bytes of image data), more than \
                 a {} byte file can hold",
                bytes.len()
            ),
        ));
    }
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| Error::format(name, "PNG too large"))?;
    let mut buf = vec![0u8; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| Error::format(name, format!("PNG: {e}")))?;
    Ok((info, buf))
}

/// Reads a PNG (grey, grey+alpha, RGB or RGBA; 8 or 16 bits) as RGB floats;
/// alpha is dropped, grey is replicated.
pub fn read_png_rgb(path: &Path) -> Result<RgbImage> {
    decode_png_rgb(path, false).map(|(img, _)| img)
}

/// Like [`read_png_rgb`], also returning the alpha channel (in [0, 1],
/// row-major) when the PNG has one (grey+alpha, RGBA, or a `tRNS` chunk);
/// the colours are returned as stored (straight, not premultiplied).
pub fn read_png_rgb_alpha(path: &Path) -> Result<(RgbImage, Option<Vec<f32>>)> {
    decode_png_rgb(path, true)
}

fn decode_png_rgb(path: &Path, keep_alpha: bool) -> Result<(RgbImage, Option<Vec<f32>>)> {
    let (info, buf) = decode_png(path, png::Transformations::EXPAND)?;
    let (w, h) = (info.width as usize, info.height as usize);
    let ch = info.color_type.samples();
    let sixteen = info.bit_depth == png::BitDepth::Sixteen;
    let sample = |i: usize| -> f32 {
        if sixteen {
            u16::from_be_bytes([buf[2 * i], buf[2 * i + 1]]) as f32 / 65535.0
        } else {
            buf[i] as f32 / 255.0
        }
    };
    let pixels = (0..w * h)
        .map(|p| {
            if ch >= 3 {
                [sample(p * ch), sample(p * ch + 1), sample(p * ch + 2)]
            } else {
                [sample(p * ch); 3]
            }
        })
        .collect();
    // grey+alpha has 2 samples, RGBA 4: alpha is the last one
    let alpha = (keep_alpha && (ch == 2 || ch == 4))
        .then(|| (0..w * h).map(|p| sample(p * ch + ch - 1)).collect());
    Ok((
        RgbImage {
            width: w,
            height: h,
            pixels,
        },
        alpha,
    ))
}

/// Linear [0, 1] float to an 8-bit value (clamped, rounded).
pub fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Decodes a PNG mask: object where channel 0 of OpenCV's BGR read is
/// nonzero, i.e. the blue byte of an RGB(A) PNG, the grey byte otherwise
/// (as the 2DGS DTU culling reads masks).
pub fn read_mask(path: &Path) -> Result<Mask> {
    let name = path.display().to_string();
    let bytes = crate::io::source::read_file(path)?;
    parse_mask(&name, &bytes)
}

/// [`read_mask`] over bytes already in memory; `name` is used in errors.
pub fn parse_mask(name: &str, bytes: &[u8]) -> Result<Mask> {
    let (info, buf) = decode_png_bytes(name, bytes, png::Transformations::normalize_to_color8())?;
    let (w, h) = (info.width as usize, info.height as usize);
    let channels = info.color_type.samples();
    // BGR channel 0 is blue: byte 2 of RGB/RGBA, the grey byte otherwise.
    let pick = match info.color_type {
        png::ColorType::Rgb | png::ColorType::Rgba => 2,
        _ => 0,
    };
    let bits = (0..w * h).map(|i| buf[i * channels + pick] != 0).collect();
    Ok(Mask {
        width: w,
        height: h,
        bits,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 8-bit RGB and 16-bit grey round-trip through the PNG codec.
    #[test]
    fn png_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.png");
        let data: Vec<u8> = (0..4 * 3 * 3).map(|i| (i * 7) as u8).collect();
        let mut f = std::fs::File::create(&p).unwrap();
        write_png8(&mut f, "a", 4, 3, 3, &data).unwrap();
        drop(f);
        let img = read_png_rgb(&p).unwrap();
        assert_eq!((img.width, img.height), (4, 3));
        for (i, px) in img.pixels.iter().enumerate() {
            for k in 0..3 {
                assert_eq!(to_u8(px[k]), data[3 * i + k]);
            }
        }
        let p16 = dir.path().join("d.png");
        let d16: Vec<u16> = vec![0, 1, 65535, 40000, 12345, 7];
        let mut f = std::fs::File::create(&p16).unwrap();
        write_png16(&mut f, "d", 3, 2, &d16).unwrap();
        drop(f);
        let g = read_png_rgb(&p16).unwrap();
        for (px, v) in g.pixels.iter().zip(&d16) {
            assert_eq!((px[0] * 65535.0).round() as u16, *v);
        }
    }
    /// A PNG of `w`×`h` grey pixels holding only a signature, an IHDR, an
    /// empty IDAT and an IEND chunk (CRCs computed here, bitwise CRC-32 as PNG defines it).
    fn header_only_png(w: u32, h: u32) -> Vec<u8> {
        fn crc32(bytes: &[u8]) -> u32 {
            let mut c = !0u32;
            for &b in bytes {
                c ^= b as u32;
                for _ in 0..8 {
                    c = if c & 1 != 0 {
                        0xEDB8_8320 ^ (c >> 1)
                    } else {
                        c >> 1
                    };
                }
            }
            !c
        }
        let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
        let mut chunk = |kind: &[u8], data: &[u8]| {
            out.extend_from_slice(&(data.len() as u32).to_be_bytes());
            let mut body = kind.to_vec();
            body.extend_from_slice(data);
            out.extend_from_slice(&body);
            out.extend_from_slice(&crc32(&body).to_be_bytes());
        };
        let mut ihdr = Vec::new();
        ihdr.extend_from_slice(&w.to_be_bytes());
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
        chunk(b"IHDR", &ihdr);
        // An empty zlib stream: image data too short for any size > 0.
        chunk(b"IDAT", &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01]);
        chunk(b"IEND", &[]);
        out
    }

    /// A few dozen bytes declaring a huge image are refused from the header,
    /// before the frame buffer is allocated: beyond 2^28 pixels, or more
    /// image data than deflate could pack into the file.
    #[test]
    fn huge_declared_sizes_are_refused_before_allocating() {
        let e = parse_mask("m.png", &header_only_png(100_000, 100_000))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("m.png") && e.contains("2^28"), "{e}");
        let e = parse_mask("m.png", &header_only_png(10_000, 10_000))
            .unwrap_err()
            .to_string();
        assert!(e.contains("byte file can hold"), "{e}");
        // A small header-only image passes the size checks and fails on the
        // missing data instead.
        let e = parse_mask("m.png", &header_only_png(4, 4))
            .unwrap_err()
            .to_string();
        assert!(!e.contains("can hold") && !e.contains("2^28"), "{e}");
    }
}
