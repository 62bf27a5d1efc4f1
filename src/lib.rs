//! geomtex: dense triangle meshes as geometry textures — height-map patches in oriented boxes.
//!
//! The core is pure Rust (no PyO3): `mesh` validates input, `convert` turns a mesh into a
//! `gtex::GeometryTextureSet`, `gtex::file` reads and writes .gtex files, `render` draws them.
//! The Python binding layer lives in `python/` behind the `python` feature.
//!
//! The modules stand in layers; each uses its own layer and those below, and no stage uses
//! another stage, so a stage changes without the others noticing (tests/structure.rs checks
//! this, and that no two files import each other):
//! - infrastructure, any module's to use: `error`, `cancel`, `progress` (reports, stage
//!   timing, the parallel loop), `profile` (GEOMTEX_PROFILE timers), `bvh` (the CPU hierarchy
//!   of boxes);
//! - the data model, what stages make and read and the renderer draws: `mesh`, `appearance`,
//!   `heightfield`, `gtex`, `convert_options`, `igt_data`, `gdm_data`, `surfel_data`;
//! - algorithms several stages share: `charts` (a mesh cut into framed charts: convert's and
//!   igt's), `filters`, `grids`;
//! - the stages: `convert` (mesh → geometry textures), `igt` (mesh → inverse geometric
//!   texture), `gdm` (a shell's distance tables and reference geometry), `surfels` (set →
//!   surfel hierarchy), `render` (draws the data model);
//! - on top, free to use anything: `python`, and `pipeline_tests` (one stage's output through
//!   another).

// Infrastructure.
pub(crate) mod bvh;
pub mod cancel;
pub mod error;
pub mod profile;
pub mod progress;
pub(crate) mod wide_bvh;

// The data model.
pub mod appearance;
pub mod convert_options;
pub mod gdm_data;
pub mod gtex;
pub mod heightfield;
pub mod igt_data;
pub mod mesh;
pub mod surfel_data;
#[cfg(test)]
mod test_shapes;

// Algorithms several stages share.
pub mod charts;
pub mod filters;
pub mod grids;

// The stages.
pub mod convert;
pub mod gdm;
pub mod igt;
pub mod render;
pub mod surfels;

// On top.
#[cfg(test)]
mod pipeline_tests;
#[cfg(feature = "python")]
mod python;

pub use cancel::Cancel;
pub use convert::{convert, ConvertArgs, ConvertOptions, ErrorScope, InPlane, NormalSource};
pub use error::{GeomtexError, Result};
pub use gtex::{GeometryTextureSet, Patch, Stats};
pub use mesh::{Mesh, NormalRule};
pub use progress::Progress;
