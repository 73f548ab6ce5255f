//! TSDF fusion: Open3D's rules one by one on hand-checked cases, then
//! analytic scenes (a plane, a sphere seen from all around) with exact depth
//! maps.

use glam::{DMat3, DVec3};

use super::*;
use crate::geom::mesh_ops::clean::signed_volume;
use crate::model::{Camera, Mesh};

/// A camera at `centre` with identity rotation (looking down +z).
fn axis_camera(w: u32, h: u32, f: f64, centre: DVec3) -> Camera {
    Camera::pinhole(
        "cam",
        w,
        h,
        f,
        f,
        w as f64 / 2.0,
        h as f64 / 2.0,
        DMat3::IDENTITY,
        -centre,
    )
}

fn params(voxel: f64, trunc: f64) -> TsdfParams {
    TsdfParams::new(voxel, trunc, 100.0)
}

fn sorted_keys(v: &TsdfVolume) -> Vec<[i32; 3]> {
    let mut k = v.keys().to_vec();
    k.sort_unstable();
    k
}

/// Voxel (x, y, z) of block `key`: (tsdf, weight).
fn voxel(v: &TsdfVolume, key: [i32; 3], x: usize, y: usize, z: usize) -> (f32, f32) {
    let b = v.block(key).expect("block exists");
    let i = (x * 16 + y) * 16 + z;
    (b.tsdf[i], b.weight[i])
}

/// Allocation samples rows and columns 0, 4, 8, …: a depth only at pixel
/// (1, 1) allocates nothing, one at (4, 4) allocates the blocks of the
/// ±sdf_trunc box around its point. Camera: 16×16, f = 16, Open3D cx = 7.5;
/// pixel (4, 4) at depth 0.96 is the point (−0.21, −0.21, 0.96); with
/// sdf_trunc 0.03 and blocks of 0.16 its box spans z blocks 5 (0.93/0.16 =
/// 5.8) and 6 (0.99/0.16 = 6.2) and x, y block −2 only.
#[test]
fn allocation_samples_every_fourth_pixel_within_the_truncation_box() {
    let cam = axis_camera(16, 16, 16.0, DVec3::ZERO);
    let mut d = vec![0.0f32; 256];
    d[16 + 1] = 0.96;
    let mut v = TsdfVolume::new(params(0.01, 0.03), false).unwrap();
    let s = v
        .integrate(&Frame {
            camera: &cam,
            depth: &d,
            color: None,
        })
        .unwrap();
    assert_eq!((s.touched, s.valid_pixels, v.len()), (0, 1, 0));
    d[16 + 1] = 0.0;
    d[4 * 16 + 4] = 0.96;
    let s = v
        .integrate(&Frame {
            camera: &cam,
            depth: &d,
            color: None,
        })
        .unwrap();
    assert_eq!((s.touched, s.created), (2, 2));
    assert_eq!(sorted_keys(&v), vec![[-2, -2, 5], [-2, -2, 6]]);
    // the same pixel with stride 1 and with stride 4 is the same; pixel
    // (1, 1) is sampled with stride 1
    let mut p1 = params(0.01, 0.03);
    p1.stride = 1;
    let mut v1 = TsdfVolume::new(p1, false).unwrap();
    let mut d1 = vec![0.0f32; 256];
    d1[16 + 1] = 0.96;
    v1.integrate(&Frame {
        camera: &cam,
        depth: &d1,
        color: None,
    })
    .unwrap();
    assert_eq!(v1.len(), 2);
}

