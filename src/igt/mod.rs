//! Inverse geometric textures (the IGT paper): per cell of a bijective primary
//! parameterization, the list of detailed-mesh triangles that overlap it. A simplified mesh is
//! then shaded with the detailed mesh's attributes: each surface point is projected into the
//! primary space, the listed triangle containing it found by a point-in-triangle test, and that
//! triangle's attributes interpolated (lookup.rs on the CPU, shaders/igt_*.wgsl on the GPU).
//! The paper's hash → list → triangle → attribute textures are plain arrays here: cell offsets,
//! list payload, entries (a triangle as one grid sees it) and per-face attributes.
//!
//! Spaces: world (the detailed mesh's, f64) in; primary space per grid in cell units
//! (primary.rs).

pub mod bake;
pub mod file;
pub mod lookup;
pub mod occlusion;
pub mod primary;
pub mod window;

use std::sync::Arc;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::appearance::{Image, TextureCoords};
use crate::charts::chart_planes;
use crate::convert_options::ConvertOptions;
use crate::error::{GeomtexError, Result};
use crate::mesh::{Mesh, MeshGeometry, NormalRule};
use crate::progress::{Progress, Stages};
pub use occlusion::OcclusionOptions;
pub use primary::{Grid, Primary};

pub const DEFAULT_RESOLUTION: u32 = 512;
/// Largest `resolution`: 8192² cells take 256 MiB of offsets alone.
pub const MAX_RESOLUTION: u32 = 8192;
/// Bins of the list-length histogram: lengths 0 to 31, then 32 or more.
pub const HISTOGRAM_BINS: usize = 33;

/// How to build an inverse geometric texture.
#[derive(Clone, Debug)]
pub struct IgtOptions {
    pub primary: Primary,
    /// The primary space holds about resolution² cells in all (charts share one cell size).
    pub resolution: u32,
    /// Normal attribute: the mesh's corner normals under this rule.
    pub normals: NormalRule,
    /// Keep vertex or face colors (when the mesh has them).
    pub colors: bool,
    /// Keep texture coordinates and the texture image (when the mesh has them).
    pub uv: bool,
    /// Compute ambient occlusion per vertex (occlusion.rs); None: no occlusion attribute.
    pub ao: Option<OcclusionOptions>,
    /// Partition options for the charts primary (convert's, one partition).
    pub charts: ConvertOptions,
}

impl Default for IgtOptions {
    fn default() -> Self {
        IgtOptions {
            primary: Primary::Charts,
            resolution: DEFAULT_RESOLUTION,
            normals: NormalRule::default(),
            colors: true,
            uv: true,
            ao: None,
            charts: ConvertOptions::default(),
        }
    }
}

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

/// Builds the inverse geometric texture of `mesh`.
pub fn build(
    mesh: &Mesh,
    opts: &IgtOptions,
    progress: Progress,
) -> Result<InverseGeometricTexture> {
    check_resolution(opts.resolution as i64)?;
    let mut stages = Stages::new(progress);
    let (grids, owners) = match opts.primary {
        Primary::Charts => chart_grids(mesh, opts, &mut stages)?,
        p => {
            stages.begin("geometry")?;
            let grid = map_grid(mesh, p, opts.resolution)?;
            stages.end("geometry");
            let all = (0..mesh.faces.len() as u32).collect();
            (vec![grid], vec![(all, Vec::new())])
        }
    };
    stages.begin("entries")?;
    let entries = make_entries(mesh, opts.primary, &grids, &owners);
    let mut face_grid = vec![u32::MAX; mesh.faces.len()];
    for (g, (own, _)) in owners.iter().enumerate() {
        for &f in own {
            face_grid[f as usize] = g as u32;
        }
    }
    stages.end("entries");
    let (cell_start, cell_entries) = lists(opts.primary, &grids, &entries, &mut stages)?;
    stages.begin("attributes")?;
    let mut attributes = attributes(mesh, opts);
    stages.end("attributes");
    if let Some(o) = &opts.ao {
        stages.begin("occlusion")?;
        attributes.ao = Some(corner_occlusion(mesh, o, stages.progress)?);
        stages.end("occlusion");
    }
    let mut igt = InverseGeometricTexture {
        primary: opts.primary,
        resolution: opts.resolution,
        grids,
        cell_start,
        cell_entries,
        entries,
        face_grid,
        positions: mesh.positions.clone(),
        faces: mesh.faces.clone(),
        attributes,
        stats: Vec::new(),
        histogram: Vec::new(),
    };
    igt.figure();
    for (stage, s) in stages.into_seconds() {
        igt.stats.push((format!("seconds_{stage}"), s));
    }
    progress.report("done", 1.0)?;
    Ok(igt)
}

