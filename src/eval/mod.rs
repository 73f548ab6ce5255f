//! Evaluation protocols (DTU Chamfer, Tanks-and-Temples F-score) as pure
//! functions on points and meshes; the `chamfer` command drives them.

pub mod cull;
pub mod dtu;
