//! The command table, above the ops: each per-command binary and the
//! umbrella `splatkit` binary parse the same argument structs and call the
//! same `run`. `cli` keeps only the conventions the commands share.

use clap::{Parser, Subcommand};

use crate::ops::{
    bake_texture, bind_gaussians, chamfer, clean, convert, decimate, demo, export_off, info,
    poisson, prune_triangles, refine, render, splat2points, tetra_mesh, train, tsdf_fuse,
};

/// splatkit: Gaussian- and triangle-splat scenes to meshes, and back.
#[derive(Parser, Debug)]
#[command(
    name = "splatkit",
    version,
    propagate_version = true,
    after_help = "Examples:
  # the built-in demo scene, end to end
  splatkit demo -o demo-out
  splatkit info scene.ply
  splatkit prune-triangles scene.pt --game-engine -o - \\
      | splatkit export-off - -o scene.off"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// The commands (each also exists as its own binary).
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Describe files: format, kind, counts, bounding box, SH degree, cameras.
    Info(info::InfoArgs),
    /// Filter a triangle-splat soup by opacity, sigma and count; solidify.
    PruneTriangles(prune_triangles::PruneTrianglesArgs),
    /// Export a triangle soup or mesh to OFF (Triangle Splatting layout), GLB, PLY or OBJ.
    ExportOff(export_off::ExportOffArgs),
    /// Evaluate a surface: generic Chamfer / F-score, DTU or Tanks-and-Temples protocol.
    Chamfer(chamfer::ChamferArgs),
    /// Screened Poisson reconstruction: oriented points to a mesh with per-vertex density.
    Poisson(poisson::PoissonArgs),
    /// Quadric-error decimation to a stated face or vertex count.
    Decimate(decimate::DecimateArgs),
    /// Mesh clean-up: duplicates, degenerate faces, non-manifold edges, small components.
    Clean(clean::CleanArgs),
    /// Convert Gaussian splats between formats (3DGS PLY, compressed PLY, SPZ, .splat), reporting the loss.
    Convert(convert::ConvertArgs),
    /// A 3DGS scene to oriented points on its density level set (SuGaR), for `poisson`.
    Splat2points(splat2points::Splat2PointsArgs),
    /// Render Gaussians, triangle splats or a mesh to colour, depth, alpha and normal images.
    Render(render::RenderArgs),
    /// Fuse depth maps (rendered from a scene, or files) into a coloured mesh: 2DGS / Open3D TSDF.
    TsdfFuse(tsdf_fuse::TsdfFuseArgs),
    /// Gaussian Opacity Fields' mesh: marching tetrahedra on the opacity field of a 3DGS scene.
    TetraMesh(tetra_mesh::TetraMeshArgs),
    /// Bind SuGaR's flat Gaussians to a mesh's triangles, or rebind them to an edited mesh.
    BindGaussians(bind_gaussians::BindGaussiansArgs),
    /// Refine bound Gaussians and their mesh against photos (SuGaR), with held-out PSNR / SSIM.
    Refine(refine::RefineArgs),
    /// Bake a Gaussian scene's colours into a texture on a mesh (SuGaR's textured OBJ export).
    BakeTexture(bake_texture::BakeTextureArgs),
    /// Train Triangle Splatting or 3DGS / SuGaR-regularised Gaussians from photos, on the CPU.
    Train(train::TrainArgs),
    /// Run every stage end to end on generated scenes: Gaussians to a mesh, bound and refined; triangles pruned and exported.
    Demo(demo::DemoArgs),
}

/// `main` of the umbrella binary.
pub fn splatkit_main() -> ! {
    let cli = Cli::parse();
    crate::cli::run_command(move || match cli.command {
        Command::Info(a) => info::run(a),
        Command::PruneTriangles(a) => prune_triangles::run(a),
        Command::ExportOff(a) => export_off::run(a),
        Command::Chamfer(a) => chamfer::run(a),
        Command::Poisson(a) => poisson::run(a),
        Command::Decimate(a) => decimate::run(a),
        Command::Clean(a) => clean::run(a),
        Command::Render(a) => render::run(a),
        Command::Convert(a) => convert::run(a),
        Command::TsdfFuse(a) => tsdf_fuse::run(a),
        Command::TetraMesh(a) => tetra_mesh::run(a),
        Command::Splat2points(a) => splat2points::run(a),
        Command::BindGaussians(a) => bind_gaussians::run(a),
        Command::Refine(a) => refine::run(a),
        Command::BakeTexture(a) => bake_texture::run(a),
        Command::Train(a) => train::run(a),
        Command::Demo(a) => demo::run(a),
    })
}

