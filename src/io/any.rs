//! The one loader and saver: every command reads its scene inputs through
//! [`load`] (or [`open`] + [`Opened::decode`] when it also wants the format)
//! and writes them through [`save`] / [`save_mesh`] / [`save_soup`] /
//! [`save_points`]. Format detection ([`FileFormat::detect`]: content first,
//! extension second), the PLY kind decision ([`PlyKind::of`]) and the choice
//! of parser happen here and nowhere else.
//!
//! Kinds by format:
//! - PLY: by its header: 3DGS properties → Gaussians, the same with two
//!   scales (`scale_0`, `scale_1`, no `scale_2`) → 2DGS surfels, faces carrying
//!   `opacity` and `sigma` → triangle soup, faces → mesh, vertices only →
//!   point cloud; SuperSplat compressed PLY (`packed_position`) → Gaussians;
//! - SPZ (by its magic, also gzip-wrapped) → Gaussians;
//! - `.splat` (antimatter15) and `.ksplat` (GaussianSplats3D), by extension:
//!   they have no magic bytes → Gaussians;
//! - `.pt` (Triangle Splatting checkpoint) → triangle soup;
//! - OBJ, OFF, glTF/GLB → mesh;
//! - `.npz` / `.json` are camera files, not scenes (see `io::cameras`).
//!
//! A command states the kinds it accepts ([`load_kinds`] and the typed
//! shorthands); any other kind gets the same error everywhere: the file,
//! what it holds, and what the command takes.

use std::path::{Path, PathBuf};

use crate::io::detect::{FileFormat, PlyKind};
use crate::io::ply::{Format, Header};
use crate::io::source::shown;
use crate::io::{Input, gltf, obj, off, ply, read_input, splat, torch_pt, write_output};
use crate::model::{
    BoundGaussians, Gaussians, Mesh, PointCloud, Scene, SceneKind, Surfels, TriangleSoup,
};
use crate::{Error, Result};

/// An input read once (file or stdin), with its detected format and, for a
/// scene file, the kind of scene it holds.
pub struct Opened {
    /// The bytes (memory-mapped file or stdin) and the display name.
    pub input: Input,
    /// The format, from content first and extension second.
    pub format: FileFormat,
    /// What a PLY's header says it holds (`None` for other formats).
    pub ply_kind: Option<PlyKind>,
    /// The folder relative files (glTF external buffers, OBJ materials and
    /// textures) are resolved in:
    /// the file's folder, or the current folder for stdin.
    pub base: PathBuf,
}

impl Opened {
    /// Display name for messages (`<stdin>` for `-`).
    pub fn name(&self) -> &str {
        &self.input.name
    }

    /// The scene kind the file holds, or why it holds none.
    pub fn kind(&self) -> Result<SceneKind> {
        let name = self.name();
        Ok(match self.format {
            FileFormat::TorchPt => SceneKind::TriangleSoup,
            FileFormat::Splat | FileFormat::Ksplat | FileFormat::Spz | FileFormat::Sog => {
                SceneKind::Gaussians
            }
            FileFormat::Obj | FileFormat::Off | FileFormat::Glb | FileFormat::Gltf => {
                SceneKind::Mesh
            }
            FileFormat::Ply => match self.ply_kind.unwrap_or(PlyKind::Other) {
                PlyKind::Gaussians | PlyKind::CompressedGaussians => SceneKind::Gaussians,
                PlyKind::Surfels => SceneKind::Surfels,
                PlyKind::TriangleSoup => SceneKind::TriangleSoup,
                PlyKind::Mesh => SceneKind::Mesh,
                PlyKind::PointCloud => SceneKind::PointCloud,
                PlyKind::Other => {
                    return Err(Error::format(
                        name,
                        "a PLY with no 'vertex' element holding x: not a scene (points, mesh, \
                         Gaussians, surfels or triangle splats)",
                    ));
                }
            },
            FileFormat::Npz | FileFormat::Json => {
                return Err(Error::format(
                    name,
                    format!("is a camera file ({}), not a scene", self.format.name()),
                ));
            }
        })
    }

