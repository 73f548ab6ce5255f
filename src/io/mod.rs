//! File formats: one module per format. Readers produce [`crate::model`]
//! types; writers take them. Paths of `-` mean stdin / stdout.

pub mod any;
pub mod budget;
pub mod cameras;
pub mod checkpoint;
pub mod dataset;
pub mod depth;
pub mod describe;
pub mod detect;
pub mod dtu;
pub mod gltf;
pub mod image;
pub mod mat;
pub mod materials;
pub mod obj;
pub mod off;
pub mod ply;
pub mod source;
pub mod splat;
pub mod tnt;
pub mod torch_pt;
pub mod transaction;
pub mod views;

pub use source::{Input, StagedDir, read_input, write_output};
