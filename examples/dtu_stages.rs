use std::time::Instant;
use splatkit::geom::*;
fn main() {
    let n: usize = 6_400_000;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let pts: Vec<[f64;3]> = (0..n).map(|i| { let z = 1.0 - 2.0*(i as f64+0.5)/n as f64; let s=(1.0-z*z).sqrt(); let t=golden*i as f64; [150.0*s*t.cos(),150.0*s*t.sin(),600.0+150.0*z]}).collect();
    let t = Instant::now();
    let order = downsample::seeded_permutation(n, 0);
    println!("perm {:.2}", t.elapsed().as_secs_f64());
    let t = Instant::now();
    let kept = downsample::greedy_radius_downsample(&pts, &order, 0.2).unwrap();
    println!("greedy {:.2} kept {}", t.elapsed().as_secs_f64(), kept.len());
    let stl: Vec<[f64;3]> = pts.iter().step_by(2).copied().collect();
    let t = Instant::now();
    let idx = knn::NnIndex::new(&stl).unwrap();
    println!("build {:.2}", t.elapsed().as_secs_f64());
    let q: Vec<[f64;3]> = kept.iter().map(|&i| pts[i]).collect();
    let t = Instant::now();
    let d = idx.nearest_distances(&q);
    println!("nn {} {:.2}", d.len(), t.elapsed().as_secs_f64());
}
