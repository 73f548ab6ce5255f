//! A seeded fuzzer over the commands (issue 23, item 8): random flag values
//! and mutated input sets, each run as its own process under the 2 GB
//! address-space limit of `tests/hostile.rs`, checked for what a hostile
//! user must never see.
//!
//! Every command has a small seed input set, generated up front in
//! `OUT/seeds` (files from `testdata/`, small files written by splatkit's
//! library, and a few written by the binary itself: a bound PLY, renders, a
//! training run). One execution:
//! 1. copies the inputs that the case names into a fresh work folder;
//! 2. builds a small, valid command line (tiny images, a couple of
//!    iterations), then changes 0–3 flags to a typical value or a hostile one
//!    (`0`, `-1`, `NaN`, `inf`, `1e30`, `1e-30`, `4294967295`, `1e12`, empty,
//!    `-`);
//! 3. points each output (`-o`, `--json=FILE`) at a fresh path, at a
//!    pre-existing file or folder with known bytes, at an input, into a
//!    missing folder, into a read-only folder or under a regular file, at a
//!    folder where a file is written (or the reverse), or at stdout;
//! 4. mutates 0–2 input files (the byte mutations of `fuzz_readers`, or the
//!    file swapped for a symlink to `/dev/zero`, a folder or an empty file);
//! 5. runs `splatkit COMMAND …` in the work folder under `RLIMIT_AS` = 2 GB
//!    with a wall timeout, stdin from `/dev/null` (or from an input when the
//!    case reads `-`).
//!
//! Classes: `ok` (exit 0), `error` (exit 1 or 2) and the failures `PANIC`
//! (stderr has "panicked"), `ABORT` (a signal, exit 134, "memory
//! allocation"), `ODD-EXIT` (another exit code), `HANG` (the timeout),
//! `OUTPUT-CHANGED` (a run that exited 1 or 2 changed or removed a file that
//! existed before it, or any run left staging files `.NAME.splatkit-*`),
//! `INPUT-CHANGED` (any run changed an input's bytes), `BOGUS` (exit 0 but a
//! JSON report holds `null` / `NaN`, or an output is empty or has 0
//! elements; best effort). Reported but not counted as failures: `NO-NAME`
//! (an exit-1 message that names neither a file nor a flag of the command
//! line) and `PARTIAL` (a run that exited 1 or 2 left new files).
//!
//! ```text
//! cargo build --release --bin splatkit --example fuzz_commands
//! target/release/examples/fuzz_commands --bin target/release/splatkit \
//!     --seconds 60 --out /dev/shm/fc [--command render,clean] [--seed 1] [--timeout 60]
//! ```
//! `--seconds` is CPU time (user + system) of the command's child processes,
//! per command; `--max-wall` caps the wall time per command (default 3 ×
//! `--seconds` + 120, so runs blocked without using CPU end too);
//! `--executions N` stops a command after N cases; `--log` writes one line
//! per case to `OUT/log.txt`. Prints a table per command and writes `OUT/summary.md`;
//! every failing case is kept in `OUT/failures/COMMAND-N/` (the work folder
//! as it was before the run, `cmd.txt`, `stderr.txt`, `classes.txt` and a
//! `replay.sh` that re-runs it under the same limits). The cases are a
//! function of the seed alone: the same seed gives the same sequence.

#[path = "support/mutate.rs"]
mod mutate;

use std::collections::{BTreeMap, BTreeSet};
use std::hash::Hasher;
use std::io::Read;
use std::os::unix::fs::PermissionsExt;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::{Duration, Instant};

use rand::RngExt;
use splatkit::model::rng::{self, Rng};

/// Address-space limit of every run, bytes (as `tests/common`'s `ulimit -v`).
const LIMIT_BYTES: u64 = 2 * 1024 * 1024 * 1024;

/// Contents of every pre-existing output: a failing run must leave them.
const KNOWN: &[u8] = b"splatkit fuzz: pre-existing file, a failing run must leave it as it is\n";

/// Hostile values tried for any valued flag.
const HOSTILE: &[&str] = &[
    "0",
    "-1",
    "NaN",
    "inf",
    "1e30",
    "1e-30",
    "4294967295",
    "1e12",
    "",
    "-",
];

/// Flags that ask for work in proportion to their value: a huge value is a
/// long run the user asked for, not a hang, so they get the hostile values
/// without the huge ones.
const WORK_FLAGS: &[&str] = &["--iterations", "--refine-iterations", "--stop-at"];

/// The commands, in the order they run.
const COMMANDS: &[&str] = &[
    "info",
    "prune-triangles",
    "export-off",
    "chamfer",
    "poisson",
    "decimate",
    "clean",
    "splat2points",
    "render",
    "tsdf-fuse",
    "tetra-mesh",
    "bind-gaussians",
    "refine",
    "bake-texture",
    "train",
    "demo",
];

/// A flag of a command's table: its name and typical values; no values
/// means a switch.
type Flag = (&'static str, &'static [&'static str]);

/// Failure classes (counted as failures), then the reported-only ones.
const FAILURES: &[&str] = &[
    "PANIC",
    "ABORT",
    "ODD-EXIT",
    "HANG",
    "OUTPUT-CHANGED",
    "INPUT-CHANGED",
    "BOGUS",
];
const NOTES: &[&str] = &["NO-NAME", "PARTIAL"];

#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    File,
    Dir,
}

/// One output of a case: its path in the work folder (or `-`) and whether
/// the command writes a file or a folder there.
struct Output {
    path: String,
    kind: Kind,
}

/// One generated command line with its setup.
#[derive(Default)]
struct Case {
    /// Arguments before the flags (subcommands, positional paths).
    positional: Vec<String>,
    /// Flags by name, each with its tokens, in insertion order.
    flags: Vec<(String, Vec<String>)>,
    /// Input paths (files or folders) relative to the work folder.
    inputs: Vec<String>,
    outputs: Vec<Output>,
    /// File (relative) or device fed on stdin; `/dev/null` when none.
    stdin: Option<String>,
    /// What was done to the case, for the failure notes.
    notes: Vec<String>,
}

impl Case {
    fn tokens(&self) -> Vec<String> {
        let mut t = self.positional.clone();
        for (_, v) in &self.flags {
            t.extend(v.iter().cloned());
        }
        t
    }
}

/// Builds a case in a prepared work folder.
struct Builder<'a> {
    r: &'a mut Rng,
    seeds: &'a Path,
    work: &'a Path,
    c: Case,
}

