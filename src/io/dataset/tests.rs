//! Tests of [`load_dataset`] on small generated folders and on the shared
//! real data sets.

use std::path::Path;

use glam::{DMat3, DVec3};

use super::*;
use crate::io::cameras::write_gs_json;
use crate::io::image::write_png8;
use crate::io::ply::Format;
use crate::io::ply::points::write_points;
use crate::testing::shared_data;

/// Writes a `w`×`h` PNG with `channels` (3 or 4) whose every pixel is `px`.
fn png(path: &Path, w: usize, h: usize, channels: usize, px: &[u8]) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    let data: Vec<u8> = (0..w * h).flat_map(|_| px[..channels].to_vec()).collect();
    let mut f = std::fs::File::create(path).unwrap();
    write_png8(&mut f, "test", w, h, channels, &data).unwrap();
}

/// A COLMAP text model in `dir`: one camera `model` 8x6, images `names`
/// (looking down +z from z = -5), two coloured points.
fn colmap_text(dir: &Path, model: &str, names: &[&str]) {
    std::fs::create_dir_all(dir).unwrap();
    let params = if model == "PINHOLE" {
        "10 10 4 3"
    } else {
        "10 10 4 3 0.1 0 0 0"
    };
    std::fs::write(
        dir.join("cameras.txt"),
        format!("# camera list\n1 {model} 8 6 {params}\n"),
    )
    .unwrap();
    let mut images = String::from("# image list\n");
    for (i, n) in names.iter().enumerate() {
        images += &format!("{} 1 0 0 0 {} 0 5 1 {n}\n\n", i + 1, i as f64 * 0.1);
    }
    std::fs::write(dir.join("images.txt"), images).unwrap();
    std::fs::write(
        dir.join("points3D.txt"),
        "# points\n1 0.5 0.25 1 255 0 10 0.3 1 0\n2 -1 0 2 0 128 255 0.1\n",
    )
    .unwrap();
}

fn err(root: &Path, opts: &DatasetOptions) -> String {
    load_dataset(root, opts).unwrap_err().to_string()
}

#[test]
fn colmap_text_layout_with_points_and_downscale() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    colmap_text(&root.join("sparse/0"), "PINHOLE", &["a.png", "b.jpg"]);
    png(&root.join("images/a.png"), 8, 6, 3, &[255, 0, 0]);
    // b.jpg is paired by its stem: a PNG called b.png
    png(&root.join("images/b.png"), 8, 6, 3, &[0, 0, 255]);
    // more photos than cameras: the extra one is ignored
    png(&root.join("images/c.png"), 8, 6, 3, &[0, 0, 0]);
    let ds = load_dataset(root, &DatasetOptions::default()).unwrap();
    assert_eq!(ds.format, "colmap");
    assert_eq!(ds.cameras_file, root.join("sparse/0"));
    assert_eq!(ds.root, root);
    assert_eq!(ds.views.len(), 2);
    let v = &ds.views[0];
    assert_eq!((v.camera.width, v.camera.height), (8, 6));
    assert_eq!(v.image.len(), 48);
    assert_eq!(v.image[0], [1.0, 0.0, 0.0]);
    assert!(v.alpha.is_none() && v.mask.is_none());
    assert_eq!(ds.views[1].image[5], [0.0, 0.0, 1.0]);
    let pts = ds.points.unwrap();
    assert_eq!(pts.positions, vec![[0.5, 0.25, 1.0], [-1.0, 0.0, 2.0]]);
    assert_eq!(pts.colors.unwrap(), vec![[255, 0, 10], [0, 128, 255]]);

    let half = DatasetOptions {
        downscale: 2,
        ..Default::default()
    };
    let ds = load_dataset(root, &half).unwrap();
    let c = &ds.views[0].camera;
    assert_eq!((c.width, c.height, c.fx, c.cx), (4, 3, 5.0, 2.0));
    assert_eq!(ds.views[0].image.len(), 12);
    // a target width: the smallest k with 8 / k ≤ width
    for (w, k) in [(8, 1), (100, 1), (7, 2), (4, 2), (3, 3), (2, 4)] {
        let ds = load_dataset(
            root,
            &DatasetOptions {
                resolution: Some(w),
                downscale: 5, // overridden
                ..Default::default()
            },
        )
        .unwrap();
        // 3DGS's rounding (crate::model::rig): 8 / 3 = 2.67 gives 3
        let want = crate::model::rig::downscaled_size(8, 6, k).0;
        assert_eq!(ds.views[0].camera.width, want, "target {w}");
        assert!(want <= w.max(1), "target {w}");
    }
    let e = err(
        root,
        &DatasetOptions {
            resolution: Some(0),
            ..Default::default()
        },
    );
    assert!(e.contains("width of 0"), "{e}");
    let e = err(
        root,
        &DatasetOptions {
            downscale: 7,
            ..Default::default()
        },
    );
    assert!(
        e.contains("without pixels") && e.contains("\"a.png\""),
        "{e}"
    );
}

