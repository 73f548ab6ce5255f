//! PLY read/write throughput on a generated 1M-Gaussian SH-3 scene (248 MB),
//! from and to the page cache, single thread.
//!
//! Run: `cargo bench --bench ply_io` (or `scripts/bench_io.sh`).
//! Environment: `SPLATKIT_BENCH_N` (default 1,000,000), `SPLATKIT_BENCH_REPS` (default 5),
//! `SPLATKIT_BENCH_KEEP=PATH` keeps the generated file (for scripts/compare/ply_io.py).
//! Prints the best and median of the repetitions in MB/s (1 MB = 10^6 bytes).

use std::time::Instant;

use rand::{RngExt, SeedableRng};
use splatkit::io::ply::Format;
use splatkit::io::ply::gaussians::{parse_gaussians, write_gaussians};
use splatkit::model::{Extras, Gaussians};

fn main() {
    let n: usize = std::env::var("SPLATKIT_BENCH_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let reps: usize = std::env::var("SPLATKIT_BENCH_REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(7);
    let mut f = || rng.random_range(-1.0f32..1.0);
    let g = Gaussians {
        means: (0..n).map(|_| [f(), f(), f()]).collect(),
        normals: Some(vec![[0.0; 3]; n]),
        sh_degree: 3,
        sh_dc: (0..n).map(|_| [f(), f(), f()]).collect(),
        sh_rest: (0..n * 45).map(|_| f()).collect(),
        opacity_logits: (0..n).map(|_| f()).collect(),
        log_scales: (0..n).map(|_| [f(), f(), f()]).collect(),
        rotations: (0..n).map(|_| [f(), f(), f(), f()]).collect(),
        extras: Extras::default(),
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("bench.ply");
    let mut write_t = Vec::new();
    let mut read_t = Vec::new();
    let mut generic_t = Vec::new();
    let mut encode_t = Vec::new();
    let mut size = 0usize;
    for _ in 0..reps {
        let t = Instant::now();
        splatkit::io::write_output(&path, |w| {
            write_gaussians(w, &g, Format::BinaryLittleEndian)
        })
        .unwrap();
        write_t.push(t.elapsed().as_secs_f64());
        size = std::fs::metadata(&path).unwrap().len() as usize;

        let t = Instant::now();
        write_gaussians(&mut std::io::sink(), &g, Format::BinaryLittleEndian).unwrap();
        encode_t.push(t.elapsed().as_secs_f64());

        let t = Instant::now();
        let input = splatkit::io::read_input(&path).unwrap();
        let back = parse_gaussians(&input.name, &input).unwrap();
        read_t.push(t.elapsed().as_secs_f64());
        assert_eq!(back.len(), n);
        drop(back);

        let t = Instant::now();
        let ply = splatkit::io::ply::parse_ply(&input.name, &input).unwrap();
        generic_t.push(t.elapsed().as_secs_f64());
        assert_eq!(ply.elements[0].count, n);
    }
    if let Some(keep) = std::env::var_os("SPLATKIT_BENCH_KEEP") {
        std::fs::copy(&path, &keep).expect("copy benchmark file");
    }
    let report = |what: &str, ts: &mut Vec<f64>| {
        ts.sort_by(f64::total_cmp);
        let mb = size as f64 / 1e6;
        println!(
            "{what:<44} best {:7.3} s {:7.0} MB/s   median {:7.3} s {:7.0} MB/s",
            ts[0],
            mb / ts[0],
            ts[ts.len() / 2],
            mb / ts[ts.len() / 2]
        );
    };
    println!(
        "ply_io: {n} Gaussians, SH degree 3, {:.1} MB, {reps} reps, 1 thread",
        size as f64 / 1e6
    );
    report("write 3DGS PLY (temp file + rename)", &mut write_t);
    report("encode 3DGS PLY only (to io::sink)", &mut encode_t);
    report("read 3DGS PLY -> Gaussians (mmap)", &mut read_t);
    report("read PLY -> generic columns (mmap)", &mut generic_t);
}
