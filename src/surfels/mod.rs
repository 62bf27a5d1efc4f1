//! Surfel hierarchies (after Object Textures): every surface texel of a geometry-texture set is a
//! surfel (a disc with a normal, radius and color); each patch is cut into square tiles of
//! `tile` texels a side, and within a tile 2x2 neighbouring surfels merge into one parent, level
//! by level, up to one surfel per tile (tile 8: the paper's 64/16/4/1). Per tile and level the
//! hierarchy keeps the perpendicular error (how far the finest surfels stray from that level's
//! discs) and a normal cone, so a renderer can pick each tile's coarsest level that stays within
//! a pixel budget (render/kinds/surfels.rs). Above the tiles, each patch's tiles form a quadtree
//! of nodes (2x2 tiles or nodes merged into one surfel per node, up to one node per patch), so a
//! far model draws fewer surfels than it has tiles (nodes.rs). This module builds hierarchies
//! and files them; their types are the data model's (surfel_data.rs), which the renderer draws.
//!
//! Spaces: world (f64, the set's), and patch-local texel grids (column i along u, row j along v)
//! for the tiling only. Level 0 is the finest.

pub mod file;
mod nodes;

use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;

use crate::error::Result;
use crate::gtex::{GeometryTextureSet, Patch};
use crate::surfel_data::{check_tile, Node, Surfel, SurfelHierarchy, Tile};

/// Steepest tangent plane a finest disc is sized for: |n·z| below this is treated as this, so a
/// texel seen edge-on by its patch gets a large but finite disc.
const MIN_SLOPE_COSINE: f64 = 0.25;

/// A surfel before its tile places it in the hierarchy's list.
#[derive(Clone, Copy)]
struct Disc {
    position: DVec3,
    normal: DVec3,
    radius: f64,
    color: [f64; 4],
    texels: [u32; 4],
}

impl Disc {
    /// Area-weighted merge of up to four children (weights r²); the radius covers every child's
    /// disc from the merged centre.
    fn merge(children: &[Disc]) -> Disc {
        let weights: Vec<f64> = children.iter().map(|c| c.radius * c.radius).collect();
        let total: f64 = weights.iter().sum::<f64>().max(f64::MIN_POSITIVE);
        let mut position = DVec3::ZERO;
        let mut normal = DVec3::ZERO;
        let mut color = [0.0; 4];
        for (c, w) in children.iter().zip(&weights) {
            position += c.position * *w;
            normal += c.normal * *w;
            for (acc, v) in color.iter_mut().zip(c.color) {
                *acc += v * w;
            }
        }
        position /= total;
        let normal = normal.try_normalize().unwrap_or(children[0].normal);
        let radius = children
            .iter()
            .map(|c| c.position.distance(position) + c.radius)
            .fold(0.0, f64::max);
        let texels = children.iter().fold([u32::MAX, u32::MAX, 0, 0], |b, c| {
            let t = c.texels;
            [
                b[0].min(t[0]),
                b[1].min(t[1]),
                b[2].max(t[2]),
                b[3].max(t[3]),
            ]
        });
        Disc {
            position,
            normal,
            radius,
            color: color.map(|v| v / total),
            texels,
        }
    }
}

/// Per texel of a patch, how far (world units, along a chamfer path of texel steps) it lies
/// from the nearest surface texel: 0 on the surface. A disc clipped to a box of texels covers
/// the box's empty texels too, so a node whose box holds empty texels (a chart's ragged rim
/// under one coarse disc, whole empty tiles beside full ones) reaches past the surface by up
/// to the largest of these: a coverage error its perpendicular error cannot see, which grew
/// the outline (the bunny at 1/16 of a 512² image: IoU 0.983 without it, 0.990 with it).
/// Tile levels leave it out: their boxes hold a tile's few empty texels at most, and counting
/// those under the silhouette share kept every tile on a chart's rim at its finest level (the
/// bunny at 1/2: 141k surfels drawn instead of 57k) for no IoU gained.
pub(crate) struct Reach {
    values: Vec<f64>,
    width: usize,
}

