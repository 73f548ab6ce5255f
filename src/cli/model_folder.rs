//! A trained model's folder and its cameras, as 3DGS / 2DGS / GOF write
//! them (`point_cloud/iteration_*/point_cloud.ply`, `cameras.json`): the
//! commands that take a model folder (`splat2points`, `tetra-mesh`) resolve
//! it here, and hold out the test views as 3DGS's `llffhold` does.

use std::path::{Path, PathBuf};

use anyhow::Context;

use crate::model::Camera;

/// The Gaussian PLY and camera file of a 3DGS model folder.
pub fn resolve_model_folder(
    dir: &Path,
    iteration: Option<u64>,
) -> anyhow::Result<(PathBuf, PathBuf)> {
    let pc = dir.join("point_cloud");
    let mut found: Vec<(u64, PathBuf)> = std::fs::read_dir(&pc)
        .with_context(|| {
            format!(
                "{} is not a 3DGS model folder (no point_cloud/)",
                dir.display()
            )
        })?
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let it = name.strip_prefix("iteration_")?.parse::<u64>().ok()?;
            let f = e.path().join("point_cloud.ply");
            f.is_file().then_some((it, f))
        })
        .collect();
    found.sort();
    let ply = match iteration {
        Some(want) => found
            .iter()
            .find(|(it, _)| *it == want)
            .map(|(_, p)| p.clone())
            .with_context(|| {
                format!(
                    "{}: no iteration_{want}/point_cloud.ply (found {:?})",
                    pc.display(),
                    found.iter().map(|f| f.0).collect::<Vec<_>>()
                )
            })?,
        None => found
            .last()
            .map(|(_, p)| p.clone())
            .with_context(|| format!("{}: no iteration_*/point_cloud.ply", pc.display()))?,
    };
    Ok((ply, dir.join("cameras.json")))
}

/// Keeps the training views: drops every `n`-th camera of the name-sorted
/// list, starting with the first (3DGS `llffhold`); `n = 0` keeps all.
pub fn training_views(mut cams: Vec<Camera>, n: usize) -> Vec<Camera> {
    if n == 0 {
        return cams;
    }
    cams.sort_by(|a, b| a.name.cmp(&b.name));
    cams.into_iter()
        .enumerate()
        .filter(|(i, _)| i % n != 0)
        .map(|(_, c)| c)
        .collect()
}
