//! splatkit: composable commands that turn Gaussian- and triangle-splat scenes
//! into meshes, bind splats back onto meshes, and evaluate surfaces.
//!
//! Layers (data flows one way): [`io`] reads files into [`model`] types,
//! [`ops`] run the algorithms, [`io`] writes the results. [`cli`] holds the
//! conventions every command shares (stdin/stdout, progress, threads, exit codes).

pub mod app;
pub mod cli;
pub mod error;
pub mod eval;
pub mod geom;
pub mod io;
pub mod model;
pub mod ops;
/// Test support (generated shapes, datasets, shared-data lookup): compiled
/// for this crate's unit tests and, through the `testing` feature that the
/// dev-dependency on itself turns on, for `tests/`, `benches/` and
/// `examples/`; never into the library a command ships with.
#[cfg(any(test, feature = "testing"))]
#[doc(hidden)]
pub mod testing;
pub mod train;

pub use error::{Error, Result};
