//! `render`: renders a Gaussian PLY, a 2DGS surfel PLY, a triangle-splat
//! soup or a mesh from a
//! camera file (or an orbit around the scene) to PNG colour, depth (float32
//! `.npy` and 16-bit PNG), alpha and normal images, and optionally compares
//! the colour renders with ground-truth images (PSNR, SSIM).
//!
//! Conventions: cameras in OpenCV axes (docs/ARCHITECTURE.md); depth is camera z in
//! scene units (median depth for splats by default, as 2DGS and Triangle
//! Splatting use; `--depth expected` for Σwz/Σw, `--depth-ratio r` for their
//! blend (1 − r)·expected + r·median); the 16-bit PNG stores
//! round(depth × `--depth-scale`) clamped to 65535, 0 = no depth; normals are
//! camera-space unit vectors mapped to 8 bits as (n + 1)/2; alpha is the
//! accumulated opacity (coverage for meshes).

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use serde_json::json;
use splatkit_render::gaussian::{self, Filter2d, RasterSettings, RenderOutput};
use splatkit_render::loss::{psnr, ssim};
use splatkit_render::surfel::{self, SurfelSettings};
use splatkit_render::{mesh as zbuffer, triangle};

use crate::cli::filter2d::Filter2dArgs;
use crate::cli::orbit::{OrbitArgs, SizeFrom, check_image_budget, image_bytes, largest_size};
use crate::cli::{Common, nonneg_f64, positive_f64, shown, usage};
use crate::geom::scenes::orbit::orbit_rings;
use crate::io::StagedDir;
use crate::io::cameras::npz::encode_npy_f32;
use crate::io::cameras::read_cameras;
use crate::io::image::{read_png_rgb, to_u8, write_png8, write_png16};
use crate::io::{any, write_output};
use crate::model::{self, Camera, Mesh, SceneKind};

/// Which depth the splat renderers write.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DepthKind {
    /// Depth of the last contribution made while the transmittance was
    /// above 0.5 (2DGS, Triangle Splatting).
    Median,
    /// Σ w·z / Σ w.
    Expected,
}

/// How `render` colours a mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Shading {
    /// Colour × a head light, 0.2 + 0.8·|n·view| (shows the shape).
    Lit,
    /// The colour as it is: texture or vertex colours, no light (what the
    /// mesh's colours were baked from, e.g. `bake-texture`).
    None,
}

/// Arguments of `render`.
#[derive(Args, Debug, Clone)]
#[command(after_help = "Examples:
  render point_cloud.ply --cameras cameras.json -o renders/
  render scene.pt --cameras sparse/0 -o renders/ --compare images/ --json
  # 2DGS surfels, 2DGS's surf_depth
  render 2dgs_model.ply --cameras cameras.json -o renders/ --depth-ratio 0
  render mesh.ply --cameras cameras.npz -o depth/ --outputs depth \\
      --depth-scale 1000
  # no camera file: orbit the scene
  render biker.ply --orbit 8 --up 0,-1,0 -o orbit/
  # texture as baked
  render textured.obj --cameras cameras.json --shading none -o views/")]
