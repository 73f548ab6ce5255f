//! `demo`: the built-in default scene, run end to end through the triangle
//! tools, so a newcomer sees every stage work with one command.
//!
//! Scene ([`demo_soup`]): a torus (major radius 1, minor 0.35) tiled with
//! solid, opaque triangles (α = 0.95, σ = 0.5) coloured by angle with SH
//! degree 3, plus "floaters" — random triangles that are either transparent
//! (α = 0.2) or soft (σ = 3) — as training leaves them. The run writes the
//! scene as a Triangle Splatting checkpoint and a soup PLY, prunes it with the
//! game-engine preset, and exports OFF and GLB; the pruned count must equal
//! the torus's triangle count (every floater removed, every surface triangle
//! kept), which the demo checks.

use std::path::{Path, PathBuf};

use anyhow::{Context, ensure};
use clap::Args;
use rand::{RngExt, SeedableRng};
use serde_json::json;

use crate::cli::Common;
use crate::io::gltf::{GltfWriteOptions, write_gltf};
use crate::io::off::{OffWriteOptions, write_off};
use crate::io::ply::{Format, soup::write_soup};
use crate::io::{torch_pt, write_output};
use crate::model::gaussians::logit;
use crate::model::{Extras, TriangleSoup};
use crate::ops::export_off::{ExportParams, soup_to_mesh};
use crate::ops::info::{describe, render_text};
use crate::ops::prune_triangles::{PruneParams, prune};

/// The demo scene: `(soup, number of torus triangles)`; floaters follow the torus.
pub fn demo_soup(seed: u64, segments: usize) -> (TriangleSoup, usize) {
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
    let (nu, nv) = (segments.max(3), (segments / 2).max(3));
    let (big_r, small_r) = (1.0f32, 0.35f32);
    let point = |i: usize, j: usize| {
        let u = i as f32 / nu as f32 * std::f32::consts::TAU;
        let v = j as f32 / nv as f32 * std::f32::consts::TAU;
        let w = big_r + small_r * v.cos();
        [w * u.cos(), small_r * v.sin(), w * u.sin()]
    };
    let mut s = TriangleSoup {
        sh_degree: 3,
        active_sh_degree: 3,
        extras: Extras::default(),
        ..Default::default()
    };
    let push = |s: &mut TriangleSoup,
                t: [[f32; 3]; 3],
                opacity: f32,
                sigma: f32,
                rgb: [f32; 3],
                rng: &mut rand_pcg::Pcg64Mcg| {
        s.triangles.push(t);
        s.opacity_raw.push(logit(opacity));
        s.sigma_raw.push((sigma - 0.01).ln());
        s.sh_dc.push(rgb.map(splatkit_render::sh::rgb_to_sh));
        // Mild view dependence in the higher bands.
        s.sh_rest
            .extend((0..45).map(|_| rng.random_range(-0.05f32..0.05)));
    };
    for i in 0..nu {
        for j in 0..nv {
            // Indices wrap so the seams share bit-identical vertices.
            let (a, b, c, d) = (
                point(i, j),
                point((i + 1) % nu, j),
                point((i + 1) % nu, (j + 1) % nv),
                point(i, (j + 1) % nv),
            );
            let hue = i as f32 / nu as f32;
            let rgb = [
                0.5 + 0.4 * (hue * std::f32::consts::TAU).cos(),
                0.5 + 0.4 * (hue * std::f32::consts::TAU + 2.1).cos(),
                0.5 + 0.4 * (hue * std::f32::consts::TAU + 4.2).cos(),
            ];
            push(&mut s, [a, b, c], 0.95, 0.5, rgb, &mut rng);
            push(&mut s, [a, c, d], 0.95, 0.5, rgb, &mut rng);
        }
    }
    let surface = s.len();
    for k in 0..surface / 4 {
        let centre: [f32; 3] = [0, 1, 2].map(|_| rng.random_range(-1.6f32..1.6));
        let t = [0, 1, 2].map(|_| [0, 1, 2].map(|c| centre[c] + rng.random_range(-0.08f32..0.08)));
        let (o, sig) = if k % 2 == 0 { (0.2, 0.5) } else { (0.95, 3.0) };
        push(&mut s, t, o, sig, [0.8, 0.8, 0.8], &mut rng);
    }
    (s, surface)
}

/// Command-line arguments of `demo`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  splatkit demo                 # writes splatkit-demo/
  splatkit demo -o /tmp/d --seed 7 --segments 128 --json")]
pub struct DemoArgs {
    /// Output folder (created if needed).
    #[arg(short, long, default_value = "splatkit-demo")]
    pub output: PathBuf,
    /// Seed of the generated scene.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Torus segments around the ring (triangles = segments² roughly).
    #[arg(long, default_value_t = 96)]
    pub segments: usize,
    #[command(flatten)]
    pub common: Common,
}

/// Runs the demo.
pub fn run(args: DemoArgs) -> anyhow::Result<()> {
    args.common.init()?;
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("creating {}", args.output.display()))?;
    let out = |f: &str| -> PathBuf { args.output.join(f) };
    let (soup, surface) = demo_soup(args.seed, args.segments);
    let pb = args.common.progress(5, "demo");
    write_output(&out("scene.pt"), |w| {
        torch_pt::write_triangle_checkpoint(w, &soup)
    })?;
    write_output(&out("scene_soup.ply"), |w| {
        write_soup(w, &soup, Format::BinaryLittleEndian)
    })?;
    pb.inc(1);
    let game = PruneParams {
        min_opacity: Some(0.7),
        max_sigma: Some(1.0),
        max_count: None,
        solidify: true,
    };
    let (solid, report) = prune(&soup, &game);
    ensure!(
        report.kept == surface,
        "demo self-check failed: pruning kept {} triangles, the torus has {surface}",
        report.kept
    );
    write_output(&out("solid.pt"), |w| {
        torch_pt::write_triangle_checkpoint(w, &solid)
    })?;
    pb.inc(1);
    let mesh = soup_to_mesh(&solid, &ExportParams::default());
    write_output(&out("solid.off"), |w| {
        write_off(w, &mesh, &OffWriteOptions::triangle_splatting())
    })?;
    pb.inc(1);
    write_output(&out("solid.glb"), |w| {
        write_gltf(w, &mesh, &GltfWriteOptions::default())
    })?;
    pb.inc(1);
    let infos: Vec<_> = ["scene.pt", "solid.off", "solid.glb"]
        .iter()
        .map(|f| describe(&out(f)))
        .collect::<crate::Result<_>>()?;
    pb.finish_and_clear();
    if !args.common.quiet && !args.common.json_to_stdout() {
        eprintln!(
            "demo: generated {} triangles ({} on a torus, {} floaters); prune kept {}; exported {} vertices / {} faces",
            soup.len(),
            surface,
            soup.len() - surface,
            report.kept,
            mesh.vertices.len(),
            mesh.faces.len()
        );
        for i in &infos {
            eprint!("{}", render_text(i));
        }
        eprintln!("outputs in {}", shown_dir(&args.output));
    }
    args.common.emit_json(&json!({
        "output": shown_dir(&args.output),
        "triangles": soup.len(),
        "surface_triangles": surface,
        "prune": report,
        "exported_vertices": mesh.vertices.len(),
        "exported_faces": mesh.faces.len(),
        "files": infos,
    }))
}

fn shown_dir(p: &Path) -> String {
    p.display().to_string()
}