impl Builder<'_> {
    fn chance(&mut self, p: f64) -> bool {
        self.r.random_bool(p)
    }

    fn pick<T: Copy>(&mut self, xs: &[T]) -> T {
        xs[self.r.random_range(0..xs.len())]
    }

    /// Copies seed `name` into the work folder (once) and records it as an
    /// input; returns the relative path.
    fn input(&mut self, name: &str) -> String {
        let dst = self.work.join(name);
        if let Some(parent) = dst.parent() {
            std::fs::create_dir_all(parent).expect("work folder");
        }
        copy_tree(&self.seeds.join(name), &dst).expect("copy a seed");
        if !self.c.inputs.iter().any(|i| i == name) {
            self.c.inputs.push(name.to_string());
        }
        name.to_string()
    }

    /// An input path given as a positional argument; sometimes `-` with the
    /// file (or `/dev/zero`) on stdin, where `stdin_ok`.
    fn positional_input(&mut self, name: &str, stdin_ok: bool) {
        let p = self.input(name);
        if stdin_ok && self.chance(0.08) {
            let src = if self.chance(0.2) {
                "/dev/zero".to_string()
            } else {
                p
            };
            self.c.notes.push(format!("stdin: {src}"));
            self.c.stdin = Some(src);
            self.c.positional.push("-".into());
        } else {
            self.c.positional.push(p);
        }
    }

    fn pos(&mut self, s: &str) {
        self.c.positional.push(s.to_string());
    }

    /// Sets flag `name` to `value` (`None`: a switch), replacing an earlier
    /// setting.
    fn set(&mut self, name: &str, value: Option<&str>) {
        let mut t = vec![name.to_string()];
        if let Some(v) = value {
            t.push(v.to_string());
        }
        self.set_tokens(name, t);
    }

    fn set_tokens(&mut self, name: &str, t: Vec<String>) {
        if let Some(e) = self.c.flags.iter_mut().find(|(n, _)| n == name) {
            e.1 = t;
        } else {
            self.c.flags.push((name.to_string(), t));
        }
    }

    /// Sets flag `name` to input seed `seed`.
    fn set_input(&mut self, name: &str, seed: &str) {
        let p = self.input(seed);
        self.set(name, Some(&p));
    }

    /// Picks where output `name` (written by `flag`) goes, prepares that
    /// place, and sets the flag. `known` are files a folder output writes:
    /// some are pre-created with [`KNOWN`] bytes. `siblings` are files
    /// written next to a file output (e.g. `.mtl`, `.png`).
    fn output(&mut self, flag: &str, name: &str, kind: Kind, known: &[&str], siblings: &[&str]) {
        let stdout_ok = kind == Kind::File && flag == "-o";
        let roll = self.r.random_range(0..100);
        let (path, what) = match roll {
            0..45 => (name.to_string(), "fresh"),
            45..65 => {
                self.precreate(name, kind, known);
                (name.to_string(), "pre-existing")
            }
            65..72 => {
                let want: Vec<String> = self
                    .c
                    .inputs
                    .iter()
                    .filter(|i| (self.work.join(i).is_dir()) == (kind == Kind::Dir))
                    .cloned()
                    .collect();
                if want.is_empty() {
                    (name.to_string(), "fresh")
                } else {
                    let i = self.r.random_range(0..want.len());
                    (want[i].clone(), "an input")
                }
            }
            72..79 => (format!("missing/{name}"), "in a missing folder"),
            79..86 => {
                if self.chance(0.5) {
                    let ro = self.work.join("ro");
                    std::fs::create_dir_all(&ro).expect("work folder");
                    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555))
                        .expect("chmod");
                    (format!("ro/{name}"), "in a read-only folder")
                } else {
                    std::fs::write(self.work.join("blocker.txt"), KNOWN).expect("work folder");
                    (format!("blocker.txt/{name}"), "under a regular file")
                }
            }
            86..93 => {
                let other = if kind == Kind::File {
                    Kind::Dir
                } else {
                    Kind::File
                };
                self.precreate(name, other, &[]);
                (name.to_string(), "the other kind exists")
            }
            _ if stdout_ok => ("-".to_string(), "stdout"),
            _ => {
                self.precreate(name, kind, known);
                (name.to_string(), "pre-existing")
            }
        };
        if kind == Kind::File && path != "-" {
            let stem = Path::new(&path).with_extension("");
            for s in siblings {
                if self.chance(0.3) {
                    let sib = format!("{}.{s}", stem.display());
                    let k = if self.chance(0.7) {
                        Kind::File
                    } else {
                        Kind::Dir
                    };
                    if !self.work.join(&sib).exists()
                        && self.work.join(&sib).parent().is_some_and(Path::is_dir)
                    {
                        self.precreate(&sib, k, &[]);
                        self.c.notes.push(format!("{sib} pre-existing"));
                    }
                }
            }
        }
        self.c.notes.push(format!("{flag} {path}: {what}"));
        if flag == "--json=" {
            self.set_tokens("--json", vec![format!("--json={path}")]);
        } else {
            self.set(flag, Some(&path));
        }
        self.c.outputs.push(Output { path, kind });
    }

    /// Creates `rel` as a file or folder holding [`KNOWN`] bytes.
    fn precreate(&mut self, rel: &str, kind: Kind, known: &[&str]) {
        let p = self.work.join(rel);
        if p.exists() {
            return;
        }
        match kind {
            Kind::File => {
                std::fs::write(&p, KNOWN).expect("pre-create");
            }
            Kind::Dir => {
                std::fs::create_dir_all(&p).expect("pre-create");
                std::fs::write(p.join("keep.txt"), KNOWN).expect("pre-create");
                for k in known {
                    if self.r.random_bool(0.5) {
                        let f = p.join(k);
                        std::fs::create_dir_all(f.parent().expect("parent")).expect("pre-create");
                        std::fs::write(f, KNOWN).expect("pre-create");
                    }
                }
            }
        }
    }

    /// `--json` to stdout, `--json=FILE` or none.
    fn json(&mut self) {
        match self.r.random_range(0..10) {
            0..3 => self.set("--json", None),
            3..6 => self.output("--json=", "report.json", Kind::File, &[], &[]),
            _ => {}
        }
    }

    /// Changes 0–3 flags of `table`: a switch is added, a valued flag gets
    /// a typical value or a hostile one (30 % for numeric flags, 10 % for
    /// flags that take names).
    fn random_flags(&mut self, table: &[Flag]) {
        let n = self.pick(&[0usize, 1, 1, 2, 2, 3]);
        for _ in 0..n {
            let (name, typical) = self.pick(table);
            let numeric = typical
                .iter()
                .any(|v| v.starts_with(|c: char| c.is_ascii_digit() || c == '-'));
            if typical.is_empty() {
                self.set(name, None);
            } else if self.chance(if numeric { 0.7 } else { 0.9 }) {
                let v = self.pick(typical);
                self.set(name, Some(v));
            } else {
                let v = if WORK_FLAGS.contains(&name) {
                    self.pick(&["0", "-1", "NaN", "inf", "1e-30", "", "-"])
                } else {
                    self.pick(HOSTILE)
                };
                self.set(name, Some(v));
            }
        }
        if self.chance(0.05) {
            let j = self.pick(&["1", "2", "0"]);
            self.set("-j", Some(j));
        }
    }

    /// Mutates 0–2 files under the inputs.
    fn mutate_inputs(&mut self) {
        let mut files = Vec::new();
        for i in &self.c.inputs {
            let p = self.work.join(i);
            if p.is_dir() {
                files_under(&p, &mut files);
            } else if p.is_file() {
                files.push(p);
            }
        }
        files.sort();
        let n = self
            .pick(&[0usize, 0, 0, 0, 0, 1, 1, 1, 2, 2])
            .min(files.len());
        for _ in 0..n {
            let f = files[self.r.random_range(0..files.len())].clone();
            let rel = f.strip_prefix(self.work).expect("under work").display();
            let Ok(meta) = std::fs::symlink_metadata(&f) else {
                continue;
            };
            if !meta.is_file() {
                continue;
            }
            match self.r.random_range(0..20) {
                0 => {
                    std::fs::remove_file(&f).expect("mutate");
                    std::os::unix::fs::symlink("/dev/zero", &f).expect("mutate");
                    self.c.notes.push(format!("{rel} -> /dev/zero"));
                }
                1 => {
                    std::fs::remove_file(&f).expect("mutate");
                    std::fs::create_dir(&f).expect("mutate");
                    self.c.notes.push(format!("{rel} is a folder"));
                }
                2 => {
                    std::fs::write(&f, b"").expect("mutate");
                    self.c.notes.push(format!("{rel} is empty"));
                }
                _ => {
                    let mut b = std::fs::read(&f).expect("mutate");
                    mutate::mutate(&mut b, &mut *self.r);
                    std::fs::write(&f, &b).expect("mutate");
                    self.c.notes.push(format!("{rel} mutated"));
                }
            }
        }
        if self.c.stdin.is_none() && self.c.tokens().iter().any(|t| t == "-") && self.chance(0.5) {
            let i = self.r.random_range(0..self.c.inputs.len().max(1));
            if let Some(s) = self.c.inputs.get(i).cloned()
                && self.work.join(&s).is_file()
            {
                self.c.notes.push(format!("stdin: {s}"));
                self.c.stdin = Some(s);
            }
        }
    }
}

const MESHES: &[&str] = &[
    "mesh.ply",
    "mesh.obj",
    "mesh.off",
    "mesh.glb",
    "trimesh_mesh_binary.ply",
    "pymeshlab_mesh.obj",
];
const SOUPS: &[&str] = &["soup.ply", "soup.pt", "ts_plus.pt", "ts_f16.pt"];
const GAUSSIANS: &[&str] = &["point_cloud.ply", "bound.ply", "gauss_run"];
const TRAIN_KNOWN: &[&str] = &[
    "cameras.json",
    "cfg_args",
    "input.ply",
    "metrics.json",
    "checkpoint/model.ply",
    "checkpoint/optimizer.bin",
];

