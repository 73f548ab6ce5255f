//! Distance of a mesh to the unit sphere (the generated training scene's
//! true surface), by `splatkit::testing::sphere_mesh_distance`: accuracy
//! (mesh → sphere), completeness (sphere → mesh) and their mean (Chamfer),
//! as one JSON line.
//!
//! cargo run --release --example sphere_distance -- MESH.ply

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: sphere_distance MESH");
    let m = splatkit::io::any::load_mesh(std::path::Path::new(&path), "sphere_distance")
        .unwrap_or_else(|e| panic!("{path}: {e}"));
    let (acc, comp) = splatkit::testing::sphere_mesh_distance(&m).expect("distance");
    println!(
        "{{\"mesh\": {path:?}, \"faces\": {}, \"accuracy\": {acc:.5}, \"completeness\": {comp:.5}, \
         \"chamfer\": {:.5}}}",
        m.faces.len(),
        0.5 * (acc + comp)
    );
}
