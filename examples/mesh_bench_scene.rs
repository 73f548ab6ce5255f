//! Generated scenes with exact ground truth for `scripts/mesh_bench.mk` and
//! the `tetra-mesh` scale benchmark.
//!
//! ```text
//! mesh_bench_scene photos SHAPE OUT [VIEWS=40] [SIZE=128]
//! mesh_bench_scene flat SHAPE GAUSSIANS OUT [VIEWS=24] [WIDTH=320]
//! ```
//!
//! SHAPE is `sphere` (radius 1), `torus` (about the y axis, ring radius 0.7,
//! tube radius 0.3) or `bunny` (the Stanford bunny `bun_zipper.ply` from
//! `../shared/data/scanned-meshes`, or the file `$BUNNY`, centred on its
//! bounding box and scaled to bounding radius 1).
//!
//! `photos` writes what a user has after a capture, in the scene frame
//! (units: the shape's radius), plus the ground truth laid out for both
//! evaluation protocols:
//! - `OUT/data/`: `images/*.png` (the shape textured by
//!   `testing::sphere_texture`, rendered by the mesh rasteriser at 4×4
//!   samples per pixel, black background), `cameras.json` (VIEWS cameras on a
//!   Fibonacci sphere at distance 3.5, SIZE² pixels, focal 1.25·SIZE) and
//!   `input.ply` (2,000 surface points with their texture colour: the SfM
//!   points a capture gives);
//! - `OUT/view.json`: the one camera the pictures of every method are
//!   rendered from (512², above and to the side, world +y up);
//! - `OUT/truth.ply`: the exact surface as a mesh (sphere and torus finely
//!   tessellated: distance to the analytic surface below 1e-4);
//! - `OUT/dtu/`: the official DTU layout for scan 1 in millimetres (scene
//!   frame × 100 mm): `Points/stl/stl001_total.ply` (16 surface samples
//!   per mm²), `ObsMask/ObsMask1_10.mat` (every 5 mm voxel of the box 20 mm
//!   around the shape observed) and `ObsMask/Plane1.mat` (a plane 10 m below:
//!   nothing is cut);
//! - `OUT/dtu_scene/`: what 2DGS's DTU evaluation culls with, `cameras.npz`
//!   (`world_mat_i` in mm, `scale_mat_i` = 100·I) and `mask/NNN.png` (the
//!   shape's silhouette per view, same order);
//! - `OUT/tnt/<Shape>/`: the Tanks-and-Temples toolbox layout (scene units):
//!   `<Shape>.ply` (500,000 surface samples), `<Shape>.json` (a crop box
//!   10 % larger than the shape), `<Shape>_trans.txt` (identity) and
//!   `<Shape>_COLMAP_SfM.log` (the cameras); `OUT/tnt/traj.log` is the
//!   reconstruction's trajectory (the same cameras).
//!
//! `flat` writes `OUT/scene.ply`, GAUSSIANS flat Gaussians covering the
//! shape (σ = 1.2 × the point spacing along the surface, 1/40 of that
//! across it; `testing::flat_gaussians`), and `OUT/cameras.json`, VIEWS
//! cameras at distance 3.5 of WIDTH × 3/4·WIDTH pixels (focal = WIDTH).

use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};

use glam::{DMat4, DVec3};
use splatkit::geom::scenes::synthetic::Torus;
use splatkit::io::any::{load_mesh, save_gaussians, save_points};
use splatkit::io::cameras::npz::encode_npy_f64;
use splatkit::io::dtu::{ObsMask, write_obs_mask, write_plane};
use splatkit::io::ply::{Format, mesh::write_mesh, points::write_points};
use splatkit::io::tnt::{LogFrame, write_crop_json, write_log};
use splatkit::io::write_output;
use splatkit::model::crop::{Axis, CropVolume};
use splatkit::model::{Camera, Mesh, PointCloud};
use splatkit::testing::{
    cameras_around, flat_gaussians, sphere_surface_points, sphere_texture, torus_surface_points,
    uv_sphere, write_photos,
};

/// Millimetres per scene unit in the DTU layout.
const MM: f64 = 100.0;
/// Torus ring and tube radii (bounding radius 1).
const RING: f64 = 0.7;
const TUBE: f64 = 0.3;