impl Reach {
    pub(crate) fn of(p: &Patch) -> Reach {
        let (w, h) = (p.width as usize, p.height as usize);
        let (sx, sy) = (p.extent.x / w as f64, p.extent.y / h as f64);
        let diagonal = sx.hypot(sy);
        let mut d: Vec<f64> = (0..w * h)
            .map(|t| if p.is_surface(t) { 0.0 } else { f64::INFINITY })
            .collect();
        crate::gtex::chamfer(&mut d, w, h, (sx, sy), diagonal, None);
        Reach {
            values: d,
            width: w,
        }
    }

    /// The farthest any texel of a box (first column, first row, end column, end row) lies
    /// from the surface.
    pub(crate) fn over(&self, b: [u32; 4]) -> f64 {
        (b[1] as usize..b[3] as usize)
            .flat_map(|j| (b[0] as usize..b[2] as usize).map(move |i| j * self.width + i))
            .map(|t| self.values[t])
            .fold(0.0, f64::max)
    }
}

/// The finest disc of a surface texel: centred on the texel's point, in its tangent plane, with
/// the radius reaching the texel's four corners lifted onto that plane.
fn texel_disc(p: &Patch, t: usize, point: DVec3, normal: DVec3) -> Disc {
    let (i, j) = ((t % p.width as usize) as u32, (t / p.width as usize) as u32);
    let (sx, sy) = (p.extent.x / p.width as f64, p.extent.y / p.height as f64);
    let local = DVec3::new(
        normal.dot(p.axes[0]),
        normal.dot(p.axes[1]),
        normal.dot(p.axes[2]),
    );
    let nz = local.z.abs().max(MIN_SLOPE_COSINE).copysign(local.z);
    let mut radius: f64 = 0.0;
    for (dx, dy) in [(0.5, 0.5), (0.5, -0.5), (-0.5, 0.5), (-0.5, -0.5)] {
        let (x, y) = (dx * sx, dy * sy);
        let z = -(local.x * x + local.y * y) / nz;
        radius = radius.max((x * x + y * y + z * z).sqrt());
    }
    Disc {
        position: point,
        normal,
        radius,
        color: p.color(t).map(f64::from),
        texels: [i, j, i + 1, j + 1],
    }
}

/// One level of a tile being built: its cells row-major (a disc and its index in the tile's
/// list, None where empty), and the grid's width and height.
type LevelGrid = (Vec<Option<(Disc, u32)>>, usize, usize);

/// The tiles of one patch, their surfels numbered from 0 (the caller offsets them).
fn patch_tiles(p: &Patch, patch: u32, tile: u32, levels: u32) -> Vec<(Tile, Vec<Surfel>)> {
    let mut grid: Vec<Option<Disc>> = vec![None; p.texels()];
    for (t, point, normal) in p.surface_texels() {
        grid[t] = Some(texel_disc(p, t, point, normal));
    }
    let mut out = Vec::new();
    for j0 in (0..p.height).step_by(tile as usize) {
        for i0 in (0..p.width).step_by(tile as usize) {
            let side = |n: u32, o: u32| tile.min(n - o) as usize;
            let (w, h) = (side(p.width, i0), side(p.height, j0));
            let finest: Vec<Option<Disc>> = (0..h)
                .flat_map(|j| (0..w).map(move |i| (i, j)))
                .map(|(i, j)| grid[(j0 as usize + j) * p.width as usize + i0 as usize + i])
                .collect();
            if finest.iter().any(Option::is_some) {
                out.push(build_tile(finest, (w, h), patch, [i0, j0], levels));
            }
        }
    }
    out
}

