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