    /// Parses the scene with the reader of its format and kind.
    pub fn decode(&self) -> Result<Scene> {
        let name = self.name();
        let bytes: &[u8] = &self.input;
        Ok(match (self.kind()?, self.format) {
            (SceneKind::TriangleSoup, FileFormat::TorchPt) => {
                Scene::TriangleSoup(torch_pt::parse_triangle_checkpoint(name, bytes)?)
            }
            (SceneKind::TriangleSoup, _) => {
                Scene::TriangleSoup(ply::soup::parse_soup(name, bytes)?)
            }
            (SceneKind::Gaussians, FileFormat::Splat) => {
                Scene::Gaussians(splat::dot_splat::read(name, bytes)?)
            }
            (SceneKind::Gaussians, FileFormat::Ksplat) => {
                Scene::Gaussians(splat::ksplat::read(name, bytes)?)
            }
            (SceneKind::Gaussians, FileFormat::Spz) => {
                Scene::Gaussians(splat::spz::read(name, bytes)?)
            }
            (SceneKind::Gaussians, FileFormat::Sog) => {
                Scene::Gaussians(splat::sog::read(name, bytes, &self.base)?)
            }
            (SceneKind::Gaussians, _) => {
                // a 3DGS or a SuperSplat compressed PLY
                Scene::Gaussians(ply::gaussians::parse_gaussians(name, bytes)?)
            }
            (SceneKind::Surfels, _) => Scene::Surfels(ply::surfels::parse_surfels(name, bytes)?),
            (SceneKind::PointCloud, _) => {
                Scene::PointCloud(ply::points::parse_points(name, bytes)?)
            }
            (SceneKind::Mesh, f) => {
                let m = parse_mesh_as(f, name, bytes, &self.base)?;
                // A zero-byte or garbage text file parses as "no statements":
                // an empty mesh is never what a user meant to pass.
                if m.vertices.is_empty() {
                    return Err(Error::format(
                        name,
                        format!(
                            "holds no vertices: an empty {} file, or not one at all",
                            f.name()
                        ),
                    ));
                }
                Scene::Mesh(m)
            }
        })
    }

    /// Decodes the scene if its kind is one of `accepts`; otherwise the
    /// common wrong-kind error naming `command`.
    pub fn decode_kinds(&self, command: &str, accepts: &[SceneKind]) -> Result<Scene> {
        let kind = self.kind()?;
        if !accepts.contains(&kind) {
            return Err(self.wrong_kind(kind, command, accepts));
        }
        self.decode()
    }

    fn wrong_kind(&self, found: SceneKind, command: &str, accepts: &[SceneKind]) -> Error {
        let takes = format!(
            "{command} takes {}, and this file holds {}",
            SceneKind::list(accepts),
            found.phrase()
        );
        // 2DGS surfels where 3D Gaussians are wanted: say what tells them apart.
        if found == SceneKind::Surfels && accepts.contains(&SceneKind::Gaussians) {
            return Error::format(
                self.name(),
                format!(
                    "{takes} (a 2DGS model: two scales per splat, scale_0 and scale_1, no \
                     scale_2); {command} works on 3D Gaussians only"
                ),
            );
        }
        // A PLY meant to be Gaussians: say which 3DGS properties are missing.
        if self.format == FileFormat::Ply
            && accepts.contains(&SceneKind::Gaussians)
            && let Err(Error::Format { path, msg }) =
                ply::gaussians::check_layout(self.name(), &self.input)
        {
            return Error::format(path, format!("{msg} ({takes})"));
        }
        Error::format(self.name(), takes)
    }
}