/// The strict `sdf > −sdf_trunc` test, free-space updates and the ray
/// factor, with values exact in binary: voxel 0.5, sdf_trunc 0.25, a 9×9
/// camera (f = 2, Open3D cx = cy = 4) centred at (0.25, 0.25, 0) so that the
/// voxel column x = y = 0 of block (0, 0, 0) lies on the optical axis
/// (factor exactly 1), and a flat depth of 1.
#[test]
fn truncation_is_strict_and_free_space_is_carved() {
    let cam = axis_camera(9, 9, 2.0, DVec3::new(0.25, 0.25, 0.0));
    let d = vec![1.0f32; 81];
    let mut v = TsdfVolume::new(TsdfParams::new(0.5, 0.25, 100.0), false).unwrap();
    v.integrate(&Frame {
        camera: &cam,
        depth: &d,
        color: None,
    })
    .unwrap();
    let k = [0, 0, 0];
    // centre z 0.25: sdf 0.75 → clamped to 1 (free space is updated)
    assert_eq!(voxel(&v, k, 0, 0, 0), (1.0, 1.0));
    // centre z 0.75: sdf 0.25 → 1
    assert_eq!(voxel(&v, k, 0, 0, 1), (1.0, 1.0));
    // centre z 1.25: sdf exactly −0.25 = −sdf_trunc → not integrated
    assert_eq!(voxel(&v, k, 0, 0, 2), (0.0, 0.0));
    assert_eq!(voxel(&v, k, 0, 0, 3), (0.0, 0.0));
    // a second frame at depth 0.9: running mean of 1 and 0.6
    let d2 = vec![0.9f32; 81];
    v.integrate(&Frame {
        camera: &cam,
        depth: &d2,
        color: None,
    })
    .unwrap();
    let want = (1.0f32 + (0.9f32 - 0.75) * (1.0 / 0.25f32)) / 2.0;
    let (t, w) = voxel(&v, k, 0, 0, 1);
    assert_eq!(w, 2.0);
    assert!((t - want).abs() < 1e-6, "{t} vs {want}");
    // the neighbouring column x = 1 (centre x 0.75, camera x 0.5) projects
    // at 0.5·2/0.75 + 4 + 0.5 = 5.83 → pixel 5, factor √(1 + (1/2)²)
    let mut v = TsdfVolume::new(TsdfParams::new(0.5, 0.25, 100.0), false).unwrap();
    v.integrate(&Frame {
        camera: &cam,
        depth: &d2,
        color: None,
    })
    .unwrap();
    let want = ((0.9f32 - 0.75) * 1.25f32.sqrt() * 4.0).min(1.0);
    let (t, w) = voxel(&v, k, 1, 0, 1);
    assert_eq!(w, 1.0);
    assert!((t - want).abs() < 1e-6, "{t} vs {want}");
}

/// The voxel reads the pixel (int)(u + 0.5): with stride-1 allocation and
/// depth only in pixel column 5, the column x = 1 voxel (u + 0.5 = 5.83) is
/// updated and the x = 0 voxel (u + 0.5 = 4.5, pixel 4) is not.
#[test]
fn voxels_read_the_nearest_pixel() {
    let cam = axis_camera(9, 9, 2.0, DVec3::new(0.25, 0.25, 0.0));
    let mut d = vec![0.0f32; 81];
    for i in 0..9 {
        d[i * 9 + 5] = 0.9;
    }
    let mut p = TsdfParams::new(0.5, 0.25, 100.0);
    p.stride = 1;
    let mut v = TsdfVolume::new(p, false).unwrap();
    v.integrate(&Frame {
        camera: &cam,
        depth: &d,
        color: None,
    })
    .unwrap();
    assert_eq!(voxel(&v, [0, 0, 0], 1, 0, 1).1, 1.0);
    assert_eq!(voxel(&v, [0, 0, 0], 0, 0, 1).1, 0.0);
}

