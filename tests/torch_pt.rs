//! Triangle Splatting checkpoint reader (`splatkit::io::torch_pt`):
//! allocation bounds on corrupted input (a tracking global allocator records
//! the largest single allocation of the thread), and the checkpoints written
//! by real PyTorch committed in `testdata/pt/` (by
//! `scripts/make_pt_fixtures.py`; always read). When `SPLATKIT_PT_FIXTURES`
//! names a folder, a checkpoint written by splatkit is also left there for the
//! script's `--check` mode (torch.load of our writer's output).

use std::path::PathBuf;

use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use splatkit::io::torch_pt::{parse_triangle_checkpoint, write_triangle_checkpoint};
use splatkit::model::TriangleSoup;

#[path = "common/largest_alloc.rs"]
mod largest_alloc;

fn soup(n: usize, seed: u64) -> TriangleSoup {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut f = || rng.random_range(-2.0f32..2.0);
    TriangleSoup {
        triangles: (0..n)
            .map(|_| [[f(), f(), f()], [f(), f(), f()], [f(), f(), f()]])
            .collect(),
        opacity_raw: (0..n).map(|_| f()).collect(),
        sigma_raw: (0..n).map(|_| f()).collect(),
        sh_degree: 3,
        active_sh_degree: 3,
        sh_dc: (0..n).map(|_| [f(), f(), f()]).collect(),
        sh_rest: (0..n * 45).map(|_| f()).collect(),
        ..Default::default()
    }
}

/// Offset and length of the first zip entry's data (`archive/data.pkl`),
/// from the central directory (the local header may defer the size to a
/// data descriptor, as torch's own writer does).
fn first_entry(bytes: &[u8]) -> (usize, usize) {
    let mut za = zip::ZipArchive::new(std::io::Cursor::new(bytes)).unwrap();
    let f = za.by_index_raw(0).unwrap();
    (
        f.data_start().unwrap() as usize,
        f.compressed_size() as usize,
    )
}

/// Parses `bytes` (no panic allowed) and returns the largest single
/// allocation made meanwhile.
fn largest_allocation_parsing(bytes: &[u8]) -> usize {
    let (r, largest) = largest_alloc::during(|| {
        std::panic::catch_unwind(|| parse_triangle_checkpoint("m.pt", bytes))
    });
    assert!(r.is_ok(), "the reader panicked");
    if let Ok(Ok(s)) = r {
        s.validate().unwrap();
    }
    largest
}

/// Corrupted checkpoints (truncations, bit flips, large integers written over
/// data.pkl bytes) never make the reader allocate more than the input
/// justifies: one allocation at most twice the file size (an f16 storage
/// widens to f32) plus 64 KiB of fixed buffers.
#[test]
fn corrupted_checkpoints_allocate_at_most_what_the_input_justifies() {
    let s = soup(40, 1);
    let mut bytes = Vec::new();
    write_triangle_checkpoint(&mut bytes, &s).unwrap();
    let bound = 2 * bytes.len() + (64 << 10);
    let clean = largest_allocation_parsing(&bytes);
    assert!(clean <= bound, "{clean} > {bound}");
    let (pkl_at, pkl_len) = first_entry(&bytes);
    let mut rng = Pcg64::seed_from_u64(2);
    let mut worst = clean;
    for trial in 0..4000 {
        let mut m = bytes.clone();
        match trial % 4 {
            0 => m.truncate(rng.random_range(0..bytes.len())),
            1 => {
                let at = rng.random_range(0..m.len());
                m[at] ^= 1 << rng.random_range(0..8);
            }
            _ => {
                // Large values over data.pkl bytes: turns BININT1 sizes and
                // storage sizes into huge or negative numbers.
                let at = pkl_at + rng.random_range(0..pkl_len - 4);
                let v: u32 = [0x7fff_ffff, 0xffff_ffff, 0x0100_0000, 0x8000_0000][trial % 4];
                if trial % 8 < 4 {
                    m[at] = b'J';
                    m[at + 1..at + 5].copy_from_slice(&v.to_le_bytes());
                } else {
                    m[at..at + 4].copy_from_slice(&v.to_le_bytes());
                }
            }
        }
        let got = largest_allocation_parsing(&m);
        assert!(
            got <= bound,
            "trial {trial}: allocation of {got} bytes > {bound}"
        );
        worst = worst.max(got);
    }
    eprintln!(
        "input {} bytes; largest allocation: clean {clean}, corrupted {worst}",
        bytes.len()
    );
}

