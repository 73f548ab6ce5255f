//! Surface-reconstruction benchmarks as pure functions on point sets: each
//! module reproduces one published evaluation protocol (DTUeval-python, the
//! Tanks-and-Temples toolbox), leaving file handling to the `chamfer` command
//! in `ops`.

pub mod chamfer;
pub mod cull;
pub mod dtu;
pub mod splat_error;
pub mod tnt;