#[test]
fn masks_auto_on_off() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    colmap_text(root, "PINHOLE", &["a.png"]);
    png(&root.join("images/a.png"), 8, 6, 3, &[9, 9, 9]);
    let on = DatasetOptions {
        masks: MaskMode::On,
        ..Default::default()
    };
    let e = err(root, &on);
    assert!(
        e.contains(&root.display().to_string()) && e.contains("no mask folder"),
        "{e}"
    );
    assert!(
        load_dataset(root, &DatasetOptions::default())
            .unwrap()
            .views[0]
            .mask
            .is_none()
    );
    // object where the blue byte is non-zero
    png(&root.join("masks/a.png"), 8, 6, 3, &[0, 0, 255]);
    for (mode, has) in [
        (MaskMode::Auto, true),
        (MaskMode::On, true),
        (MaskMode::Off, false),
    ] {
        let ds = load_dataset(
            root,
            &DatasetOptions {
                masks: mode,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(ds.views[0].mask.is_some(), has, "{mode:?}");
        if has {
            assert!(ds.views[0].mask.as_ref().unwrap().iter().all(|&b| b));
        }
    }
    // a mask whose size disagrees names the mask file
    png(&root.join("masks/a.png"), 7, 6, 3, &[0, 0, 255]);
    let e = err(root, &DatasetOptions::default());
    assert!(
        e.contains("masks/a.png") && e.contains("7x6") && e.contains("8x6"),
        "{e}"
    );
}

#[test]
fn colmap_errors_name_folder_file_and_camera() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    let opts = DatasetOptions::default();
    // no camera data at all
    let e = err(root, &opts);
    assert!(e.contains("no camera data"), "{e}");
    colmap_text(root, "PINHOLE", &["a.png", "b.png"]);
    // missing images folder
    let e = err(root, &opts);
    assert!(
        e.contains("missing images folder") && e.contains("images"),
        "{e}"
    );
    // empty images folder
    std::fs::create_dir(root.join("images")).unwrap();
    let e = err(root, &opts);
    assert!(e.contains("images") && e.contains("no PNG or JPEG"), "{e}");
    // a camera without its photo (fewer photos than cameras)
    png(&root.join("images/a.png"), 8, 6, 3, &[1, 2, 3]);
    let e = err(root, &opts);
    assert!(
        e.contains("camera \"b.png\"") && e.contains("no image"),
        "{e}"
    );
    // a photo whose size disagrees with its camera: both sizes
    png(&root.join("images/b.png"), 6, 4, 3, &[1, 2, 3]);
    let e = err(root, &opts);
    assert!(
        e.contains("b.png") && e.contains("6x4") && e.contains("8x6"),
        "{e}"
    );
    png(&root.join("images/b.png"), 8, 6, 3, &[1, 2, 3]);
    assert_eq!(load_dataset(root, &opts).unwrap().views.len(), 2);
    // zero cameras
    std::fs::write(root.join("images.txt"), "# no images\n").unwrap();
    let e = err(root, &opts);
    assert!(e.contains("images.txt") && e.contains("no cameras"), "{e}");
    // only non-pinhole cameras: no usable view
    colmap_text(root, "OPENCV", &["a.png", "b.png"]);
    let e = err(root, &opts);
    assert!(
        e.contains(&root.display().to_string())
            && e.contains("no usable view")
            && e.contains("OPENCV"),
        "{e}"
    );
    // a file that is not a folder
    let e = err(&root.join("images/a.png"), &opts);
    assert!(e.contains("a.png") && e.contains("not a folder"), "{e}");
}