/// Builds one case of `cmd`.
fn build_case(cmd: &str, b: &mut Builder) {
    match cmd {
        "info" => {
            b.pos("info");
            let pool = [
                "mesh.ply",
                "mesh.glb",
                "soup.pt",
                "point_cloud.ply",
                "bound.ply",
                "points.ply",
                "cameras_sphere.npz",
                "cams.json",
                "ts_views.pt",
                "colmap",
            ];
            let n = b.r.random_range(1..=3);
            for _ in 0..n {
                let s = b.pick(&pool);
                b.positional_input(s, true);
            }
            b.json();
        }
        "prune-triangles" => {
            b.pos("prune-triangles");
            let s = b.pick(SOUPS);
            b.positional_input(s, true);
            let o = b.pick(&["out.ply", "out.pt"]);
            b.output("-o", o, Kind::File, &[], &[]);
            b.random_flags(&[
                ("--format", &["ply", "pt"]),
                ("--min-opacity", &["0.1", "0.5", "0.99"]),
                ("--max-sigma", &["0.5", "2"]),
                ("--max-count", &["10", "100"]),
                ("--solidify", &[]),
                ("--game-engine", &[]),
            ]);
            b.json();
        }
        "export-off" => {
            b.pos("export-off");
            let s = b.pick(&["soup.ply", "soup.pt", "ts_plus.pt", "mesh.ply", "mesh.obj"]);
            b.positional_input(s, true);
            let o = b.pick(&["out.off", "out.glb", "out.ply", "out.obj", "out.gltf"]);
            b.output("-o", o, Kind::File, &[], &["bin", "mtl"]);
            b.random_flags(&[
                ("--format", &["off", "glb", "gltf", "ply", "obj"]),
                ("--no-dedup", &[]),
                ("--per-vertex-colors", &[]),
                ("--alpha", &[]),
                ("--dc-only", &[]),
                ("--view-from", &["0,0,3", "1,2,3", "0,0,0"]),
            ]);
            b.json();
        }
        "chamfer" => {
            b.pos("chamfer");
            let pool = [
                "mesh.ply",
                "mesh2.ply",
                "points.ply",
                "mesh.obj",
                "mesh.glb",
            ];
            let a = b.pick(&pool);
            let c = b.pick(&pool);
            b.positional_input(a, false);
            b.positional_input(c, true);
            b.set("--count", Some("2000"));
            b.random_flags(&[
                ("--sample", &["area", "vertices"]),
                ("--count", &["500", "3000"]),
                ("--spacing", &["0.05", "0.2"]),
                ("--max-samples", &["5000", "100"]),
                ("--vertices", &[]),
                ("--tau", &["0.01", "0.01,0.1"]),
                ("--max-dist", &["0.5", "2"]),
                ("--seed", &["1", "7"]),
            ]);
            if b.chance(0.2) {
                b.output("--plot", "plot.png", Kind::File, &[], &[]);
            }
            b.json();
        }
        "poisson" => {
            b.pos("poisson");
            b.positional_input("points.ply", true);
            b.output("-o", "out.ply", Kind::File, &[], &[]);
            b.set("--depth", Some("5"));
            b.random_flags(&[
                ("--depth", &["4", "6"]),
                ("--full-depth", &["2", "5"]),
                ("--samples-per-node", &["1.5", "4"]),
                ("--point-weight", &["2", "0"]),
                ("--scale", &["1.1", "2"]),
                ("--iters", &["8", "2"]),
                ("--linear-fit", &[]),
                ("--uniform-extraction", &[]),
                ("--width", &["0.1", "0.3"]),
                ("--flip-normals", &[]),
                ("--sugar", &[]),
                ("--trim-quantile", &["0.1", "0.5"]),
                ("--trim", &["0.5", "3"]),
                ("--fg-factor", &["1.1"]),
                ("--bg-factor", &["4"]),
                ("--bbox", &["-1,-1,-1,1,1,1", "0,0,0,1,1,1"]),
                ("--foreground-only", &[]),
                ("--auto-depth", &[]),
                ("--outlier-k", &["4", "8"]),
                ("--outlier-std", &["2"]),
            ]);
            if b.chance(0.1) {
                b.set_input("--split-by-cameras", "cams.json");
            }
            b.json();
        }
        "decimate" => {
            b.pos("decimate");
            let s = b.pick(MESHES);
            b.positional_input(s, true);
            b.output("-o", "out.ply", Kind::File, &[], &[]);
            let (f, v) = b.pick(&[("--faces", "50"), ("--vertices", "30"), ("--ratio", "0.5")]);
            b.set(f, Some(v));
            let table: &[Flag] = match f {
                "--faces" => &[("--faces", &["10", "100", "4"])],
                "--vertices" => &[("--vertices", &["10", "40"])],
                _ => &[("--ratio", &["0.1", "0.9", "1"])],
            };
            b.random_flags(table);
            b.json();
        }
        "clean" => {
            b.pos("clean");
            let s = b.pick(MESHES);
            b.positional_input(s, true);
            b.output("-o", "out.ply", Kind::File, &[], &[]);
            b.random_flags(&[
                ("--no-merge", &[]),
                ("--no-degenerate", &[]),
                ("--no-duplicates", &[]),
                ("--no-nonmanifold", &[]),
                ("--no-unreferenced", &[]),
                ("--keep-largest", &["1", "2"]),
                ("--min-component-faces", &["3", "50"]),
                ("--min-component-area", &["0.01", "0.5"]),
            ]);
            b.json();
        }
        "splat2points" => {
            b.pos("splat2points");
            let s = b.pick(GAUSSIANS);
            b.positional_input(s, false);
            let orbit = b.chance(0.5);
            if orbit {
                b.set("--orbit", Some("2"));
                b.set("--size", Some("24x24"));
                b.random_flags(&[
                    ("--orbit", &["2", "3"]),
                    ("--size", &["24x24", "16x12"]),
                    ("--fov", &["50", "90"]),
                    ("--elevation", &["15", "0,30"]),
                    ("--radius", &["3", "5"]),
                    ("--up", &["0,-1,0", "0,0,1"]),
                ]);
            } else {
                b.set_input("--cameras", "cams.json");
            }
            b.output("-o", "out.ply", Kind::File, &[], &[]);
            b.set("--min-opacity", Some("0.01"));
            b.random_flags(&[
                ("--method", &["levelset", "centers", "depth"]),
                ("--level", &["0.3", "0.1,0.5"]),
                ("--depth", &["diamonds", "gaussian"]),
                ("--max-points", &["1000", "10"]),
                ("--min-opacity", &["0.5", "0.01"]),
                ("--every-nth-test", &["8", "1"]),
                ("--all-views", &[]),
                ("--iteration", &["2", "7"]),
                ("--provenance", &[]),
                ("--seed", &["1"]),
                ("--near", &["0.2", "0"]),
            ]);
            b.json();
        }
        "render" => {
            b.pos("render");
            let s = b.pick(&[
                "point_cloud.ply",
                "bound.ply",
                "mesh.ply",
                "soup.pt",
                "ts_plus.pt",
            ]);
            b.positional_input(s, false);
            if b.chance(0.5) {
                b.set_input("--cameras", "cams.json");
            } else {
                b.set("--orbit", Some("2"));
                b.set("--size", Some("24x24"));
                b.random_flags(&[
                    ("--orbit", &["2", "3"]),
                    ("--size", &["24x24", "16x12"]),
                    ("--fov", &["50", "90"]),
                    ("--elevation", &["15", "0,30"]),
                    ("--radius", &["3", "5"]),
                    ("--up", &["0,-1,0", "0,0,1"]),
                ]);
            }
            b.output(
                "-o",
                "rend",
                Kind::Dir,
                &["v00.png", "v00_depth.png", "cameras.json"],
                &[],
            );
            b.random_flags(&[
                ("--outputs", &["rgb", "rgb,depth,alpha,normal", "depth"]),
                ("--depth", &["median", "expected"]),
                ("--depth-ratio", &["0.5", "1"]),
                ("--depth-scale", &["1000", "1"]),
                ("--background", &["0,0,0", "1,1,1"]),
                ("--shading", &["lit", "none"]),
                ("--near", &["0.2", "0"]),
            ]);
            if b.chance(0.1) {
                b.set_input("--compare", "photos");
            }
            b.json();
        }
        "tsdf-fuse" => {
            b.pos("tsdf-fuse");
            if b.chance(0.7) {
                let s = b.pick(&["mesh.ply", "point_cloud.ply", "bound.ply"]);
                b.positional_input(s, false);
                b.set_input("--cameras", "cams.json");
            } else {
                b.set_input("--cameras", "cams.json");
                b.set_input("--depth", "rend");
                if b.chance(0.5) {
                    b.set_input("--color", "rend");
                }
            }
            b.output("-o", "out.ply", Kind::File, &[], &[]);
            b.set("--voxel", Some("0.05"));
            b.set("--mesh-res", Some("64"));
            b.random_flags(&[
                ("--depth-scale", &["1000", "5000"]),
                ("--depth-ratio", &["1", "0.5"]),
                ("--voxel", &["0.05", "0.1"]),
                ("--sdf-trunc", &["0.2", "0.1"]),
                ("--depth-trunc", &["5", "3"]),
                ("--mesh-res", &["64", "32"]),
                ("--dtu", &[]),
                ("--keep-clusters", &["1", "3"]),
                ("--min-cluster-faces", &["50", "0"]),
                ("--no-color", &[]),
                ("--unbounded", &[]),
                ("--bound", &["2", "1"]),
                ("--downscale", &["1", "2"]),
                ("--near", &["0.2"]),
            ]);
            if b.chance(0.1) {
                b.set_input("--masks", "masks");
            }
            b.json();
        }
        "tetra-mesh" => {
            b.pos("tetra-mesh");
            let s = b.pick(&["point_cloud.ply", "mesh.ply", "bound.ply"]);
            b.positional_input(s, false);
            b.set_input("--cameras", "cams.json");
            b.output("-o", "out.ply", Kind::File, &[], &[]);
            b.random_flags(&[
                ("--level", &["0.5", "0.1"]),
                ("--iterations", &["8", "0"]),
                ("--cameras-subset", &["1", "2"]),
                ("--filter-mesh", &[]),
                ("--no-color", &[]),
                ("--near", &["0.02", "0"]),
                ("--far", &["100", "1e6"]),
                ("--kernel-size", &["0", "0.1"]),
                ("--white-background", &[]),
                ("--every-nth-test", &["0", "8"]),
                ("--low-memory", &[]),
            ]);
            b.json();
        }
        "bind-gaussians" => {
            b.pos("bind-gaussians");
            if b.chance(0.25) {
                b.positional_input("bound.ply", false);
                b.set_input("--rebind", "mesh.ply");
                b.output("-o", "out.ply", Kind::File, &[], &[]);
                b.random_flags(&[("--scale-rule", &["mean-side", "anisotropic"])]);
            } else {
                let s = b.pick(&["mesh.ply", "mesh.obj", "mesh.glb"]);
                b.positional_input(s, false);
                match b.r.random_range(0..4) {
                    0 => b.set_input("--cameras", "cams.json"),
                    1 => b.set_input("--colors-from", "point_cloud.ply"),
                    2 => {
                        b.set_input("--cameras", "data/cameras.json");
                        b.set_input("--images", "data/images");
                    }
                    _ => {}
                }
                b.output("-o", "out.ply", Kind::File, &[], &[]);
                b.random_flags(&[
                    ("--per-triangle", &["1", "4"]),
                    ("--thickness", &["0.01", "0.1"]),
                    ("--sh-degree", &["0", "3"]),
                    ("--downscale", &["1", "2"]),
                ]);
            }
            b.json();
        }
        "refine" => {
            b.pos("refine");
            b.positional_input("bound.ply", false);
            if b.chance(0.3) {
                b.positional_input("mesh.ply", false);
            }
            b.set_input("--images", "data/images");
            b.set_input("--cameras", "data/cameras.json");
            b.output("-o", "refined", Kind::Dir, TRAIN_KNOWN, &[]);
            b.set("--iterations", Some("2"));
            b.random_flags(&[
                ("--iterations", &["2", "3"]),
                ("--downscale", &["1", "2"]),
                ("--resolution", &["16", "12"]),
                ("--white-background", &[]),
                ("--test-every", &["8", "2"]),
                ("--eval-every", &["500", "1"]),
                ("--normal-consistency", &["0.1", "0"]),
                ("--seed", &["1"]),
            ]);
            if b.chance(0.15) {
                b.set_input("--masks", "masks");
            }
            if b.chance(0.15) {
                b.set_input("--resume", "refine_run");
            }
            b.json();
        }
        "bake-texture" => {
            b.pos("bake-texture");
            let m = b.pick(&["mesh.ply", "mesh.obj"]);
            b.positional_input(m, false);
            let g = b.pick(&["bound.ply", "bound.ply", "bound.ply", "point_cloud.ply"]);
            b.positional_input(g, false);
            b.set_input("--cameras", "cams.json");
            b.output("-o", "tex.obj", Kind::File, &[], &["mtl", "png"]);
            b.set("--square-size", Some("8"));
            b.set("--max-texture", Some("256"));
            b.random_flags(&[
                ("--square-size", &["8", "16", "4"]),
                ("--max-texture", &["256", "64"]),
                ("--near", &["0.2", "1"]),
            ]);
            b.json();
        }
        "train" => {
            b.pos("train");
            let model = b.pick(&["triangles", "gaussians"]);
            b.pos(model);
            b.positional_input("data", false);
            b.output("-o", "run", Kind::Dir, TRAIN_KNOWN, &[]);
            b.set("--iterations", Some("2"));
            b.set("--init-points", Some("100"));
            let mut table: Vec<Flag> = vec![
                ("--iterations", &["2", "3"]),
                ("--downscale", &["1", "2"]),
                ("--resolution", &["16", "12"]),
                ("--masks", &[]),
                ("--no-masks", &[]),
                ("--white-background", &[]),
                ("--random-background", &[]),
                ("--test-every", &["8", "2"]),
                ("--eval-every", &["1000", "1"]),
                ("--init-points", &["100", "50"]),
                ("--stop-at", &["1"]),
                ("--seed", &["1"]),
            ];
            if model == "triangles" {
                b.set("--max-shapes", Some("200"));
                table.extend_from_slice(&[
                    ("--indoor", &[]),
                    ("--outdoor", &[]),
                    ("--game-engine", &[]),
                    ("--max-shapes", &["200", "50"]),
                    ("--dome", &[]),
                ]);
            } else {
                table.extend_from_slice(&[
                    ("--regularize", &["density", "sdf", "dn-consistency"]),
                    ("--samples", &["100", "500"]),
                ]);
                b.set("--samples", Some("100"));
            }
            b.random_flags(&table);
            if b.chance(0.15) {
                let r = if model == "gaussians" {
                    "gauss_run"
                } else {
                    "tri_run"
                };
                b.set_input("--resume", r);
            }
            b.json();
        }
        "demo" => {
            b.pos("demo");
            b.output(
                "-o",
                "demo_out",
                Kind::Dir,
                &["scene.ply", "mesh.ply", "cameras.json"],
                &[],
            );
            for (f, v) in [
                ("--views", "3"),
                ("--size", "24"),
                ("--depth", "5"),
                ("--refine-iterations", "2"),
                ("--bind-faces", "100"),
                ("--segments", "8"),
            ] {
                b.set(f, Some(v));
            }
            b.random_flags(&[
                ("--seed", &["1", "2"]),
                ("--views", &["2", "4"]),
                ("--size", &["16", "32"]),
                ("--depth", &["4", "6"]),
                ("--refine-iterations", &["1", "3"]),
                ("--bind-faces", &["50", "200"]),
                ("--segments", &["6", "12"]),
            ]);
            b.json();
        }
        other => panic!("unknown command {other}"),
    }
    // Quiet keeps stderr to the message that matters.
    if !b.c.flags.iter().any(|(n, _)| n == "-q") {
        b.set("-q", None);
    }
    b.mutate_inputs();
}

