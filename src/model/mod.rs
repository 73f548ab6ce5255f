//! In-memory scene types. Storage is f32 (as in the files); algorithms
//! accumulate in f64 where precision matters.

pub mod attributes;
pub mod camera;
pub mod gaussians;
pub mod mesh;
pub mod point_cloud;
pub mod triangle_soup;

pub use attributes::{Column, Element, Extras, Property, ScalarData, ScalarType};
pub use camera::{Camera, CameraModel};
pub use gaussians::Gaussians;
pub use mesh::Mesh;
pub use point_cloud::PointCloud;
pub use triangle_soup::TriangleSoup;