/// Depths at or beyond depth_trunc, NaN, infinite and negative depths are
/// missing; sizes that are not the camera's are errors that leave the
/// volume as it was; the block limit is checked before allocating.
#[test]
fn bad_frames_are_errors_or_missing() {
    let cam = axis_camera(16, 16, 16.0, DVec3::ZERO);
    let mut v = TsdfVolume::new(TsdfParams::new(0.01, 0.03, 2.0), true).unwrap();
    let mut d = vec![0.0f32; 256];
    for (k, x) in [2.0, 5.0, f32::NAN, f32::INFINITY, -1.0].iter().enumerate() {
        d[k * 3 * 16] = *x;
    }
    let rgb = vec![[10u8; 3]; 256];
    let s = v
        .integrate(&Frame {
            camera: &cam,
            depth: &d,
            color: Some(&rgb),
        })
        .unwrap();
    assert_eq!((s.valid_pixels, s.touched, v.len()), (0, 0, 0));
    let short = vec![1.0f32; 255];
    let e = v.integrate(&Frame {
        camera: &cam,
        depth: &short,
        color: Some(&rgb),
    });
    assert!(e.unwrap_err().to_string().contains("255 values"));
    let ok = vec![1.0f32; 256];
    assert!(
        v.integrate(&Frame {
            camera: &cam,
            depth: &ok,
            color: None,
        })
        .is_err(),
        "colour volume without colour"
    );
    let mut p = TsdfParams::new(0.01, 0.03, 2.0);
    p.max_blocks = 3;
    let mut small = TsdfVolume::new(p, false).unwrap();
    let e = small.integrate(&Frame {
        camera: &cam,
        depth: &ok,
        color: None,
    });
    assert!(e.unwrap_err().to_string().contains("over the limit of 3"));
    assert!(small.is_empty());
    assert!(TsdfVolume::new(TsdfParams::new(0.0, 0.03, 2.0), false).is_err());
    assert!(TsdfVolume::new(TsdfParams::new(0.01, f64::NAN, 2.0), false).is_err());
}

/// Face normals (right hand) of a mesh.
fn face_normals(m: &Mesh) -> Vec<DVec3> {
    m.faces
        .iter()
        .map(|f| {
            let p = f.map(|i| DVec3::from(m.vertices[i as usize].map(f64::from)));
            (p[1] - p[0]).cross(p[2] - p[0])
        })
        .collect()
}

/// A plane tsdf = z_centre − c in one block of voxel 0.1 (inside below):
/// the cubes whose corners are all in the block (15 × 15 per layer) give
/// 450 triangles on 16 × 16 vertices, each at ((x, y) + 0.5)·voxel and
/// z = c exactly (linear interpolation of a linear function), normals +z
/// (toward positive tsdf), colour interpolated as (f1·c0 + f0·c1)/(f0+f1).
#[test]
fn plane_cubes_vertices_offset_and_winding() {
    let c = 0.73f64;
    let plane = |g: [i32; 3]| {
        let z = (g[2] as f64 + 0.5) * 0.1;
        Some(((z - c) as f32, [g[2] as f32 * 10.0, 0.0, 0.0]))
    };
    let v = TsdfVolume::from_fn(params(0.1, 0.3), &[[0, 0, 0]], plane);
    let m = extract_mesh(&v);
    assert_eq!((m.vertices.len(), m.faces.len()), (256, 450));
    for (k, p) in m.vertices.iter().enumerate() {
        assert!((p[2] as f64 - c).abs() < 1e-6, "{p:?}");
        // sorted (x, y) order: vertex k is column (k / 16, k % 16)
        let (x, y) = ((k / 16) as f64, (k % 16) as f64);
        assert!((p[0] as f64 - (x + 0.5) * 0.1).abs() < 1e-6);
        assert!((p[1] as f64 - (y + 0.5) * 0.1).abs() < 1e-6);
    }
    assert!(
        face_normals(&m)
            .iter()
            .all(|n| n.z > 0.0 && n.x.abs() < 1e-9)
    );
    // voxels 6 (z 0.65, red 60) and 7 (z 0.75, red 70): 0.8·70 + 0.2·60
    let rgb = m.vertex_colors.as_ref().unwrap();
    assert!(rgb.iter().all(|c| *c == [68, 0, 0, 255]), "{:?}", rgb[0]);

    // a corner of weight 0 skips the 4 crossing cubes around it (8 faces)
    // and the vertex on its edge, which only those cubes hold
    let hole = |g: [i32; 3]| if g == [5, 5, 7] { None } else { plane(g) };
    let m = extract_mesh(&TsdfVolume::from_fn(params(0.1, 0.3), &[[0, 0, 0]], hole));
    assert_eq!((m.vertices.len(), m.faces.len()), (255, 442));

    // the +x neighbour block makes the cubes at x = 15 complete: 31 × 15
    let m = extract_mesh(&TsdfVolume::from_fn(
        params(0.1, 0.3),
        &[[0, 0, 0], [1, 0, 0]],
        plane,
    ));
    assert_eq!((m.vertices.len(), m.faces.len()), (32 * 16, 31 * 15 * 2));

    // tsdf exactly 0 counts as outside: the surface sits on the voxel centre
    let on = |g: [i32; 3]| Some((((g[2] as f64 + 0.5) * 0.1 - 0.75) as f32, [0.0; 3]));
    let m = extract_mesh(&TsdfVolume::from_fn(params(0.1, 0.3), &[[0, 0, 0]], on));
    assert_eq!(m.faces.len(), 450);
    assert!(m.vertices.iter().all(|p| (p[2] - 0.75).abs() < 1e-6));
}

