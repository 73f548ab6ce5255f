//! Generated scenes and cameras.
//!
//! - [`synthetic`]: a torus of flat Gaussians with its exact distance
//!   function (the demo's built-in scene, also used by tests and benches);
//! - [`orbit`]: cameras on an orbit around a scene that comes without a
//!   camera file.
pub mod orbit;
pub mod synthetic;
