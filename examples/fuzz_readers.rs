//! A seeded mutation fuzzer over every file reader (issue 11): PLY (generic,
//! Gaussians, 2DGS surfels, mesh, points, soup), OBJ, OFF, glTF/GLB, Triangle Splatting
//! `.pt`, MATLAB `.mat`, NumPy `.npy` / NeuS `.npz`, COLMAP binary and text,
//! 3DGS `cameras.json`, `transforms.json`, the Tanks-and-Temples `.log`,
//! `_trans.txt` and crop JSON, and the Gaussian-splat formats (SuperSplat
//! compressed PLY, antimatter15 `.splat`, GaussianSplats3D `.ksplat`,
//! Niantic SPZ, PlayCanvas SOG bundled and `meta.json`).
//!
//! Seeds are the files in `testdata/` plus small files written by
//! splatkit's own writers. Each execution takes a seed, applies 1–4 random
//! mutations (bit flips, boundary bytes and integers, truncation, chunk
//! deletion / duplication / insertion, number tokens replaced by extreme
//! values in text) and calls the reader. A reader must return `Ok` or `Err`:
//! a panic is a crash (the input is saved to `OUT/crash-READER-N.bin`). Run
//! it under an address-space limit (`scripts/fuzz.sh` does) so that an
//! allocation driven by a declared size aborts the run; the input being
//! read is always in `OUT/current-READER.bin` for that case. With
//! `--big-alloc BYTES`, an input that makes one allocation of that size or
//! more is saved as `OUT/big-READER-N.bin` whatever memory the machine has
//! (`--replay` with it prints the allocation's backtrace).
//!
//! ```text
//! cargo run --release --example fuzz_readers -- --seconds 60 --out fuzz-out [--reader ply] [--seed 1]
//! cargo run --release --example fuzz_readers -- --replay fuzz-out/crash-gltf-0.bin --reader gltf
//! ```
//! `--seconds` is CPU time per reader. One JSON line per reader on stdout:
//! executions, Ok / Err counts, crashes, large allocations, CPU and wall seconds.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

#[path = "support/mutate.rs"]
mod mutate;

use mutate::mutate;
use rand::RngExt;
use splatkit::io::any::save;
use splatkit::io::cameras::colmap;
use splatkit::io::detect::FileFormat;
use splatkit::model::rng;
use splatkit::model::{Mesh, PointCloud, Scene};

type Reader = fn(&[u8]) -> bool;

/// The system allocator, watched: a single request of [`BIG_ALLOC`] bytes or
/// more is remembered (its size in [`LARGEST`]) and, in `--replay`, printed
/// with a backtrace, so that `--big-alloc BYTES` names the inputs that drive
/// large allocations even on a machine that has the memory for them.
struct Watched;

static BIG_ALLOC: AtomicUsize = AtomicUsize::new(usize::MAX);
static LARGEST: AtomicUsize = AtomicUsize::new(0);
static BACKTRACE: AtomicBool = AtomicBool::new(false);

thread_local! {
    static IN_HOOK: Cell<bool> = const { Cell::new(false) };
}

fn watch(size: usize) {
    if size < BIG_ALLOC.load(Ordering::Relaxed) {
        return;
    }
    LARGEST.fetch_max(size, Ordering::Relaxed);
    if BACKTRACE.load(Ordering::Relaxed) && !IN_HOOK.with(|h| h.replace(true)) {
        eprintln!(
            "allocation of {size} bytes:\n{}",
            std::backtrace::Backtrace::force_capture()
        );
        IN_HOOK.with(|h| h.set(false));
    }
}