type Res<T> = Result<T, String>;

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let r = match a.first().map(String::as_str) {
        Some("photos") if a.len() >= 3 => photos(
            &a[1],
            Path::new(&a[2]),
            arg(&a, 3, 40),
            arg(&a, 4, 128) as u32,
        ),
        Some("flat") if a.len() >= 4 => flat(
            &a[1],
            arg(&a, 2, 0),
            Path::new(&a[3]),
            arg(&a, 4, 24),
            arg(&a, 5, 320) as u32,
        ),
        _ => {
            eprintln!(
                "usage: mesh_bench_scene photos SHAPE OUT [VIEWS=40] [SIZE=128]\n       \
                 mesh_bench_scene flat SHAPE GAUSSIANS OUT [VIEWS=24] [WIDTH=320]\n\
                 SHAPE: sphere | torus | bunny"
            );
            std::process::exit(2);
        }
    };
    if let Err(e) = r {
        eprintln!("mesh_bench_scene: {e}");
        std::process::exit(1);
    }
}

fn arg(a: &[String], i: usize, default: usize) -> usize {
    a.get(i).map_or(default, |v| {
        v.parse().unwrap_or_else(|_| {
            eprintln!(
                "mesh_bench_scene: argument {} ('{v}') is not a count",
                i + 1
            );
            std::process::exit(2)
        })
    })
}

fn err<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// The shape's exact surface as a mesh in the scene frame.
fn truth(shape: &str) -> Res<Mesh> {
    match shape {
        "sphere" => Ok(uv_sphere(256, 1.0)),
        "torus" => Ok(Torus {
            major: RING,
            minor: TUBE,
        }
        .mesh(1024, 384)),
        "bunny" => {
            let path = std::env::var_os("BUNNY")
                .map(PathBuf::from)
                .unwrap_or_else(|| {
                    Path::new(env!("CARGO_MANIFEST_DIR"))
                        .join("../shared/data/scanned-meshes/bun_zipper.ply")
                });
            let mut m = load_mesh(&path, "mesh_bench_scene").map_err(err)?;
            let (lo, hi) = bounds(&m.vertices);
            let c = (lo + hi) / 2.0;
            let r = m
                .vertices
                .iter()
                .map(|p| (DVec3::from_array(p.map(f64::from)) - c).length())
                .fold(0.0, f64::max);
            for p in &mut m.vertices {
                *p = ((DVec3::from_array(p.map(f64::from)) - c) / r)
                    .as_vec3()
                    .to_array();
            }
            Ok(Mesh::new(m.vertices, m.faces))
        }
        _ => Err(format!("unknown shape '{shape}' (sphere, torus, bunny)")),
    }
}

fn bounds(v: &[[f32; 3]]) -> (DVec3, DVec3) {
    let (lo, hi) = splatkit::model::mesh::bounds(v).unwrap_or_default();
    let d = |p: [f32; 3]| DVec3::from_array(p.map(f64::from));
    (d(lo), d(hi))
}

fn samples(m: &Mesh, count: usize, seed: u64) -> Res<Vec<[f64; 3]>> {
    let v: Vec<[f64; 3]> = m.vertices.iter().map(|p| p.map(f64::from)).collect();
    splatkit::geom::sampling::sample::sample_area_uniform_count(&v, &m.faces, count, seed)
        .map_err(err)
}

fn cloud(p: &[[f64; 3]], scale: f64, colors: bool) -> PointCloud {
    PointCloud {
        positions: p.iter().map(|q| q.map(|x| (x * scale) as f32)).collect(),
        colors: colors.then(|| {
            p.iter()
                .map(|q| sphere_texture(DVec3::from_array(*q)).map(splatkit::io::image::to_u8))
                .collect()
        }),
        ..Default::default()
    }
}

fn mkdir(p: &Path) -> Res<()> {
    std::fs::create_dir_all(p).map_err(|e| format!("{}: {e}", p.display()))
}

fn png(path: &Path, w: usize, h: usize, channels: usize, bytes: &[u8]) -> Res<()> {
    let name = path.display().to_string();
    write_output(path, |out| {
        splatkit::io::image::write_png8(out, &name, w, h, channels, bytes)
    })
    .map_err(err)
}