/// Writes the seed pool into `dir`: library-written files, `testdata/`
/// files, and files written by `bin` itself.
fn write_seeds(dir: &Path, bin: &Path) {
    use splatkit::io::any::{save, save_mesh, save_points};
    use splatkit::io::detect::FileFormat;
    use splatkit::model::{PointCloud, Scene};
    if dir.exists() {
        make_writable(dir);
        std::fs::remove_dir_all(dir).expect("clear the seed folder");
    }
    std::fs::create_dir_all(dir).expect("seed folder");
    let coloured = |n: usize, r: f64| {
        let mut m = splatkit::testing::uv_sphere(n, r);
        m.vertex_colors = Some(
            m.vertices
                .iter()
                .map(|v| {
                    [0, 1, 2, 3].map(|k| {
                        if k == 3 {
                            255
                        } else {
                            (127.0 * (v[k] + 1.0)) as u8
                        }
                    })
                })
                .collect(),
        );
        m
    };
    let mesh = coloured(8, 1.0);
    save_mesh(
        &dir.join("mesh.ply"),
        &mesh,
        FileFormat::Ply,
        &Default::default(),
    )
    .expect("seed");
    for ext in ["obj", "off", "glb"] {
        let p = dir.join(format!("mesh.{ext}"));
        let f = FileFormat::from_extension(&p).expect("known extension");
        save(&p, &Scene::Mesh(mesh.clone()), f).expect("seed");
    }
    save_mesh(
        &dir.join("mesh2.ply"),
        &coloured(6, 1.05),
        FileFormat::Ply,
        &Default::default(),
    )
    .expect("seed");
    let (soup, _) = splatkit::geom::scenes::synthetic::demo_soup(1, 6);
    save(
        &dir.join("soup.ply"),
        &Scene::TriangleSoup(soup.clone()),
        FileFormat::Ply,
    )
    .expect("seed");
    save(
        &dir.join("soup.pt"),
        &Scene::TriangleSoup(soup),
        FileFormat::TorchPt,
    )
    .expect("seed");
    // Oriented points on the unit sphere, for poisson.
    let mut pts: PointCloud = splatkit::testing::sphere_points(400, 3);
    pts.normals = Some(pts.positions.clone());
    save_points(
        &dir.join("points.ply"),
        &pts,
        splatkit::io::ply::header::Format::BinaryLittleEndian,
    )
    .expect("seed");
    let cams = splatkit::testing::cameras_around(3, 3.0, 24, 24.0);
    splatkit::io::cameras::write_gs_json(&dir.join("cams.json"), &cams).expect("seed");
    splatkit::testing::write_sphere_dataset(&dir.join("data"), 4, 24, 100).expect("seed");
    copy_tree(&dir.join("data/images"), &dir.join("photos")).expect("seed");
    std::fs::create_dir_all(dir.join("masks")).expect("seed");
    for k in 0..4 {
        let mut f = std::fs::File::create(dir.join(format!("masks/v{k:02}.png"))).expect("seed");
        splatkit::io::image::write_png8(&mut f, "mask", 24, 24, 1, &[255u8; 24 * 24])
            .expect("seed");
    }
    let td = Path::new(env!("CARGO_MANIFEST_DIR")).join("testdata");
    for (from, to) in [
        ("mesh/trimesh_mesh_binary.ply", "trimesh_mesh_binary.ply"),
        ("mesh/pymeshlab_mesh.obj", "pymeshlab_mesh.obj"),
        ("gaussians/point_cloud.ply", "point_cloud.ply"),
        ("pt/ts_plus.pt", "ts_plus.pt"),
        ("pt/ts_f16.pt", "ts_f16.pt"),
        ("pt/ts_views.pt", "ts_views.pt"),
        ("npz/cameras_sphere.npz", "cameras_sphere.npz"),
        ("mat/ObsMask1_10.mat", "ObsMask1_10.mat"),
        ("colmap", "colmap"),
    ] {
        copy_tree(&td.join(from), &dir.join(to)).expect("copy testdata");
    }
    // Written by the binary: what the commands themselves produce.
    let steps: &[&[&str]] = &[
        &["bind-gaussians", "mesh.ply", "-o", "bound.ply", "-q"],
        &[
            "render",
            "mesh.ply",
            "--cameras",
            "cams.json",
            "-o",
            "rend",
            "-q",
        ],
        &[
            "train",
            "gaussians",
            "data",
            "-o",
            "gauss_run",
            "--iterations",
            "2",
            "--init-points",
            "100",
            "--samples",
            "100",
            "-q",
        ],
        &[
            "train",
            "triangles",
            "data",
            "-o",
            "tri_run",
            "--iterations",
            "2",
            "--init-points",
            "100",
            "--max-shapes",
            "200",
            "-q",
        ],
        &[
            "refine",
            "bound.ply",
            "--images",
            "data/images",
            "--cameras",
            "data/cameras.json",
            "-o",
            "refine_run",
            "--iterations",
            "2",
            "-q",
        ],
    ];
    for args in steps.iter() {
        let out = std::process::Command::new(bin)
            .args(*args)
            .current_dir(dir)
            .stdin(Stdio::null())
            .output()
            .expect("run the binary");
        assert!(
            out.status.success(),
            "seed step {args:?} failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    for name in [
        "mesh.ply",
        "mesh2.ply",
        "soup.pt",
        "points.ply",
        "cams.json",
        "data/cameras.json",
        "data/input.ply",
        "masks/v00.png",
        "bound.ply",
        "rend/v00_depth.npy",
        "gauss_run/cameras.json",
        "tri_run/cameras.json",
        "refine_run/metrics.json",
    ] {
        assert!(dir.join(name).exists(), "seed {name} was not written");
    }
}

/// Copies a file, symlink or folder tree (permissions of folders kept),
/// merging into an existing folder; paths that exist already are kept.
fn copy_tree(from: &Path, to: &Path) -> std::io::Result<()> {
    let meta = std::fs::symlink_metadata(from)?;
    let exists = std::fs::symlink_metadata(to).is_ok();
    if exists && !meta.is_dir() {
        Ok(())
    } else if meta.file_type().is_symlink() {
        std::os::unix::fs::symlink(std::fs::read_link(from)?, to)
    } else if meta.is_dir() {
        std::fs::create_dir_all(to)?;
        let mut names: Vec<_> = std::fs::read_dir(from)?
            .flatten()
            .map(|e| e.file_name())
            .collect();
        names.sort();
        for n in names {
            copy_tree(&from.join(&n), &to.join(&n))?;
        }
        std::fs::set_permissions(to, meta.permissions())
    } else if meta.is_file() {
        std::fs::copy(from, to).map(|_| ())
    } else {
        Ok(())
    }
}

/// Makes every folder under `dir` writable again, so it can be removed.
fn make_writable(dir: &Path) {
    let Ok(meta) = std::fs::symlink_metadata(dir) else {
        return;
    };
    if meta.is_dir() {
        let _ = std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o755));
        if let Ok(rd) = std::fs::read_dir(dir) {
            for e in rd.flatten() {
                make_writable(&e.path());
            }
        }
    }
}