pub struct RenderArgs {
    /// Scene: 3DGS Gaussian PLY, 2DGS surfel PLY (rendered with 2DGS's
    /// surfel rasteriser), Triangle Splatting `.pt` or soup PLY, or a mesh
    /// (PLY, OBJ, OFF, glTF/GLB).
    pub scene: PathBuf,
    /// Camera file or folder (COLMAP, cameras.json, transforms.json,
    /// cameras.npz). Without it, `--orbit` cameras are used and written to
    /// `DIR/cameras.json`.
    #[arg(long)]
    pub cameras: Option<PathBuf>,
    /// Output folder (created if missing).
    #[arg(short, long)]
    pub output: PathBuf,
    /// What to write, comma-separated: rgb, depth, alpha, normal.
    #[arg(long, value_delimiter = ',', default_value = "rgb,depth,alpha,normal")]
    pub outputs: Vec<String>,
    /// Depth written for splats.
    #[arg(long, value_enum, default_value = "median")]
    pub depth: DepthKind,
    /// Depth written for splats as 2DGS blends it: (1 − r)·expected + r·median
    /// (`--depth median` is r = 1, `--depth expected` r = 0); what
    /// `tsdf-fuse --depth-ratio r` fuses.
    #[arg(long, value_name = "R", value_parser = crate::cli::unit_f64, conflicts_with = "depth")]
    pub depth_ratio: Option<f64>,
    /// Scale of the 16-bit depth PNG: stored value = round(depth × scale).
    #[arg(long, default_value_t = 1000.0, value_parser = positive_f64)]
    pub depth_scale: f64,
    /// Background colour r,g,b in [0, 1].
    #[arg(long, value_delimiter = ',', default_value = "0,0,0")]
    pub background: Vec<f32>,
    /// Mesh colouring: `lit` multiplies the colour (texture, vertex colours,
    /// else grey 0.8) by a head light 0.2 + 0.8·|n·view|; `none` gives the
    /// colour as it is. Splats ignore it.
    #[arg(long, value_enum, default_value = "lit")]
    pub shading: Shading,
    /// Near plane (camera z) for splats and meshes.
    #[arg(long, default_value_t = 0.2, value_parser = nonneg_f64)]
    pub near: f64,
    /// Triangle splats: draw triangles whose projected inradius is at least
    /// this many pixels (Triangle Splatting's kernel: 1); give the value a
    /// model was trained with (`train triangles --min-inradius`).
    #[arg(long, default_value_t = 1.0, value_parser = crate::cli::min_inradius_arg)]
    pub min_inradius: f64,
    #[command(flatten)]
    pub filter: Filter2dArgs,
    #[command(flatten)]
    pub orbit: OrbitArgs,
    /// Folder of ground-truth PNGs named after the cameras: report PSNR and
    /// SSIM of each colour render against them.
    #[arg(long)]
    pub compare: Option<PathBuf>,
    #[command(flatten)]
    pub common: Common,
}

/// A scene ready to rasterise.
enum Raster {
    Gaussians(gaussian::Gaussians3),
    Surfels(surfel::Surfels2),
    Triangles(triangle::Triangles3),
    Mesh(Mesh),
}

impl Raster {
    fn kind(&self) -> &'static str {
        match self {
            Raster::Gaussians(_) => "gaussians",
            Raster::Surfels(_) => "surfels",
            Raster::Triangles(_) => "triangles",
            Raster::Mesh(_) => "mesh",
        }
    }

    fn len(&self) -> usize {
        match self {
            Raster::Gaussians(g) => g.len(),
            Raster::Surfels(s) => s.len(),
            Raster::Triangles(t) => t.len(),
            Raster::Mesh(m) => m.faces.len(),
        }
    }

    /// Points that stand for the scene's extent.
    fn points(&self) -> Vec<[f32; 3]> {
        match self {
            Raster::Gaussians(g) => g.means.clone(),
            Raster::Surfels(s) => s.means.clone(),
            Raster::Triangles(t) => t.vertices.iter().flatten().copied().collect(),
            Raster::Mesh(m) => m.vertices.clone(),
        }
    }
}

/// Bytes per pixel `render` holds for the one view it works on: the
/// rasteriser's output and working buffers (splats: 52 of
/// [`RenderOutput`] + 12 of transmittance, last index and weight sum; a
/// mesh: the z-buffer's 28 + 52 of shaded output = 80, the larger), plus
/// the images encoded for writing (8-bit RGB 3, alpha 1, normal 3, the
/// surface depth 4, its `.npy` bytes 4 and 16-bit PNG 2 = 17), plus 7 for
/// the encoders' row buffers.
pub const RENDER_BYTES_PER_PIXEL: u64 = 80 + 17 + 7;

/// Extra bytes per pixel with `--compare`: the clamped render and the
/// ground truth (12 + 12) and SSIM's f64 maps (per channel, the three in
/// parallel: the two images, five blurred moments, a product and a blur
/// temporary, 9 × 8 = 72; × 3 = 216).
pub const COMPARE_BYTES_PER_PIXEL: u64 = 24 + 216;

