//! Generalized displacement maps (Wang et al. 2004): non-height-field mesostructure (chain links,
//! weaves, lattices) tiled over a base mesh. `volume` holds the tile (an occupancy grid,
//! periodic in x and y), `distance` the exact march through it and the 5D distance function
//! d(x, y, z, theta, phi) the paper looks up, `shell` the prisms over a base mesh and the
//! explicit reference geometry (the tile's surface mapped through every prism).
//!
//! Spaces: texture space in voxel units of the tile (volume.rs); the base mesh's object space.

pub mod distance;
pub mod shell;
pub mod volume;

pub use distance::{distance_function, DistanceFunction, Marcher, DEFAULT_DIRECTIONS};
pub use shell::{Shell, TileSurface};
pub use volume::{Pattern, Volume, PATTERNS};

use std::sync::Arc;

/// A shell ready to render: the prisms over a base mesh and the tile they carry, drawn in
/// `color` (RGBA).
pub struct GdmShell {
    pub shell: Shell,
    pub volume: Arc<Volume>,
    pub color: [u8; 4],
    /// Straight pieces each prism's ray is cut into in texture space (each piece's ends mapped
    /// exactly), so the march follows the prism's curved map.
    pub pieces: u32,
    /// When set, the paper's lookup in the SVD-compressed distance function replaces the exact
    /// march.
    pub lookup: Option<CompressedTable>,
}

/// A distance function as k SVD terms: d = sum_i W_i(x, y, phi) E_i(theta, z).
pub struct CompressedTable {
    /// [theta, phi] direction counts.
    pub directions: [usize; 2],
    pub k: usize,
    /// W[((x * ny + y) * n_phi + phi) * k + i].
    pub weights: Vec<f32>,
    /// E[(i * n_theta + theta) * nz + z].
    pub eigen: Vec<f32>,
}

/// Default pieces per prism.
pub const DEFAULT_PIECES: u32 = 4;