fn files_under(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        let Ok(m) = std::fs::symlink_metadata(&p) else {
            continue;
        };
        if m.is_dir() {
            files_under(&p, out);
        } else {
            out.push(p);
        }
    }
}

/// What a path in the work folder is: a file (its length and hash), a
/// symlink (its target), a folder.
#[derive(Clone, PartialEq, Eq, Debug)]
enum Entry {
    File(u64, u64),
    Link(PathBuf),
    Dir,
    Other,
}

/// Every path under `root` (relative) with what it is; symlinks are not
/// followed.
fn snapshot(root: &Path) -> BTreeMap<String, Entry> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, Entry>) {
        let Ok(rd) = std::fs::read_dir(dir) else {
            return;
        };
        for e in rd.flatten() {
            let p = e.path();
            let rel = p
                .strip_prefix(root)
                .expect("under root")
                .to_string_lossy()
                .into_owned();
            let Ok(m) = std::fs::symlink_metadata(&p) else {
                continue;
            };
            let entry = if m.file_type().is_symlink() {
                Entry::Link(std::fs::read_link(&p).unwrap_or_default())
            } else if m.is_dir() {
                walk(root, &p, out);
                Entry::Dir
            } else if m.is_file() {
                Entry::File(m.len(), hash_file(&p))
            } else {
                Entry::Other
            };
            out.insert(rel, entry);
        }
    }
    let mut out = BTreeMap::new();
    walk(root, root, &mut out);
    out
}

fn hash_file(p: &Path) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    if let Ok(mut f) = std::fs::File::open(p) {
        let mut buf = vec![0u8; 1 << 16];
        while let Ok(n) = f.read(&mut buf) {
            if n == 0 {
                break;
            }
            h.write(&buf[..n]);
        }
    }
    h.finish()
}

/// The result of one run.
struct Run {
    code: Option<i32>,
    signal: Option<i32>,
    hang: bool,
    cpu: f64,
    stderr: String,
    stdout: Vec<u8>,
}