/// Bytes `render` needs for its image buffers, given the pixels of its
/// largest view: those × ([`RENDER_BYTES_PER_PIXEL`] +
/// [`COMPARE_BYTES_PER_PIXEL`] with `--compare`); views are rendered one at
/// a time, so nothing is held per view. Saturating.
pub fn render_bytes(largest_pixels: u64, compare: bool) -> u64 {
    let per = RENDER_BYTES_PER_PIXEL + if compare { COMPARE_BYTES_PER_PIXEL } else { 0 };
    largest_pixels.saturating_mul(per)
}

/// The scene file, through the common loader, ready to rasterise, and the
/// 2-D filter for Gaussians: a `filter_3D` property (Mip-Splatting, GOF)
/// is baked into the scales and opacities here
/// ([`model::filter3d::baked_for_rendering`]) and picks the Mip filter
/// under `--filter-2d auto`.
fn load_scene(path: &Path, filter: &Filter2dArgs) -> anyhow::Result<(Raster, Filter2d)> {
    let accepts = [
        SceneKind::Gaussians,
        SceneKind::Surfels,
        SceneKind::TriangleSoup,
        SceneKind::Mesh,
    ];
    let mut filtered = false;
    let scene = match any::load_kinds(path, "render", &accepts)? {
        model::Scene::Gaussians(g) => {
            let (g, f) = model::filter3d::baked_for_rendering(g)
                .map_err(|e| e.in_file(shown(path, false)))?;
            filtered = f;
            Raster::Gaussians(g.to_raster())
        }
        model::Scene::Surfels(s) => Raster::Surfels(s.to_raster()),
        model::Scene::TriangleSoup(t) => Raster::Triangles(t.to_raster()),
        model::Scene::Mesh(m) => Raster::Mesh(m),
        model::Scene::PointCloud(_) => unreachable!("load_kinds returns an accepted kind"),
    };
    let f = model::filter3d::choose_filter_2d(filter.choice(), filter.kernel_size, filtered);
    Ok((scene, f))
}