/// Exact z-depth of the first hit of each pixel's ray with a sphere at the
/// origin (0 where it misses).
fn sphere_depth(cam: &Camera, r: f64) -> Vec<f32> {
    sphere_in_room_depth(cam, r, None)
}

/// [`sphere_depth`], and where the ray misses the sphere, the depth of the
/// inside of a concentric `room` sphere around the cameras (an unbounded
/// scene has something behind every pixel).
fn sphere_in_room_depth(cam: &Camera, r: f64, room: Option<f64>) -> Vec<f32> {
    let (w, h) = (cam.width as usize, cam.height as usize);
    let o = cam.center();
    let rt = cam.rotation.transpose();
    let mut out = vec![0.0f32; w * h];
    for i in 0..h {
        for j in 0..w {
            let dc = DVec3::new(
                (j as f64 + 0.5 - cam.cx) / cam.fx,
                (i as f64 + 0.5 - cam.cy) / cam.fy,
                1.0,
            );
            let d = rt * dc; // z-depth t: point o + t·d
            let (a, b, c) = (d.dot(d), 2.0 * o.dot(d), o.dot(o) - r * r);
            let disc = b * b - 4.0 * a * c;
            if disc >= 0.0 {
                let t = (-b - disc.sqrt()) / (2.0 * a);
                if t > 0.0 {
                    out[i * w + j] = t as f32;
                    continue;
                }
            }
            if let Some(big) = room {
                let c = o.dot(o) - big * big; // < 0: the camera is inside
                let t = (-b + (b * b - 4.0 * a * c).sqrt()) / (2.0 * a);
                out[i * w + j] = t as f32;
            }
        }
    }
    out
}

/// Cameras at distance `dist` on a Fibonacci sphere, looking at the origin.
fn ring(n: usize, dist: f64, size: u32, f: f64) -> Vec<Camera> {
    crate::testing::cameras_around(n, dist, size, f)
}

/// A sphere of radius 0.8 seen by 24 cameras all around, exact depth maps,
/// voxel 0.025: vertices within 0.1 voxel of the sphere on average, closed
/// (every edge shared by exactly two faces), normals outward (positive
/// volume, within 2 % of 4/3·π·r³); the same mesh for 1 and 2 threads.
#[test]
fn sphere_from_all_around_is_closed_and_on_the_surface() {
    let r = 0.8;
    let voxel = 0.025;
    let cams = ring(24, 3.0, 192, 180.0);
    let fuse = || {
        let mut v = TsdfVolume::new(TsdfParams::new(voxel, 4.0 * voxel, 10.0), true).unwrap();
        for c in &cams {
            let d = sphere_depth(c, r);
            let rgb = vec![[200u8, 100, 50]; d.len()];
            v.integrate(&Frame {
                camera: c,
                depth: &d,
                color: Some(&rgb),
            })
            .unwrap();
        }
        extract_mesh(&v)
    };
    let m = fuse();
    assert!(m.faces.len() > 5000, "{} faces", m.faces.len());
    let err: f64 = m
        .vertices
        .iter()
        .map(|p| (DVec3::from(p.map(f64::from)).length() - r).abs())
        .sum::<f64>()
        / m.vertices.len() as f64;
    assert!(
        err < 0.1 * voxel,
        "mean distance {err} ({} voxel)",
        err / voxel
    );
    let mut edges = rustc_hash::FxHashMap::default();
    for f in &m.faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_insert(0usize) += 1;
        }
    }
    assert!(
        edges.values().all(|&c| c == 2),
        "open or non-manifold edges"
    );
    let vol = signed_volume(&m);
    let want = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
    assert!((vol - want).abs() < 0.02 * want, "volume {vol} vs {want}");
    assert!(
        m.vertex_colors
            .as_ref()
            .unwrap()
            .iter()
            .all(|c| *c == [200, 100, 50, 255])
    );
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(fuse);
    assert_eq!(one.vertices, m.vertices);
    assert_eq!(one.faces, m.faces);
}