/// Reads `path` (`-` = stdin, read once) and detects its format and kind.
pub fn open(path: &Path) -> Result<Opened> {
    let input = read_input(path)?;
    let format = FileFormat::detect(path, &input).ok_or_else(|| {
        Error::format(
            &input.name,
            "unknown file format (expected PLY, OBJ, OFF, glTF/GLB, a .pt checkpoint, \
             .spz, .splat or .ksplat)",
        )
    })?;
    let ply_kind = if format == FileFormat::Ply {
        Some(PlyKind::of(&Header::parse(&input.name, &input)?))
    } else {
        None
    };
    let base = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() && !input.is_stdin() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    Ok(Opened {
        input,
        format,
        ply_kind,
        base,
    })
}

/// Loads any scene file.
pub fn load(path: &Path) -> Result<Scene> {
    open(path)?.decode()
}

/// Loads a scene of one of the kinds `command` accepts.
pub fn load_kinds(path: &Path, command: &str, accepts: &[SceneKind]) -> Result<Scene> {
    open(path)?.decode_kinds(command, accepts)
}

/// Loads a mesh (PLY with faces, OBJ, OFF, glTF/GLB).
pub fn load_mesh(path: &Path, command: &str) -> Result<Mesh> {
    match load_kinds(path, command, &[SceneKind::Mesh])? {
        Scene::Mesh(m) => Ok(m),
        _ => unreachable!("load_kinds returns an accepted kind"),
    }
}

/// Loads a triangle-splat soup (Triangle Splatting checkpoint or soup PLY).
pub fn load_soup(path: &Path, command: &str) -> Result<TriangleSoup> {
    match load_kinds(path, command, &[SceneKind::TriangleSoup])? {
        Scene::TriangleSoup(s) => Ok(s),
        _ => unreachable!("load_kinds returns an accepted kind"),
    }
}

/// Loads 3DGS Gaussians.
pub fn load_gaussians(path: &Path, command: &str) -> Result<Gaussians> {
    match load_kinds(path, command, &[SceneKind::Gaussians])? {
        Scene::Gaussians(g) => Ok(g),
        _ => unreachable!("load_kinds returns an accepted kind"),
    }
}

/// Loads 2DGS surfels.
pub fn load_surfels(path: &Path, command: &str) -> Result<Surfels> {
    match load_kinds(path, command, &[SceneKind::Surfels])? {
        Scene::Surfels(s) => Ok(s),
        _ => unreachable!("load_kinds returns an accepted kind"),
    }
}

/// Writes surfels as a binary little-endian 2DGS PLY, atomically
/// (`-` = stdout).
pub fn save_surfels(path: &Path, s: &Surfels) -> Result<()> {
    write_output(path, |w| {
        ply::surfels::write_surfels(w, s, Format::BinaryLittleEndian)
    })
}

/// Loads Gaussians bound to a mesh (a file written by `bind-gaussians` or
/// `refine`): the binding, checked for consistency, and the file's standard
/// 3DGS values.
pub fn load_bound(path: &Path, command: &str) -> Result<(BoundGaussians, Gaussians)> {
    let g = load_gaussians(path, command)?;
    let b = ply::bound::detach(&shown(path, false), &g)?;
    Ok((b, g))
}

/// Refuses a mesh with a NaN or infinite vertex coordinate (every vertex,
/// used by a face or not: an optimiser moves them all), naming `name`, the
/// vertex (0-based) and the coordinate, e.g. `mesh.ply: vertex 17 has a
/// non-finite coordinate (y = NaN)`. For the commands that optimise, bind
/// or fuse a mesh (`refine`, `bind-gaussians`, `tsdf-fuse`); `clean` (which
/// removes such faces), `info` and `render` (which draws what is finite)
/// read meshes without it.
pub fn check_finite_mesh(name: &str, mesh: &Mesh) -> Result<()> {
    match ply::first_non_finite(mesh.vertices.as_flattened()) {
        Some(t) => Err(Error::format(
            name,
            format!(
                "vertex {} has a non-finite coordinate ({} = {}): this command needs finite \
                 vertices (`clean` removes the faces that use such vertices)",
                t / 3,
                ["x", "y", "z"][t % 3],
                mesh.vertices[t / 3][t % 3]
            ),
        )),
        None => Ok(()),
    }
}