fn photos(shape: &str, out: &Path, views: usize, size: u32) -> Res<()> {
    let m = truth(shape)?;
    let cams = cameras_around(views, 3.5, size, 1.25 * size as f64);
    let data = out.join("data");
    write_photos(&data, &m, &cams).map_err(err)?;
    save_points(
        &data.join("input.ply"),
        &cloud(&samples(&m, 2000, 3)?, 1.0, true),
        Format::BinaryLittleEndian,
    )
    .map_err(err)?;
    write_output(&out.join("truth.ply"), |w| {
        write_mesh(w, &m, Format::BinaryLittleEndian)
    })
    .map_err(err)?;
    splatkit::io::cameras::write_gs_json(&out.join("view.json"), &[picture_camera()])
        .map_err(err)?;
    write_dtu(&m, &cams, out)?;
    write_tnt(shape, &m, &cams, &out.join("tnt"))
}

/// The one view every method's picture is rendered from: 512² pixels from
/// above and to the side, world +y up in the image.
fn picture_camera() -> Camera {
    let pos = DVec3::new(1.6, 1.4, 2.4).normalize() * 3.2;
    let z = (-pos).normalize();
    let x = (-DVec3::Y).cross(z).normalize();
    let (r, t) = Camera::pose_from_c2w(glam::DMat3::from_cols(x, z.cross(x), z), pos);
    Camera::pinhole("picture", 512, 512, 600.0, 600.0, 256.0, 256.0, r, t)
}

fn write_dtu(m: &Mesh, cams: &[Camera], out: &Path) -> Res<()> {
    let root = out.join("dtu");
    mkdir(&root.join("Points/stl"))?;
    mkdir(&root.join("ObsMask"))?;
    let (lo, hi) = bounds(&m.vertices);
    let area_mm2: f64 = {
        let v: Vec<[f64; 3]> = m.vertices.iter().map(|p| p.map(f64::from)).collect();
        m.faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| DVec3::from_array(v[i as usize]));
                0.5 * (b - a).cross(c - a).length()
            })
            .sum::<f64>()
            * MM
            * MM
    };
    let stl = samples(m, (16.0 * area_mm2) as usize, 5)?;
    write_output(&root.join("Points/stl/stl001_total.ply"), |w| {
        write_points(w, &cloud(&stl, MM, false), Format::BinaryLittleEndian)
    })
    .map_err(err)?;
    let res = 5.0;
    let bb_lo = lo * MM - DVec3::splat(20.0);
    let bb_hi = hi * MM + DVec3::splat(20.0);
    let dims = ((bb_hi - bb_lo) / res).ceil().as_uvec3() + glam::UVec3::ONE;
    let dims = [dims.x as usize, dims.y as usize, dims.z as usize];
    let obs = ObsMask {
        mask: vec![1; dims[0] * dims[1] * dims[2]],
        dims,
        bb: [
            bb_lo.to_array(),
            (bb_lo + res * (dims_vec(dims) - 1.0)).to_array(),
        ],
        res,
    };
    write_obs_mask(&root.join("ObsMask/ObsMask1_10.mat"), &obs).map_err(err)?;
    write_plane(&root.join("ObsMask/Plane1.mat"), [0.0, 0.0, 1.0, 1e4]).map_err(err)?;

    // cameras.npz: world_mat = K' [R | MM·t] (mm frame, pixel centres at
    // integers: K' = K − 0.5 on the principal point), scale_mat = MM·I, so
    // world_mat · scale_mat · x = MM · K'(R x + t) for a scene point x.
    let scene = out.join("dtu_scene");
    mkdir(&scene.join("mask"))?;
    let rows = |m: DMat4| -> Vec<f64> {
        (0..4)
            .flat_map(|i| (0..4).map(move |j| m.col(j)[i]))
            .collect()
    };
    let scale = DMat4::from_diagonal(glam::DVec4::new(MM, MM, MM, 1.0));
    let mut zip = zip::ZipWriter::new(Cursor::new(Vec::new()));
    let opts =
        zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    for (i, c) in cams.iter().enumerate() {
        let mut k = c.intrinsics();
        k.z_axis.x -= 0.5;
        k.z_axis.y -= 0.5;
        let mut world = DMat4::from_mat3(k * c.rotation);
        world.w_axis = (k * (MM * c.translation)).extend(1.0);
        for (name, mat) in [("world_mat", world), ("scale_mat", scale)] {
            zip.start_file(format!("{name}_{i}.npy"), opts)
                .map_err(err)?;
            zip.write_all(&encode_npy_f64(&[4, 4], &rows(mat)))
                .map_err(err)?;
        }
        let z = splatkit_render::mesh::render(&m.vertices, &m.faces, c, 0.01);
        let mask: Vec<u8> = z
            .face
            .iter()
            .map(|&f| {
                if f == splatkit_render::mesh::NO_FACE {
                    0
                } else {
                    255
                }
            })
            .collect();
        png(
            &scene.join("mask").join(format!("{i:03}.png")),
            c.width as usize,
            c.height as usize,
            1,
            &mask,
        )?;
    }
    let bytes = zip.finish().map_err(err)?.into_inner();
    write_output(&scene.join("cameras.npz"), |w| {
        w.write_all(&bytes)
            .map_err(|e| splatkit::Error::invalid(format!("cameras.npz: {e}")))
    })
    .map_err(err)
}