/// A fronto-parallel plane at z = 2 filling the view of one camera: the
/// fused surface lies on z = 2 (to f32 rounding) and faces the camera.
#[test]
fn plane_seen_by_one_camera_faces_it() {
    let cam = axis_camera(64, 48, 60.0, DVec3::ZERO);
    let d = vec![2.0f32; 64 * 48];
    let mut v = TsdfVolume::new(TsdfParams::new(0.01, 0.04, 10.0), false).unwrap();
    v.integrate(&Frame {
        camera: &cam,
        depth: &d,
        color: None,
    })
    .unwrap();
    let m = extract_mesh(&v);
    assert!(m.faces.len() > 1000);
    assert!(
        m.vertices.iter().all(|p| (p[2] - 2.0).abs() < 1e-4),
        "off the plane"
    );
    assert!(
        face_normals(&m).iter().all(|n| n.z < 0.0),
        "not facing the camera"
    );
    assert!(m.vertex_colors.is_none());
}

/// contract and uncontract invert each other below ‖y‖ = 2; the box bound
/// is numpy's linear 0.95-quantile of the contracted radii + 0.01, capped
/// at 1.9.
#[test]
fn contraction_and_bound() {
    use super::unbounded::{contract, samples_per_axis, uncontract};
    for p in [
        DVec3::new(0.3, -0.2, 0.1),
        DVec3::new(3.0, 1.0, -2.0),
        DVec3::new(-40.0, 5.0, 0.5),
    ] {
        let y = contract(p);
        assert!(y.length() < 2.0);
        assert!(
            (uncontract(y) - p).length() < 1e-9 * p.length().max(1.0),
            "{p:?}"
        );
    }
    // radii 0.0, 0.1, …, 1.9 (20 values, all below 1 stay): q95 at h = 18.05
    let pts: Vec<[f32; 3]> = (0..20).map(|i| [i as f32 * 0.05, 0.0, 0.0]).collect();
    let b = bound_from_points(&pts, DVec3::ZERO, 1.0);
    let want = 0.9 + 0.05 * 0.05 + 0.01; // r[18] = 0.9, r[19] = 0.95
    assert!((b - want).abs() < 1e-6, "{b} vs {want}");
    assert_eq!(bound_from_points(&[[1e6, 0.0, 0.0]], DVec3::ZERO, 1.0), 1.9);
    assert_eq!(samples_per_axis(1024), 1023);
    assert_eq!(samples_per_axis(512), 512);
    assert_eq!(samples_per_axis(96), 96);
}