/// Refuses a triangle soup with a NaN or infinite value in what a trainer
/// reads: vertex coordinates, opacity, sigma, SH (DC and rest). The error
/// names `name`, the triangle (0-based) and the value, e.g. `triangle 4
/// has sigma = inf, not a finite number`.
pub fn check_finite_soup(name: &str, soup: &TriangleSoup) -> Result<()> {
    let k3 = soup.rest_per_channel() * 3;
    // (values, values per row, name of the value at a position in a row)
    type Named<'a> = (&'a [f32], usize, &'a dyn Fn(usize) -> String);
    let arrays: [Named; 5] = [
        (soup.triangles.as_flattened().as_flattened(), 9, &|j| {
            format!("vertex {} {}", j / 3, ["x", "y", "z"][j % 3])
        }),
        (&soup.opacity_raw, 1, &|_| "opacity".into()),
        (&soup.sigma_raw, 1, &|_| "sigma".into()),
        (soup.sh_dc.as_flattened(), 3, &|j| format!("SH DC {j}")),
        (&soup.sh_rest, k3.max(1), &|j| format!("SH rest {j}")),
    ];
    for (values, width, what) in arrays {
        if let Some(t) = ply::first_non_finite(values) {
            return Err(Error::format(
                name,
                format!(
                    "triangle {} has {} = {}, not a finite number",
                    t / width,
                    what(t % width),
                    values[t]
                ),
            ));
        }
    }
    Ok(())
}

/// [`load_mesh`], then [`check_finite_mesh`]: for commands that bind or
/// optimise the mesh.
pub fn load_mesh_finite(path: &Path, command: &str) -> Result<Mesh> {
    let m = load_mesh(path, command)?;
    check_finite_mesh(&shown(path, false), &m)?;
    Ok(m)
}

/// [`load_gaussians`], then [`ply::gaussians::check_finite`]: for commands
/// that train from the Gaussians or take values from them.
pub fn load_gaussians_finite(path: &Path, command: &str) -> Result<Gaussians> {
    let g = load_gaussians(path, command)?;
    ply::gaussians::check_finite(&shown(path, false), &g)?;
    Ok(g)
}

/// [`load_soup`], then [`check_finite_soup`]: for commands that train it.
pub fn load_soup_finite(path: &Path, command: &str) -> Result<TriangleSoup> {
    let s = load_soup(path, command)?;
    check_finite_soup(&shown(path, false), &s)?;
    Ok(s)
}

/// Writes Gaussians as a binary little-endian 3DGS PLY, atomically
/// (`-` = stdout).
pub fn save_gaussians(path: &Path, g: &Gaussians) -> Result<()> {
    write_output(path, |w| {
        ply::gaussians::write_gaussians(w, g, Format::BinaryLittleEndian)
    })
}

/// Loads points: a point cloud, or a mesh's vertices (with their normals
/// and colours).
pub fn load_points(path: &Path, command: &str) -> Result<PointCloud> {
    let scene = load_kinds(path, command, &[SceneKind::PointCloud, SceneKind::Mesh])?;
    Ok(scene.into_points().expect("points or mesh"))
}

fn parse_mesh_as(f: FileFormat, name: &str, bytes: &[u8], base: &Path) -> Result<Mesh> {
    match f {
        FileFormat::Ply => ply::mesh::parse_mesh(name, bytes),
        FileFormat::Obj => obj::parse_obj_in(name, bytes, base),
        FileFormat::Off => off::parse_off(name, bytes),
        FileFormat::Glb | FileFormat::Gltf => gltf::parse_gltf_in(name, bytes, base),
        other => Err(Error::format(
            name,
            format!("is a {} file, not a mesh", other.name()),
        )),
    }
}