macro_rules! single_command {
    ($fn_name:ident, $bin:literal, $args:ty, $run:path, $about:literal) => {
        /// `main` of the single-command binary.
        pub fn $fn_name() -> ! {
            #[derive(Parser, Debug)]
            #[command(name = $bin, version, about = $about)]
            struct One {
                #[command(flatten)]
                args: $args,
            }
            let args = One::parse().args;
            crate::cli::run_command(move || $run(args))
        }
    };
}

single_command!(
    info_main,
    "info",
    info::InfoArgs,
    info::run,
    "Describe files: format, kind, counts, bounding box, SH degree, cameras."
);
single_command!(
    prune_triangles_main,
    "prune-triangles",
    prune_triangles::PruneTrianglesArgs,
    prune_triangles::run,
    "Filter a triangle-splat soup by opacity, sigma and count; solidify for game engines."
);
single_command!(
    export_off_main,
    "export-off",
    export_off::ExportOffArgs,
    export_off::run,
    "Export a triangle soup or mesh to OFF (Triangle Splatting layout), GLB, glTF, PLY or OBJ."
);
single_command!(
    chamfer_main,
    "chamfer",
    chamfer::ChamferArgs,
    chamfer::run,
    "Evaluate a surface: generic Chamfer / F-score, or the DTU and Tanks-and-Temples protocols."
);
single_command!(
    poisson_main,
    "poisson",
    poisson::PoissonArgs,
    poisson::run,
    "Screened Poisson reconstruction: oriented points to a mesh with per-vertex density."
);
single_command!(
    decimate_main,
    "decimate",
    decimate::DecimateArgs,
    decimate::run,
    "Quadric-error decimation of a mesh to a stated face or vertex count."
);
single_command!(
    clean_main,
    "clean",
    clean::CleanArgs,
    clean::run,
    "Mesh clean-up: duplicates, degenerate faces, non-manifold edges, small components."
);
single_command!(
    render_main,
    "render",
    render::RenderArgs,
    render::run,
    "Render Gaussians, triangle splats or a mesh to colour, depth, alpha and normal images."
);
single_command!(
    tetra_mesh_main,
    "tetra-mesh",
    tetra_mesh::TetraMeshArgs,
    tetra_mesh::run,
    "Gaussian Opacity Fields' mesh: marching tetrahedra on the opacity field of a 3DGS scene."
);
single_command!(
    tsdf_fuse_main,
    "tsdf-fuse",
    tsdf_fuse::TsdfFuseArgs,
    tsdf_fuse::run,
    "Fuse depth maps (rendered from a scene, or files) into a coloured mesh: 2DGS / Open3D TSDF."
);
single_command!(
    convert_main,
    "convert",
    convert::ConvertArgs,
    convert::run,
    "Convert Gaussian splats between formats (3DGS PLY, compressed PLY, SPZ, .splat), reporting the loss."
);
single_command!(
    splat2points_main,
    "splat2points",
    splat2points::Splat2PointsArgs,
    splat2points::run,
    "A 3DGS scene to oriented points on its density level set (SuGaR), for `poisson`."
);
single_command!(
    bind_gaussians_main,
    "bind-gaussians",
    bind_gaussians::BindGaussiansArgs,
    bind_gaussians::run,
    "Bind SuGaR's flat Gaussians to a mesh's triangles (1, 3, 4 or 6 per face), or rebind them to an edited mesh."
);
single_command!(
    refine_main,
    "refine",
    refine::RefineArgs,
    refine::run,
    "Refine Gaussians bound to a mesh, and the mesh, against photos (SuGaR's refinement)."
);
single_command!(
    bake_texture_main,
    "bake-texture",
    bake_texture::BakeTextureArgs,
    bake_texture::run,
    "Bake a Gaussian scene's colours into a texture on a mesh (SuGaR's textured OBJ export)."
);
single_command!(
    train_main,
    "train",
    train::TrainArgs,
    train::run,
    "Train Triangle Splatting or 3DGS / SuGaR-regularised Gaussians from photos, on the CPU."
);