/// The unbounded variant on the sphere of radius 0.8 seen from 24 cameras
/// at distance 3 (normalised by the cameras' sphere: centre 0, radius 3)
/// inside a room sphere of radius 12 (without a background every sample
/// whose rays all miss the sphere would keep its initial −1 and close the
/// box with walls, as 2DGS's fusion would), 384² pixels at focal 180,
/// resolution 128 over the box R = 0.3: closed and outward, and on the
/// sphere within what 2DGS's rules allow:
/// - outward: every sample starts at −1 with weight 1, so the zero crossing
///   sits where the views' observations sum to 1, outside the sphere by
///   trunc / Σ 1/cos θᵢ ≤ trunc / n over the n views that see the point
///   (trunc = 5·voxel = 5·6/128); every point of the sphere is seen by at
///   least 6 of the 24 cameras, so at most trunc/6;
/// - inward: depth is sampled bilinearly (`grid_sample`), so within a pixel
///   of a view's silhouette the sphere's depth is blended with the room's
///   and a point up to one pixel footprint behind the rim reads as free
///   space; the rim is 2.89 from the camera, a footprint of 2.89/180.
///
/// The mean stays within half a footprint inward.
#[test]
fn unbounded_sphere_is_closed_and_on_the_surface() {
    let r = 0.8;
    let cams = ring(24, 3.0, 384, 180.0);
    let maps: Vec<Vec<f32>> = cams
        .iter()
        .map(|c| sphere_in_room_depth(c, r, Some(12.0)))
        .collect();
    let views: Vec<UnboundedView> = cams
        .iter()
        .zip(&maps)
        .map(|(c, d)| UnboundedView {
            camera: c,
            depth: d,
            rgb: None,
        })
        .collect();
    let s = camera_sphere(&cams).unwrap();
    assert!(s.center.length() < 1e-9 && (s.radius - 3.0).abs() < 1e-9);
    let p = UnboundedParams {
        center: s.center,
        radius: s.radius,
        resolution: 128,
        bound: 0.3,
        max_range: 32.0,
    };
    let m = fuse_unbounded(&views, &p).unwrap();
    let step = 0.6 * 3.0 / 127.0;
    let trunc = 5.0 * 6.0 / 128.0;
    assert!(m.faces.len() > 2000, "{} faces", m.faces.len());
    let ds: Vec<f64> = m
        .vertices
        .iter()
        .map(|v| DVec3::from(v.map(f64::from)).length() - r)
        .collect();
    let (lo, hi) = ds
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &d| (a.min(d), b.max(d)));
    let mean = ds.iter().sum::<f64>() / ds.len() as f64;
    eprintln!(
        "unbounded sphere: {} vertices, distance min {:.3} / mean {:.3} / max {:.3} grid steps, trunc/6 = {:.3}",
        ds.len(),
        lo / step,
        mean / step,
        hi / step,
        trunc / 6.0 / step
    );
    let footprint = (3.0f64 * 3.0 - r * r).sqrt() / 180.0;
    for (v, d) in m.vertices.iter().zip(&ds) {
        assert!(
            *d > -footprint && *d < trunc / 6.0,
            "vertex {v:?} at {d} from the sphere"
        );
    }
    assert!(mean > -0.5 * footprint && mean < trunc / 6.0, "mean {mean}");
    let mut edges = rustc_hash::FxHashMap::default();
    for f in &m.faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_insert(0usize) += 1;
        }
    }
    assert!(
        edges.values().all(|&c| c == 2),
        "open or non-manifold edges"
    );
    assert!(signed_volume(&m) > 0.0, "normals point inward");
}

/// Fusing frames in batches gives exactly the volume of fusing them one by
/// one (per voxel the updates come in the same order), including the
/// blocks created, for batches that do not divide the frame count; and a
/// bad frame anywhere in a batch leaves the volume as it was.
#[test]
fn batches_fuse_exactly_like_single_frames() {
    let cams = ring(11, 3.0, 96, 90.0);
    let maps: Vec<Vec<f32>> = cams.iter().map(|c| sphere_depth(c, 0.8)).collect();
    let rgb: Vec<Vec<[u8; 3]>> = maps
        .iter()
        .enumerate()
        .map(|(k, d)| vec![[k as u8 * 20, 100, 50]; d.len()])
        .collect();
    let frames: Vec<Frame> = cams
        .iter()
        .zip(&maps)
        .zip(&rgb)
        .map(|((c, d), rgb)| Frame {
            camera: c,
            depth: d,
            color: Some(rgb),
        })
        .collect();
    let params = TsdfParams::new(0.05, 0.2, 10.0);
    let mut one = TsdfVolume::new(params, true).unwrap();
    let mut stats_one = Vec::new();
    for f in &frames {
        stats_one.push(one.integrate(f).unwrap());
    }
    let mut batched = TsdfVolume::new(params, true).unwrap();
    let mut stats_b = Vec::new();
    for chunk in frames.chunks(4) {
        stats_b.extend(batched.integrate_batch(chunk).unwrap());
    }
    assert_eq!(stats_one, stats_b);
    assert_eq!(one.len(), batched.len());
    let (a, b) = (extract_mesh(&one), extract_mesh(&batched));
    assert!(a.faces.len() > 500);
    assert_eq!(a.vertices, b.vertices);
    assert_eq!(a.faces, b.faces);
    assert_eq!(a.vertex_colors, b.vertex_colors);
    // a frame of the wrong size in the middle of a batch: nothing fused
    let short = vec![1.0f32; 10];
    let mut bad = frames[..3].to_vec();
    bad[1].depth = &short;
    let mut v = TsdfVolume::new(params, true).unwrap();
    assert!(v.integrate_batch(&bad).is_err());
    assert_eq!(v.len(), 0);
}

