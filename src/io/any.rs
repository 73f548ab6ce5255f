//! Loading and saving by kind of scene, whatever the file format: the
//! commands call these so every format works everywhere it makes sense.

use std::io::Write;
use std::path::Path;

use crate::io::detect::{FileFormat, PlyKind};
use crate::io::ply::{Format, Header};
use crate::io::{gltf, obj, off, ply, read_input, torch_pt};
use crate::model::{Mesh, TriangleSoup};
use crate::{Error, Result};

/// A triangle-splat soup or a plain mesh (what `export-off` accepts).
#[derive(Clone, Debug)]
pub enum SoupOrMesh {
    Soup(TriangleSoup),
    Mesh(Mesh),
}

fn detect(path: &Path, name: &str, bytes: &[u8]) -> Result<FileFormat> {
    FileFormat::detect(path, bytes).ok_or_else(|| {
        Error::format(
            name,
            "unknown file format (expected PLY, OBJ, OFF, glTF/GLB or a .pt checkpoint)",
        )
    })
}

/// Reads a triangle soup: a Triangle Splatting checkpoint
/// (`point_cloud_state_dict.pt`) or a splatkit triangle-soup PLY.
pub fn load_soup(path: &Path) -> Result<TriangleSoup> {
    match load_soup_or_mesh(path)? {
        SoupOrMesh::Soup(s) => Ok(s),
        SoupOrMesh::Mesh(_) => Err(Error::format(
            crate::cli::shown(path, false),
            "is a mesh, not a triangle-splat soup (no per-triangle opacity and sigma)",
        )),
    }
}

/// Reads a soup (checkpoint or soup PLY) or, for any other mesh file, a mesh.
pub fn load_soup_or_mesh(path: &Path) -> Result<SoupOrMesh> {
    let input = read_input(path)?;
    let name = input.name.clone();
    let bytes: &[u8] = &input;
    Ok(match detect(path, &name, bytes)? {
        FileFormat::TorchPt => SoupOrMesh::Soup(torch_pt::parse_triangle_checkpoint(&name, bytes)?),
        FileFormat::Ply => {
            let h = Header::parse(&name, bytes)?;
            match PlyKind::of(&h) {
                PlyKind::TriangleSoup => SoupOrMesh::Soup(ply::soup::parse_soup(&name, bytes)?),
                PlyKind::Gaussians | PlyKind::CompressedGaussians => {
                    return Err(Error::format(
                        &name,
                        "is a Gaussian splat PLY, not triangles or a mesh",
                    ));
                }
                _ => SoupOrMesh::Mesh(ply::mesh::parse_mesh(&name, bytes)?),
            }
        }
        other => SoupOrMesh::Mesh(parse_mesh_as(other, &name, bytes)?),
    })
}

/// Reads a mesh in any supported format.
pub fn load_mesh(path: &Path) -> Result<Mesh> {
    let input = read_input(path)?;
    let name = input.name.clone();
    let f = detect(path, &name, &input)?;
    parse_mesh_as(f, &name, &input)
}

fn parse_mesh_as(f: FileFormat, name: &str, bytes: &[u8]) -> Result<Mesh> {
    match f {
        FileFormat::Ply => ply::mesh::parse_mesh(name, bytes),
        FileFormat::Obj => obj::parse_obj(name, bytes),
        FileFormat::Off => off::parse_off(name, bytes),
        FileFormat::Glb | FileFormat::Gltf => gltf::parse_gltf(name, bytes),
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

/// Writes a soup as a soup PLY (binary little-endian) or a `.pt` checkpoint.
pub fn write_soup_as(w: &mut dyn Write, soup: &TriangleSoup, f: FileFormat) -> Result<()> {
    match f {
        FileFormat::Ply => ply::soup::write_soup(w, soup, Format::BinaryLittleEndian),
        FileFormat::TorchPt => torch_pt::write_triangle_checkpoint(w, soup),
        other => Err(Error::invalid(format!(
            "a triangle soup can be written as ply or pt, not {}",
            other.name()
        ))),
    }
}

/// Writes a mesh as PLY (binary little-endian, every attribute kept), OBJ,
/// OFF (COFF with vertex colours) or glTF/GLB.
pub fn write_mesh_as(w: &mut dyn Write, mesh: &Mesh, f: FileFormat) -> Result<()> {
    match f {
        FileFormat::Ply => ply::mesh::write_mesh(w, mesh, Format::BinaryLittleEndian),
        FileFormat::Obj => obj::write_obj(w, mesh, &obj::ObjWriteOptions::default()),
        FileFormat::Off => off::write_off(w, mesh, &off::OffWriteOptions::for_mesh(mesh)),
        FileFormat::Glb | FileFormat::Gltf => gltf::write_gltf(
            w,
            mesh,
            &gltf::GltfWriteOptions {
                container: if f == FileFormat::Gltf {
                    gltf::GltfContainer::Gltf
                } else {
                    gltf::GltfContainer::Glb
                },
            },
        ),
        other => Err(Error::invalid(format!(
            "a mesh can be written as ply, obj, off, glb or gltf, not {}",
            other.name()
        ))),
    }
}