// SAFETY: every call is passed on unchanged to `System`.
unsafe impl GlobalAlloc for Watched {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        watch(l.size());
        // SAFETY: same contract as the caller\'s.
        unsafe { System.alloc(l) }
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        watch(l.size());
        // SAFETY: same contract as the caller\'s.
        unsafe { System.alloc_zeroed(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        // SAFETY: same contract as the caller\'s.
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        watch(new);
        // SAFETY: same contract as the caller\'s.
        unsafe { System.realloc(p, l, new) }
    }
}

#[global_allocator]
static GLOBAL: Watched = Watched;

/// The readers under test, one entry per reader the issue names: its name,
/// the reader (true = Ok) and which seed files (by path suffix) feed it.
/// Where one reader has several entry points (the PLY element kinds, COLMAP
/// binary and text, the `.npy` inside a `.npz`), every input goes through
/// all of them.
fn readers() -> Vec<(&'static str, Reader, &'static [&'static str])> {
    use splatkit::io::{cameras, gltf, image, mat, obj, off, ply, splat, tnt, torch_pt};
    vec![
        (
            "ply",
            |b| {
                ply::parse_ply("f", b).is_ok()
                    | ply::gaussians::parse_gaussians("f", b).is_ok()
                    | ply::surfels::parse_surfels("f", b).is_ok()
                    | ply::mesh::parse_mesh("f", b).is_ok()
                    | ply::points::parse_points("f", b).is_ok()
                    | ply::soup::parse_soup("f", b).is_ok()
            },
            &[".ply"],
        ),
        ("obj", |b| obj::parse_obj("f", b).is_ok(), &[".obj"]),
        ("off", |b| off::parse_off("f", b).is_ok(), &[".off"]),
        (
            "gltf",
            |b| gltf::parse_gltf("f", b).is_ok(),
            &[".glb", ".gltf"],
        ),
        (
            "pt",
            |b| torch_pt::parse_triangle_checkpoint("f", b).is_ok(),
            &[".pt"],
        ),
        ("mat", |b| mat::parse_mat("f", b).is_ok(), &[".mat"]),
        (
            "npz",
            |b| {
                cameras::npz::parse_npy("f", b).is_ok()
                    | cameras::npz::parse_neus_npz(
                        "f",
                        b,
                        None,
                        &cameras::npz::NpzOptions::default(),
                    )
                    .is_ok()
            },
            &[".npy", ".npz"],
        ),
        (
            "colmap",
            |b| {
                let s = String::from_utf8_lossy(b);
                colmap::decode_cameras_bin("f", b).is_ok()
                    | colmap::decode_images_bin("f", b).is_ok()
                    | colmap::decode_points3d_bin("f", b).is_ok()
                    | colmap::decode_cameras_txt("f", &s).is_ok()
                    | colmap::decode_images_txt("f", &s).is_ok()
                    | colmap::decode_points3d_txt("f", &s).is_ok()
            },
            &[".bin", "cameras.txt", "images.txt", "points3D.txt"],
        ),
        (
            "json-cameras",
            |b| {
                cameras::gs_json::parse_gs_json("f", b).is_ok()
                    | cameras::nerf_json::parse_transforms_json("f", b, Path::new(".")).is_ok()
                    | tnt::parse_crop_json("f", b).is_ok()
            },
            &["cameras.json", "transforms.json", "_crop.json"],
        ),
        (
            "tnt",
            |b| tnt::parse_log("f", b).is_ok() | tnt::parse_trans("f", b).is_ok(),
            &[".log", "_trans.txt"],
        ),
        ("png-mask", |b| image::parse_mask("f", b).is_ok(), &[".png"]),
        (
            "compressed-ply",
            |b| splat::compressed_ply::read("f", b).is_ok(),
            &[".compressed.ply"],
        ),
        (
            "splat",
            |b| splat::dot_splat::read("f", b).is_ok(),
            &[".splat"],
        ),
        (
            "ksplat",
            |b| splat::ksplat::read("f", b).is_ok(),
            &[".ksplat"],
        ),
        (
            "spz",
            |b| splatkit::io::splat::spz::read("f", b).is_ok(),
            &[".spz"],
        ),
        (
            "sog",
            |b| {
                splatkit::io::splat::sog::read("f", b, Path::new("/nonexistent")).is_ok()
                    | splatkit::io::splat::sog::sniff_zip(b)
                    | splatkit::io::splat::sog::sniff_meta(b)
            },
            &[".sog", "sog_meta.json"],
        ),
    ]
}

fn files_under(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            files_under(&p, out);
        } else {
            out.push(p);
        }
    }
}