/// Per chart of the conversion's partition, a grid over its frame's bounds; all share one cell
/// size, chosen so the grids hold about resolution² cells together. Owners: each chart's faces
/// and ring faces.
type Owners = Vec<(Vec<u32>, Vec<u32>)>;

fn chart_grids(mesh: &Mesh, opts: &IgtOptions, stages: &mut Stages) -> Result<(Vec<Grid>, Owners)> {
    let planes = chart_planes(mesh, &opts.charts, stages)?;
    let target = (opts.resolution as f64).powi(2);
    let area: f64 = planes
        .iter()
        .map(|p| {
            let s = p.frame.hi - p.frame.lo;
            s.x.max(1e-12) * s.y.max(1e-12)
        })
        .sum();
    // Whole cells round every chart up: shrink the cell until the total is within the target
    // (a few passes; the rounding matters only for many small charts).
    let mut cell = (area / target).sqrt();
    let boxes = |cell: f64| -> Vec<_> {
        let cap = MAX_RESOLUTION;
        planes
            .iter()
            .map(|p| p.frame.patch_box(cell, cap, 16))
            .collect()
    };
    let mut bxs = boxes(cell);
    for _ in 0..8 {
        let total: f64 = bxs.iter().map(|b| b.width as f64 * b.height as f64).sum();
        if total <= target * 1.02 {
            break;
        }
        cell *= (total / target).sqrt() * 1.01;
        bxs = boxes(cell);
    }
    let mut first = 0u64;
    let mut grids = Vec::with_capacity(bxs.len());
    for b in bxs {
        grids.push(Grid {
            origin: b.origin,
            axes: b.axes,
            cell: DVec2::splat(cell),
            width: b.width,
            height: b.height,
            first_cell: first as u32,
        });
        first += b.width as u64 * b.height as u64;
    }
    if first >= u32::MAX as u64 / 2 {
        return Err(GeomtexError::Parameter(format!(
            "resolution {} gives {first} cells over the charts: too many",
            opts.resolution
        )));
    }
    let owners = planes.into_iter().map(|p| (p.faces, p.ring)).collect();
    Ok((grids, owners))
}

/// The one grid of a spherical or cylindrical map: centred at the surface's area-weighted
/// centroid; the cylinder's axis along the bounding box's longest side.
fn map_grid(mesh: &Mesh, primary: Primary, resolution: u32) -> Result<Grid> {
    let geo = MeshGeometry::new(mesh);
    let total: f64 = geo.face_areas.iter().sum();
    if total <= 0.0 {
        return Err(GeomtexError::Mesh(
            "every face is degenerate: the mesh has no area to map".into(),
        ));
    }
    let centroid = (0..mesh.faces.len())
        .map(|f| mesh.centroid(f) * geo.face_areas[f])
        .sum::<DVec3>()
        / total;
    let (lo, hi) = mesh.bounds();
    let size = hi - lo;
    let long = if size.x >= size.y && size.x >= size.z {
        0
    } else if size.y >= size.z {
        1
    } else {
        2
    };
    let world = [DVec3::X, DVec3::Y, DVec3::Z];
    let z = world[long];
    let axes = [world[(long + 1) % 3], world[(long + 2) % 3], z];
    let (origin, cell) = match primary {
        Primary::Cylindrical => {
            let length = size[long].max(1e-12);
            let base = centroid + z * (lo[long] - centroid[long]);
            (base, DVec2::new(0.0, length / resolution as f64))
        }
        _ => (centroid, DVec2::ZERO),
    };
    Ok(Grid {
        origin,
        axes,
        cell,
        width: resolution,
        height: resolution,
        first_cell: 0,
    })
}

