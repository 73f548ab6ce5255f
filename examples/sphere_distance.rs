//! Distance of a mesh to the unit sphere (the generated training scene's
//! true surface), measured independently of any reconstruction code:
//! accuracy = mean | |p| − 1 | over points sampled uniformly by area on the
//! mesh; completeness = mean distance from points uniform on the sphere to
//! the nearest mesh sample; Chamfer = their mean. Prints one JSON line.
//!
//! cargo run --release --example sphere_distance -- MESH.ply

use splatkit::geom::knn::NnIndex;
use splatkit::geom::sample::sample_area_uniform;

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: sphere_distance MESH");
    let m = splatkit::io::any::load_mesh(std::path::Path::new(&path), "sphere_distance")
        .unwrap_or_else(|e| panic!("{path}: {e}"));
    let v: Vec<[f64; 3]> = m.vertices.iter().map(|p| p.map(f64::from)).collect();
    let area: f64 = m
        .faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|i| glam::DVec3::from_array(v[i as usize]));
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    let pts = sample_area_uniform(&v, &m.faces, 200_000.0 / area.max(1e-9), 1).expect("sampling");
    let acc: Vec<f64> = pts
        .iter()
        .map(|p| ((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - 1.0).abs())
        .collect();
    let mut sorted = acc.clone();
    sorted.sort_by(f64::total_cmp);
    let accuracy = acc.iter().sum::<f64>() / acc.len().max(1) as f64;
    // Fibonacci points on the sphere
    let n = 20_000;
    let sphere: Vec<[f64; 3]> = (0..n)
        .map(|k| {
            let y = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let a = k as f64 * 2.399_963_229_728_653;
            let s = (1.0 - y * y).sqrt();
            [s * a.cos(), y, s * a.sin()]
        })
        .collect();
    let index = NnIndex::new(&pts).expect("index");
    let comp = index.nearest_distances(&sphere);
    let completeness = comp.iter().sum::<f64>() / n as f64;
    println!(
        "{{\"mesh\": {path:?}, \"faces\": {}, \"accuracy\": {accuracy:.5}, \"accuracy_p90\": {:.5}, \
         \"completeness\": {completeness:.5}, \"chamfer\": {:.5}}}",
        m.faces.len(),
        sorted[(sorted.len() as f64 * 0.9) as usize],
        0.5 * (accuracy + completeness)
    );
}