/// Runs `bin args` in `work` under the address-space limit and `timeout`;
/// stdout and stderr go to files in `scratch`.
fn execute(
    bin: &Path,
    args: &[String],
    work: &Path,
    stdin: Option<&Path>,
    scratch: &Path,
    timeout: Duration,
) -> Run {
    let so = scratch.join("stdout");
    let se = scratch.join("stderr");
    let stdin = match stdin {
        Some(p) => match std::fs::File::open(p) {
            Ok(f) => Stdio::from(f),
            Err(_) => Stdio::null(),
        },
        None => Stdio::null(),
    };
    let mut cmd = std::process::Command::new(bin);
    cmd.args(args)
        .current_dir(work)
        .stdin(stdin)
        .stdout(std::fs::File::create(&so).expect("scratch"))
        .stderr(std::fs::File::create(&se).expect("scratch"))
        .env_remove("RUST_BACKTRACE")
        .env_remove("RUST_LIB_BACKTRACE")
        .process_group(0);
    // SAFETY: setrlimit is async-signal-safe; the closure allocates nothing.
    unsafe {
        cmd.pre_exec(|| {
            let lim = libc::rlimit {
                rlim_cur: LIMIT_BYTES as libc::rlim_t,
                rlim_max: LIMIT_BYTES as libc::rlim_t,
            };
            if libc::setrlimit(libc::RLIMIT_AS, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let child = cmd.spawn().expect("spawn the binary");
    let pid = child.id() as libc::pid_t;
    // Wall time counted in steps of at most one second: while this driver
    // and its child are stopped (SIGSTOP, to give a benchmark the machine),
    // the pause does not count towards the hang timeout.
    let mut last = Instant::now();
    let mut waited = Duration::ZERO;
    let mut status: libc::c_int = 0;
    // SAFETY: a zeroed rusage is a valid value for wait4 to fill.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    let mut hang = false;
    // Waits on a pidfd (poll wakes the moment the child exits: most cases
    // take a few milliseconds, and a sleeping poll loop would double their
    // wall time); falls back to short naps where pidfd_open is missing.
    // SAFETY: pidfd_open takes a pid and flags and returns a new fd or -1.
    let pidfd = unsafe { libc::syscall(libc::SYS_pidfd_open, pid, 0) } as libc::c_int;
    let mut nap = Duration::from_millis(1);
    loop {
        // SAFETY: pid is our child; status and ru are valid out-pointers.
        let r = unsafe { libc::wait4(pid, &mut status, libc::WNOHANG, &mut ru) };
        if r == pid {
            break;
        }
        if r < 0 {
            panic!("wait4: {}", std::io::Error::last_os_error());
        }
        let now = Instant::now();
        waited += (now - last).min(Duration::from_secs(1));
        last = now;
        if waited > timeout {
            hang = true;
            // SAFETY: kills the child's own process group.
            unsafe {
                libc::kill(-pid, libc::SIGKILL);
                libc::wait4(pid, &mut status, 0, &mut ru);
            }
            break;
        }
        if pidfd >= 0 {
            let mut fds = libc::pollfd {
                fd: pidfd,
                events: libc::POLLIN,
                revents: 0,
            };
            // SAFETY: one valid pollfd; at most 100 ms, so that the pause
            // rule above sees the time in small steps.
            unsafe { libc::poll(&mut fds, 1, 100) };
        } else {
            std::thread::sleep(nap);
            nap = (nap * 2).min(Duration::from_millis(20));
        }
    }
    if pidfd >= 0 {
        // SAFETY: our own fd, closed once.
        unsafe { libc::close(pidfd) };
    }
    drop(child);
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    let cpu = tv(ru.ru_utime) + tv(ru.ru_stime);
    let (code, signal) = if libc::WIFEXITED(status) {
        (Some(libc::WEXITSTATUS(status)), None)
    } else if libc::WIFSIGNALED(status) {
        (None, Some(libc::WTERMSIG(status)))
    } else {
        (None, None)
    };
    let mut stderr = std::fs::read(&se).unwrap_or_default();
    stderr.truncate(1 << 16);
    let mut stdout = Vec::new();
    if let Ok(f) = std::fs::File::open(&so) {
        let _ = f.take(1 << 20).read_to_end(&mut stdout);
    }
    Run {
        code,
        signal,
        hang,
        cpu,
        stderr: String::from_utf8_lossy(&stderr).into_owned(),
        stdout,
    }
}

/// Keys of a JSON report that are `null` because a setting was left out
/// (not a number that became NaN).
const OPTIONAL_KEYS: &[&str] = &[
    "trim_threshold",
    "max_dist",
    "depth",
    "iteration",
    "mask",
    "masks",
    "resume",
    "scan",
    "scene",
    "compare",
    "cameras",
    "width",
    "bbox",
    "split_by_cameras",
    "max_screen_radius",
    "regularize",
    "final_loss",
];

/// Keys of a JSON text whose value is `null` (serde writes NaN and
/// infinities as `null`), or `NaN` / `Infinity` tokens; keys in
/// [`OPTIONAL_KEYS`] and keys named like a flag of `args` are left out.
fn json_nulls(text: &str, args: &[String]) -> Vec<String> {
    let optional = |k: &str| {
        OPTIONAL_KEYS.contains(&k)
            || args
                .iter()
                .filter_map(|a| a.strip_prefix("--"))
                .any(|f| f.replace('-', "_") == k)
    };
    let mut keys = Vec::new();
    for pat in [": null", ":null"] {
        let mut from = 0;
        while let Some(i) = text[from..].find(pat) {
            let at = from + i;
            let head = &text[..at];
            let key = head
                .rfind('"')
                .and_then(|e| head[..e].rfind('"').map(|s| head[s + 1..e].to_string()))
                .unwrap_or_default();
            if !optional(&key) {
                keys.push(key);
            }
            from = at + pat.len();
        }
    }
    for tok in ["NaN", "Infinity", "[null", ",null", ", null"] {
        if text.contains(tok) {
            keys.push(tok.to_string());
        }
    }
    keys.sort();
    keys.dedup();
    keys
}

/// Why an output file looks empty, if it does: 0 bytes, a PLY / OFF / OBJ
/// with no elements.
fn empty_output(p: &Path) -> Option<String> {
    let m = std::fs::metadata(p).ok()?;
    if !m.is_file() {
        return None;
    }
    if m.len() == 0 {
        return Some("0 bytes".into());
    }
    let mut head = Vec::new();
    std::fs::File::open(p)
        .ok()?
        .take(1 << 16)
        .read_to_end(&mut head)
        .ok()?;
    let text = String::from_utf8_lossy(&head);
    // By content, not by name: `--format` may write OBJ into `x.off`.
    let first = text
        .lines()
        .find(|l| !l.starts_with('#'))
        .and_then(|l| l.split_whitespace().next())
        .unwrap_or("");
    let kind = if text.starts_with("ply") {
        "ply"
    } else if first.ends_with("OFF") {
        "off"
    } else if head.starts_with(b"glTF") || text.starts_with('{') {
        ""
    } else if head.starts_with(b"\x89PNG") || head.contains(&0) {
        // binary (a PNG, an .npy): its compressed bytes may hold "\nv "
        // by chance, which once passed for an OBJ without faces
        ""
    } else if p.extension().is_some_and(|e| e == "obj") || text.lines().any(|l| l.starts_with("v "))
    {
        "obj"
    } else {
        ""
    };
    match kind {
        "ply" => {
            let end = text.find("end_header").unwrap_or(text.len());
            let header = &text[..end];
            for line in header.lines() {
                let w: Vec<&str> = line.split_whitespace().collect();
                if w.len() == 3 && w[0] == "element" && w[2] == "0" && w[1] != "camera" {
                    return Some(format!("PLY element {} 0", w[1]));
                }
            }
            None
        }
        "off" => {
            let nums: Vec<&str> = text
                .lines()
                .filter(|l| !l.starts_with('#'))
                .flat_map(str::split_whitespace)
                .skip_while(|w| w.ends_with("OFF"))
                .take(2)
                .collect();
            (nums.len() == 2 && (nums[0] == "0" || nums[1] == "0"))
                .then(|| format!("OFF {} vertices {} faces", nums[0], nums[1]))
        }
        "obj" => (!text.lines().any(|l| l.starts_with("f ")) && m.len() < (1 << 16))
            .then(|| "OBJ without faces".into()),
        _ => None,
    }
}

/// Does the message name a flag (any `--name`), or a file of the command
/// line (the path, or one of its components)?
fn names_something(stderr: &str, args: &[String]) -> bool {
    let b = stderr.as_bytes();
    if b.windows(3)
        .any(|w| w[0] == b'-' && w[1] == b'-' && w[2].is_ascii_alphabetic())
    {
        return true;
    }
    for a in args {
        if !a.starts_with('-')
            && Path::new(a).components().any(|c| {
                c.as_os_str().len() >= 3 && stderr.contains(&*c.as_os_str().to_string_lossy())
            })
        {
            return true;
        }
        if a.len() >= 2 && a.starts_with('-') && !a.starts_with("--json=") {
            if stderr.contains(a.as_str()) {
                return true;
            }
        } else if a.len() >= 2 {
            let name = Path::new(a)
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            if stderr.contains(a.as_str()) || (name.len() >= 3 && stderr.contains(&name)) {
                return true;
            }
        }
        if let Some(p) = a.strip_prefix("--json=")
            && (stderr.contains(p) || stderr.contains("--json"))
        {
            return true;
        }
    }
    stderr.contains("stdin") || stderr.contains("<-")
}

/// The classes of one run, with a short reason for each.
fn classify(
    run: &Run,
    case: &Case,
    args: &[String],
    work: &Path,
    before: &BTreeMap<String, Entry>,
) -> Vec<(&'static str, String)> {
    let mut cls = Vec::new();
    let err = &run.stderr;
    let killed = run.hang
        || run.signal.is_some()
        || run.code == Some(134)
        || err.contains("memory allocation");
    if run.hang {
        cls.push(("HANG", "timeout".to_string()));
    } else if err.contains("panicked") {
        let line = err
            .lines()
            .skip_while(|l| !l.contains("panicked"))
            .take(2)
            .collect::<Vec<_>>()
            .join(" | ");
        cls.push(("PANIC", line));
    } else if killed {
        let line = err
            .lines()
            .find(|l| l.contains("memory allocation"))
            .unwrap_or("")
            .to_string();
        cls.push((
            "ABORT",
            format!("signal {:?} exit {:?} {line}", run.signal, run.code),
        ));
    } else if !matches!(run.code, Some(0..=2)) {
        cls.push(("ODD-EXIT", format!("exit {:?}", run.code)));
    }
    let after = snapshot(work);
    let input_roots: Vec<&String> = case.inputs.iter().collect();
    let is_input = |rel: &str| {
        input_roots
            .iter()
            .any(|i| rel == i.as_str() || rel.starts_with(&format!("{i}/")))
    };
    // Inputs: byte-identical after any run.
    for (rel, e) in before {
        if is_input(rel) && after.get(rel) != Some(e) {
            let what = if after.contains_key(rel) {
                "changed"
            } else {
                "removed"
            };
            let via = if case.stdin.as_deref() == Some(rel.as_str()) {
                " (the file on stdin)"
            } else {
                ""
            };
            cls.push(("INPUT-CHANGED", format!("{rel} {what}{via}")));
            break;
        }
    }
    let failed = matches!(run.code, Some(1 | 2)) && !killed;
    if failed {
        for (rel, e) in before {
            if !is_input(rel) && after.get(rel) != Some(e) {
                let what = if after.contains_key(rel) {
                    "changed"
                } else {
                    "removed"
                };
                cls.push(("OUTPUT-CHANGED", format!("{rel} {what}")));
                break;
            }
        }
        if let Some(rel) = after.keys().find(|k| !before.contains_key(*k)) {
            cls.push(("PARTIAL", format!("{rel} created")));
        }
    }
    if !killed
        && let Some(rel) = after.keys().find(|k| {
            let n = Path::new(k)
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            n.starts_with('.') && n.contains(".splatkit-") && !before.contains_key(*k)
        })
    {
        cls.push(("OUTPUT-CHANGED", format!("staging {rel} left")));
    }
    if run.code == Some(0) && !killed {
        let mut bogus = Vec::new();
        let stdout_json = case
            .flags
            .iter()
            .any(|(n, t)| n == "--json" && t.len() == 1 && t[0] == "--json");
        if stdout_json {
            let nulls = json_nulls(&String::from_utf8_lossy(&run.stdout), args);
            if !nulls.is_empty() {
                bogus.push(format!("--json null: {}", nulls.join(",")));
            }
        }
        for o in &case.outputs {
            if o.path == "-" {
                if run.stdout.is_empty() {
                    bogus.push("stdout output empty".into());
                }
                continue;
            }
            let p = work.join(&o.path);
            if o.path.ends_with(".json")
                && o.kind == Kind::File
                && let Ok(t) = std::fs::read_to_string(&p)
            {
                let nulls = json_nulls(&t, args);
                if !nulls.is_empty() {
                    bogus.push(format!("{} null: {}", o.path, nulls.join(",")));
                }
            }
            let mut files = Vec::new();
            if o.kind == Kind::Dir {
                files_under(&p, &mut files);
            } else {
                files.push(p.clone());
            }
            for f in files {
                let rel = f.strip_prefix(work).unwrap_or(&f).display().to_string();
                if before.get(&rel) == after.get(&rel) {
                    continue; // not written by this run
                }
                if rel.ends_with("metrics.json")
                    && let Ok(t) = std::fs::read_to_string(&f)
                {
                    let nulls = json_nulls(&t, args);
                    if !nulls.is_empty() {
                        bogus.push(format!("{rel} null: {}", nulls.join(",")));
                    }
                }
                if let Some(why) = empty_output(&f) {
                    bogus.push(format!("{rel}: {why}"));
                }
            }
        }
        if !bogus.is_empty() {
            cls.push(("BOGUS", bogus.join("; ")));
        }
    }
    if run.code == Some(1) && !killed && !names_something(err, args) {
        cls.push(("NO-NAME", err.lines().last().unwrap_or("").to_string()));
    }
    cls
}

/// A signature that groups failures of the same kind: the class and its
/// reason with digits and the work folder's names folded.
fn signature(class: &str, reason: &str) -> String {
    let mut s = String::new();
    let mut last_digit = false;
    for ch in reason.chars() {
        if ch.is_ascii_digit() {
            if !last_digit {
                s.push('#');
            }
            last_digit = true;
        } else {
            s.push(ch);
            last_digit = false;
        }
    }
    s.truncate(160);
    format!("{class}: {s}")
}

fn shell_quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=,:".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// Per-command counters.
#[derive(Default)]
struct Tally {
    execs: u64,
    ok: u64,
    error: u64,
    classes: BTreeMap<&'static str, u64>,
    cpu: f64,
    wall: f64,
    /// Signature → (count, first failure folder).
    kinds: BTreeMap<String, (u64, String)>,
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
        .unwrap_or(30.0);
    let out = PathBuf::from(opt("--out").unwrap_or_else(|| "fuzz-commands-out".into()));
    let seed: u64 = opt("--seed").and_then(|s| s.parse().ok()).unwrap_or(1);
    let timeout = Duration::from_secs_f64(
        opt("--timeout")
            .and_then(|s| s.parse().ok())
            .unwrap_or(60.0),
    );
    // Runs blocked without using CPU (a hang waiting on input) would never
    // use up a CPU budget: wall time per command is capped too.
    let max_wall: f64 = opt("--max-wall")
        .and_then(|s| s.parse().ok())
        .unwrap_or(3.0 * seconds + 120.0);
    let max_execs: u64 = opt("--executions")
        .and_then(|s| s.parse().ok())
        .unwrap_or(u64::MAX);
    let bin = opt("--bin").map(PathBuf::from).unwrap_or_else(|| {
        let profile = opt("--profile").unwrap_or_else(|| "release".into());
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("target")
            .join(profile)
            .join("splatkit")
    });
    let bin = std::fs::canonicalize(&bin)
        .unwrap_or_else(|e| panic!("{}: {e} (build it first)", bin.display()));
    let only: Option<Vec<String>> =
        opt("--command").map(|s| s.split(',').map(str::to_string).collect());
    if let Some(o) = &only {
        for c in o {
            assert!(COMMANDS.contains(&c.as_str()), "unknown command {c}");
        }
    }
    std::fs::create_dir_all(&out).expect("output folder");
    let out = std::fs::canonicalize(&out).expect("output folder");
    let seeds = out.join("seeds");
    write_seeds(&seeds, &bin);
    let failures = out.join("failures");
    let work = out.join("work/case");
    let pristine = out.join("work/pristine");
    let scratch = out.join("work");
    // `--log`: one line per execution in OUT/log.txt (command line, exit,
    // classes, the message's last line), to check what the cases reach.
    let mut log = args
        .iter()
        .any(|a| a == "--log")
        .then(|| std::io::BufWriter::new(std::fs::File::create(out.join("log.txt")).expect("log")));
    let mut table: Vec<(&str, Tally)> = Vec::new();
    for &cmd in COMMANDS {
        if only.as_ref().is_some_and(|o| !o.iter().any(|x| x == cmd)) {
            continue;
        }
        let mut t = Tally::default();
        let mut r = rng::stream(seed, rng::splitmix64(cmd.len() as u64) ^ fnv(cmd));
        let mut last_step = Instant::now();
        let mut wall = 0.0f64;
        let mut last_report = Instant::now();
        let mut saved: BTreeMap<&'static str, u64> = BTreeMap::new();
        let mut nfail = 0u64;
        while t.cpu < seconds && wall < max_wall && t.execs < max_execs {
            for d in [&work, &pristine] {
                make_writable(d);
                let _ = std::fs::remove_dir_all(d);
            }
            std::fs::create_dir_all(&work).expect("work folder");
            let mut b = Builder {
                r: &mut r,
                seeds: &seeds,
                work: &work,
                c: Case::default(),
            };
            build_case(cmd, &mut b);
            let case = b.c;
            let tokens = case.tokens();
            copy_tree(&work, &pristine).expect("keep the case");
            let before = snapshot(&work);
            let stdin = case.stdin.as_ref().map(|s| {
                if s.starts_with('/') {
                    PathBuf::from(s)
                } else {
                    work.join(s)
                }
            });
            let run = execute(&bin, &tokens, &work, stdin.as_deref(), &scratch, timeout);
            t.execs += 1;
            t.cpu += run.cpu;
            match run.code {
                Some(0) => t.ok += 1,
                Some(1 | 2) => t.error += 1,
                _ => {}
            }
            let cls = classify(&run, &case, &tokens, &work, &before);
            if let Some(l) = log.as_mut() {
                use std::io::Write as _;
                let line: Vec<String> = tokens.iter().map(|t| shell_quote(t)).collect();
                let _ = writeln!(
                    l,
                    "{cmd}\t{}\texit {:?}\t{:?}\t{}\t{}",
                    line.join(" "),
                    run.code,
                    cls.iter().map(|c| c.0).collect::<Vec<_>>(),
                    run.stderr.lines().last().unwrap_or(""),
                    case.notes.join("; ")
                );
            }
            let keep = cls
                .iter()
                .any(|(c, _)| FAILURES.contains(c) || *c == "NO-NAME");
            let mut folder = String::new();
            if keep {
                let first = cls
                    .iter()
                    .find(|(c, _)| FAILURES.contains(c))
                    .map(|(c, _)| *c)
                    .unwrap_or("NO-NAME");
                let n = saved.entry(first).or_default();
                if *n < 20 {
                    *n += 1;
                    folder = format!("{cmd}-{nfail}");
                    nfail += 1;
                    save_failure(
                        &failures.join(&folder),
                        &pristine,
                        &bin,
                        &tokens,
                        &case,
                        &run,
                        &cls,
                        timeout,
                    );
                }
            }
            for (c, reason) in &cls {
                *t.classes.entry(c).or_default() += 1;
                let e = t
                    .kinds
                    .entry(signature(c, reason))
                    .or_insert((0, folder.clone()));
                e.0 += 1;
                if e.1.is_empty() {
                    e.1 = folder.clone();
                }
            }
            // Wall time with pauses left out (as in `execute`): one case
            // counts at most its timeout plus five seconds.
            let now = Instant::now();
            let step = now - last_step;
            wall += if step.as_secs_f64() > timeout.as_secs_f64() + 5.0 {
                timeout.as_secs_f64() + 5.0
            } else {
                step.as_secs_f64()
            };
            last_step = now;
            if last_report.elapsed() > Duration::from_secs(60) {
                eprintln!(
                    "{cmd}: {} executions, {:.0} s CPU, {:?}",
                    t.execs, t.cpu, t.classes
                );
                last_report = Instant::now();
            }
        }
        t.wall = wall;
        eprintln!(
            "{cmd}: {} executions, ok {}, error {}, {:?}, {:.1} s CPU",
            t.execs, t.ok, t.error, t.classes, t.cpu
        );
        table.push((cmd, t));
    }
    for d in [&work, &pristine] {
        make_writable(d);
        let _ = std::fs::remove_dir_all(d);
    }
    let report = summary(&table, seed, seconds);
    print!("{report}");
    std::fs::write(out.join("summary.md"), report).expect("write the summary");
}

fn fnv(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    })
}

/// Keeps a failing case: the work folder before the run, the command line,
/// stderr, the classes and a replay script.
#[allow(clippy::too_many_arguments)]
fn save_failure(
    dir: &Path,
    pristine: &Path,
    bin: &Path,
    tokens: &[String],
    case: &Case,
    run: &Run,
    cls: &[(&str, String)],
    timeout: Duration,
) {
    if dir.exists() {
        make_writable(dir);
        let _ = std::fs::remove_dir_all(dir);
    }
    std::fs::create_dir_all(dir).expect("failure folder");
    copy_tree(pristine, &dir.join("work")).expect("keep the case");
    let line: Vec<String> = tokens.iter().map(|t| shell_quote(t)).collect();
    let stdin = match &case.stdin {
        Some(s) => format!(" < {}", shell_quote(s)),
        None => " < /dev/null".into(),
    };
    std::fs::write(
        dir.join("cmd.txt"),
        format!("splatkit {}{stdin}\n", line.join(" ")),
    )
    .expect("failure folder");
    std::fs::write(dir.join("stderr.txt"), &run.stderr).expect("failure folder");
    let mut classes = String::new();
    for (c, reason) in cls {
        classes.push_str(&format!("{c}: {reason}\n"));
    }
    classes.push_str(&format!(
        "exit {:?} signal {:?} cpu {:.2} s\n",
        run.code, run.signal, run.cpu
    ));
    for n in &case.notes {
        classes.push_str(&format!("case: {n}\n"));
    }
    std::fs::write(dir.join("classes.txt"), classes).expect("failure folder");
    let script = format!(
        "#!/bin/sh\n\
         # Replays one fuzz_commands case: a fresh copy of work/ (the folder as it was\n\
         # before the run) in run/, then the command there under the same limits.\n\
         # SPLATKIT=path overrides the binary.\n\
         here=$(cd \"$(dirname \"$0\")\" && pwd)\n\
         chmod -R u+w \"$here/run\" 2>/dev/null; rm -rf \"$here/run\"\n\
         cp -a \"$here/work\" \"$here/run\"\n\
         cd \"$here/run\" || exit 1\n\
         ulimit -v {}\n\
         exec timeout {} \"${{SPLATKIT:-{}}}\" {}{stdin}\n",
        LIMIT_BYTES / 1024,
        timeout.as_secs(),
        bin.display(),
        line.join(" "),
    );
    let rs = dir.join("replay.sh");
    std::fs::write(&rs, script).expect("failure folder");
    std::fs::set_permissions(&rs, std::fs::Permissions::from_mode(0o755)).expect("chmod");
}

/// The per-command table and the distinct failure kinds, as Markdown.
fn summary(table: &[(&str, Tally)], seed: u64, seconds: f64) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# fuzz_commands, seed {seed}, {seconds} CPU-seconds per command\n"
    );
    let mut head = "| command | executions | ok | error |".to_string();
    let mut rule = "|---|---|---|---|".to_string();
    for c in FAILURES.iter().chain(NOTES) {
        head.push_str(&format!(" {c} |"));
        rule.push_str("---|");
    }
    head.push_str(" CPU s | wall s |");
    rule.push_str("---|---|");
    let _ = writeln!(s, "{head}\n{rule}");
    for (cmd, t) in table {
        let mut row = format!("| {cmd} | {} | {} | {} |", t.execs, t.ok, t.error);
        for c in FAILURES.iter().chain(NOTES) {
            row.push_str(&format!(" {} |", t.classes.get(c).copied().unwrap_or(0)));
        }
        row.push_str(&format!(" {:.1} | {:.1} |", t.cpu, t.wall));
        let _ = writeln!(s, "{row}");
    }
    let _ = writeln!(s, "\n## Distinct kinds (count, first kept case)\n");
    let mut seen = BTreeSet::new();
    for (cmd, t) in table {
        for (sig, (n, folder)) in &t.kinds {
            seen.insert(sig.clone());
            let _ = writeln!(s, "- {cmd}: {sig} — {n}× ({folder})");
        }
    }
    s
}
