//! The visual hull of a masked multi-view capture, as a mesh: a starting
//! mesh for `bind-gaussians` / `refine` when no splats exist (DTU).
//!
//! usage: cargo run --release --example visual_hull -- CAMERAS MASK_DIR OUT.ply [N] [HALF]
//!
//! A voxel of an N³ grid over the cube [−HALF, HALF]³ (default 160, 1.1: the
//! NeuS unit-sphere frame of `cameras_sphere.npz`) is kept when its centre
//! projects onto an object pixel (mask ≠ 0) in every view whose image it
//! falls in, and falls in at least one (DTU objects overflow some frames, so
//! a view carves only what it sees). The kept set is smoothed by a 3×3×3 box filter and the 0.5 level is
//! extracted with the crate's marching-cubes table, with vertices shared
//! between cubes (a closed, edge-manifold mesh). Faces are wound so their
//! normals point out of the hull.

use std::collections::HashMap;
use std::path::PathBuf;

use rayon::prelude::*;
use splatkit::geom::meshing::marching_cubes::{edge_corners, table, triangulate};
use splatkit::io::any::save_mesh;
use splatkit::io::cameras::read_cameras;
use splatkit::io::detect::FileFormat;
use splatkit::io::image::read_mask;
use splatkit::model::Mesh;

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    if a.len() < 3 {
        anyhow::bail!("usage: visual_hull CAMERAS MASK_DIR OUT.ply [N] [HALF]");
    }
    let n: usize = a.get(3).map_or(Ok(160), |s| s.parse())?;
    let half: f64 = a.get(4).map_or(Ok(1.1), |s| s.parse())?;
    let mut cams = read_cameras(&PathBuf::from(&a[0]))?;
    cams.sort_by(|x, y| x.name.cmp(&y.name));
    let mut masks = Vec::new();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&a[1])?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    files.sort();
    if files.len() != cams.len() {
        anyhow::bail!("{} masks for {} cameras", files.len(), cams.len());
    }
    for (c, f) in cams.iter().zip(&files) {
        let m = read_mask(f)?;
        if (m.width, m.height) != (c.width as usize, c.height as usize) {
            anyhow::bail!(
                "{}: {}x{} for a {}x{} camera",
                f.display(),
                m.width,
                m.height,
                c.width,
                c.height
            );
        }
        masks.push(m);
    }
    let step = 2.0 * half / n as f64;
    let centre = |i: usize| -half + (i as f64 + 0.5) * step;
    // occupancy of voxel centres
    let occ: Vec<u8> = (0..n * n * n)
        .into_par_iter()
        .map(|idx| {
            let (i, j, k) = (idx % n, (idx / n) % n, idx / (n * n));
            let p = glam::DVec3::new(centre(i), centre(j), centre(k));
            let mut seen = 0;
            let inside = cams.iter().zip(&masks).all(|(c, m)| match c.project(p) {
                Some((px, _))
                    if px.x >= 0.0
                        && px.y >= 0.0
                        && (px.x as usize) < m.width
                        && (px.y as usize) < m.height =>
                {
                    seen += 1;
                    m.bits[px.y as usize * m.width + px.x as usize]
                }
                // outside this view's image: the view says nothing
                _ => true,
            });
            (inside && seen > 0) as u8
        })
        .collect();
    let kept = occ.iter().filter(|&&o| o == 1).count();
    // 3×3×3 box-smoothed field at the voxel centres
    let at = |i: isize, j: isize, k: isize| -> f64 {
        if i < 0 || j < 0 || k < 0 || i >= n as isize || j >= n as isize || k >= n as isize {
            return 0.0;
        }
        occ[(k as usize * n + j as usize) * n + i as usize] as f64
    };
    let field: Vec<f64> = (0..n * n * n)
        .into_par_iter()
        .map(|idx| {
            let (i, j, k) = (
                (idx % n) as isize,
                ((idx / n) % n) as isize,
                (idx / (n * n)) as isize,
            );
            let mut s = 0.0;
            for dk in -1..=1 {
                for dj in -1..=1 {
                    for di in -1..=1 {
                        s += at(i + di, j + dj, k + dk);
                    }
                }
            }
            s / 27.0
        })
        .collect();
    let f = |i: usize, j: usize, k: usize| field[(k * n + j) * n + i];
    // marching cubes at 0.5, inside = field > 0.5
    let tab = table();
    let mut verts: Vec<[f64; 3]> = Vec::new();
    let mut ids: HashMap<(usize, usize, usize, usize), u32> = HashMap::new();
    let mut tris: Vec<[u32; 3]> = Vec::new();
    for k in 0..n - 1 {
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let corner = |c: usize| (i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2));
                let mut case = 0usize;
                for c in 0..8 {
                    let (x, y, z) = corner(c);
                    if f(x, y, z) > 0.5 {
                        case |= 1 << c;
                    }
                }
                for lp in &tab[case] {
                    let mut poly = Vec::with_capacity(lp.len());
                    for &e in lp {
                        let (c0, c1) = edge_corners(e as usize);
                        let (a0, a1) = (corner(c0), corner(c1));
                        let key = (a0.0, a0.1, a0.2, e as usize / 4);
                        let id = *ids.entry(key).or_insert_with(|| {
                            let (v0, v1) = (f(a0.0, a0.1, a0.2), f(a1.0, a1.1, a1.2));
                            let t = (0.5 - v0) / (v1 - v0);
                            let p0 = [centre(a0.0), centre(a0.1), centre(a0.2)];
                            let p1 = [centre(a1.0), centre(a1.1), centre(a1.2)];
                            verts.push(std::array::from_fn(|d| p0[d] + t * (p1[d] - p0[d])));
                            (verts.len() - 1) as u32
                        });
                        poly.push(id);
                    }
                    triangulate(&poly, &verts, &mut tris);
                }
            }
        }
    }
    let mesh = Mesh::new(verts.iter().map(|v| v.map(|x| x as f32)).collect(), tris);
    save_mesh(
        &PathBuf::from(&a[2]),
        &mesh,
        FileFormat::Ply,
        &Default::default(),
    )?;
    eprintln!(
        "visual_hull: {} views, {n}³ voxels of {step:.4}, {kept} kept -> {} vertices, {} faces -> {}",
        cams.len(),
        mesh.vertices.len(),
        mesh.faces.len(),
        a[2]
    );
    Ok(())
}