/// One tile's levels from its finest discs (`w` x `h`, row-major, None where empty).
fn build_tile(
    finest: Vec<Option<Disc>>,
    (w, h): (usize, usize),
    patch: u32,
    texel: [u32; 2],
    levels: u32,
) -> (Tile, Vec<Surfel>) {
    // Per level: its grid of (disc, index within the tile's list) and its side lengths.
    let mut grids: Vec<LevelGrid> = Vec::new();
    let mut surfels: Vec<Surfel> = Vec::new();
    let mut start = vec![0u32];
    let mut level_grid: Vec<Option<Disc>> = finest;
    let (mut gw, mut gh) = (w, h);
    for level in 0..levels {
        let indexed: Vec<Option<(Disc, u32)>> = level_grid
            .iter()
            .map(|d| {
                d.map(|d| {
                    surfels.push(Surfel {
                        position: d.position,
                        normal: d.normal,
                        radius: d.radius,
                        color: d.color.map(|c| c.round().clamp(0.0, 255.0) as u8),
                        parent: u32::MAX,
                        level: level as u8,
                        texels: d.texels,
                    });
                    (d, surfels.len() as u32 - 1)
                })
            })
            .collect();
        start.push(surfels.len() as u32);
        grids.push((indexed, gw, gh));
        if level + 1 == levels {
            break;
        }
        let (pw, ph) = (gw.div_ceil(2), gh.div_ceil(2));
        let (below, bw, bh) = grids.last().expect("just pushed");
        level_grid = (0..ph)
            .flat_map(|j| (0..pw).map(move |i| (i, j)))
            .map(|(i, j)| {
                let children: Vec<Disc> = [(0, 0), (1, 0), (0, 1), (1, 1)]
                    .iter()
                    .map(|&(di, dj)| (2 * i + di, 2 * j + dj))
                    .filter(|&(ci, cj)| ci < *bw && cj < *bh)
                    .filter_map(|(ci, cj)| below[cj * bw + ci].map(|(d, _)| d))
                    .collect();
                (!children.is_empty()).then(|| Disc::merge(&children))
            })
            .collect();
        (gw, gh) = (pw, ph);
    }
    link_parents(&grids, &mut surfels);
    let tile = tile_figures(&grids, &surfels, patch, texel, start);
    (tile, surfels)
}

/// Sets each surfel's parent: the cell (i/2, j/2) one level up.
fn link_parents(grids: &[LevelGrid], surfels: &mut [Surfel]) {
    for pair in grids.windows(2) {
        let ((below, bw, _), (above, aw, _)) = (&pair[0], &pair[1]);
        for (cell, entry) in below.iter().enumerate() {
            if let Some((_, index)) = entry {
                let (i, j) = (cell % bw, cell / bw);
                let (_, parent) = above[(j / 2) * aw + i / 2].expect("a child's parent exists");
                surfels[*index as usize].parent = parent;
            }
        }
    }
}

/// How far a coarse disc (centre, unit normal) strays from one finest surfel `f` below it: the
/// distance of f's surface point from the disc's plane. (Not f's disc's rim: tilted by a
/// scanner's noisy normals, it reaches up to a texel off the surface the points sample, an
/// error of the finest discs no image of a coarse level can show. The disc's own rim, reaching
/// past the texels it stands for, is clipped away when drawn: Surfel::texels.)
fn disc_error(f: &Surfel, centre: DVec3, normal: DVec3) -> f64 {
    (f.position - centre).dot(normal).abs()
}

