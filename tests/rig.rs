//! Commands given the same cameras agree on the rig geometry
//! (`splatkit::model::rig`, docs/ARCHITECTURE.md): a camera downscaled by
//! `train` has the size and intrinsics `tsdf-fuse` expects of the same
//! camera at the same `--downscale`, so depth maps rendered at `train`'s
//! training resolution fuse with the original camera file.

mod common;

use common::{mesh_file, run, s, succeeds};
use splatkit::testing::{uv_sphere, write_sphere_dataset};

/// 35 × 35 photos at `--downscale 2`: 17.5 rounds to 18 by 3DGS's rule
/// (ties to even), where flooring gives 17, so a command that floored
/// would disagree with one that rounds. `train` writes its cameras at the
/// training size; a sphere rendered from them gives depth maps that
/// `tsdf-fuse --downscale 2` must accept for the original cameras (it
/// refuses a depth map whose size is not its camera's) and fuse into a
/// mesh near the sphere.
#[test]
fn train_and_tsdf_fuse_downscale_the_same_cameras_alike() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    write_sphere_dataset(&data, 6, 35, 200).unwrap();
    let run_dir = dir.path().join("run");
    succeeds(&run(
        "train",
        &[
            "gaussians",
            s(&data),
            "-o",
            s(&run_dir),
            "--downscale",
            "2",
            "--iterations",
            "1",
            "--test-every",
            "0",
            "-q",
        ],
        None,
    ));
    let cams: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run_dir.join("cameras.json")).unwrap()).unwrap();
    for c in cams.as_array().unwrap() {
        assert_eq!(
            (c["width"].as_u64(), c["height"].as_u64()),
            (Some(18), Some(18))
        );
    }
    let sphere = mesh_file(dir.path(), "sphere.ply", uv_sphere(48, 1.0));
    let depths = dir.path().join("depths");
    succeeds(&run(
        "render",
        &[
            s(&sphere),
            "--cameras",
            s(&run_dir.join("cameras.json")),
            "--outputs",
            "depth",
            "-o",
            s(&depths),
            "-q",
        ],
        None,
    ));
    let out = run(
        "tsdf-fuse",
        &[
            "--depth",
            s(&depths),
            "--cameras",
            s(&data.join("cameras.json")),
            "--downscale",
            "2",
            "--voxel",
            "0.05",
            "--sdf-trunc",
            "0.2",
            "--depth-trunc",
            "10",
            "--no-color",
            "-o",
            s(&dir.path().join("fused.ply")),
            "--json",
        ],
        None,
    );
    succeeds(&out);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["views"].as_array().map(Vec::len), Some(6));
    assert!(report["faces"].as_u64().unwrap() > 100, "{report}");
}
