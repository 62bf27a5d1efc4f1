//! Building inverse geometric textures (the IGT paper): per cell of a bijective primary
//! parameterization, the list of detailed-mesh triangles that overlap it. A simplified mesh is
//! then shaded with the detailed mesh's attributes: each surface point is projected into the
//! primary space, the listed triangle containing it found by a point-in-triangle test, and that
//! triangle's attributes interpolated. The texture, its lookup and its file are the data
//! model's (igt_data/); here are its build (with ambient occlusion, occlusion.rs) and the
//! preparation of a simplified mesh shaded through it (`IgtMesh::new`, window.rs).
//!
//! Spaces: world (the detailed mesh's, f64) in; primary space per grid in cell units
//! (igt_data/primary.rs).

pub mod occlusion;
pub mod window;

use std::sync::Arc;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::appearance::TextureCoords;
use crate::charts::chart_planes;
use crate::convert_options::ConvertOptions;
use crate::error::{GeomtexError, Result};
use crate::igt_data::{
    check_resolution, Attributes, Entry, Grid, IgtMesh, InverseGeometricTexture, Lod, Lookup,
    Primary, MAX_RESOLUTION,
};
use crate::mesh::{Mesh, MeshGeometry, NormalRule};
use crate::progress::{Progress, Stages};
pub use occlusion::OcclusionOptions;

pub const DEFAULT_RESOLUTION: u32 = 512;

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

#[cfg(test)]
mod tests;

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
}