/// Output format for `path`: `explicit` if given, else the extension, else
/// `default` (used for stdout).
pub fn output_format(
    path: &Path,
    explicit: Option<FileFormat>,
    default: FileFormat,
) -> Result<FileFormat> {
    if let Some(f) = explicit {
        return Ok(f);
    }
    if path.as_os_str() == "-" {
        return Ok(default);
    }
    FileFormat::from_extension(path).ok_or_else(|| {
        Error::invalid(format!(
            "{}: cannot tell the output format from the extension; give --format",
            path.display()
        ))
    })
}

/// Writes a soup as a soup PLY (binary little-endian) or a `.pt` checkpoint,
/// atomically (`-` = stdout).
pub fn save_soup(path: &Path, soup: &TriangleSoup, f: FileFormat) -> Result<()> {
    if !matches!(f, FileFormat::Ply | FileFormat::TorchPt) {
        return Err(Error::invalid(format!(
            "a triangle soup can be written as ply or pt, not {}",
            f.name()
        )));
    }
    write_output(path, |w| match f {
        FileFormat::Ply => ply::soup::write_soup(w, soup, Format::BinaryLittleEndian),
        _ => torch_pt::write_triangle_checkpoint(w, soup),
    })
}

/// How a mesh is written where a format has choices.
#[derive(Clone, Debug, Default)]
pub struct MeshWriteOptions {
    /// OFF layout; `None` = [`off::OffWriteOptions::for_mesh`] (COFF when
    /// the mesh has vertex colours).
    pub off: Option<off::OffWriteOptions>,
    /// glTF/GLB: `alphaMode` BLEND for the colour material even when every
    /// alpha is 255 (see [`gltf::GltfWriteOptions::blend`]).
    pub gltf_blend: bool,
    /// glTF/GLB: mark the colour material `doubleSided` (triangle soups).
    pub double_sided: bool,
}

/// The vertex and face counts of the file [`save_mesh`] writes for `mesh`
/// as `f`: glTF/GLB and OBJ un-share the vertices of a mesh that has face
/// colours and no vertex colours (three per face, see
/// [`gltf::face_colors_to_corners`]); PLY and OFF keep the mesh's counts.
/// Reading the written file back gives these counts.
pub fn written_counts(mesh: &Mesh, f: FileFormat) -> (usize, usize) {
    let unshared = match f {
        FileFormat::Glb | FileFormat::Gltf => gltf::unshares_vertices(mesh),
        FileFormat::Obj => obj::unshares_vertices(mesh, &obj::ObjWriteOptions::default()),
        _ => false,
    };
    if unshared {
        (3 * mesh.faces.len(), mesh.faces.len())
    } else {
        (mesh.vertices.len(), mesh.faces.len())
    }
}

/// Writes a mesh as PLY (binary little-endian, every attribute kept), OBJ,
/// OFF or glTF/GLB, atomically (`-` = stdout). Texture coordinates are
/// written to OBJ only; a mesh with a texture written as OBJ to a file
/// becomes three files, `NAME.obj`, `NAME.mtl` (material `material_0`,
/// `map_Kd NAME.png`) and `NAME.png`, renamed into place together (see
/// [`crate::io::source::write_outputs`]).
pub fn save_mesh(path: &Path, mesh: &Mesh, f: FileFormat, opts: &MeshWriteOptions) -> Result<()> {
    if let (FileFormat::Obj, Some(tex), false) = (f, &mesh.texture, path.as_os_str() == "-") {
        return save_textured_obj(path, mesh, tex);
    }
    if !matches!(
        f,
        FileFormat::Ply | FileFormat::Obj | FileFormat::Off | FileFormat::Glb | FileFormat::Gltf
    ) {
        return Err(Error::invalid(format!(
            "a mesh can be written as ply, obj, off, glb or gltf, not {}",
            f.name()
        )));
    }
    write_output(path, |w| match f {
        FileFormat::Ply => ply::mesh::write_mesh(w, mesh, Format::BinaryLittleEndian),
        FileFormat::Obj => obj::write_obj(w, mesh, &obj::ObjWriteOptions::default()),
        FileFormat::Off => {
            let o = opts
                .off
                .unwrap_or_else(|| off::OffWriteOptions::for_mesh(mesh));
            off::write_off(w, mesh, &o)
        }
        _ => gltf::write_gltf(
            w,
            mesh,
            &gltf::GltfWriteOptions {
                container: if f == FileFormat::Gltf {
                    gltf::GltfContainer::Gltf
                } else {
                    gltf::GltfContainer::Glb
                },
                blend: opts.gltf_blend,
                double_sided: opts.double_sided,
            },
        ),
    })
}

