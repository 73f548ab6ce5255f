//! glTF 2.0 meshes, as binary `.glb` or JSON `.gltf` (geometry only:
//! positions, normals, vertex colours, triangles; materials, textures,
//! skins, morph targets and animations are ignored).
//!
//! # Writing
//! One scene, one node without transform, one mesh with one primitive:
//! `POSITION` (f32 VEC3, with the `min`/`max` the specification requires,
//! computed over finite coordinates), `NORMAL` (f32 VEC3) when the mesh has
//! normals, `COLOR_0` (f32 VEC4, RGBA) when it has colours, and u32
//! indices in mode TRIANGLES.
//!
//! Colours: glTF defines `COLOR_0` as linear, our meshes hold 8-bit sRGB.
//! RGB is decoded with the exact sRGB EOTF (piecewise, not a 2.2 power; see
//! `color.rs`) and stored as f32, which every glTF reader must accept and
//! which keeps each of the 256 codes exactly (normalised u8 would merge the
//! 13 darkest codes, whose linear values lie under 1/255); alpha is linear
//! already and is stored as `a / 255`. A coloured mesh gets one material:
//! `baseColorFactor` (1, 1, 1, 1) and no texture, so the colour is
//! `COLOR_0` alone (Blender's importer then wires the colour attribute into
//! the Principled BSDF's base colour and alpha), `metallicFactor` 0,
//! `roughnessFactor` 1, `alphaMode` BLEND when some alpha is below 255 or
//! [`GltfWriteOptions::blend`] asks for it (OPAQUE otherwise), and
//! `doubleSided` as [`GltfWriteOptions::double_sided`] says. Every section of the binary buffer is 4-byte
//! aligned. `.glb` puts the buffer in the BIN chunk; `.gltf` embeds it as a
//! base64 `data:application/octet-stream;base64,…` URI.
//!
//! glTF has no per-face colours: when the mesh has face colours and no vertex
//! colours, vertices are un-shared (three per face, see
//! [`face_colors_to_corners`]) and each face's colour is copied to its three
//! corners. Vertex colours win when both exist. A mesh with vertices but no
//! faces is written as a POINTS primitive without indices; an empty mesh as a
//! document without scene or mesh. Non-finite coordinates are stored as they are in the
//! binary buffer (`min`/`max` ignore them); other tools may reject them.
//!
//! # Reading
//! Buffers come from the GLB BIN chunk, from base64 `data:` URIs, or (with
//! [`read_gltf`] only) from files relative to the `.gltf` file. Meshes are
//! instantiated through the scene graph: the default scene, else the first
//! scene, else every root node. Each node's world transform (parent × local,
//! `matrix` or translation × rotation × scale, computed in f64) is applied
//! to positions, and its inverse transpose to normals (renormalised); a
//! transform with negative determinant also swaps two indices of every
//! triangle so that the winding stays counter-clockwise. A mesh used by two
//! nodes appears twice. When no node references a mesh, every mesh is read
//! once, untransformed.
//!
//! All primitives are merged into one mesh. Modes TRIANGLES, TRIANGLE_STRIP
//! and TRIANGLE_FAN give triangles; POINTS gives vertices only; line modes are
//! skipped. `POSITION` and `NORMAL` must be f32; `COLOR_0` may be f32, or
//! normalised u8/u16, VEC3 (alpha 255) or VEC4; indices u8, u16 or u32.
//! `COLOR_0` is read as linear, as the specification defines it, whoever
//! wrote the file: RGB is clamped to [0, 1] and encoded with the sRGB OETF
//! to 8 bits (`round(255 · OETF(v))`), alpha is `round(255 · a)`. So a file
//! that stored 8-bit sRGB values unconverted (trimesh 5.2 does) reads
//! brighter, as it shows in Blender and other viewers that follow the
//! specification. A
//! primitive lacking normals or colours that others have gets (0, 0, 0) /
//! opaque white. Sparse accessors are refused. Errors name the file and the
//! byte offset (container) or the mesh / primitive / accessor (content).
//!
//! # Crates and hand-written parts
//! Base64 in data URIs is the `base64` crate's: the standard alphabet with
//! padding on writing; on reading also the URL-safe alphabet, missing padding
//! and non-zero trailing bits. It replaced hand-written code that was slower
//! on a 50 MB buffer (a 1M-vertex mesh with normals and colours and 2M faces;
//! 2-vCPU machine, release build): encoding 104 ms instead of 238 ms,
//! decoding 92 ms instead of 609 ms.
//!
//! The GLB container is written by `gltf::binary::Glb::to_writer`, but split
//! on reading by our own `split_glb` (~70 lines), not `Glb::from_slice`
//! (gltf 1.4.1). Speed decides nothing (both only slice: under 0.1 µs on that
//! 50 MB file); `from_slice`
//! - panics ("attempt to subtract with overflow") on a header that declares a
//!   length below 12, in builds with overflow checks such as our debug and test
//!   builds;
//! - refuses a chunk of unknown type after the JSON chunk ("unknown chunk
//!   type"), which the glTF 2.0 specification says readers must ignore;
//! - names neither the file nor the byte offset ("could not completely read
//!   the object", "failed to fill whole buffer"), which the `malformed_glb`
//!   test requires.

mod color;
mod inventory;
mod read;
#[cfg(test)]
mod tests;
mod write;

use std::borrow::Cow;

pub use inventory::{GltfInventory, inventory};
pub use read::{parse_gltf, parse_gltf_in, read_gltf};
pub use write::{
    GltfContainer, GltfWriteOptions, face_colors_to_corners, unshares_vertices, write_gltf,
};

fn pad4(n: usize) -> usize {
    n.div_ceil(4) * 4
}

/// Standard base64 (RFC 4648, with `=` padding), as data URIs carry it.
fn base64_encode(data: &[u8]) -> String {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD.encode(data)
}

/// Decodes base64 (standard or URL-safe alphabet, padding optional, unused
/// trailing bits ignored); `Err(position)` names the first invalid character.
fn base64_decode(s: &str) -> std::result::Result<Vec<u8>, usize> {
    use base64::engine::{DecodePaddingMode, GeneralPurpose, GeneralPurposeConfig};
    use base64::{DecodeError, Engine};
    const LENIENT: GeneralPurpose = GeneralPurpose::new(
        &base64::alphabet::STANDARD,
        GeneralPurposeConfig::new()
            .with_decode_padding_mode(DecodePaddingMode::Indifferent)
            .with_decode_allow_trailing_bits(true),
    );
    // The URL-safe alphabet differs in two characters only.
    let text: Cow<str> = if s.contains(['-', '_']) {
        Cow::Owned(s.replace('-', "+").replace('_', "/"))
    } else {
        Cow::Borrowed(s)
    };
    LENIENT.decode(text.as_bytes()).map_err(|e| match e {
        DecodeError::InvalidByte(at, _) | DecodeError::InvalidLastSymbol { offset: at, .. } => at,
        // A last group of one character cannot encode a byte.
        DecodeError::InvalidLength(symbols) => symbols.saturating_sub(1),
        DecodeError::InvalidPadding => s.find('=').unwrap_or(s.len()),
    })
}
