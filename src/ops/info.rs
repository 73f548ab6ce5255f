//! `info`: what a file is — format, kind of scene, elements and properties,
//! counts, bounding box, SH degree, camera count — as text or `--json`.
//!
//! The core, [`crate::io::describe::describe`], reads one path and returns a
//! [`FileInfo`](crate::io::describe::FileInfo).

use std::path::PathBuf;

use clap::Args;

use crate::cli::Common;
use crate::io::describe::{describe, render_text};

/// Command-line arguments of `info`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  info bun_zipper.ply
  info point_cloud.ply cameras.json sparse/0 --json
  prune-triangles scene.pt -o - | info -")]
pub struct InfoArgs {
    /// Files or camera folders (COLMAP sparse/0, cameras.json, transforms.json, cameras_sphere.npz); `-` = stdin.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    #[command(flatten)]
    pub common: Common,
}

/// Runs the command. Every file is described even if one fails; the exit
/// code is 1 when any failed.
pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    args.common.init()?;
    let mut infos = Vec::new();
    let mut failed = 0;
    for f in &args.files {
        match describe(f) {
            Ok(i) => {
                if args.common.json.is_none() {
                    crate::io::source::print_stdout(&render_text(&i));
                }
                infos.push(i);
            }
            // An output of the run over an input is a usage error: stop.
            Err(e @ crate::Error::Usage(_)) => return Err(e.into()),
            Err(e) => {
                eprintln!("error: {e}");
                failed += 1;
            }
        }
    }
    args.common.emit_json(&serde_json::to_value(&infos)?)?;
    if failed > 0 {
        anyhow::bail!("{failed} of {} inputs could not be read", args.files.len());
    }
    Ok(())
}
