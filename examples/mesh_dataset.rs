//! Writes a training DATA folder (images/, cameras.json, no initial points)
//! of any mesh, the way `sphere_dataset` writes the generated sphere: the
//! mesh centred on its bounding-box centre and scaled to bounding radius 1,
//! coloured by `testing::sphere_texture` of each surface point's direction
//! from the centre (smooth, unlit), black background, `CAMERAS` views of
//! `SIZE`² pixels from `testing::cameras_around(CAMERAS, 3.5, SIZE,
//! 1.25·SIZE)`. Used for issue 27's second random-init case, the Stanford
//! bunny (docs/train.md, "Random initial points"):
//!
//! cargo run --release --example mesh_dataset -- ../shared/data/scanned-meshes/bun_zipper.ply OUT_DIR 40 128

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 3 {
        eprintln!("usage: mesh_dataset MESH OUT_DIR [CAMERAS=40] [SIZE=128]");
        std::process::exit(2);
    }
    let n = a.get(3).map_or(40, |v| v.parse().expect("CAMERAS"));
    let size = a.get(4).map_or(128, |v| v.parse().expect("SIZE"));
    if let Err(e) = run(&a[1], &a[2], n, size) {
        eprintln!("mesh_dataset: {e}");
        std::process::exit(1);
    }
}

fn run(mesh: &str, out: &str, n: usize, size: u32) -> splatkit::Result<()> {
    let mesh = splatkit::io::any::load_mesh(std::path::Path::new(mesh), "mesh_dataset")?;
    let (lo, hi) = mesh
        .bounds()
        .ok_or_else(|| splatkit::Error::invalid("the mesh has no vertices"))?;
    let c: [f32; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let r = mesh
        .vertices
        .iter()
        .map(|v| (0..3).map(|k| (v[k] - c[k]).powi(2)).sum::<f32>().sqrt())
        .fold(0.0f32, f32::max)
        .max(f32::MIN_POSITIVE);
    let vertices = mesh
        .vertices
        .iter()
        .map(|v| std::array::from_fn(|k| (v[k] - c[k]) / r))
        .collect();
    let unit = splatkit::model::Mesh::new(vertices, mesh.faces.clone());
    let cams = splatkit::testing::cameras_around(n, 3.5, size, 1.25 * size as f64);
    splatkit::testing::write_photos(std::path::Path::new(out), &unit, &cams)
}
