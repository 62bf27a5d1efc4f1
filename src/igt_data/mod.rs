//! An inverse geometric texture's data (the IGT paper): per cell of a bijective primary
//! parameterization (primary.rs), the list of detailed-mesh triangles that overlap it, and the
//! detailed faces' attributes. The paper's hash → list → triangle → attribute textures are plain
//! arrays here: cell offsets, list payload, entries (a triangle as one grid sees it) and
//! per-face attributes. Reading it: the lookup (lookup.rs on the CPU, shaders/igt_*.wgsl on the
//! GPU), the shader LoD's baked texture (bake.rs) and the .gtigt file (file.rs). `igt` builds
//! textures and prepares the simplified meshes shaded through them (`IgtMesh`); the renderer
//! draws those.
//!
//! Spaces: world (the detailed mesh's, f64); primary space per grid in cell units (primary.rs).

pub mod bake;
pub mod file;
pub mod lookup;
pub mod primary;

use std::sync::Arc;

use glam::{DVec2, DVec3};

use crate::appearance::Image;
use crate::error::{GeomtexError, Result};
use crate::mesh::Mesh;
pub use primary::{Grid, Primary};

/// Largest `resolution`: 8192² cells take 256 MiB of offsets alone.
pub const MAX_RESOLUTION: u32 = 8192;
/// Bins of the list-length histogram: lengths 0 to 31, then 32 or more.
pub const HISTOGRAM_BINS: usize = 33;

/// `resolution` if it is possible.
pub fn check_resolution(resolution: i64) -> Result<u32> {
    if !(1..=MAX_RESOLUTION as i64).contains(&resolution) {
        return Err(GeomtexError::Parameter(format!(
            "resolution must be 1 to {MAX_RESOLUTION} (cells a side of the primary space), got \
             {resolution}"
        )));
    }
    Ok(resolution as u32)
}

/// A detailed triangle as one grid sees it: a row of the triangle table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Entry {
    pub face: u32,
    pub grid: u32,
    /// Corners in the grid's primary space (cell units), in the face's corner order.
    pub corners: [[f32; 2]; 3],
}

impl Entry {
    pub fn corners64(&self) -> [DVec2; 3] {
        self.corners.map(|c| DVec2::new(c[0] as f64, c[1] as f64))
    }
}

/// The attribute table: per detailed face, per corner.
#[derive(Clone, Debug, Default)]
pub struct Attributes {
    /// Unit normals (the mesh's corner normals under the build's rule).
    pub normals: Vec<[[f32; 3]; 3]>,
    /// RGBA8 vertex (or face) colors.
    pub colors: Option<Vec<[[u8; 4]; 3]>>,
    /// The mesh's texture coordinates, and its texture image.
    pub uv: Option<Vec<[[f32; 2]; 3]>>,
    pub image: Option<Arc<Image>>,
    /// Ambient occlusion at each corner (its vertex's, occlusion.rs), 0 to 255 for the
    /// unoccluded fraction 0 to 1.
    pub ao: Option<Vec<[u8; 3]>>,
}

/// An inverse geometric texture of a detailed mesh.
#[derive(Clone, Debug)]
pub struct InverseGeometricTexture {
    pub primary: Primary,
    pub resolution: u32,
    pub grids: Vec<Grid>,
    /// The list of cell c is `cell_entries[cell_start[c] .. cell_start[c + 1]]` (entry indices,
    /// ascending: a grid's own faces before its ring's).
    pub cell_start: Vec<u32>,
    pub cell_entries: Vec<u32>,
    pub entries: Vec<Entry>,
    /// Per detailed face: the grid it belongs to (u32::MAX for degenerate faces, never listed).
    pub face_grid: Vec<u32>,
    /// The detailed mesh's geometry (kept for simplification; not uploaded to the GPU).
    pub positions: Vec<DVec3>,
    pub faces: Vec<[u32; 3]>,
    pub attributes: Attributes,
    /// Named figures (list lengths, bytes per part, seconds per stage).
    pub stats: Vec<(String, f64)>,
    /// Cells per list length (`HISTOGRAM_BINS`, the last bin for all longer lists).
    pub histogram: Vec<u64>,
}