/// The block bounds hold on real frames: one usable pixel creates between
/// `per_sample_min` and `per_sample_max` blocks; random depths from three
/// tilted cameras (up to depth_trunc) create at most `upper` blocks; a
/// truncation billions of blocks wide saturates, and integration refuses
/// it at the limit instead of walking it.
#[test]
fn block_bounds_hold() {
    use crate::model::rng::seeded;
    use rand::RngExt;
    for (voxel, trunc) in [(0.01, 0.03), (0.02, 0.5), (0.05, 0.01)] {
        let mut p = TsdfParams::new(voxel, trunc, 3.0);
        p.stride = 1;
        let cam = axis_camera(16, 12, 14.0, DVec3::new(0.1, -0.2, -1.0));
        // one usable pixel
        let mut one = vec![0.0f32; 16 * 12];
        one[5 * 16 + 7] = 1.37;
        let mut v = TsdfVolume::new(p, false).unwrap();
        v.integrate(&Frame {
            camera: &cam,
            depth: &one,
            color: None,
        })
        .unwrap();
        let b = p.block_bounds(std::slice::from_ref(&cam));
        let n = v.len() as u64;
        assert!(
            b.per_sample_min <= n && n <= b.per_sample_max,
            "{voxel} {trunc}: {n} vs {b:?}"
        );
        // random depths from three tilted cameras, many more blocks
        let mut rng = seeded(7);
        let cams: Vec<Camera> = (0..3)
            .map(|k| {
                let a = 0.4 * k as f64;
                let rot = DMat3::from_rotation_y(a) * DMat3::from_rotation_x(0.2 * a);
                Camera::pinhole(
                    "c",
                    24,
                    20,
                    20.0,
                    22.0,
                    11.0,
                    9.0,
                    rot,
                    DVec3::new(0.3 * k as f64, 0.1, 0.5),
                )
            })
            .collect();
        let mut v = TsdfVolume::new(p, false).unwrap();
        for c in &cams {
            let d: Vec<f32> = (0..24 * 20)
                .map(|_| rng.random_range(0.01f32..2.999))
                .collect();
            v.integrate(&Frame {
                camera: c,
                depth: &d,
                color: None,
            })
            .unwrap();
        }
        let b = p.block_bounds(&cams);
        assert!(
            (v.len() as u64) <= b.upper,
            "{voxel} {trunc}: {} blocks, bound {b:?}",
            v.len()
        );
        assert!(b.upper < 50 * v.len() as u64, "{b:?} vs {}", v.len());
    }
    let mut p = TsdfParams::new(0.01, 1e30, 3.0);
    assert_eq!(p.sample_blocks(), (u64::MAX, u64::MAX));
    p.max_blocks = 1000;
    let cam = axis_camera(16, 12, 14.0, DVec3::ZERO);
    let mut v = TsdfVolume::new(p, false).unwrap();
    let e = v
        .integrate(&Frame {
            camera: &cam,
            depth: &[1.0; 16 * 12],
            color: None,
        })
        .unwrap_err();
    assert!(e.to_string().contains("over the limit of 1000"), "{e}");
    assert!(v.is_empty());
}