/// The triangle table: every grid's own faces, then its ring's, projected.
fn make_entries(mesh: &Mesh, primary: Primary, grids: &[Grid], owners: &Owners) -> Vec<Entry> {
    grids
        .par_iter()
        .zip(owners)
        .enumerate()
        .flat_map_iter(|(g, (grid, (own, ring)))| {
            own.iter().chain(ring).map(move |&f| {
                let corners = mesh.faces[f as usize].map(|v| mesh.positions[v as usize]);
                let t = grid.triangle(primary, corners);
                Entry {
                    face: f,
                    grid: g as u32,
                    corners: t.map(|c| [c.x as f32, c.y as f32]),
                }
            })
        })
        .collect()
}

/// Entries per parallel job of the list stage (also how often it polls for cancellation).
const CHUNK: usize = 4096;

/// The hash and list tables: every (cell, entry) overlap, sorted, as offsets and payload.
fn lists(
    primary: Primary,
    grids: &[Grid],
    entries: &[Entry],
    stages: &mut Stages,
) -> Result<(Vec<u32>, Vec<u32>)> {
    stages.begin("lists")?;
    let chunks: Vec<(usize, &[Entry])> = entries
        .chunks(CHUNK)
        .enumerate()
        .map(|(k, c)| (k * CHUNK, c))
        .collect();
    let parts =
        crate::progress::each_chart(&chunks, stages.progress, "lists", |&(start, chunk)| {
            let mut pairs = Vec::with_capacity(chunk.len() * 4);
            let mut cells = Vec::new();
            for (k, e) in chunk.iter().enumerate() {
                let grid = &grids[e.grid as usize];
                cells.clear();
                grid.overlapped_cells(primary, &e.corners64(), &mut cells);
                let id = (start + k) as u64;
                pairs.extend(
                    cells
                        .iter()
                        .map(|&c| (((grid.first_cell + c) as u64) << 32) | id),
                );
            }
            pairs
        })?;
    let mut pairs: Vec<u64> = parts.concat();
    pairs.par_sort_unstable();
    let n_cells = grids.last().map_or(0, |g| g.first_cell + g.cells()) as usize;
    let mut cell_start = vec![0u32; n_cells + 1];
    for &p in &pairs {
        cell_start[(p >> 32) as usize + 1] += 1;
    }
    for c in 0..n_cells {
        cell_start[c + 1] += cell_start[c];
    }
    let cell_entries = pairs.iter().map(|&p| p as u32).collect();
    stages.end("lists");
    Ok((cell_start, cell_entries))
}

/// The attribute table of `mesh`'s faces.
fn attributes(mesh: &Mesh, opts: &IgtOptions) -> Attributes {
    let geo = MeshGeometry::new(mesh);
    let normals = geo
        .corner_normals(mesh, opts.normals)
        .faces()
        .map(|c| c.map(|n| n.as_vec3().to_array()))
        .collect();
    // Face colors before vertex colors, as the mesh itself is drawn (Mesh::face_color).
    let colors = if !opts.colors {
        None
    } else if let Some(fc) = &mesh.appearance.face_colors {
        Some(fc.iter().map(|&c| [c; 3]).collect())
    } else {
        (mesh.colors.as_ref()).map(|vc| {
            mesh.faces
                .iter()
                .map(|t| t.map(|v| vc[v as usize]))
                .collect()
        })
    };
    let texture = mesh.appearance.texture.as_ref().filter(|_| opts.uv);
    let uv = texture.map(|t| match &t.coords {
        TextureCoords::PerVertex(uv) => mesh
            .faces
            .iter()
            .map(|f| f.map(|v| uv[v as usize].as_vec2().to_array()))
            .collect(),
        TextureCoords::PerCorner(c) => c
            .iter()
            .map(|f| f.map(|p| p.as_vec2().to_array()))
            .collect(),
    });
    Attributes {
        normals,
        colors,
        uv,
        image: texture.map(|t| t.image.clone()),
        ao: None,
    }
}

