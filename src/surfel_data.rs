//! A surfel hierarchy's data: the surfels of a geometry-texture set's surface texels, tile by
//! tile and level by level (level 0 the finest), the quadtree nodes above the tiles, and the
//! figures a renderer selects a level by (render/kinds/surfels.rs). `surfels` builds it
//! (`SurfelHierarchy::build`) and files it (surfels/file.rs, which rebuilds it on load).
//!
//! Spaces: world (f64, the set's), and patch-local texel grids (column i along u, row j along v).

use std::sync::Arc;

use glam::DVec3;

use crate::error::{GeomtexError, Result};
use crate::gtex::GeometryTextureSet;

/// Largest tile side (texels): seven levels, the GPU record's room.
pub const MAX_TILE: u32 = 64;
/// Most levels a tile can have (log2(MAX_TILE) + 1).
pub const MAX_LEVELS: usize = 7;
/// Default tile side: 64/16/4/1 surfels, as in the paper.
pub const DEFAULT_TILE: u32 = 8;

/// One disc of the hierarchy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surfel {
    /// World position.
    pub position: DVec3,
    /// World unit normal.
    pub normal: DVec3,
    /// Disc radius (world units): covers the texel's footprint (level 0), or every child's disc.
    pub radius: f64,
    pub color: [u8; 4],
    /// Index of the parent surfel one level up; `u32::MAX` at the top level.
    pub parent: u32,
    pub level: u8,
    /// The box of surface texels it stands for in its patch's grid: first column, first row,
    /// end column, end row (exclusive). The renderer clips the disc to it (plus a margin), so a
    /// coarse disc, sized to cover its children, does not reach past the surface they cover.
    pub texels: [u32; 4],
}

/// One tile of a patch: its surfels level by level, with the figures a renderer selects by.
#[derive(Clone, Debug, PartialEq)]
pub struct Tile {
    pub patch: u32,
    /// First texel (column, row) of the tile in its patch.
    pub texel: [u32; 2],
    /// `start[l]..start[l + 1]` are the tile's surfels of level l (indices into `surfels`).
    pub start: Vec<u32>,
    /// Per level: the largest distance of the tile's finest surfels (their surface points) from
    /// the plane of their ancestor at that level; never smaller than the level below's (0 at
    /// level 0).
    pub error: Vec<f64>,
    /// Per level: the normal cone of that level's surfels (unit axis, the same at every level;
    /// half angle in radians). Each level's own spread, not the finest's: a drawn level's
    /// depth error follows its discs' normals, and noise in the finest normals that a coarse
    /// level averages away cannot show in the image.
    pub cone: Vec<(DVec3, f64)>,
    /// A sphere holding every disc of every level.
    pub centre: DVec3,
    pub bound: f64,
    /// The node one level above the tile (index into `SurfelHierarchy::nodes`), or u32::MAX.
    pub parent: u32,
}

/// A surfel hierarchy over a geometry-texture set, kept beside the set it was built from (files
/// store the set and rebuild the hierarchy, file.rs).
#[derive(Clone, Debug)]
pub struct SurfelHierarchy {
    pub tile: u32,
    pub levels: u32,
    pub tiles: Vec<Tile>,
    pub surfels: Vec<Surfel>,
    /// The quadtree nodes above the tiles, patch by patch, each level's nodes before the next
    /// level's.
    pub nodes: Vec<Node>,
    pub source: Arc<GeometryTextureSet>,
}

/// A tile side's check: a power of two in 1..=MAX_TILE.
pub fn check_tile(tile: i64) -> Result<u32> {
    if tile < 1 || tile > MAX_TILE as i64 || (tile & (tile - 1)) != 0 {
        return Err(GeomtexError::Parameter(format!(
            "tile must be a power of two from 1 to {MAX_TILE} texels, got {tile}"
        )));
    }
    Ok(tile as u32)
}

/// A node above the tiles: one surfel standing for the 2x2 tiles (or nodes) below it.
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    /// Its disc; `level` counts on from the tiles' top level; `parent` is u32::MAX (nodes link
    /// through `Node::parent`).
    pub surfel: Surfel,
    /// The node one level up (index into `SurfelHierarchy::nodes`), or u32::MAX at a root.
    pub parent: u32,
    /// The largest `disc_error` of the finest surfels below against this disc, or how far its
    /// clipped disc reaches past the surface (Reach) where that is more; never smaller than a
    /// child's error.
    pub error: f64,
    /// Normal cone of the tiles' top-level surfels below (unit axis, half angle in radians):
    /// the normals at the scale a node is drawn at. It holds the node's own normal (their
    /// weighted mean, level by level), so a renderer's depth bound along its disc holds; the
    /// finest normals' spread, wide on a noisy scan, would flag nodes as grazing that no
    /// pixel shows as such.
    pub cone: (DVec3, f64),
    /// A sphere holding its disc and every child's sphere.
    pub centre: DVec3,
    pub bound: f64,
    pub patch: u32,
}

