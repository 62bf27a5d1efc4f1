//! Generalized displacement maps (Wang et al. 2004): non-height-field mesostructure (chain links,
//! weaves, lattices) tiled over a base mesh. The tile, the shell's prisms and the shell the
//! renderer draws are the data model's (gdm_data/); here, `distance` is the exact march through
//! the tile and the 5D distance function d(x, y, z, theta, phi) the paper looks up, `bound` its
//! conservative lower bound, and `explicit` with `caps` the explicit reference geometry (the
//! tile's surface mapped through every prism, closed where a texture seam cuts it).
//!
//! Spaces: texture space in voxel units of the tile (gdm_data/volume.rs); the base mesh's object
//! space.

pub mod bound;
pub mod caps;
pub mod distance;
pub mod explicit;

pub use bound::lower_bound_function;
pub use caps::Seams;
pub use distance::{distance_function, DistanceFunction, Marcher, DEFAULT_DIRECTIONS};
pub use explicit::TileSurface;