/// Ambient occlusion at every corner of `mesh` (its vertex's), as bytes.
fn corner_occlusion(
    mesh: &Mesh,
    opts: &OcclusionOptions,
    progress: Progress,
) -> Result<Vec<[u8; 3]>> {
    let geo = MeshGeometry::new(mesh);
    let open = occlusion::vertex_occlusion(mesh, &geo, opts, progress)?;
    let byte = |v: u32| (open[v as usize] * 255.0).round() as u8;
    Ok(mesh.faces.iter().map(|t| t.map(byte)).collect())
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

#[cfg(test)]
mod tests;

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

/// How far past the detailed mesh's bounding box (a share of its diagonal, on every side) a mesh
/// shaded through its texture may reach: a simplification stays within a fraction of a percent.
pub const MAX_REACH_PAST_SOURCE: f64 = 0.25;

/// Refuses a mesh that does not lie where the texture's detailed mesh lies: its faces' windows
/// and nearest detailed faces are searched outward from the detailed surface, so a mesh moved
/// away (10 diagonals) made the search run for minutes without an answer that means anything.
pub fn check_near_source(igt: &InverseGeometricTexture, mesh: &Mesh) -> Result<()> {
    let bounds = |points: &[DVec3]| {
        points.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        )
    };
    let (lo, hi) = bounds(&igt.positions);
    let reach = MAX_REACH_PAST_SOURCE * (hi - lo).length();
    let used: Vec<DVec3> = (mesh.faces.iter().flatten())
        .map(|&v| mesh.positions[v as usize])
        .collect();
    let (mlo, mhi) = bounds(&used);
    let past = (lo - mlo).max(mhi - hi).max_element();
    if past > reach {
        return Err(GeomtexError::Parameter(format!(
            "the mesh reaches {past:.4e} past the texture's detailed mesh's bounding box \
             ({lo:?} to {hi:?}), more than {MAX_REACH_PAST_SOURCE} of its diagonal: shade a mesh \
             simplified from that mesh, in its space"
        )));
    }
    Ok(())
}

impl IgtMesh {
    pub fn new(
        igt: Arc<InverseGeometricTexture>,
        mesh: Mesh,
        face_grid: Vec<i64>,
        lookup: Lookup,
        cancel: &crate::cancel::Cancel,
    ) -> Result<Self> {
        if face_grid.len() != mesh.faces.len() {
            return Err(GeomtexError::Parameter(format!(
                "{} face grids for {} faces",
                face_grid.len(),
                mesh.faces.len()
            )));
        }
        let n = igt.grids.len() as i64;
        if let Some(f) = face_grid.iter().position(|&g| !(0..n).contains(&g)) {
            return Err(GeomtexError::Parameter(format!(
                "face {f} names grid {} but the texture has {n} grids",
                face_grid[f]
            )));
        }
        check_near_source(&igt, &mesh)?;
        let face_grid: Vec<u32> = face_grid.into_iter().map(|g| g as u32).collect();
        let (face_window, face_search_grids) = window::windows(&igt, &mesh, &face_grid, cancel)?;
        Ok(IgtMesh {
            igt,
            mesh,
            face_grid,
            lookup,
            face_window,
            face_search_grids,
            samples: 1,
            lod: Lod::default(),
        })
    }

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
