//! Writes the generated textured-sphere scene as a training DATA folder
//! (images/, cameras.json, input.ply): the scene `train`'s acceptance
//! tests and benchmarks use.
//!
//! cargo run --release --example sphere_dataset -- OUT_DIR [CAMERAS] [SIZE] [POINTS]

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 2 {
        eprintln!("usage: sphere_dataset OUT_DIR [CAMERAS=40] [SIZE=128] [POINTS=2000]");
        std::process::exit(2);
    }
    let n = a.get(2).map_or(40, |v| v.parse().expect("CAMERAS"));
    let size = a.get(3).map_or(128, |v| v.parse().expect("SIZE"));
    let points = a.get(4).map_or(2000, |v| v.parse().expect("POINTS"));
    if let Err(e) =
        splatkit::testing::write_sphere_dataset(std::path::Path::new(&a[1]), n, size, points)
    {
        eprintln!("sphere_dataset: {e}");
        std::process::exit(1);
    }
}
