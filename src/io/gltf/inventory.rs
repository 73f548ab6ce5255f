//! What a glTF file holds besides geometry, for `info`: the vertex
//! attributes of its primitives, its materials and their textures, and the
//! image files they use.

use std::path::Path;

use serde_json::Value;

use super::read::{percent_decode, split_glb};
use crate::io::materials::{MaterialInfo, MaterialTexture, TextureFile, note_file};
use crate::{Error, Result};

/// The materials and images of a glTF document (see [`inventory`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GltfInventory {
    /// Attribute names over all primitives, sorted (`COLOR_0`, `NORMAL`,
    /// `POSITION`, `TEXCOORD_0`, …).
    pub attributes: Vec<String>,
    /// Every material, in document order, with its `alphaMode` (default
    /// `OPAQUE`), the primitives that use it and its textures.
    pub materials: Vec<MaterialInfo>,
    /// Every image a material texture uses: a file resolved against `base`
    /// (with whether it exists), an embedded image, or a `data:` URI.
    pub textures: Vec<TextureFile>,
}

/// The material slots that hold a texture (`pbrMetallicRoughness` ones
/// first), as glTF 2.0 names them.
const SLOTS: [(&str, &str); 5] = [
    ("pbrMetallicRoughness", "baseColorTexture"),
    ("pbrMetallicRoughness", "metallicRoughnessTexture"),
    ("", "normalTexture"),
    ("", "occlusionTexture"),
    ("", "emissiveTexture"),
];

/// Lists the attributes, materials and image files of a `.glb` / `.gltf`
/// (`name` for messages; `base` the file's folder, against which relative
/// image URIs are resolved; without it they are listed as written, not
/// found). Only the JSON is read: the document must be valid JSON, and a
/// missing or malformed material field is skipped, not an error (the
/// geometry reader judges the rest).
pub fn inventory(name: &str, bytes: &[u8], base: Option<&Path>) -> Result<GltfInventory> {
    let json = if bytes.starts_with(b"glTF") {
        split_glb(name, bytes)?.0
    } else {
        bytes
    };
    let root: Value = serde_json::from_slice(json)
        .map_err(|e| Error::format(name, format!("invalid glTF JSON: {e}")))?;
    let arr = |v: &Value, k: &str| {
        v.get(k)
            .and_then(Value::as_array)
            .cloned()
            .unwrap_or_default()
    };
    let mut inv = GltfInventory::default();
    let mut used = vec![0usize; arr(&root, "materials").len()];
    for mesh in arr(&root, "meshes") {
        for prim in arr(&mesh, "primitives") {
            if let Some(attrs) = prim.get("attributes").and_then(Value::as_object) {
                inv.attributes.extend(attrs.keys().cloned());
            }
            if let Some(u) = prim
                .get("material")
                .and_then(Value::as_u64)
                .and_then(|m| used.get_mut(m as usize))
            {
                *u += 1;
            }
        }
    }
    inv.attributes.sort();
    inv.attributes.dedup();
    let images = arr(&root, "images");
    let textures = arr(&root, "textures");
    let image_name = |files: &mut Vec<TextureFile>, i: usize| -> Option<String> {
        let img = images.get(i)?;
        let mime = img.get("mimeType").and_then(Value::as_str).unwrap_or("?");
        Some(match img.get("uri").and_then(Value::as_str) {
            Some(uri) if uri.starts_with("data:") => {
                note_file(files, format!("embedded image {i} (data URI)"), true)
            }
            Some(uri) => {
                let rel = percent_decode(uri);
                match base {
                    Some(b) => {
                        let p = b.join(&rel);
                        note_file(files, p.display().to_string(), p.is_file())
                    }
                    None => note_file(files, rel, false),
                }
            }
            None => note_file(files, format!("embedded image {i} ({mime})"), true),
        })
    };
    for (mi, m) in arr(&root, "materials").iter().enumerate() {
        let mut info = MaterialInfo {
            name: m
                .get("name")
                .and_then(Value::as_str)
                .map_or_else(|| format!("material {mi}"), str::to_string),
            alpha_mode: Some(
                m.get("alphaMode")
                    .and_then(Value::as_str)
                    .unwrap_or("OPAQUE")
                    .to_string(),
            ),
            used_by: used[mi],
            defined: true,
            textures: Vec::new(),
        };
        for (group, slot) in SLOTS {
            let holder = if group.is_empty() {
                Some(m)
            } else {
                m.get(group)
            };
            let Some(tex) = holder
                .and_then(|h| h.get(slot))
                .and_then(|t| t.get("index"))
                .and_then(Value::as_u64)
            else {
                continue;
            };
            let source = textures
                .get(tex as usize)
                .and_then(|t| t.get("source"))
                .and_then(Value::as_u64);
            let file = source
                .and_then(|s| image_name(&mut inv.textures, s as usize))
                .unwrap_or_else(|| format!("texture {tex} (no image)"));
            info.textures.push(MaterialTexture {
                slot: slot.to_string(),
                file,
            });
        }
        inv.materials.push(info);
    }
    Ok(inv)
}