/// Errors, cones and the bounding sphere of a built tile (surfel indices local to the tile).
fn tile_figures(
    grids: &[LevelGrid],
    surfels: &[Surfel],
    patch: u32,
    texel: [u32; 2],
    start: Vec<u32>,
) -> Tile {
    let levels = grids.len();
    let finest = &surfels[start[0] as usize..start[1] as usize];
    let mut error = vec![0.0f64; levels];
    for f in finest {
        let mut a = f;
        for e in error.iter_mut().skip(1) {
            a = &surfels[a.parent as usize];
            *e = e.max(disc_error(f, a.position, a.normal));
        }
    }
    for l in 1..levels {
        error[l] = error[l].max(error[l - 1]);
    }
    // One axis for every level (the GPU record keeps one axis and a half angle per level).
    let sum: DVec3 = finest.iter().map(|s| s.normal * s.radius * s.radius).sum();
    let axis = sum.try_normalize().unwrap_or(finest[0].normal);
    let cone = (0..levels)
        .map(|l| {
            let level = &surfels[start[l] as usize..start[l + 1] as usize];
            let angle = level
                .iter()
                .map(|s| s.normal.dot(axis).clamp(-1.0, 1.0).acos())
                .fold(0.0, f64::max);
            (axis, angle)
        })
        .collect();
    let (lo, hi) = surfels.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), s| (lo.min(s.position), hi.max(s.position)),
    );
    let centre = 0.5 * (lo + hi);
    let bound = surfels
        .iter()
        .map(|s| s.position.distance(centre) + s.radius)
        .fold(0.0, f64::max);
    Tile {
        patch,
        texel,
        start,
        error,
        cone,
        centre,
        bound,
        parent: u32::MAX,
    }
}

/// One patch's tiles (with their surfels numbered from 0) and the nodes above them (numbered
/// from 0 within the patch).
type PatchParts = (Vec<(Tile, Vec<Surfel>)>, Vec<Node>);

/// An index moved by `by`; u32::MAX (none) stays.
fn offset(index: u32, by: u32) -> u32 {
    if index == u32::MAX {
        index
    } else {
        index + by
    }
}

impl SurfelHierarchy {
    /// The hierarchy of `set` with `tile` x `tile` texel tiles (a power of two up to MAX_TILE).
    /// Deterministic: the same set and tile give the same hierarchy. A hybrid set's triangles
    /// get no surfels: renderers draw them as its mesh beside the surfels (`Scene::drawn`), as
    /// they are the cheaper form there.
    pub fn build(source: Arc<GeometryTextureSet>, tile: u32) -> Result<SurfelHierarchy> {
        let tile = check_tile(tile as i64)?;
        let levels = tile.trailing_zeros() + 1;
        let per_patch: Vec<PatchParts> = source
            .patches
            .par_iter()
            .enumerate()
            .map(|(k, p)| {
                let reach = Reach::of(p);
                let mut tiles = patch_tiles(p, k as u32, tile, levels);
                let nodes = nodes::patch_nodes(&mut tiles, tile, levels, &reach);
                (tiles, nodes)
            })
            .collect();
        let mut tiles = Vec::new();
        let mut surfels = Vec::new();
        let mut all_nodes = Vec::new();
        for (patch_tiles, mut patch_nodes) in per_patch {
            let first = all_nodes.len() as u32;
            for n in &mut patch_nodes {
                n.parent = offset(n.parent, first);
            }
            all_nodes.extend(patch_nodes);
            for (mut t, local) in patch_tiles {
                t.parent = offset(t.parent, first);
                Self::append_tile(&mut tiles, &mut surfels, t, local);
            }
        }
        Ok(SurfelHierarchy {
            tile,
            levels,
            tiles,
            surfels,
            nodes: all_nodes,
            source,
        })
    }

    /// Appends one tile and its surfels (numbered from 0 within the tile) to the lists.
    fn append_tile(
        tiles: &mut Vec<Tile>,
        surfels: &mut Vec<Surfel>,
        mut t: Tile,
        local: Vec<Surfel>,
    ) {
        let offset = surfels.len() as u32;
        for s in &mut t.start {
            *s += offset;
        }
        surfels.extend(local.into_iter().map(|mut s| {
            if s.parent != u32::MAX {
                s.parent += offset;
            }
            s
        }));
        tiles.push(t);
    }
}

#[cfg(test)]
mod tests;