/// Bytes per GPU entry (corners 6 f32, face, grid) and per face of each attribute (three
/// corners: a normal as two snorm16, a color as four unorm8, texture coordinates as two f32,
/// ambient occlusion as one unorm8, the three in one u32).
pub const ENTRY_BYTES: usize = 32;
pub const NORMAL_BYTES: usize = 12;
pub const COLOR_BYTES: usize = 12;
pub const UV_BYTES: usize = 24;
pub const AO_BYTES: usize = 4;
/// Bytes per cell of the shader LoD's baked texture (a normal and a color).
pub const BAKED_BYTES: usize = 8;
/// Bytes per grid record on the GPU.
pub const GRID_BYTES: usize = 64;

impl InverseGeometricTexture {
    pub fn cells(&self) -> usize {
        self.cell_start.len() - 1
    }

    pub fn face_count(&self) -> usize {
        self.face_grid.len()
    }

    /// The list of cell `c` (global index).
    pub fn list(&self, c: usize) -> &[u32] {
        &self.cell_entries[self.cell_start[c] as usize..self.cell_start[c + 1] as usize]
    }

    pub fn stat(&self, name: &str) -> Option<f64> {
        self.stats.iter().find(|(n, _)| n == name).map(|s| s.1)
    }

    fn set(&mut self, name: &str, v: f64) {
        match self.stats.iter_mut().find(|(n, _)| n == name) {
            Some(e) => e.1 = v,
            None => self.stats.push((name.into(), v)),
        }
    }

    /// Bytes of each part as the GPU holds it: (hash, lists, triangles, attributes, image).
    pub fn part_bytes(&self) -> [usize; 5] {
        let a = &self.attributes;
        let faces = self.face_count();
        let attributes = faces * NORMAL_BYTES
            + a.colors.as_ref().map_or(0, |_| faces * COLOR_BYTES)
            + a.uv.as_ref().map_or(0, |_| faces * UV_BYTES)
            + a.ao.as_ref().map_or(0, |_| faces * AO_BYTES);
        let image = a.image.as_ref().map_or(0, |i| i.width() * i.height() * 4);
        [
            self.cell_start.len() * 4 + self.grids.len() * GRID_BYTES,
            self.cell_entries.len() * 4,
            self.entries.len() * ENTRY_BYTES,
            attributes,
            image,
        ]
    }

    /// Recomputes the figures derived from the tables (list lengths, bytes).
    pub fn figure(&mut self) {
        let mut histogram = vec![0u64; HISTOGRAM_BINS];
        let (mut filled, mut sum, mut max) = (0usize, 0usize, 0usize);
        for c in 0..self.cells() {
            let n = self.list(c).len();
            histogram[n.min(HISTOGRAM_BINS - 1)] += 1;
            if n > 0 {
                filled += 1;
                sum += n;
                max = max.max(n);
            }
        }
        self.histogram = histogram;
        let cells = self.cells();
        let bytes = self.part_bytes();
        let total: usize = bytes[..4].iter().sum();
        let figures = [
            ("faces", self.face_count() as f64),
            ("grids", self.grids.len() as f64),
            ("cells", cells as f64),
            ("empty_cells", (cells - filled) as f64),
            (
                "empty_fraction",
                (cells - filled) as f64 / cells.max(1) as f64,
            ),
            ("entries", self.entries.len() as f64),
            ("list_mean", sum as f64 / filled.max(1) as f64),
            ("list_max", max as f64),
            ("bytes_hash", bytes[0] as f64),
            ("bytes_lists", bytes[1] as f64),
            ("bytes_triangles", bytes[2] as f64),
            ("bytes_attributes", bytes[3] as f64),
            ("bytes_image", bytes[4] as f64),
            // Built when the texture is first drawn (bake.rs), one record per cell.
            ("bytes_lod", (cells * BAKED_BYTES) as f64),
            ("bytes", total as f64),
            (
                "bytes_per_face",
                total as f64 / self.face_count().max(1) as f64,
            ),
        ];
        for (name, v) in figures {
            self.set(name, v);
        }
    }
}