/// The three files of a textured OBJ (see [`save_mesh`]).
fn save_textured_obj(path: &Path, mesh: &Mesh, tex: &crate::model::Texture) -> Result<()> {
    mesh.validate()
        .map_err(|e| Error::invalid(format!("cannot write OBJ: {e}")))?;
    let mtl = path.with_extension("mtl");
    let png = path.with_extension("png");
    let file_name = |p: &Path| {
        p.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let (mtl_name, png_name) = (file_name(&mtl), file_name(&png));
    let material = "material_0";
    let bytes: Vec<u8> = tex.pixels.iter().flatten().copied().collect();
    crate::io::source::write_outputs(vec![
        (
            png.clone(),
            Box::new(|w: &mut dyn std::io::Write| {
                crate::io::image::write_png8(w, &png_name, tex.width, tex.height, 3, &bytes)
            }),
        ),
        (
            mtl.clone(),
            Box::new(|w: &mut dyn std::io::Write| obj::write_mtl(w, material, &png_name)),
        ),
        (
            path.to_path_buf(),
            Box::new(|w: &mut dyn std::io::Write| {
                obj::write_obj_with_material(
                    w,
                    mesh,
                    &obj::ObjWriteOptions::default(),
                    &mtl_name,
                    material,
                )
            }),
        ),
    ])
}

/// Writes a point cloud as PLY in `format` (every attribute kept),
/// atomically (`-` = stdout).
pub fn save_points(path: &Path, points: &PointCloud, format: Format) -> Result<()> {
    write_output(path, |w| ply::points::write_points(w, points, format))
}

/// Writes any scene in its natural file (Gaussians: 3DGS PLY; surfels: 2DGS
/// PLY; soup: soup
/// PLY or `.pt`; mesh: `f`; points: binary PLY), atomically.
pub fn save(path: &Path, scene: &Scene, f: FileFormat) -> Result<()> {
    match scene {
        Scene::Gaussians(g) => {
            if f != FileFormat::Ply {
                return Err(Error::invalid(format!(
                    "Gaussians are written as a 3DGS ply, not {}",
                    f.name()
                )));
            }
            write_output(path, |w| {
                ply::gaussians::write_gaussians(w, g, Format::BinaryLittleEndian)
            })
        }
        Scene::Surfels(s) => {
            if f != FileFormat::Ply {
                return Err(Error::invalid(format!(
                    "surfels are written as a 2DGS ply, not {}",
                    f.name()
                )));
            }
            save_surfels(path, s)
        }
        Scene::TriangleSoup(s) => save_soup(path, s, f),
        Scene::Mesh(m) => save_mesh(path, m, f, &MeshWriteOptions::default()),
        Scene::PointCloud(p) => {
            if f != FileFormat::Ply {
                return Err(Error::invalid(format!(
                    "a point cloud is written as ply, not {}",
                    f.name()
                )));
            }
            save_points(path, p, Format::BinaryLittleEndian)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Mesh;

    fn tri() -> Mesh {
        Mesh::new(
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        )
    }

    /// Every kind round-trips through save + load, and the loader tells the
    /// kind from the content, not the name.
    #[test]
    fn save_then_load_gives_the_same_kind_and_data() {
        let dir = tempfile::tempdir().unwrap();
        let m = tri();
        for ext in ["ply", "obj", "off", "glb", "gltf"] {
            let p = dir.path().join(format!("m.{ext}"));
            let f = FileFormat::from_extension(&p).unwrap();
            save(&p, &Scene::Mesh(m.clone()), f).unwrap();
            let back = load(&p).unwrap();
            assert_eq!(back.kind(), SceneKind::Mesh, "{ext}");
            let Scene::Mesh(b) = back else { unreachable!() };
            assert_eq!(b.faces, m.faces, "{ext}");
            assert_eq!(b.vertices, m.vertices, "{ext}");
        }
        let pts = PointCloud {
            positions: vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]],
            ..Default::default()
        };
        let p = dir.path().join("p.ply");
        save(&p, &Scene::PointCloud(pts.clone()), FileFormat::Ply).unwrap();
        assert_eq!(
            load(&p).unwrap().into_points().unwrap().positions,
            pts.positions
        );
    }

    /// A kind the command does not take is refused with one message shape:
    /// the file, what the command takes, what the file holds.
    #[test]
    fn wrong_kinds_get_the_same_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.obj");
        save(&p, &Scene::Mesh(tri()), FileFormat::Obj).unwrap();
        let e = load_soup(&p, "prune-triangles").unwrap_err().to_string();
        assert!(e.starts_with(&p.display().to_string()), "{e}");
        assert!(
            e.ends_with("prune-triangles takes a triangle-splat soup, and this file holds a mesh"),
            "{e}"
        );
        let e = load_gaussians(&p, "render").unwrap_err().to_string();
        assert!(
            e.ends_with("render takes Gaussian splats, and this file holds a mesh"),
            "{e}"
        );
        // A PLY of points asked for as Gaussians names the missing properties.
        let q = dir.path().join("p.ply");
        save(
            &q,
            &Scene::PointCloud(PointCloud {
                positions: vec![[0.0; 3]],
                ..Default::default()
            }),
            FileFormat::Ply,
        )
        .unwrap();
        let e = load_gaussians(&q, "splat2points").unwrap_err().to_string();
        assert!(
            e.contains("is not a 3DGS Gaussian layout: missing properties"),
            "{e}"
        );
        assert!(
            e.contains("splat2points takes Gaussian splats, and this file holds a point cloud"),
            "{e}"
        );
        // camera files and unknown bytes are not scenes
        let c = dir.path().join("cameras.json");
        std::fs::write(&c, "[]").unwrap();
        assert!(load(&c).unwrap_err().to_string().contains("camera file"));
        let u = dir.path().join("x.bin");
        std::fs::write(&u, "hello").unwrap();
        assert!(
            load(&u)
                .unwrap_err()
                .to_string()
                .contains("unknown file format")
        );
    }

    /// A `.gltf` whose buffer is an external file next to it loads through
    /// the common loader (the buffer is resolved in the file's folder).
    #[test]
    fn gltf_external_buffers_resolve_next_to_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let mut bin = Vec::new();
        for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            bin.extend_from_slice(&v.to_le_bytes());
        }
        for i in [0u16, 1, 2, 0] {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        std::fs::write(dir.path().join("tri.bin"), &bin).unwrap();
        let json = r#"{"asset":{"version":"2.0"},
            "buffers":[{"uri":"tri.bin","byteLength":44}],
            "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},
                           {"buffer":0,"byteOffset":36,"byteLength":6}],
            "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
                          "min":[0,0,0],"max":[1,1,0]},
                         {"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}],
            "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
            "nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0}"#;
        let p = dir.path().join("tri.gltf");
        std::fs::write(&p, json).unwrap();
        let m = load_mesh(&p, "test").unwrap();
        assert_eq!(m.faces, vec![[0, 1, 2]]);
        assert_eq!(m.vertices[1], [1.0, 0.0, 0.0]);
    }
}