impl SurfelHierarchy {
    /// The hierarchy cut into pieces of whole patches, each holding at most `max_records`
    /// surfels and node surfels together, so that a set too large for one storage binding still
    /// draws (in several draws). Each patch's tiles and nodes form their own quadtree, so a
    /// piece is the same hierarchy over fewer patches, its indices counted from 0 again; tiles
    /// and nodes keep their patch numbers (the set's), so ids and patch frames stay the set's.
    /// An error only when one patch alone holds more than `max_records`.
    pub fn pieces(&self, max_records: usize) -> Result<Vec<SurfelHierarchy>> {
        let patches = self.source.patches.len();
        // Per patch: its first tile, first surfel and first node (tiles, surfels and nodes are
        // stored patch by patch, in patch order).
        let mut tile_at = vec![self.tiles.len(); patches + 1];
        let mut node_at = vec![self.nodes.len(); patches + 1];
        for (k, t) in self.tiles.iter().enumerate().rev() {
            tile_at[t.patch as usize] = k;
        }
        for (k, n) in self.nodes.iter().enumerate().rev() {
            node_at[n.patch as usize] = k;
        }
        for p in (0..patches).rev() {
            tile_at[p] = tile_at[p].min(tile_at[p + 1]);
            node_at[p] = node_at[p].min(node_at[p + 1]);
        }
        let surfel_at = |p: usize| {
            self.tiles
                .get(tile_at[p])
                .map_or(self.surfels.len(), |t| t.start[0] as usize)
        };
        let records = |a: usize, b: usize| surfel_at(b) - surfel_at(a) + node_at[b] - node_at[a];
        let mut pieces = Vec::new();
        let mut first = 0;
        while first < patches {
            let mut end = first + 1;
            if records(first, end) > max_records {
                return Err(GeomtexError::Device(format!(
                    "patch {first} alone holds {} surfels, more than the {max_records} one storage \
                     binding of this adapter holds; build the surfels with a larger tile or convert \
                     with a lower max_resolution",
                    records(first, end)
                )));
            }
            while end < patches && records(first, end + 1) <= max_records {
                end += 1;
            }
            pieces.push(self.piece(
                tile_at[first]..tile_at[end],
                surfel_at(first)..surfel_at(end),
                node_at[first]..node_at[end],
            ));
            first = end;
        }
        Ok(pieces)
    }

    /// The tiles, surfels and nodes in these ranges (whole patches), renumbered from 0.
    fn piece(
        &self,
        tiles: std::ops::Range<usize>,
        surfels: std::ops::Range<usize>,
        nodes: std::ops::Range<usize>,
    ) -> SurfelHierarchy {
        let (surfel_base, node_base) = (surfels.start as u32, nodes.start as u32);
        let back = |index: u32, by: u32| if index == u32::MAX { index } else { index - by };
        SurfelHierarchy {
            tile: self.tile,
            levels: self.levels,
            tiles: self.tiles[tiles]
                .iter()
                .map(|t| Tile {
                    start: t.start.iter().map(|s| s - surfel_base).collect(),
                    parent: back(t.parent, node_base),
                    ..t.clone()
                })
                .collect(),
            surfels: self.surfels[surfels]
                .iter()
                .map(|s| Surfel {
                    parent: back(s.parent, surfel_base),
                    ..*s
                })
                .collect(),
            nodes: self.nodes[nodes]
                .iter()
                .map(|n| Node {
                    parent: back(n.parent, node_base),
                    ..n.clone()
                })
                .collect(),
            source: self.source.clone(),
        }
    }

    /// Surfels of each level, finest first.
    pub fn per_level(&self) -> Vec<usize> {
        let mut counts = vec![0usize; self.levels as usize];
        for s in &self.surfels {
            counts[s.level as usize] += 1;
        }
        counts
    }

    /// Bytes the hierarchy takes on the GPU: a 32-byte record and a patch index per surfel
    /// (nodes' surfels too), a tile record per tile and a node record per node
    /// (render/gpu_types.rs).
    pub fn gpu_bytes(&self) -> usize {
        (self.surfels.len() + self.nodes.len()) * (32 + 4)
            + self.tiles.len() * 144
            + self.nodes.len() * 48
    }

    /// Nodes per level above the tiles, lowest first (empty when every patch is one tile).
    pub fn nodes_per_level(&self) -> Vec<usize> {
        let mut counts = Vec::new();
        for n in &self.nodes {
            let k = (n.surfel.level as u32 - self.levels) as usize;
            if counts.len() <= k {
                counts.resize(k + 1, 0);
            }
            counts[k] += 1;
        }
        counts
    }

    /// The tile of each surfel.
    pub fn surfel_tiles(&self) -> Vec<usize> {
        let mut out = vec![0; self.surfels.len()];
        for (k, t) in self.tiles.iter().enumerate() {
            let all = t.start[0] as usize..*t.start.last().expect("levels >= 1") as usize;
            out[all].fill(k);
        }
        out
    }

    /// World bounding box of every disc.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.tiles.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), t| {
                (
                    lo.min(t.centre - DVec3::splat(t.bound)),
                    hi.max(t.centre + DVec3::splat(t.bound)),
                )
            },
        )
    }
}