#[test]
fn gs_cameras_json_with_input_ply() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    let (r, t) = Camera::pose_from_c2w(DMat3::IDENTITY, DVec3::new(0.0, 0.0, -4.0));
    let cams = vec![
        Camera::pinhole("v1", 4, 4, 5.0, 5.0, 2.0, 2.0, r, t),
        Camera::pinhole("v0", 4, 4, 5.0, 5.0, 2.0, 2.0, r, t),
    ];
    write_gs_json(&root.join("cameras.json"), &cams).unwrap();
    png(&root.join("images/v0.png"), 4, 4, 3, &[10, 20, 30]);
    png(&root.join("images/v1.png"), 4, 4, 3, &[40, 50, 60]);
    let ds = load_dataset(root, &DatasetOptions::default()).unwrap();
    assert_eq!(ds.format, "3dgs cameras.json");
    assert_eq!(ds.cameras_file, root.join("cameras.json"));
    assert!(ds.points.is_none());
    // sorted by name, as 3DGS does
    assert_eq!(ds.views[0].camera.name, "v0");
    assert_eq!(to_u8(ds.views[1].image[0][0]), 40);
    let pc = PointCloud {
        positions: vec![[1.0, 2.0, 3.0]],
        colors: Some(vec![[7, 8, 9]]),
        ..Default::default()
    };
    let mut f = std::fs::File::create(root.join("input.ply")).unwrap();
    write_points(&mut f, &pc, Format::BinaryLittleEndian).unwrap();
    drop(f);
    let ds = load_dataset(root, &DatasetOptions::default()).unwrap();
    let p = ds.points.unwrap();
    assert_eq!(p.positions, pc.positions);
    assert_eq!(p.colors, pc.colors);
}

fn to_u8(v: f32) -> u8 {
    crate::io::image::to_u8(v)
}