/// Small valid files from splatkit's writers, into `dir`.
fn write_generated_seeds(dir: &Path) {
    std::fs::create_dir_all(dir).expect("seed folder");
    // SPZ and SOG of the 3DGS fixture (SH degree 3), and a loose SOG meta.json
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata");
    let ply = std::fs::read(root.join("gaussians/point_cloud.ply")).expect("fixture");
    let g = splatkit::io::ply::gaussians::parse_gaussians("seed", &ply).expect("fixture");
    let spz = splatkit::io::splat::spz::write("seed", &g, true).expect("write seed");
    std::fs::write(dir.join("gen.spz"), spz).expect("write seed");
    let sog = splatkit::io::splat::sog::write("seed", &g, true).expect("write seed");
    let mut z = zip::ZipArchive::new(std::io::Cursor::new(&sog[..])).expect("our zip");
    let mut meta = Vec::new();
    std::io::Read::read_to_end(&mut z.by_name("meta.json").expect("meta"), &mut meta)
        .expect("meta");
    std::fs::write(dir.join("gen.sog"), &sog).expect("write seed");
    std::fs::write(dir.join("gen_sog_meta.json"), meta).expect("write seed");
    let mesh = Mesh::new(
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ],
        vec![[0, 1, 2], [0, 2, 3], [0, 3, 1]],
    );
    for ext in ["ply", "obj", "off", "glb", "gltf"] {
        let p = dir.join(format!("gen_mesh.{ext}"));
        let f = FileFormat::from_extension(&p).expect("known extension");
        save(&p, &Scene::Mesh(mesh.clone()), f).expect("write seed");
    }
    let (soup, _) = splatkit::geom::scenes::synthetic::demo_soup(1, 4);
    save(
        &dir.join("gen_soup.ply"),
        &Scene::TriangleSoup(soup.clone()),
        FileFormat::Ply,
    )
    .expect("write seed");
    save(
        &dir.join("gen_soup.pt"),
        &Scene::TriangleSoup(soup),
        FileFormat::TorchPt,
    )
    .expect("write seed");
    let pts = PointCloud {
        positions: vec![[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]],
        normals: Some(vec![[0.0, 0.0, 1.0]; 2]),
        colors: Some(vec![[1, 2, 3]; 2]),
        ..Default::default()
    };
    save(
        &dir.join("gen_points.ply"),
        &Scene::PointCloud(pts),
        FileFormat::Ply,
    )
    .expect("write seed");
    std::fs::write(
        dir.join("gen.npy"),
        splatkit::io::cameras::npz::encode_npy_f64(&[2, 3], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
    )
    .expect("write seed");
    let cams: Vec<_> = (0..3)
        .map(|i| {
            splatkit::model::Camera::pinhole(
                format!("im{i}.png"),
                64,
                48,
                50.0,
                50.0,
                32.0,
                24.0,
                glam::DMat3::IDENTITY,
                glam::DVec3::new(i as f64, 0.0, 3.0),
            )
        })
        .collect();
    splatkit::io::cameras::write_gs_json(&dir.join("cameras.json"), &cams).expect("write seed");
    splatkit::io::cameras::write_transforms_json(&dir.join("transforms.json"), &cams)
        .expect("write seed");
    let model = colmap::ColmapModel::from_cameras(&cams).expect("colmap model");
    let bin = dir.join("colmap_bin");
    std::fs::create_dir_all(&bin).expect("seed folder");
    model.write_binary(&bin).expect("write seed");
    let txt = dir.join("colmap_txt");
    std::fs::create_dir_all(&txt).expect("seed folder");
    model.write_text(&txt).expect("write seed");
    for (i, (ch, w, h)) in [(1usize, 5usize, 3usize), (3, 4, 4), (4, 2, 6)]
        .into_iter()
        .enumerate()
    {
        let data: Vec<u8> = (0..ch * w * h).map(|k| (k * 37 % 256) as u8).collect();
        let mut f = std::fs::File::create(dir.join(format!("mask{i}.png"))).expect("seed file");
        splatkit::io::image::write_png8(&mut f, "seed", w, h, ch, &data).expect("write seed");
    }
    let mut f = std::fs::File::create(dir.join("depth16.png")).expect("seed file");
    splatkit::io::image::write_png16(&mut f, "seed", 3, 2, &[0, 1, 256, 65535, 7, 9])
        .expect("write seed");
    drop(f);
    std::fs::write(
        dir.join("scene_crop.json"),
        r#"{"class_name":"SelectionPolygonVolume","orthogonal_axis":"Z","axis_max":1.0,"axis_min":-1.0,
"bounding_polygon":[[0,0,0],[1,0,0],[1,1,0],[0,1,0]],"version_major":1,"version_minor":0}"#,
    )
    .expect("write seed");
    std::fs::write(
        dir.join("scene_trans.txt"),
        "1 0 0 0.5\n0 1 0 0\n0 0 1 0\n0 0 0 1\n",
    )
    .expect("write seed");
    std::fs::write(
        dir.join("scene.log"),
        "0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n1 1 2\n1 0 0 1\n0 1 0 0\n0 0 1 0\n0 0 0 1\n",
    )
    .expect("write seed");
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let opt = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1).cloned())
    };
    let seconds: f64 = opt("--seconds")
        .and_then(|s| s.parse().ok())
        .unwrap_or(10.0);
    let out = PathBuf::from(opt("--out").unwrap_or_else(|| "fuzz-out".into()));
    let only = opt("--reader");
    let seed: u64 = opt("--seed").and_then(|s| s.parse().ok()).unwrap_or(1);
    if let Some(b) = opt("--big-alloc").and_then(|s| s.parse().ok()) {
        BIG_ALLOC.store(b, Ordering::Relaxed);
    }
    // `--replay FILE --reader NAME`: run one input with panics shown.
    if let (Some(file), Some(name)) = (opt("--replay"), only.as_deref()) {
        let bytes = std::fs::read(&file).expect("read the replayed file");
        BACKTRACE.store(true, Ordering::Relaxed);
        let (_, read, _) = readers()
            .into_iter()
            .find(|(n, _, _)| *n == name)
            .expect("a known --reader");
        println!("{}", if read(&bytes) { "ok" } else { "err" });
        return;
    }
    std::fs::create_dir_all(&out).expect("output folder");
    let gen_dir = out.join("seeds");
    write_generated_seeds(&gen_dir);
    let mut files = Vec::new();
    files_under(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata"),
        &mut files,
    );
    files_under(&gen_dir, &mut files);
    files.sort();
    // Panics are the findings: keep their messages out of the output.
    std::panic::set_hook(Box::new(|_| {}));
    for (name, read, suffixes) in readers() {
        if only
            .as_deref()
            .is_some_and(|o| !o.split(',').any(|x| x == name))
        {
            continue;
        }
        let seeds: Vec<Vec<u8>> = files
            .iter()
            .filter(|p| {
                let s = p.to_string_lossy();
                suffixes.iter().any(|x| s.ends_with(x))
            })
            .filter_map(|p| std::fs::read(p).ok())
            .collect();
        if seeds.is_empty() {
            println!("{{\"reader\":\"{name}\",\"error\":\"no seed files\"}}");
            continue;
        }
        let mut r = rng::stream(seed, name.len() as u64 * 7919 + seeds.len() as u64);
        let current = out.join(format!("current-{name}.bin"));
        let (mut execs, mut ok, mut crashes, mut bigs) = (0u64, 0u64, 0u64, 0u64);
        let t0 = Instant::now();
        let cpu0 = cpu_seconds();
        let mut last_report = Instant::now();
        // The budget is CPU time of this process, so a run sharing the
        // machine still gives each reader its full share.
        while execs % 256 != 0 || cpu_seconds() - cpu0 < seconds {
            if last_report.elapsed() > Duration::from_secs(60) {
                eprintln!(
                    "{name}: {execs} executions, {crashes} crashes, {:.0} s CPU",
                    cpu_seconds() - cpu0
                );
                last_report = Instant::now();
            }
            let mut input = seeds[r.random_range(0..seeds.len())].clone();
            mutate(&mut input, &mut r);
            // Kept on disk so a run killed by the address-space limit leaves
            // the input that did it.
            std::fs::write(&current, &input).expect("write current input");
            LARGEST.store(0, Ordering::Relaxed);
            let result = std::panic::catch_unwind(|| read(&input));
            let largest = LARGEST.load(Ordering::Relaxed);
            if largest > 0 {
                let f = out.join(format!("big-{name}-{bigs}.bin"));
                std::fs::write(&f, &input).expect("write big");
                eprintln!(
                    "{name}: an allocation of {largest} bytes, input {}",
                    f.display()
                );
                bigs += 1;
            }
            match result {
                Ok(true) => ok += 1,
                Ok(false) => {}
                Err(_) => {
                    std::fs::write(out.join(format!("crash-{name}-{crashes}.bin")), &input)
                        .expect("write crash");
                    crashes += 1;
                }
            }
            execs += 1;
        }
        let _ = std::fs::remove_file(&current);
        println!(
            "{{\"reader\":\"{name}\",\"seeds\":{},\"executions\":{execs},\"ok\":{ok},\"err\":{},\"crashes\":{crashes},\"big_allocs\":{bigs},\"cpu_seconds\":{:.1},\"wall_seconds\":{:.1}}}",
            seeds.len(),
            execs - ok - crashes,
            cpu_seconds() - cpu0,
            t0.elapsed().as_secs_f64()
        );
    }
}

/// CPU time (user + system) of this process so far, in seconds, from
/// `/proc/self/stat` (Linux; the fuzz script is Linux-only anyway).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").expect("read /proc/self/stat");
    // Fields after the `(comm)`: state is field 3; utime and stime are 14, 15.
    let rest = &stat[stat.rfind(')').expect("stat format") + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f[11].parse::<f64>().unwrap_or(0.0) + f[12].parse::<f64>().unwrap_or(0.0);
    ticks / 100.0
}
