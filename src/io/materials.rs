//! Materials and texture files of a mesh file, as `info` reports them
//! (OBJ + MTL, glTF/GLB). Filled by [`crate::io::obj::inventory`] and
//! [`crate::io::gltf::inventory`].

use serde::Serialize;

/// One material a mesh file defines or uses.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct MaterialInfo {
    /// Its name (`newmtl` / `usemtl`, glTF `name`; glTF materials without a
    /// name are `material N`).
    pub name: String,
    /// glTF `alphaMode` (`OPAQUE`, `MASK`, `BLEND`); absent for OBJ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alpha_mode: Option<String>,
    /// Faces that use it (OBJ `usemtl`), or primitives (glTF).
    pub used_by: usize,
    /// False for an OBJ material that faces use but no MTL file defines.
    pub defined: bool,
    /// Its texture maps.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub textures: Vec<MaterialTexture>,
}

/// A texture map of a material.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct MaterialTexture {
    /// The slot: the MTL statement (`map_Kd`, `bump`, …) or the glTF
    /// property (`baseColorTexture`, `normalTexture`, …).
    pub slot: String,
    /// The image as [`TextureFile::file`] names it.
    pub file: String,
}

/// An image file a mesh file refers to.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct TextureFile {
    /// The path resolved against the mesh file's folder, or for an image
    /// inside a glTF file `embedded image N (MIME type)`.
    pub file: String,
    /// Whether the file is there (true for embedded images).
    pub exists: bool,
}

/// Adds `file` to `files` once, checking that it exists; returns its name.
pub(crate) fn note_file(files: &mut Vec<TextureFile>, file: String, exists: bool) -> String {
    if !files.iter().any(|f| f.file == file) {
        files.push(TextureFile {
            file: file.clone(),
            exists,
        });
    }
    file
}