fn floats(v: &serde_json::Value, key: &str) -> Vec<f64> {
    v[key]
        .as_array()
        .unwrap_or_else(|| panic!("{key} missing"))
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn compare(file: &str, what: &str, got: &[f32], want: &[f64], exact: bool, tol: f64) {
    assert_eq!(got.len(), want.len(), "{file}: {what} length");
    for (i, (&g, &w)) in got.iter().zip(want).enumerate() {
        if exact {
            // f32 (or f16 widened) values written by torch, serialised by
            // Python as the exact f64 of the f32: equality is bit equality.
            assert_eq!(g, w as f32, "{file}: {what}[{i}]");
        } else {
            assert!(
                (g as f64 - w).abs() <= tol * w.abs().max(1.0),
                "{file}: {what}[{i}] = {g}, expected {w}"
            );
        }
    }
}

/// Checkpoints written by PyTorch itself (`testdata/pt/`, see
/// scripts/make_pt_fixtures.py), compared with the values PyTorch reported
/// in `testdata/pt/expected.json`; every truncated copy is an error.
#[test]
fn pytorch_written_fixtures() {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/testdata/pt"));
    let text = std::fs::read_to_string(dir.join("expected.json")).unwrap();
    let expected: serde_json::Value = serde_json::from_str(&text).unwrap();
    let cases = expected.as_object().unwrap();
    assert!(!cases.is_empty());
    for (file, e) in cases {
        let soup = splatkit::io::torch_pt::read_triangle_checkpoint(&dir.join(file)).unwrap();
        let exact = e["exact"].as_bool().unwrap();
        let tol = e["tol"].as_f64().unwrap();
        assert_eq!(soup.len() as u64, e["n"].as_u64().unwrap(), "{file}");
        assert_eq!(
            soup.sh_degree as u64,
            e["sh_degree"].as_u64().unwrap(),
            "{file}"
        );
        assert_eq!(
            soup.active_sh_degree as u64,
            e["active_sh_degree"].as_u64().unwrap(),
            "{file}"
        );
        let tri: &[f32] = bytemuck::cast_slice(&soup.triangles);
        compare(file, "triangles", tri, &floats(e, "triangles"), exact, tol);
        compare(
            file,
            "opacity",
            &soup.opacity_raw,
            &floats(e, "opacity_raw"),
            exact,
            tol,
        );
        compare(
            file,
            "sigma",
            &soup.sigma_raw,
            &floats(e, "sigma_raw"),
            exact,
            tol,
        );
        let dc: &[f32] = bytemuck::cast_slice(&soup.sh_dc);
        compare(file, "sh_dc", dc, &floats(e, "sh_dc"), exact, tol);
        compare(
            file,
            "sh_rest",
            &soup.sh_rest,
            &floats(e, "sh_rest"),
            exact,
            tol,
        );
        let extras = e.get("extras").and_then(|x| x.as_object());
        for (name, want) in extras.into_iter().flatten() {
            let col = soup
                .extras
                .item
                .iter()
                .find(|p| &p.name == name)
                .unwrap_or_else(|| panic!("{file}: extra {name} missing"));
            let data = col.data.as_scalar().unwrap();
            let want: Vec<f64> = want
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            let got: Vec<f64> = (0..data.len()).map(|i| data.get_f64(i)).collect();
            // Integers and f32 values: exact in f64.
            assert_eq!(got, want, "{file}: extra {name}");
        }
        // Truncated copies of a PyTorch-written file are all errors.
        let bytes = std::fs::read(dir.join(file)).unwrap();
        for len in 0..bytes.len() {
            assert!(parse_triangle_checkpoint("cut.pt", &bytes[..len]).is_err());
        }
        eprintln!("{file}: {} triangles match", soup.len());
    }
}

/// The other direction: when `SPLATKIT_PT_FIXTURES` names a folder, writes a
/// checkpoint made by splatkit there (`from_splatkit.pt`) with its values
/// (`from_splatkit.json`), for `make_pt_fixtures.py --check DIR` to load with
/// torch.load. Without the variable there is nothing to hand over.
#[test]
fn checkpoint_for_torch_load_check() {
    let Some(dir) = std::env::var_os("SPLATKIT_PT_FIXTURES").map(PathBuf::from) else {
        eprintln!(
            "SPLATKIT_PT_FIXTURES is not set: no checkpoint left for make_pt_fixtures.py --check"
        );
        return;
    };
    std::fs::create_dir_all(&dir).unwrap();
    let mut s = soup(9, 3);
    s.active_sh_degree = 2;
    s.extras.item.push(splatkit::model::attributes::Property {
        name: "importance".into(),
        data: splatkit::model::Column::Scalar(splatkit::model::ScalarData::I32(
            (0..9).map(|i| i * 1000 - 4000).collect(),
        )),
    });
    let mut out = Vec::new();
    write_triangle_checkpoint(&mut out, &s).unwrap();
    std::fs::write(dir.join("from_splatkit.pt"), out).unwrap();
    let values = serde_json::json!({
        "triangles_points": bytemuck::cast_slice::<_, f32>(&s.triangles),
        "sigma": s.sigma_raw,
        "opacity": s.opacity_raw,
        "features_dc": bytemuck::cast_slice::<_, f32>(&s.sh_dc),
        "features_rest": s.sh_rest,
        "active_sh_degree": s.active_sh_degree,
        "importance": (0..9).map(|i| i * 1000 - 4000).collect::<Vec<i32>>(),
        "n": s.len(),
    });
    std::fs::write(dir.join("from_splatkit.json"), values.to_string()).unwrap();
    eprintln!("wrote from_splatkit.pt for `make_pt_fixtures.py --check`");
}

/// Throughput at real scale (1 M triangles, a 236 MB checkpoint): write to a
/// temporary file, read back, compare. A long run: ignored by default,
/// run by `cargo test --workspace -- --ignored` (as `.ci/run` does) or
/// alone with `cargo test --release --test torch_pt -- --ignored`.
#[test]
#[ignore = "long run (1M triangles, 236 MB): cargo test --workspace -- --ignored, as .ci/run does"]
fn large_checkpoint_throughput() {
    let s = soup(1_000_000, 4);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.pt");
    let t0 = std::time::Instant::now();
    splatkit::io::write_output(&path, |w| write_triangle_checkpoint(w, &s)).unwrap();
    let write_s = t0.elapsed().as_secs_f64();
    let size = std::fs::metadata(&path).unwrap().len();
    let t1 = std::time::Instant::now();
    let back = splatkit::io::torch_pt::read_triangle_checkpoint(&path).unwrap();
    let read_s = t1.elapsed().as_secs_f64();
    assert_eq!(back, s);
    eprintln!(
        "{} triangles, {:.1} MB: write {:.3} s ({:.0} MB/s), read {:.3} s ({:.0} MB/s)",
        s.len(),
        size as f64 / 1e6,
        write_s,
        size as f64 / 1e6 / write_s,
        read_s,
        size as f64 / 1e6 / read_s
    );
    if let Some(keep) = std::env::var_os("SPLATKIT_PT_KEEP_LARGE") {
        std::fs::copy(&path, keep).unwrap();
    }
    // The same content re-saved by torch.save, when such a file is given.
    if let Some(other) = std::env::var_os("SPLATKIT_PT_TORCH_LARGE") {
        let t2 = std::time::Instant::now();
        let theirs = splatkit::io::torch_pt::read_triangle_checkpoint(other.as_ref()).unwrap();
        eprintln!(
            "torch-written copy read in {:.3} s",
            t2.elapsed().as_secs_f64()
        );
        assert_eq!(theirs, s);
    }
}