fn dims_vec(d: [usize; 3]) -> DVec3 {
    DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64)
}

fn write_tnt(shape: &str, m: &Mesh, cams: &[Camera], root: &Path) -> Res<()> {
    let mut name = shape.to_string();
    name[..1].make_ascii_uppercase();
    let dir = root.join(&name);
    mkdir(&dir)?;
    let gt = samples(m, 500_000, 7)?;
    write_output(&dir.join(format!("{name}.ply")), |w| {
        write_points(w, &cloud(&gt, 1.0, false), Format::BinaryLittleEndian)
    })
    .map_err(err)?;
    let (lo, hi) = bounds(&m.vertices);
    let (c, h) = ((lo + hi) / 2.0, (hi - lo) * 0.55);
    let crop = CropVolume {
        orthogonal_axis: Axis::Z,
        axis_min: c.z - h.z,
        axis_max: c.z + h.z,
        bounding_polygon: vec![
            [c.x - h.x, c.y - h.y, 0.0],
            [c.x + h.x, c.y - h.y, 0.0],
            [c.x + h.x, c.y + h.y, 0.0],
            [c.x - h.x, c.y + h.y, 0.0],
        ],
    };
    write_crop_json(&dir.join(format!("{name}.json")), &crop).map_err(err)?;
    write_output(&dir.join(format!("{name}_trans.txt")), |w| {
        w.write_all(b"1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n")
            .map_err(|e| splatkit::Error::invalid(format!("trans: {e}")))
    })
    .map_err(err)?;
    let frames: Vec<LogFrame> = cams
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let mut pose = DMat4::from_mat3(c.c2w_rotation());
            pose.w_axis = c.center().extend(1.0);
            LogFrame {
                meta: [i as i64, i as i64, 0],
                pose,
            }
        })
        .collect();
    write_log(&dir.join(format!("{name}_COLMAP_SfM.log")), &frames).map_err(err)?;
    write_log(&root.join("traj.log"), &frames).map_err(err)
}

fn flat(shape: &str, n: usize, out: &Path, views: usize, width: u32) -> Res<()> {
    if n == 0 {
        return Err("GAUSSIANS must be at least 1".into());
    }
    let (points, area) = match shape {
        "sphere" => (sphere_surface_points(n, 1.0), 4.0 * std::f64::consts::PI),
        "torus" => {
            let tau = std::f64::consts::TAU;
            (torus_surface_points(n, RING, TUBE), tau * tau * RING * TUBE)
        }
        _ => return Err(format!("flat scenes are sphere or torus, not '{shape}'")),
    };
    let spacing = (area / points.len() as f64).sqrt();
    let g = flat_gaussians(&points, 1.2 * spacing, 1.2 * spacing / 40.0, 3);
    mkdir(out)?;
    save_gaussians(&out.join("scene.ply"), &g).map_err(err)?;
    let height = width * 3 / 4;
    let cams: Vec<Camera> = cameras_around(views, 3.5, width, width as f64)
        .into_iter()
        .map(|mut c| {
            c.height = height;
            c.cy = height as f64 / 2.0;
            c
        })
        .collect();
    splatkit::io::cameras::write_gs_json(&out.join("cameras.json"), &cams).map_err(err)
}