/// A file-name stem for a camera: its name without folders or extension.
fn stem(cam: &Camera, i: usize) -> String {
    let base = Path::new(&cam.name)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let clean: String = base
        .chars()
        .map(|c| {
            if c.is_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect();
    if clean.is_empty() {
        format!("view_{i:03}")
    } else {
        clean
    }
}

/// Shades a mesh z-buffer; alpha = coverage. The colour of a pixel is, in
/// order of preference: the texture sampled (bilinear, see
/// [`model::texture`]) at the perspective-correct interpolation of its
/// face's corner UVs, when the mesh has a texture and the face finite UVs;
/// the barycentric interpolation of the vertex colours; grey 0.8. `Lit`
/// multiplies it by a head light 0.2 + 0.8·|n·view|; `None` keeps it.
pub fn shade_mesh(
    m: &Mesh,
    z: &zbuffer::MeshRender,
    bg: [f32; 3],
    shading: Shading,
) -> RenderOutput {
    let n = z.width * z.height;
    let mut out = RenderOutput {
        width: z.width,
        height: z.height,
        rgb: vec![bg; n],
        alpha: vec![0.0; n],
        expected_depth: z.depth.clone(),
        median_depth: z.depth.clone(),
        normal: z.normal.clone(),
        // one opaque layer of weight 1: Σ w n is the normal (zero off the mesh)
        normal_sum: z.normal.clone(),
        count: vec![0; n],
    };
    for i in 0..n {
        let f = z.face[i];
        if f == zbuffer::NO_FACE {
            continue;
        }
        out.alpha[i] = 1.0;
        out.count[i] = 1;
        let light = match shading {
            Shading::Lit => 0.2 + 0.8 * (-z.normal[i][2]).max(0.0),
            Shading::None => 1.0,
        };
        let [u, v] = z.bary[i];
        let w = [1.0 - u - v, u, v];
        let textured = match (&m.texture, &m.uvs) {
            (Some(t), Some(uvs)) => {
                let c = uvs[f as usize];
                let uv: [f32; 2] = std::array::from_fn(|k| (0..3).map(|j| w[j] * c[j][k]).sum());
                uv.iter()
                    .all(|x| x.is_finite())
                    .then(|| t.sample(uv[0], uv[1]))
            }
            _ => None,
        };
        let colour = match (textured, &m.vertex_colors) {
            (Some(c), _) => c,
            (None, Some(c)) => {
                let face = m.faces[f as usize];
                std::array::from_fn(|k| {
                    (0..3)
                        .map(|j| w[j] * c[face[j] as usize][k] as f32 / 255.0)
                        .sum::<f32>()
                })
            }
            (None, None) => [0.8; 3],
        };
        out.rgb[i] = colour.map(|c| c * light);
    }
    out
}

fn render_view(scene: &Raster, cam: &Camera, s: &RasterSettings, shading: Shading) -> RenderOutput {
    match scene {
        Raster::Gaussians(g) => gaussian::render(g, cam, s),
        Raster::Surfels(sf) => surfel::render(
            sf,
            cam,
            &SurfelSettings {
                background: s.background,
                near: s.near,
                ..SurfelSettings::default()
            },
        ),
        Raster::Triangles(t) => triangle::render(t, cam, s),
        Raster::Mesh(m) => shade_mesh(
            m,
            &zbuffer::render(&m.vertices, &m.faces, cam, s.near),
            s.background,
            shading,
        ),
    }
}

fn write_file(
    path: &Path,
    bytes_of: impl FnOnce(&mut dyn std::io::Write) -> crate::Result<()>,
) -> anyhow::Result<()> {
    write_output(path, bytes_of).with_context(|| format!("writing {}", path.display()))
}

/// Writes the requested images of one view; returns the file names.
fn write_view(
    out: &RenderOutput,
    dir: &Path,
    stem: &str,
    what: &[String],
    depth_ratio: f32,
    depth_scale: f64,
) -> anyhow::Result<Vec<String>> {
    let (w, h) = (out.width, out.height);
    let mut files = Vec::new();
    let depth = &out.surface_depth(depth_ratio);
    for item in what {
        match item.as_str() {
            "rgb" => {
                let name = format!("{stem}.png");
                let data: Vec<u8> = out.rgb.iter().flat_map(|p| p.map(to_u8)).collect();
                write_file(&dir.join(&name), |wr| write_png8(wr, &name, w, h, 3, &data))?;
                files.push(name);
            }
            "depth" => {
                let name = format!("{stem}_depth.npy");
                let bytes = encode_npy_f32(&[h, w], depth);
                write_file(&dir.join(&name), |wr| {
                    wr.write_all(&bytes).map_err(crate::io::source::werr)
                })?;
                files.push(name);
                let name = format!("{stem}_depth.png");
                let d16: Vec<u16> = depth
                    .iter()
                    .map(|&d| (d as f64 * depth_scale).round().clamp(0.0, 65535.0) as u16)
                    .collect();
                write_file(&dir.join(&name), |wr| write_png16(wr, &name, w, h, &d16))?;
                files.push(name);
            }
            "alpha" => {
                let name = format!("{stem}_alpha.png");
                let data: Vec<u8> = out.alpha.iter().map(|&a| to_u8(a)).collect();
                write_file(&dir.join(&name), |wr| write_png8(wr, &name, w, h, 1, &data))?;
                files.push(name);
            }
            "normal" => {
                let name = format!("{stem}_normal.png");
                let data: Vec<u8> = out
                    .normal
                    .iter()
                    .flat_map(|n| {
                        if *n == [0.0; 3] {
                            [0; 3]
                        } else {
                            n.map(|v| to_u8(0.5 * (v + 1.0)))
                        }
                    })
                    .collect();
                write_file(&dir.join(&name), |wr| write_png8(wr, &name, w, h, 3, &data))?;
                files.push(name);
            }
            other => bail!("unknown --outputs item {other:?} (rgb, depth, alpha, normal)"),
        }
    }
    Ok(files)
}

/// Finds the ground-truth image of a camera in `dir`.
fn ground_truth(dir: &Path, cam: &Camera, stem: &str) -> anyhow::Result<PathBuf> {
    let candidates = [
        dir.join(&cam.name),
        dir.join(format!("{stem}.png")),
        dir.join(format!("{stem}.PNG")),
    ];
    candidates
        .iter()
        .find(|p| p.is_file() && p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")))
        .cloned()
        .with_context(|| {
            format!(
                "no ground-truth PNG for camera {:?} in {} (looked for {}.png)",
                cam.name,
                dir.display(),
                stem
            )
        })
}

/// `render` entry point: checks the flags, stages the output folder,
/// loads the scene and the cameras, renders and writes every view
/// ([`render_views`]), commits the folder and reports.
pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    args.common.init()?;
    check_flags(&args)?;
    // Files go to a staging folder moved into place only when every view
    // was rendered and compared, so a failed run leaves the output as it
    // was; made first, so an unusable output path fails before any work.
    let staged = StagedDir::new(&args.output)
        .with_context(|| format!("creating {}", args.output.display()))?;
    let orbit = orbit_spec(&args)?;
    let t0 = std::time::Instant::now();
    let (scene, filter_2d) = load_render_scene(&args)?;
    let cams = render_cameras(&args, &scene, orbit.as_ref())?;
    // Every ground-truth image is found before anything is rendered or
    // written, so a missing one cannot leave the output folder half-replaced.
    let gt_paths: Vec<Option<PathBuf>> = cams
        .iter()
        .enumerate()
        .map(|(i, cam)| {
            args.compare
                .as_ref()
                .map(|dir| ground_truth(dir, cam, &stem(cam, i)))
                .transpose()
        })
        .collect::<anyhow::Result<_>>()?;
    if args.cameras.is_none() {
        // keep the made-up views so other scenes can be rendered from them
        crate::io::cameras::write_gs_json(&staged.path().join("cameras.json"), &cams)?;
    }
    let rendered = render_views(&args, &scene, filter_2d, &cams, &gt_paths, staged.path())?;
    staged.commit()?;
    report(&args, &scene, filter_2d, cams.len(), &rendered, t0)
}

/// The usage errors among `--outputs`, `--background` and
/// `--depth-scale`, before anything is made.
fn check_flags(args: &RenderArgs) -> anyhow::Result<()> {
    for item in &args.outputs {
        if !["rgb", "depth", "alpha", "normal"].contains(&item.as_str()) {
            return Err(usage(format!(
                "unknown --outputs item {item:?} (rgb, depth, alpha, normal)"
            )));
        }
    }
    if args.background.len() != 3 || args.background.iter().any(|v| !v.is_finite()) {
        return Err(usage("--background takes three finite numbers r,g,b"));
    }
    if !(args.depth_scale > 0.0 && args.depth_scale.is_finite()) {
        return Err(usage("--depth-scale must be positive"));
    }
    Ok(())
}

/// The orbit of the `--orbit` flags when no camera file is given, checked
/// (with its image buffers against the memory budget) before the scene is
/// read; `None` with `--cameras`.
fn orbit_spec(args: &RenderArgs) -> anyhow::Result<Option<model::OrbitSpec>> {
    let orbit = match &args.cameras {
        Some(_) => None,
        None => Some(args.orbit.spec(args.orbit.orbit.unwrap_or(8))?),
    };
    // The orbit's image buffers are a flag's: refused before the scene is read.
    if let Some(spec) = &orbit {
        check_image_budget(
            SizeFrom::Flag(&format!("--size {}", args.orbit.size)),
            "the render buffers of one view",
            render_bytes(
                u64::from(spec.width) * u64::from(spec.height),
                args.compare.is_some(),
            ),
        )?;
    }
    Ok(orbit)
}

/// The scene, ready to rasterise: an error when it holds no primitive (the
/// images would show the background only); a note when a mesh has texture
/// coordinates but no texture image.
fn load_render_scene(args: &RenderArgs) -> anyhow::Result<(Raster, Filter2d)> {
    let (scene, filter_2d) = load_scene(&args.scene, &args.filter)
        .with_context(|| format!("reading {}", shown(&args.scene, false)))?;
    // Images of nothing but the background are not a render of the scene.
    if scene.len() == 0 {
        bail!(
            "{}: holds no {} (0 primitives): nothing to render",
            shown(&args.scene, false),
            scene.kind()
        );
    }
    if let Raster::Mesh(m) = &scene
        && m.uvs.is_some()
        && m.texture.is_none()
    {
        args.common.say(format!(
            "note: {} has texture coordinates but no texture image was found (mtllib / \
             map_Kd PNG next to it); rendering its vertex colours or grey",
            shown(&args.scene, false)
        ));
    }
    Ok((scene, filter_2d))
}

/// The cameras to render from: the camera file's, or the `orbit` around
/// the scene's points; each a pinhole, and a camera file's largest view
/// within the memory budget.
fn render_cameras(
    args: &RenderArgs,
    scene: &Raster,
    orbit: Option<&model::OrbitSpec>,
) -> anyhow::Result<Vec<Camera>> {
    let cams = match (&args.cameras, orbit) {
        (Some(p), _) => {
            read_cameras(p).with_context(|| format!("reading cameras {}", p.display()))?
        }
        (None, Some(spec)) => orbit_rings(&scene.points(), spec).with_context(|| {
            format!(
                "{}: no usable --orbit around this scene (check its coordinates, or give --radius \
                 or --cameras)",
                shown(&args.scene, false)
            )
        })?,
        (None, None) => unreachable!("an orbit is made when no camera file is given"),
    };
    for c in &cams {
        c.require_pinhole()
            .map_err(|e| anyhow::anyhow!("camera {:?}: {e}", c.name))?;
    }
    if let Some(p) = &args.cameras {
        check_image_budget(
            SizeFrom::File(p),
            &format!("the render buffers of a {} view", largest_size(&cams)),
            render_bytes(image_bytes(&cams, 1, 0), args.compare.is_some()),
        )?;
    }
    Ok(cams)
}

/// What [`render_views`] did: each view's report entry (camera, files,
/// PSNR and SSIM with `--compare`) and the sums of PSNR (dB) and SSIM.
struct Rendered {
    views: Vec<serde_json::Value>,
    psnr_sum: f64,
    ssim_sum: f64,
}

/// Renders every camera's view of `scene`, writes its images into
/// `out_dir` and, where `gt_paths` has its ground truth, compares the
/// colour render with it; one view at a time, under a progress bar.
fn render_views(
    args: &RenderArgs,
    scene: &Raster,
    filter_2d: Filter2d,
    cams: &[Camera],
    gt_paths: &[Option<PathBuf>],
    out_dir: &Path,
) -> anyhow::Result<Rendered> {
    let s = RasterSettings {
        background: [args.background[0], args.background[1], args.background[2]],
        near: args.near,
        filter_2d,
        min_inradius: args.min_inradius,
    };
    let depth_ratio = match (args.depth_ratio, args.depth) {
        (Some(r), _) => r as f32,
        (None, DepthKind::Median) => 1.0,
        (None, DepthKind::Expected) => 0.0,
    };
    let pb = args.common.progress(cams.len() as u64, "render");
    let mut views = Vec::new();
    let (mut psnr_sum, mut ssim_sum) = (0.0, 0.0);
    for (i, cam) in cams.iter().enumerate() {
        let out = render_view(scene, cam, &s, args.shading);
        let st = stem(cam, i);
        let files = write_view(
            &out,
            out_dir,
            &st,
            &args.outputs,
            depth_ratio,
            args.depth_scale,
        )?;
        let mut v = json!({ "camera": cam.name, "files": files });
        if let Some(gt_path) = &gt_paths[i] {
            let (p, q) = compare_view(gt_path, cam, &out)?;
            psnr_sum += p;
            ssim_sum += q;
            v["psnr"] = json!(p);
            v["ssim"] = json!(q);
            args.common
                .say(format!("{}: PSNR {p:.2} dB, SSIM {q:.4}", cam.name));
        }
        views.push(v);
        pb.inc(1);
    }
    pb.finish_and_clear();
    Ok(Rendered {
        views,
        psnr_sum,
        ssim_sum,
    })
}

/// PSNR (dB) and SSIM of the colour render `out` of `cam`, clamped to
/// [0, 1], against the ground-truth PNG at `gt_path`, which must have the
/// render's size.
fn compare_view(gt_path: &Path, cam: &Camera, out: &RenderOutput) -> anyhow::Result<(f64, f64)> {
    let gt = read_png_rgb(gt_path)?;
    if (gt.width, gt.height) != (out.width, out.height) {
        bail!(
            "{}: {}x{} pixels, but camera {:?} renders {}x{}",
            gt_path.display(),
            gt.width,
            gt.height,
            cam.name,
            out.width,
            out.height
        );
    }
    let img: Vec<[f32; 3]> = out
        .rgb
        .iter()
        .map(|p| p.map(|v| v.clamp(0.0, 1.0)))
        .collect();
    let p = psnr(&img, &gt.pixels);
    let q = ssim(&img, &gt.pixels, out.width, out.height);
    Ok((p, q))
}

/// The human summary (stderr: the mean PSNR and SSIM with `--compare`,
/// then the counts and seconds since `t0`) and the JSON report.
fn report(
    args: &RenderArgs,
    scene: &Raster,
    filter_2d: Filter2d,
    n_cams: usize,
    r: &Rendered,
    t0: std::time::Instant,
) -> anyhow::Result<()> {
    let n = n_cams.max(1) as f64;
    let mut report = json!({
        "scene": shown(&args.scene, false),
        "kind": scene.kind(),
        "primitives": scene.len(),
        "views": r.views,
        "output": args.output.display().to_string(),
        "seconds": t0.elapsed().as_secs_f64(),
    });
    if let Raster::Gaussians(_) = scene {
        report["filter_2d"] = json!(model::filter3d::filter_2d_label(filter_2d));
    }
    if args.compare.is_some() {
        report["mean_psnr"] = json!(r.psnr_sum / n);
        report["mean_ssim"] = json!(r.ssim_sum / n);
        args.common.say(format!(
            "mean over {} views: PSNR {:.2} dB, SSIM {:.4}",
            n_cams,
            r.psnr_sum / n,
            r.ssim_sum / n
        ));
    }
    args.common.say(format!(
        "render: {} {} from {} cameras into {} ({:.1} s)",
        scene.len(),
        scene.kind(),
        n_cams,
        args.output.display(),
        t0.elapsed().as_secs_f64()
    ));
    args.common.emit_json(&report)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use glam::{DMat3, DVec3};

    use super::*;
    use crate::model::Texture;

    /// A 64×64 camera at the origin looking down +z (OpenCV axes), f = 60.
    fn camera() -> Camera {
        Camera::pinhole(
            "c",
            64,
            64,
            60.0,
            60.0,
            32.0,
            32.0,
            DMat3::IDENTITY,
            DVec3::ZERO,
        )
    }

    /// The square x, y ∈ [−1, 1] at z = 3 (two triangles), tilted by
    /// `tilt` radians about the y axis.
    fn quad(tilt: f64) -> Mesh {
        let v = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]].map(|[x, y]| {
            let (s, c) = tilt.sin_cos();
            [(x * c) as f32, y as f32, (3.0 + x * s) as f32]
        });
        Mesh::new(v.to_vec(), vec![[0, 1, 2], [0, 2, 3]])
    }

    fn shade(m: &Mesh, shading: Shading) -> RenderOutput {
        let cam = camera();
        shade_mesh(
            m,
            &zbuffer::render(&m.vertices, &m.faces, &cam, 0.1),
            [0.0; 3],
            shading,
        )
    }

    /// Unlit vertex colours: a colour linear in x and y, which both
    /// triangles interpolate exactly, against the image computed from the
    /// pixel rays; and a constant colour reproduced exactly.
    #[test]
    fn unlit_vertex_colours_match_the_analytic_image() {
        let mut m = quad(0.0);
        let colour = |x: f32, y: f32| [(x + 1.0) / 2.0, (y + 1.0) / 2.0, 128.0 / 255.0];
        m.vertex_colors = Some(
            m.vertices
                .iter()
                .map(|p| {
                    let c = colour(p[0], p[1]).map(|v| (v * 255.0).round() as u8);
                    [c[0], c[1], c[2], 255]
                })
                .collect(),
        );
        let out = shade(&m, Shading::None);
        let cam = camera();
        let expect: Vec<[f32; 3]> = (0..64 * 64)
            .map(|i| {
                let (px, py) = ((i % 64) as f64 + 0.5, (i / 64) as f64 + 0.5);
                let (x, y) = ((px - cam.cx) / cam.fx * 3.0, (py - cam.cy) / cam.fy * 3.0);
                if x.abs() <= 1.0 && y.abs() <= 1.0 {
                    colour(x as f32, y as f32)
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        let p = psnr(&out.rgb, &expect);
        eprintln!("unlit vertex colours vs the analytic image: {p:.1} dB");
        assert!(p >= 50.0, "PSNR {p:.1} dB");
        // a constant colour is given exactly at every covered pixel
        m.vertex_colors = Some(vec![[200, 100, 50, 255]; 4]);
        let out = shade(&m, Shading::None);
        let want = [200.0 / 255.0, 100.0 / 255.0, 50.0 / 255.0];
        let covered: Vec<_> = (0..out.rgb.len()).filter(|&i| out.alpha[i] > 0.0).collect();
        assert!(covered.len() > 1000);
        for i in covered {
            for (got, want) in out.rgb[i].iter().zip(want) {
                assert!((got - want).abs() < 1e-6, "{:?}", out.rgb[i]);
            }
        }
    }

    #[test]
    fn lit_is_darker_than_unlit_on_a_tilted_face() {
        let mut m = quad(0.8);
        m.vertex_colors = Some(vec![[200, 200, 200, 255]; 4]);
        let mean = |o: &RenderOutput| o.rgb.iter().map(|c| c[0] as f64).sum::<f64>();
        let (lit, none) = (shade(&m, Shading::Lit), shade(&m, Shading::None));
        assert!(
            mean(&lit) < 0.9 * mean(&none),
            "{} {}",
            mean(&lit),
            mean(&none)
        );
        // untextured, uncoloured: grey 0.8, unlit
        m.vertex_colors = None;
        let o = shade(&m, Shading::None);
        assert!(
            o.rgb
                .iter()
                .zip(&o.alpha)
                .all(|(c, &a)| a == 0.0 || *c == [0.8; 3])
        );
    }

    /// A textured quad: texel (col, row) of a 4×4 image shows at the pixel
    /// where its centre lands, v pointing up (row 0 at the top of the view,
    /// since the camera's y axis points down and v = 1 is at y = −1).
    #[test]
    fn textured_quad_samples_the_right_texels() {
        let mut m = quad(0.0);
        // corners (−1,−1) (1,−1) (1,1) (−1,1): top-left, top-right, bottom-right, bottom-left in the view
        let uv = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
        m.uvs = Some(m.faces.iter().map(|f| f.map(|i| uv[i as usize])).collect());
        let pixels: Vec<[u8; 3]> = (0..16u8)
            .map(|i| [i * 16, 255 - i * 16, (i % 4) * 60])
            .collect();
        m.texture = Some(Box::new(Texture {
            name: "t.png".into(),
            width: 4,
            height: 4,
            pixels: pixels.clone(),
        }));
        m.vertex_colors = Some(vec![[0, 0, 0, 255]; 4]); // the texture wins
        let out = shade(&m, Shading::None);
        for row in 0..4 {
            for col in 0..4 {
                // texel centre in world x, y, then its pixel (f = 60, z = 3: 20 px per unit)
                let (x, y) = (
                    -1.0 + (col as f64 + 0.5) / 2.0,
                    -1.0 + (row as f64 + 0.5) / 2.0,
                );
                let (px, py) = ((32.0 + 20.0 * x) as usize, (32.0 + 20.0 * y) as usize);
                let got = out.rgb[py * 64 + px];
                let want = pixels[row * 4 + col].map(|v| v as f32 / 255.0);
                for k in 0..3 {
                    // the pixel centre is 0.5 px (1/40 texel) from the texel centre
                    assert!(
                        (got[k] - want[k]).abs() < 0.05,
                        "texel {col},{row}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }
}