/// How a simplified mesh's fragments find the detailed triangle they show.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Lookup {
    /// The first detailed triangle the view ray meets within the face's window around the
    /// simplified surface (walking the grid's cells the ray crosses); the projection where it
    /// meets none. Charts only: a wrapping primary projects.
    #[default]
    Ray,
    /// The paper's lookup: the triangle under the point projected along the chart's axis.
    /// Cheaper, but off wherever the simplified and detailed surfaces part.
    Projection,
}

impl std::str::FromStr for Lookup {
    type Err = GeomtexError;
    fn from_str(s: &str) -> Result<Self> {
        let choices = [("ray", Lookup::Ray), ("projection", Lookup::Projection)];
        crate::error::parse_choice("lookup", s, &choices)
    }
}

impl Lookup {
    pub fn name(self) -> &'static str {
        match self {
            Lookup::Ray => "ray",
            Lookup::Projection => "projection",
        }
    }
}

/// When fragments shade from the baked texture (bake.rs) instead of the lists: the shader LoD.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Lod {
    /// Always through the lists (the default: the accuracy figures are the lookup's).
    #[default]
    Off,
    /// Where one cell of the primary space covers less than a pixel (the lookup then
    /// resolves detail the pixel cannot show).
    Auto,
    /// Beyond this distance from the camera (view units).
    Distance(f32),
}

impl Lod {
    /// From the keyword's forms: "off", "auto", or a distance (positive, finite).
    pub fn from_keyword(text: Option<&str>, distance: Option<f64>) -> Result<Lod> {
        match (text, distance) {
            (None, None) => Ok(Lod::default()),
            (Some("off"), None) => Ok(Lod::Off),
            (Some("auto"), None) => Ok(Lod::Auto),
            (None, Some(d)) if d.is_finite() && d > 0.0 => Ok(Lod::Distance(d as f32)),
            (None, Some(d)) => Err(GeomtexError::Parameter(format!(
                "lod distance must be positive and finite, got {d}"
            ))),
            (Some(t), _) => Err(GeomtexError::Parameter(format!(
                "lod must be 'auto', 'off' or a distance, got {t:?}"
            ))),
        }
    }

    pub fn name(self) -> String {
        match self {
            Lod::Off => "off".into(),
            Lod::Auto => "auto".into(),
            Lod::Distance(d) => format!("{d}"),
        }
    }
}

/// A simplified mesh shaded through an inverse geometric texture: each of its faces names the
/// grid its points are projected into (for the charts primary, the chart of the detailed
/// surface around it; grid 0 for a spherical or cylindrical map).
#[derive(Clone, Debug)]
pub struct IgtMesh {
    pub igt: Arc<InverseGeometricTexture>,
    pub mesh: Mesh,
    pub face_grid: Vec<u32>,
    pub lookup: Lookup,
    /// Per face: how far (object units, along the face's normal) the ray lookup searches
    /// outside (the side its winding's normal points to) and inside the face's plane
    /// (window.rs).
    pub face_window: Vec<[f32; 2]>,
    /// Per face: the grids the ray lookup walks, its own first (window.rs).
    pub face_search_grids: Vec<Vec<u32>>,
    /// Lookups per pixel: 1 (its centre) or 5 (and four points of its footprint, the
    /// attributes averaged: the paper's filtering option).
    pub samples: u32,
    /// Where the baked texture replaces the lookup.
    pub lod: Lod,
}

impl IgtMesh {
    /// The same mesh shaded with `samples` lookups per pixel (1 or 5).
    pub fn with_samples(mut self, samples: i64) -> Result<Self> {
        if samples != 1 && samples != 5 {
            return Err(GeomtexError::Parameter(format!(
                "samples must be 1 or 5 (lookups per pixel), got {samples}"
            )));
        }
        self.samples = samples as u32;
        Ok(self)
    }

    /// The same mesh with the shader LoD `lod`.
    pub fn with_lod(mut self, lod: Lod) -> Self {
        self.lod = lod;
        self
    }
}