#[test]
fn nerf_transforms_rgba_composited_with_alpha_kept() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    let frame = |p: &str, z: f64| {
        format!(
            r#"{{"file_path": "{p}", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,{z}],[0,0,0,1]]}}"#
        )
    };
    std::fs::write(
        root.join("transforms_train.json"),
        format!(
            r#"{{"camera_angle_x": 0.9, "w": 4, "h": 4, "frames": [{}, {}]}}"#,
            frame("./train/r_0", 4.0),
            frame("train/r_1.png", 5.0)
        ),
    )
    .unwrap();
    // 4x4 RGBA: red at alpha 51/255 = 0.2
    png(&root.join("train/r_0.png"), 4, 4, 4, &[255, 0, 0, 51]);
    png(&root.join("train/r_1.png"), 4, 4, 4, &[0, 255, 0, 255]);
    let white = DatasetOptions {
        background: [1.0; 3],
        ..Default::default()
    };
    let ds = load_dataset(root, &white).unwrap();
    assert_eq!(ds.format, "nerf transforms");
    assert_eq!(ds.cameras_file, root.join("transforms_train.json"));
    assert!(ds.points.is_none());
    let v = &ds.views[0];
    assert_eq!(v.camera.name, "r_0");
    let a = v.alpha.as_ref().unwrap();
    assert_eq!(a.len(), 16);
    assert!((a[3] - 0.2).abs() < 1e-6);
    // rgb·a + bg·(1 − a) = (1·0.2 + 0.8, 0.8, 0.8)
    let px = v.image[3];
    assert!(
        (px[0] - 1.0).abs() < 1e-6 && (px[1] - 0.8).abs() < 1e-6,
        "{px:?}"
    );
    assert_eq!(ds.views[1].image[0], [0.0, 1.0, 0.0]);
    assert!(
        ds.views[1]
            .alpha
            .as_ref()
            .unwrap()
            .iter()
            .all(|&a| a == 1.0)
    );
    // black background, downscale 2: alpha box-filtered too
    let ds = load_dataset(
        root,
        &DatasetOptions {
            downscale: 2,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(ds.views[0].alpha.as_ref().unwrap().len(), 4);
    assert!((ds.views[0].image[0][0] - 0.2).abs() < 1e-6);
    // masks on: this layout has none
    let e = err(
        root,
        &DatasetOptions {
            masks: MaskMode::On,
            ..Default::default()
        },
    );
    assert!(e.contains("no mask folder") && e.contains("alpha"), "{e}");
    // a frame without its photo names the camera and the file
    std::fs::remove_file(root.join("train/r_1.png")).unwrap();
    let e = err(root, &white);
    assert!(
        e.contains("camera \"r_1.png\" (frame 1)") && e.contains("does not exist"),
        "{e}"
    );
    // a missing folder
    std::fs::remove_dir_all(root.join("train")).unwrap();
    let e = err(root, &white);
    assert!(
        e.contains("missing images folder") && e.contains("train"),
        "{e}"
    );
}

#[test]
fn real_colmap_kunkun_loads_with_points() {
    let Some(root) = shared_data("colmap-kunkun-figurine") else {
        return;
    };
    let ds = load_dataset(
        &root,
        &DatasetOptions {
            downscale: 8,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(ds.format, "colmap");
    assert!(!ds.views.is_empty());
    for v in &ds.views {
        let c = &v.camera;
        assert_eq!(v.image.len(), (c.width * c.height) as usize);
        assert!(v.alpha.is_none());
    }
    let p = ds.points.expect("points3D.bin");
    assert!(p.len() > 100, "{} points", p.len());
    assert_eq!(p.colors.as_ref().unwrap().len(), p.len());
}

#[test]
fn real_nerf_lego_loads_with_alpha() {
    let Some(root) = shared_data("nerf-synthetic-lego-subset") else {
        return;
    };
    // the subset has 10 of the 100 photos the JSON lists: a camera without
    // its photo is named
    let e = err(&root, &DatasetOptions::default());
    assert!(
        e.contains("no image for camera") && e.contains("does not exist"),
        "{e}"
    );
    // the 10 present ones, through a copy of the JSON with only their frames
    let d = tempfile::tempdir().unwrap();
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(root.join("transforms_train.json")).unwrap())
            .unwrap();
    let mut sub = json.clone();
    let frames: Vec<serde_json::Value> = json["frames"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| {
            let p = f["file_path"].as_str().unwrap();
            root.join(format!("{p}.png")).is_file()
        })
        .map(|f| {
            let mut f = f.clone();
            let p = f["file_path"].as_str().unwrap().trim_start_matches("./");
            f["file_path"] = root.join(p).display().to_string().into();
            f
        })
        .collect();
    assert_eq!(frames.len(), 10);
    sub["frames"] = frames.into();
    std::fs::write(
        d.path().join("transforms_train.json"),
        serde_json::to_vec(&sub).unwrap(),
    )
    .unwrap();
    let ds = load_dataset(
        d.path(),
        &DatasetOptions {
            resolution: Some(200),
            background: [1.0; 3],
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(ds.format, "nerf transforms");
    assert_eq!(ds.views.len(), 10);
    let v = &ds.views[0];
    assert_eq!((v.camera.width, v.camera.height), (200, 200));
    let a = v.alpha.as_ref().expect("RGBA photos keep their alpha");
    assert!(a.contains(&0.0) && a.iter().any(|&x| x > 0.99));
    // the transparent corner is the white background
    assert!(v.image[0].iter().all(|&c| (c - 1.0).abs() < 1e-6));
}

#[test]
fn real_dtu_loads_49_views_with_masks() {
    let Some(root) = shared_data("dtu-scan24-neus") else {
        return;
    };
    let ds = load_dataset(
        &root,
        &DatasetOptions {
            downscale: 4,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(ds.format, "dtu npz");
    assert_eq!(ds.cameras_file, root.join("cameras_sphere.npz"));
    assert!(ds.points.is_none());
    assert_eq!(ds.views.len(), 49);
    for v in &ds.views {
        assert_eq!((v.camera.width, v.camera.height), (400, 300));
        let m = v.mask.as_ref().expect("masks on in Auto mode");
        assert_eq!(m.len(), 400 * 300);
        assert!(m.iter().any(|&b| b) && m.iter().any(|&b| !b));
        // image_full holds 3 of the 49 photos: image_half serves
        assert!(v.source.contains("image_half"), "{}", v.source);
    }
    // normalised frame: the cameras look at the unit sphere from outside it
    let c = &ds.views[0].camera;
    assert!(c.center().length() > 1.0 && c.center().length() < 10.0);
    // odd downscale on half-size photos
    let e = err(
        &root,
        &DatasetOptions {
            downscale: 3,
            ..Default::default()
        },
    );
    assert!(e.contains("odd") && e.contains("image_half"), "{e}");
}

/// A NeuS-layout folder: `cameras_sphere.npz` with two cameras (fx = fy =
/// 10, principal point (4, 3) in Camera pixels, looking down +z from z = -5),
/// 8x6 masks in `mask/`, 4x3 photos in `image_half/`.
fn dtu_folder(root: &Path) {
    use std::io::Write;
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let o = zip::write::SimpleFileOptions::default();
    let id = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ];
    for (i, tx) in [(0, 0.0), (1, 1.0)] {
        // K [I | t], t = (tx, 0, 5); NeuS pixel centres are integers: cx = 3.5
        let p = [
            10.0,
            0.0,
            3.5,
            10.0 * tx + 3.5 * 5.0,
            0.0,
            10.0,
            2.5,
            2.5 * 5.0,
            0.0,
            0.0,
            1.0,
            5.0,
            0.0,
            0.0,
            0.0,
            1.0,
        ];
        for (n, m) in [("world_mat", &p), ("scale_mat", &id)] {
            w.start_file(format!("{n}_{i}.npy"), o).unwrap();
            w.write_all(&crate::io::cameras::npz::encode_npy_f64(&[4, 4], m))
                .unwrap();
        }
    }
    let bytes = w.finish().unwrap().into_inner();
    std::fs::write(root.join("cameras_sphere.npz"), bytes).unwrap();
    for i in 0..2 {
        png(&root.join(format!("mask/{i:03}.png")), 8, 6, 3, &[255; 3]);
        png(
            &root.join(format!("image_half/{i:06}.png")),
            4,
            3,
            3,
            &[60, 120, 180],
        );
    }
}

#[test]
fn dtu_layout_half_size_photos_and_folder_choice() {
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    dtu_folder(root);
    let with = |downscale: u32, resolution: Option<u32>| DatasetOptions {
        downscale,
        resolution,
        ..Default::default()
    };
    let ds = load_dataset(root, &with(1, None)).unwrap();
    assert_eq!(ds.format, "dtu npz");
    assert_eq!(ds.cameras_file, root.join("cameras_sphere.npz"));
    assert!(ds.points.is_none());
    assert_eq!(ds.views.len(), 2);
    // downscale 1 = the half-size photos as stored: cameras halved
    let v = &ds.views[1];
    assert_eq!(v.camera.name, "001");
    assert_eq!(
        (v.camera.width, v.camera.height, v.camera.fx, v.camera.cx),
        (4, 3, 5.0, 2.0)
    );
    assert!(v.source.ends_with("000001.png"), "{}", v.source);
    assert_eq!(v.mask.as_ref().unwrap().len(), 12);
    assert_eq!(to_u8(v.image[0][2]), 180);
    // even downscales only; a target width picks the smallest even k
    for (opts, w) in [
        (with(2, None), 4),
        (with(4, None), 2),
        (with(1, Some(4)), 4),
        (with(1, Some(3)), 2),
        (with(1, Some(100)), 4),
    ] {
        let ds = load_dataset(root, &opts).unwrap();
        assert_eq!(ds.views[0].camera.width, w, "{opts:?}");
        assert_eq!(
            ds.views[0].image.len(),
            ds.views[0].mask.as_ref().unwrap().len()
        );
    }
    let e = err(root, &with(3, None));
    assert!(e.contains("odd") && e.contains("image_half"), "{e}");
    // an incomplete full-size folder is passed over; a complete one wins
    png(&root.join("image/000000.png"), 8, 6, 3, &[1, 1, 1]);
    let ds = load_dataset(root, &with(1, None)).unwrap();
    assert_eq!(ds.views[0].camera.width, 4);
    png(&root.join("image/000001.png"), 8, 6, 3, &[1, 1, 1]);
    let ds = load_dataset(root, &with(1, None)).unwrap();
    assert_eq!(ds.views[0].camera.width, 8);
    assert!(
        ds.views[0].source.contains("image/"),
        "{}",
        ds.views[0].source
    );
    // no complete folder: the preferred one's missing camera is named
    std::fs::remove_dir_all(root.join("image_half")).unwrap();
    std::fs::remove_file(root.join("image/000001.png")).unwrap();
    let e = err(root, &with(1, None));
    assert!(
        e.contains("camera \"001\"") && e.contains("image_half") && e.contains("every camera"),
        "{e}"
    );
    std::fs::remove_dir_all(root.join("image")).unwrap();
    let e = err(root, &with(1, None));
    assert!(e.contains("missing images folder"), "{e}");
    // masks off
    dtu_folder(root);
    let ds = load_dataset(
        root,
        &DatasetOptions {
            masks: MaskMode::Off,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(ds.views[0].mask.is_none());
}

#[test]
fn load_views_without_background_drops_alpha() {
    let d = tempfile::tempdir().unwrap();
    let (r, t) = Camera::pose_from_c2w(DMat3::IDENTITY, DVec3::new(0.0, 0.0, -4.0));
    let cams = vec![Camera::pinhole("a", 2, 2, 5.0, 5.0, 1.0, 1.0, r, t)];
    png(&d.path().join("a.png"), 2, 2, 4, &[255, 0, 0, 0]);
    let v = crate::io::views::load_views(
        &cams,
        d.path(),
        &ViewOptions {
            downscale: 1,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(v[0].alpha.is_none());
    assert_eq!(v[0].image[0], [1.0, 0.0, 0.0]);
}

/// [`views_bytes`] covers the views a load holds (image, mask and alpha at
/// their real element sizes) at every downscale; two 16384² cameras need
/// more than 9 GiB (the CLI test `budget::image_buffers_beyond_the_budget`
/// checks the refusal).
#[test]
fn photo_memory_is_estimated_before_decoding() {
    use std::mem::size_of;
    let d = tempfile::tempdir().unwrap();
    let root = d.path();
    colmap_text(&root.join("sparse/0"), "PINHOLE", &["a.png", "b.png"]);
    png(&root.join("images/a.png"), 8, 6, 4, &[255, 0, 0, 128]);
    png(&root.join("images/b.png"), 8, 6, 4, &[0, 0, 255, 255]);
    for k in [1u32, 2] {
        let ds = load_dataset(
            root,
            &DatasetOptions {
                downscale: k,
                ..Default::default()
            },
        )
        .unwrap();
        let held: usize = ds
            .views
            .iter()
            .map(|v| {
                v.image.len() * size_of::<[f32; 3]>()
                    + v.mask.as_ref().map_or(0, |m| m.len() * size_of::<bool>())
                    + v.alpha.as_ref().map_or(0, |a| a.len() * size_of::<f32>())
            })
            .sum();
        assert!(ds.views[0].alpha.is_some());
        let cams: Vec<Camera> = read_cameras(&root.join("sparse/0")).unwrap();
        assert!(views_bytes(&cams, k, 1, 0) >= held as u64, "k = {k}");
    }
    // 16384² declared: 2 × 2^28 × 17 bytes held, beyond a 24 GiB machine too
    let big = Camera::pinhole(
        "a.png",
        16384,
        16384,
        1e4,
        1e4,
        8192.0,
        8192.0,
        DMat3::IDENTITY,
        DVec3::ZERO,
    );
    assert!(views_bytes(&[big.clone(), big], 1, 2, 0) > 9 << 30);
    assert_eq!(views_bytes(&[], 1, 4, 100), 0);
}
