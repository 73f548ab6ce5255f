//! DTU / NeuS files the tests write: `cameras.npz` and RGB PNG masks.

use std::io::Write;
use std::path::Path;

use glam::DMat4;
use splatkit::io::cameras::npz::encode_npy_f64;

/// Writes a NeuS `cameras.npz` holding `world_mat_i` and `scale_mat_i` for
/// each pair of `mats` (stored uncompressed, rows first, as numpy does).
pub fn write_neus_npz(path: &Path, mats: &[(DMat4, DMat4)]) {
    let rows = |m: DMat4| -> Vec<f64> {
        (0..4)
            .flat_map(|i| (0..4).map(move |j| m.col(j)[i]))
            .collect()
    };
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let opts =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    for (i, (world, scale)) in mats.iter().enumerate() {
        for (name, m) in [("world_mat", world), ("scale_mat", scale)] {
            zip.start_file(format!("{name}_{i}.npy"), opts).unwrap();
            zip.write_all(&encode_npy_f64(&[4, 4], &rows(*m))).unwrap();
        }
    }
    std::fs::write(path, zip.finish().unwrap().into_inner()).unwrap();
}

/// Writes an 8-bit RGB PNG of `w` × `h` pixels (`rgb` row by row).
pub fn write_rgb_png(path: &Path, w: u32, h: u32, rgb: &[u8]) {
    let file = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header().unwrap().write_image_data(rgb).unwrap();
}
