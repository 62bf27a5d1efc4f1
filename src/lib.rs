//! geomtex: dense triangle meshes as geometry textures — height-map patches in oriented boxes.
//!
//! The core is pure Rust (no PyO3): `mesh` validates input, `convert` turns a mesh into a
//! `gtex::GeometryTextureSet`, `gtex::file` reads and writes .gtex files. The Python binding layer
//! lives in `python/` behind the `python` feature.

pub mod appearance;
pub(crate) mod bvh;
pub mod cancel;
pub mod charts;
pub mod convert;
pub mod convert_options;
pub mod error;
pub mod filters;
pub mod gdm;
pub mod gdm_data;
pub mod grids;
pub mod gtex;
pub mod heightfield;
pub mod igt;
pub mod igt_data;
pub mod mesh;
#[cfg(test)]
mod pipeline_tests;
pub mod profile;
pub mod progress;
pub mod render;
pub mod surfel_data;
pub mod surfels;
#[cfg(test)]
mod test_shapes;

#[cfg(feature = "python")]
mod python;

pub use cancel::Cancel;
pub use convert::{convert, ConvertArgs, ConvertOptions, ErrorScope, InPlane, NormalSource};
pub use error::{GeomtexError, Result};
pub use gtex::{GeometryTextureSet, Patch, Stats};
pub use mesh::{Mesh, NormalRule};
pub use progress::Progress;
