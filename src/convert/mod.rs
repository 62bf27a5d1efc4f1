//! Mesh → geometry textures, stage by stage:
//! partition (VSA) → folding repair → overlap rings → frames → texel size → raster → dilation.
//!
//! Space: world (the mesh's coordinates, f64) in, patch boxes in world out.

pub mod error;
pub mod frame;
pub mod overlap;
pub mod raster;
pub mod vsa;

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

pub use frame::InPlane;
pub use raster::NormalSource;

use crate::error::{GeomtexError, Result};
use crate::gtex::{vertical_extent, GeometryTextureSet, Patch, Stats};
use crate::mesh::{Mesh, MeshGeometry};
use frame::FOLD_COS;
use raster::PatchBox;
use vsa::{ChartTarget, FaceSet, NONE};

/// Whose reconstruction error `max_error` bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorScope {
    /// The set's (its area-weighted p99, the figure in `stats`): each chart gets the level that
    /// buys the most accuracy per byte, so a chart whose tail (a crease, a steep rim) would be
    /// dear to remove keeps it while cheap charts get finer.
    Set,
    /// Every chart's own: each gets the coarsest level within the bound.
    Chart,
}

/// Keywords of `convert`. `Default` gives the documented defaults.
#[derive(Clone, Debug)]
pub struct ConvertOptions {
    /// Longest side of any patch, in texels. The texel size is one for the whole set, chosen so
    /// the largest chart just fits.
    /// `None`: 256, or 1024 with `max_error` (where the error sets each chart's texel and the cap
    /// only bounds a chart's memory, 10 MiB at 1024²).
    pub max_resolution: Option<u32>,
    /// World size of a texel; grown if a chart would then exceed `max_resolution`.
    pub texel_size: Option<f64>,
    /// Error-driven resolution: each chart gets the coarsest texel that keeps its reconstruction
    /// error (the area-weighted p99, see `error`) within this many world units, up to
    /// `max_resolution` texels on its longest side. `None`: one texel size for all charts.
    pub max_error: Option<f64>,
    /// `max_error` as a fraction of the mesh's bounding-box diagonal.
    pub max_error_rel: Option<f64>,
    /// Whose error `max_error` bounds.
    pub error_scope: ErrorScope,
    /// Exact chart count for VSA (before folding repair). `None`: driven by `chart_error`.
    pub charts: Option<usize>,
    /// Target area-weighted mean L2,1 error of VSA, sum(area |n - N|^2) / sum(area).
    /// `None`: 0.1, or with `max_error` the cheapest of `ERROR_DRIVEN_CHART_ERRORS`.
    pub chart_error: Option<f64>,
    /// Cap on VSA charts when driven by `chart_error`.
    pub max_charts: usize,
    /// Weight of VSA's compactness term (0 = plain L2,1 VSA); rounder charts waste fewer texels.
    pub compactness: f64,
    /// Lloyd iterations after the last chart insertion.
    pub lloyd_iterations: usize,
    /// Rings of neighbouring faces each chart also draws.
    pub overlap_rings: usize,
    /// Texels of normal/color dilation into empty space.
    pub dilation: usize,
    pub in_plane: InPlane,
    pub normals: NormalSource,
    /// Bits per height code, 8 or 16: 8 halves the height map's bytes and rounds heights to
    /// 1/254 of each patch's height range.
    pub height_bits: u8,
}

impl Default for ConvertOptions {
    fn default() -> Self {
        ConvertOptions {
            max_resolution: None,
            texel_size: None,
            max_error: None,
            max_error_rel: None,
            error_scope: ErrorScope::Set,
            charts: None,
            chart_error: None,
            max_charts: 4096,
            compactness: 1.0,
            lloyd_iterations: 6,
            overlap_rings: 1,
            dilation: 2,
            in_plane: InPlane::MinAreaRect,
            normals: NormalSource::Smooth,
            height_bits: 16,
        }
    }
}

impl ConvertOptions {
    pub fn error_driven(&self) -> bool {
        self.max_error.is_some() || self.max_error_rel.is_some()
    }

    /// `max_resolution`, or its default.
    pub fn resolution_cap(&self) -> u32 {
        self.max_resolution
            .unwrap_or(if self.error_driven() { 1024 } else { 256 })
    }

    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(GeomtexError::Parameter(m));
        if !(2..=16384).contains(&self.resolution_cap()) {
            return bad(format!(
                "max_resolution must be in [2, 16384], got {}",
                self.resolution_cap()
            ));
        }
        if let Some(t) = self.texel_size {
            if !(t.is_finite() && t > 0.0) {
                return bad(format!(
                    "texel_size must be a positive finite number, got {t}"
                ));
            }
        }
        for (name, e) in [
            ("max_error", self.max_error),
            ("max_error_rel", self.max_error_rel),
        ] {
            if let Some(e) = e {
                if !(e.is_finite() && e > 0.0) {
                    return bad(format!("{name} must be a positive finite number, got {e}"));
                }
            }
        }
        if self.max_error.is_some() && self.max_error_rel.is_some() {
            return bad("give max_error or max_error_rel, not both".into());
        }
        if self.texel_size.is_some() && (self.max_error.is_some() || self.max_error_rel.is_some()) {
            return bad(
                "texel_size fixes the texel while max_error chooses it per chart: give one".into(),
            );
        }
        if self.charts == Some(0) {
            return bad("charts must be at least 1".into());
        }
        if let Some(c) = self.chart_error {
            if !(c.is_finite() && (0.0..=4.0).contains(&c)) {
                return bad(format!("chart_error must be in [0, 4], got {c}"));
            }
        }
        if !(self.compactness.is_finite() && (0.0..=100.0).contains(&self.compactness)) {
            return bad(format!(
                "compactness must be in [0, 100], got {}",
                self.compactness
            ));
        }
        if self.max_charts == 0 {
            return bad("max_charts must be at least 1".into());
        }
        if self.overlap_rings > 16 {
            return bad(format!(
                "overlap_rings must be at most 16, got {}",
                self.overlap_rings
            ));
        }
        if self.dilation > 64 {
            return bad(format!(
                "dilation must be at most 64, got {}",
                self.dilation
            ));
        }
        if !crate::gtex::HEIGHT_BITS.contains(&self.height_bits) {
            return bad(format!(
                "height_bits must be 8 or 16, got {}",
                self.height_bits
            ));
        }
        if self.lloyd_iterations > 1000 {
            return bad(format!(
                "lloyd_iterations must be at most 1000, got {}",
                self.lloyd_iterations
            ));
        }
        Ok(())
    }
}

/// Progress: called with a stage name and its completed fraction in [0, 1]; returning false
/// cancels the conversion. May be called from worker threads.
pub type Progress<'a> = &'a (dyn Fn(&str, f64) -> bool + Sync);

struct Timer {
    start: Instant,
    seconds: Vec<(String, f64)>,
}

impl Timer {
    fn lap(&mut self, stage: &str) {
        let now = Instant::now();
        self.seconds
            .push((stage.into(), (now - self.start).as_secs_f64()));
        self.start = now;
    }
}

fn report(progress: Progress, stage: &str, fraction: f64) -> Result<()> {
    if progress(stage, fraction) {
        Ok(())
    } else {
        Err(GeomtexError::Cancelled(stage.into()))
    }
}

/// A chart after repair: its faces and height direction.
struct Chart {
    faces: Vec<u32>,
    z: DVec3,
}

/// Charts sample their surface at most this often to measure reconstruction error.
const ERROR_SAMPLES_PER_CHART: usize = 20_000;
/// Reconstruction error is this quantile (by area) of the distances: the maximum would be set
/// by the few samples at creases and rims, where a bilinear map of any resolution rounds corners.
const ERROR_QUANTILE: f64 = 0.99;

/// A chart drawn at one texel size: its box, its maps, and its reconstruction errors with the
/// area each stands for (see `error`), whose `ERROR_QUANTILE` is `error`.
struct Drawn {
    bx: PatchBox,
    maps: raster::Maps,
    errors: Vec<error::Weighted>,
    error: f64,
}

/// Draws a chart (its own faces first, then its ring) at texel size `texel` and measures its
/// reconstruction error against `samples` of its own faces and its lips.
#[allow(clippy::too_many_arguments)]
fn draw_chart(
    mesh: &Mesh,
    geo: &MeshGeometry,
    faces: &[u32],
    chart_faces: usize,
    frame: &([DVec3; 3], DVec3, DVec3, DVec3),
    texel: f64,
    opts: &ConvertOptions,
    samples: &[(DVec3, f64)],
) -> Drawn {
    let bx = patch_box(frame, texel, opts);
    let mut maps = raster::rasterize(mesh, geo, faces, chart_faces, &bx, opts.normals);
    // The height field as a patch for the error lookups; its heights go back to the maps.
    let probe = bx.into_patch(
        raster::Maps {
            heights: std::mem::take(&mut maps.heights),
            ..Default::default()
        },
        Vec::new(),
        Vec::new(),
    );
    let mut errors = error::gaps(&probe, samples);
    maps.heights = probe.heights;
    // Surface reaching `d` past the mesh over a texel's width stands for about d × texel of
    // area (a texel at most): a lip, or an overhanging corner. A chart's box is padded by up to
    // half a texel, so its flat border often reaches a little past the outline; counted as a
    // whole texel each, such slivers alone would set the p99 of a map a few hundred texels wide.
    let texel_len = ((bx.extent.x / bx.width as f64) * (bx.extent.y / bx.height as f64)).sqrt();
    let area = |d: f64| texel_len * d.min(texel_len);
    errors.extend(maps.lips.iter().map(|&(_, d)| (d, area(d))));
    errors.extend(maps.overhangs.iter().map(|&d| (d, area(d))));
    let error = error::quantile(&mut errors, ERROR_QUANTILE);
    Drawn {
        bx,
        maps,
        errors,
        error,
    }
}

/// A chart ready to draw: its own faces then its ring, its frame (axes, reference point,
/// local bounds) and the longer side of its bounds.
struct ChartJob<'a> {
    faces: Vec<u32>,
    chart_faces: usize,
    frame: &'a ([DVec3; 3], DVec3, DVec3, DVec3),
    long: f64,
}

/// `work` on every item in parallel, reporting progress as `stage` and stopping early when the
/// callback cancels.
fn each_chart<J: Sync, T: Send>(
    items: &[J],
    progress: Progress,
    stage: &str,
    work: impl Fn(&J) -> T + Sync,
) -> Result<Vec<T>> {
    let done = AtomicUsize::new(0);
    let cancelled = AtomicBool::new(false);
    let out: Vec<Option<T>> = items
        .par_iter()
        .map(|item| {
            if cancelled.load(Ordering::Relaxed) {
                return None;
            }
            let t = work(item);
            let k = done.fetch_add(1, Ordering::Relaxed) + 1;
            if k % 16 == 0 && !progress(stage, k as f64 / items.len() as f64) {
                cancelled.store(true, Ordering::Relaxed);
            }
            Some(t)
        })
        .collect();
    if cancelled.load(Ordering::Relaxed) {
        return Err(GeomtexError::Cancelled(stage.into()));
    }
    Ok(out.into_iter().flatten().collect())
}

/// Long-side resolutions the error-driven search tries, finest first: `max` down to 2 in
/// steps of 2^(1/4), so neighbouring levels differ by ~30% in texel count.
fn resolution_levels(max: u32) -> Vec<u32> {
    let mut levels: Vec<u32> = (0..)
        .map(|k| (max as f64 * 0.5f64.powf(k as f64 / 4.0)).round() as u32)
        .take_while(|&r| r > 2)
        .collect();
    levels.push(2);
    levels.dedup();
    levels
}

/// The coarsest level whose measured error is within `max_error`, by bisection (error grows as
/// the resolution falls, up to aliasing); the finest level if none is. Whatever is returned
/// was measured, so a chart said to be within the bound is.
fn coarsest_within(levels: &[u32], max_error: f64, draw: impl Fn(u32) -> Drawn) -> u32 {
    let (mut lo, mut hi) = (0, levels.len());
    let mut within = None;
    while lo < hi {
        let mid = (lo + hi) / 2;
        if draw(levels[mid]).error <= max_error {
            lo = mid + 1;
            within = Some(levels[mid]); // each later success is coarser
        } else {
            hi = mid;
        }
    }
    within.unwrap_or(levels[0])
}

/// A chart at one resolution: its bytes, and the area of its surface over the error bound
/// out of all the area its errors stand for.
#[derive(Clone, Copy, Debug)]
struct LevelCost {
    resolution: u32,
    bytes: f64,
    over: f64,
    area: f64,
}

/// A chart's costs from its coarsest level up to the first that has next to nothing over the
/// bound, or the finest.
fn level_costs(levels: &[u32], max_error: f64, draw: impl Fn(u32) -> Drawn) -> Vec<LevelCost> {
    let mut costs = Vec::new();
    for &resolution in levels.iter().rev() {
        let d = draw(resolution);
        let over: f64 = d
            .errors
            .iter()
            .filter(|e| e.0 > max_error)
            .map(|e| e.1)
            .sum();
        let area: f64 = d.errors.iter().map(|e| e.1).sum();
        let texels = d.bx.width as usize * d.bx.height as usize;
        let bytes = crate::gtex::map_bytes(texels, d.bx.height_bits) as f64;
        costs.push(LevelCost {
            resolution,
            bytes,
            over,
            area,
        });
        // Finer levels could lower this chart's share of the set's budget by a tenth of its
        // density at most: not worth measuring.
        if over <= 0.1 * (1.0 - ERROR_QUANTILE) * area {
            break;
        }
    }
    costs
}

/// Each chart's level for the fewest bytes with at most `1 - quantile` of all the area over the
/// bound, so the set's error quantile is within it. A multiple-choice knapsack, solved by its
/// Lagrangian: for a price `lambda` per unit of area over the bound each chart takes its
/// cheapest level on its own, and the price rises until the set fits. None if even the finest
/// levels do not fit.
fn allocate(costs: &[Vec<LevelCost>], quantile: f64) -> Option<Vec<u32>> {
    let slack = 1.0 - quantile;
    let choose = |lambda: f64| -> (Vec<u32>, f64) {
        let mut excess = 0.0;
        let picks = costs
            .iter()
            .map(|levels| {
                let price = |c: &LevelCost| c.bytes + lambda * (c.over - slack * c.area);
                let best = levels
                    .iter()
                    .min_by(|a, b| price(a).total_cmp(&price(b)))
                    .expect("every chart has a level");
                excess += best.over - slack * best.area;
                best.resolution
            })
            .collect();
        (picks, excess)
    };
    // The price is in bytes per unit area: bracket it in powers of ten around bytes / area.
    let bytes: f64 = costs.iter().filter_map(|c| c.last()).map(|c| c.bytes).sum();
    let area: f64 = costs.iter().filter_map(|c| c.last()).map(|c| c.area).sum();
    let unit = bytes / area.max(f64::MIN_POSITIVE);
    let (mut lo, mut hi) = (-12.0f64, 24.0f64); // log10 of lambda / unit
    let (fine, excess) = choose(unit * 10f64.powf(hi));
    if excess > 0.0 {
        return None;
    }
    let mut best = fine;
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        let (picks, excess) = choose(unit * 10f64.powf(mid));
        if excess <= 0.0 {
            hi = mid;
            best = picks;
        } else {
            lo = mid;
        }
    }
    Some(best)
}

/// The box of a chart (its frame: axes, reference point, local bounds) at texel size `texel`.
fn patch_box(
    frame: &([DVec3; 3], DVec3, DVec3, DVec3),
    texel: f64,
    opts: &ConvertOptions,
) -> PatchBox {
    let (axes, reference, lo, hi) = frame;
    let size = *hi - *lo;
    let res = |s: f64| ((s / texel).ceil() as u32).clamp(2, opts.resolution_cap().max(2));
    let (w, h) = (res(size.x), res(size.y));
    // Centre the chart in its whole-texel box.
    let pad_x = (w as f64 * texel - size.x) * 0.5;
    let pad_y = (h as f64 * texel - size.y) * 0.5;
    let (thickness, height_bits) = vertical_extent(size.z, texel, opts.height_bits);
    let pad_z = (thickness - size.z) * 0.5;
    let corner = DVec3::new(lo.x - pad_x, lo.y - pad_y, lo.z - pad_z);
    PatchBox {
        origin: *reference + axes[0] * corner.x + axes[1] * corner.y + axes[2] * corner.z,
        axes: *axes,
        extent: DVec3::new(w as f64 * texel, h as f64 * texel, thickness),
        width: w,
        height: h,
        height_bits,
    }
}

/// VSA's target mean error when none is given.
const DEFAULT_CHART_ERROR: f64 = 0.1;
/// Partitions tried when `max_error` is given without `chart_error` or `charts`: with a texel
/// of its own, a chart no longer sets everyone's texel, so fewer, larger charts (fewer ring
/// faces drawn twice) often cost fewer bytes; sharp-creased CAD models still want the finest.
const ERROR_DRIVEN_CHART_ERRORS: [f64; 3] = [0.1, 0.2, 0.3];

pub fn convert(
    mesh: &Mesh,
    opts: &ConvertOptions,
    progress: Progress,
) -> Result<GeometryTextureSet> {
    opts.validate()?;
    if !opts.error_driven() || opts.chart_error.is_some() || opts.charts.is_some() {
        return convert_once(mesh, opts, progress);
    }
    // The set within the bound with the fewest bytes (or the most accurate, if none is).
    let start = Instant::now();
    let mut best: Option<GeometryTextureSet> = None;
    for tolerance in ERROR_DRIVEN_CHART_ERRORS {
        let o = ConvertOptions {
            chart_error: Some(tolerance),
            ..opts.clone()
        };
        let set = convert_once(mesh, &o, progress)?;
        let key = |s: &GeometryTextureSet| {
            let st = |n: &str| s.stats.get(n).unwrap_or(f64::INFINITY);
            let within = st("reconstruction_error_p99") <= st("max_error");
            (
                !within,
                if within {
                    st("bytes")
                } else {
                    st("reconstruction_error_p99")
                },
            )
        };
        if best.as_ref().is_none_or(|b| key(&set) < key(b)) {
            best = Some(set);
        }
    }
    let mut best = best.expect("at least one partition");
    best.stats
        .set("partitions_tried", ERROR_DRIVEN_CHART_ERRORS.len() as f64);
    best.stats
        .seconds
        .push(("all_partitions".into(), start.elapsed().as_secs_f64()));
    Ok(best)
}

/// One conversion with one partition target.
fn convert_once(
    mesh: &Mesh,
    opts: &ConvertOptions,
    progress: Progress,
) -> Result<GeometryTextureSet> {
    let total_start = Instant::now();
    let mut timer = Timer {
        start: total_start,
        seconds: Vec::new(),
    };
    let mut stats = Stats::default();

    report(progress, "geometry", 0.0)?;
    let mut geo = MeshGeometry::new(mesh);
    let inconsistent_edges = geo.edge_counts.inconsistent;
    // Charts are grown from face normals, so reversed triangles would split them into thousands
    // of slivers: wind every face like its neighbours first (face indices stay the same).
    let flips = geo.winding_flips();
    let flipped_faces = flips.iter().filter(|&&f| f).count();
    let oriented;
    let mesh = if flipped_faces > 0 {
        oriented = Mesh {
            faces: mesh
                .faces
                .iter()
                .zip(&flips)
                .map(|(&[a, b, c], &flip)| if flip { [a, c, b] } else { [a, b, c] })
                .collect(),
            ..mesh.clone()
        };
        geo = MeshGeometry::new(&oriented);
        &oriented
    } else {
        mesh
    };
    let active: Vec<u32> = (0..mesh.faces.len() as u32)
        .filter(|&f| !geo.degenerate[f as usize])
        .collect();
    if active.is_empty() {
        return Err(GeomtexError::Mesh(format!(
            "all {} faces are degenerate (zero area or a repeated vertex): nothing to convert",
            mesh.faces.len()
        )));
    }
    timer.lap("geometry");

    // Partition.
    report(progress, "partition", 0.0)?;
    let mut scratch = vec![NONE; mesh.faces.len()];
    let set = FaceSet::new(&geo, &active, &mut scratch);
    let target = match opts.charts {
        Some(n) => ChartTarget::Count(n),
        None => ChartTarget::MeanError {
            tolerance: opts.chart_error.unwrap_or(DEFAULT_CHART_ERROR),
            max_charts: opts.max_charts,
        },
    };
    let part = vsa::partition(&set, target, opts.lloyd_iterations, opts.compactness);
    let mut groups: Vec<Vec<u32>> = vec![Vec::new(); part.proxies.len()];
    for (l, &c) in part.labels.iter().enumerate() {
        groups[c as usize].push(set.global[l]);
    }
    groups.retain(|g| !g.is_empty());
    let vsa_mean_error = part.mean_error;
    drop(set);
    timer.lap("partition");

    // Folding repair: a chart folds if any face has normal·z <= 0 in its frame. The paper's
    // frame (median normal) is the yardstick for the "before" figures.
    report(progress, "repair", 0.0)?;
    let initial_charts = groups.len();
    let (mut folding_before, mut inverted_before) = (0usize, 0usize);
    for g in &groups {
        let z = frame::median_normal(&geo, g)
            .try_normalize()
            .unwrap_or(DVec3::Z);
        let inv = g
            .iter()
            .filter(|&&f| geo.face_normals[f as usize].dot(z) <= 0.0)
            .count();
        folding_before += (inv > 0) as usize;
        inverted_before += inv;
    }
    let mut queue = groups;
    let mut charts: Vec<Chart> = Vec::with_capacity(queue.len());
    let mut splits = 0usize;
    while let Some(faces) = queue.pop() {
        let (z, worst) = frame::choose_z(&geo, &faces);
        if worst > FOLD_COS || faces.len() == 1 {
            charts.push(Chart { faces, z });
            continue;
        }
        let sub = FaceSet::new(&geo, &faces, &mut scratch);
        let halves = vsa::split_in_two(&sub, z);
        let mut parts: Vec<Vec<u32>> = vec![Vec::new(); halves.proxies.len()];
        for (l, &c) in halves.labels.iter().enumerate() {
            if c != NONE {
                parts[c as usize].push(sub.global[l]);
            }
        }
        parts.retain(|p| !p.is_empty());
        if parts.len() < 2 {
            // VSA could not separate them (identical normals cannot fold): split by facing.
            let (up, down): (Vec<u32>, Vec<u32>) = faces
                .iter()
                .partition(|&&f| geo.face_normals[f as usize].dot(z) > FOLD_COS);
            parts = vec![up, down];
            parts.retain(|p| !p.is_empty());
        }
        splits += 1;
        queue.extend(parts);
    }
    // Largest charts first: a stable, meaningful order for users and for atlas packing.
    charts.sort_by(|a, b| {
        b.faces
            .len()
            .cmp(&a.faces.len())
            .then(a.faces[0].cmp(&b.faces[0]))
    });
    timer.lap("repair");

    // Overlap rings.
    report(progress, "overlap", 0.0)?;
    let rings: Vec<(Vec<u32>, usize)> = charts
        .par_iter()
        .map(|c| overlap::ring_faces(mesh, &geo, &c.faces, c.z, opts.overlap_rings))
        .collect();
    let ring_faces_skipped: usize = rings.iter().map(|r| r.1).sum();
    timer.lap("overlap");

    // Frames: axes and the tight box of everything each chart draws, relative to a chart vertex.
    report(progress, "frame", 0.0)?;
    let frames: Vec<([DVec3; 3], DVec3, DVec3, DVec3)> = charts
        .par_iter()
        .zip(&rings)
        .map(|(c, (ring, _))| {
            let mut verts: Vec<u32> = c
                .faces
                .iter()
                .chain(ring)
                .flat_map(|&f| mesh.faces[f as usize])
                .collect();
            verts.sort_unstable();
            verts.dedup();
            let points: Vec<DVec3> = verts.iter().map(|&v| mesh.positions[v as usize]).collect();
            let axes = frame::in_plane_axes(&points, c.z, opts.in_plane);
            let reference = points[0];
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for p in &points {
                let d = *p - reference;
                let l = DVec3::new(d.dot(axes[0]), d.dot(axes[1]), d.dot(axes[2]));
                lo = lo.min(l);
                hi = hi.max(l);
            }
            (axes, reference, lo, hi)
        })
        .collect();
    // The longer in-plane side of a chart's bounds.
    let long_side = |f: &([DVec3; 3], DVec3, DVec3, DVec3)| (f.3 - f.2).x.max((f.3 - f.2).y);
    let longest = frames.iter().map(long_side).fold(0.0, f64::max);
    let fit = longest / opts.resolution_cap() as f64;
    let mut texel = opts.texel_size.map_or(fit, |t| t.max(fit));
    if texel <= 0.0 {
        texel = geo.diagonal.max(f64::MIN_POSITIVE) * 1e-6; // every chart is a point
    }
    let max_error = opts
        .max_error
        .or(opts.max_error_rel.map(|r| r * geo.diagonal));
    let levels = resolution_levels(opts.resolution_cap());
    timer.lap("frame");

    // Raster and reconstruction error, chart by chart: at the one texel size, or each at its own
    // resolution chosen for max_error.
    let jobs: Vec<ChartJob> = charts
        .iter()
        .zip(&rings)
        .zip(&frames)
        .map(|((c, (ring, _)), frame)| ChartJob {
            faces: c.faces.iter().chain(ring).copied().collect(),
            chart_faces: c.faces.len(),
            frame,
            long: long_side(frame).max(texel * 1e-3),
        })
        .collect();
    // Samples about a texel apart at the finest texel a chart can get.
    let spacing = |j: &ChartJob| match max_error {
        None => texel,
        Some(_) => j.long / opts.resolution_cap() as f64,
    };
    let samples = |j: &ChartJob| {
        error::surface_samples(
            mesh,
            &j.faces[..j.chart_faces],
            spacing(j),
            ERROR_SAMPLES_PER_CHART,
        )
    };
    let draw = |j: &ChartJob, t: f64, samples: &[(DVec3, f64)]| {
        draw_chart(
            mesh,
            &geo,
            &j.faces,
            j.chart_faces,
            j.frame,
            t,
            opts,
            samples,
        )
    };
    let resolution_texel = |j: &ChartJob, r: u32| j.long / r as f64;
    // Each chart's texel size.
    let texels: Vec<f64> = match max_error {
        None => vec![texel; jobs.len()],
        Some(e) => {
            report(progress, "resolution", 0.0)?;
            let picks = match opts.error_scope {
                ErrorScope::Chart => each_chart(&jobs, progress, "resolution", |j| {
                    let s = samples(j);
                    coarsest_within(&levels, e, |r| draw(j, resolution_texel(j, r), &s))
                })?,
                ErrorScope::Set => {
                    let costs = each_chart(&jobs, progress, "resolution", |j| {
                        let s = samples(j);
                        level_costs(&levels, e, |r| draw(j, resolution_texel(j, r), &s))
                    })?;
                    // Not even the finest levels fit: every chart at its finest measured.
                    allocate(&costs, ERROR_QUANTILE).unwrap_or_else(|| {
                        costs.iter().map(|c| c.last().unwrap().resolution).collect()
                    })
                }
            };
            timer.lap("resolution");
            jobs.iter()
                .zip(picks)
                .map(|(j, r)| resolution_texel(j, r))
                .collect()
        }
    };
    // Drawn once more at the chosen texel: keeping the maps of every level measured would hold
    // a few times the finest maps in memory.
    report(progress, "raster", 0.0)?;
    let jobs_texels: Vec<(&ChartJob, f64)> = jobs.iter().zip(texels).collect();
    let mut drawn = each_chart(&jobs_texels, progress, "raster", |&(j, t)| {
        draw(j, t, &samples(j))
    })?;
    timer.lap("raster");

    report(progress, "dilate", 0.0)?;
    drawn
        .par_iter_mut()
        .for_each(|d| raster::dilate(&mut d.maps, d.bx.width, d.bx.height, opts.dilation));
    timer.lap("dilate");

    let patch_errors: Vec<f64> = drawn.iter().map(|d| d.error).collect();
    let mut all_errors: Vec<error::Weighted> = drawn
        .iter_mut()
        .flat_map(|d| std::mem::take(&mut d.errors))
        .collect();
    let reconstruction_max = all_errors.iter().map(|e| e.0).fold(0.0, f64::max);
    let reconstruction_p99 = error::quantile(&mut all_errors, ERROR_QUANTILE);
    drop(all_errors);

    let patches: Vec<Patch> = charts
        .into_iter()
        .zip(rings)
        .zip(drawn)
        .map(|((c, (ring, _)), Drawn { bx, maps, .. })| bx.into_patch(maps, c.faces, ring))
        .collect();
    let patch_texel = |p: &Patch| (p.extent.x / p.width as f64).min(p.extent.y / p.height as f64);
    // The set's texel size: the one texel, or the finest chart's when each has its own.
    if max_error.is_some() {
        texel = patches
            .iter()
            .map(patch_texel)
            .fold(f64::INFINITY, f64::min);
    }

    // Figures, recomputed from the output rather than carried along.
    let folding_after = patches
        .iter()
        .filter(|p| frame::min_dot(&geo, &p.faces, p.axes[2]) <= 0.0)
        .count();
    let inverted_after: usize = patches
        .iter()
        .map(|p| {
            p.faces
                .iter()
                .filter(|&&f| geo.face_normals[f as usize].dot(p.axes[2]) <= 0.0)
                .count()
        })
        .sum();
    let mut set = GeometryTextureSet {
        patches,
        texel_size: texel,
        stats: Stats::default(),
    };
    if let Some(e) = max_error {
        // Charts that stayed over the bound at max_resolution.
        let over = patch_errors.iter().filter(|&&p| p > e).count();
        stats.set("max_error", e);
        stats.set("charts_over_max_error", over as f64);
    }
    stats.per_patch = vec![
        (
            "patch_texel".into(),
            set.patches.iter().map(patch_texel).collect(),
        ),
        ("patch_error".into(), patch_errors),
        (
            "patch_resolution".into(),
            set.patches
                .iter()
                .map(|p| p.width.max(p.height) as f64)
                .collect(),
        ),
    ];
    let (texels, empty) = (set.texels(), set.empty_texels());
    for (name, v) in [
        ("faces", mesh.faces.len() as f64),
        ("vertices", mesh.positions.len() as f64),
        ("degenerate_faces", (mesh.faces.len() - active.len()) as f64),
        ("duplicate_vertices", geo.duplicate_vertices as f64),
        ("boundary_edges", geo.edge_counts.boundary as f64),
        ("nonmanifold_edges", geo.edge_counts.nonmanifold as f64),
        ("inconsistent_edges", inconsistent_edges as f64),
        ("flipped_faces", flipped_faces as f64),
        ("charts", set.patches.len() as f64),
        ("vsa_charts", initial_charts as f64),
        ("vsa_mean_error", vsa_mean_error),
        (
            "chart_error",
            opts.chart_error.unwrap_or(DEFAULT_CHART_ERROR),
        ),
        ("repair_splits", splits as f64),
        ("folding_charts", folding_after as f64),
        ("inverted_triangles", inverted_after as f64),
        ("folding_charts_before_repair", folding_before as f64),
        ("inverted_triangles_before_repair", inverted_before as f64),
        (
            "ring_faces",
            set.patches
                .iter()
                .map(|p| p.ring_faces.len())
                .sum::<usize>() as f64,
        ),
        ("ring_faces_skipped", ring_faces_skipped as f64),
        ("texels", texels as f64),
        ("empty_texels", empty as f64),
        ("empty_fraction", empty as f64 / texels.max(1) as f64),
        ("bytes", set.map_bytes() as f64),
        ("height_bits", opts.height_bits as f64),
        (
            "patches_kept_at_16_bits",
            set.patches
                .iter()
                .filter(|p| p.height_bits > opts.height_bits)
                .count() as f64,
        ),
        (
            "max_quantization_error",
            set.patches
                .iter()
                .map(Patch::quantization_error)
                .fold(0.0, f64::max),
        ),
        ("texel_size", texel),
        ("reconstruction_error_p99", reconstruction_p99),
        ("reconstruction_error_max", reconstruction_max),
        ("diagonal", geo.diagonal),
    ] {
        stats.set(name, v);
    }
    timer
        .seconds
        .push(("total".into(), total_start.elapsed().as_secs_f64()));
    stats.seconds = timer.seconds;
    set.stats = stats;
    report(progress, "done", 1.0)?;
    Ok(set)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolution_levels_step_by_a_quarter_octave_down_to_two() {
        let l = resolution_levels(256);
        assert_eq!(l[..5], [256, 215, 181, 152, 128]);
        assert_eq!(*l.last().unwrap(), 2);
        assert!(l.windows(2).all(|w| w[0] > w[1]));
        assert_eq!(resolution_levels(2), [2]);
    }

    fn cost(resolution: u32, bytes: f64, over: f64, area: f64) -> LevelCost {
        LevelCost {
            resolution,
            bytes,
            over,
            area,
        }
    }

    #[test]
    fn allocation_is_the_cheapest_that_fits_the_quantile() {
        // Three charts of equal area, coarse to fine; at most 1% of all area may be over.
        let costs = vec![
            // Cheap to fix: 4% over at 10 bytes, nothing over at 40.
            vec![cost(2, 10.0, 4.0, 100.0), cost(4, 40.0, 0.0, 100.0)],
            // Dear to fix: 2% over at 10 bytes, 1% at 1000, nothing at 5000.
            vec![
                cost(2, 10.0, 2.0, 100.0),
                cost(4, 1000.0, 1.0, 100.0),
                cost(8, 5000.0, 0.0, 100.0),
            ],
            // Within the bound already.
            vec![cost(2, 10.0, 0.0, 100.0)],
        ];
        // Budget 3 units of area: fix the first chart, keep the second's tail.
        assert_eq!(allocate(&costs, 0.99), Some(vec![4, 2, 2]));
        // Budget 1.5: the second must reach 1%, and the first must be fixed too.
        assert_eq!(allocate(&costs, 0.995), Some(vec![4, 4, 2]));
        // Brute force agrees on the cheapest feasible choice for a range of budgets.
        for q in [0.9, 0.97, 0.98, 0.99, 0.995, 0.999, 1.0] {
            let mut best = (f64::INFINITY, vec![]);
            for a in &costs[0] {
                for b in &costs[1] {
                    let c = &costs[2][0];
                    let over = a.over + b.over + c.over;
                    let bytes = a.bytes + b.bytes + c.bytes;
                    if over <= (1.0 - q) * 300.0 + 1e-9 && bytes < best.0 {
                        best = (bytes, vec![a.resolution, b.resolution, c.resolution]);
                    }
                }
            }
            assert_eq!(allocate(&costs, q), Some(best.1), "quantile {q}");
        }
        // Nothing fits when even the finest levels are over.
        assert_eq!(allocate(&[vec![cost(2, 1.0, 50.0, 100.0)]], 0.99), None);
    }

    /// A UV sphere of radius 1 (poles are fans): closed, so it can never be a single height field.
    fn uv_sphere(rings: usize, segments: usize) -> Mesh {
        let mut pos = vec![0.0, 0.0, 1.0];
        for r in 1..rings {
            let theta = std::f64::consts::PI * r as f64 / rings as f64;
            for s in 0..segments {
                let phi = std::f64::consts::TAU * s as f64 / segments as f64;
                pos.extend_from_slice(&[
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                ]);
            }
        }
        pos.extend_from_slice(&[0.0, 0.0, -1.0]);
        let ring = |r: usize, s: usize| (1 + (r - 1) * segments + s % segments) as i64;
        let south = (pos.len() / 3 - 1) as i64;
        let mut faces = Vec::new();
        for s in 0..segments {
            faces.extend_from_slice(&[0, ring(1, s), ring(1, s + 1)]);
            faces.extend_from_slice(&[south, ring(rings - 1, s + 1), ring(rings - 1, s)]);
        }
        for r in 1..rings - 1 {
            for s in 0..segments {
                let (a, b, c, d) = (
                    ring(r, s),
                    ring(r, s + 1),
                    ring(r + 1, s + 1),
                    ring(r + 1, s),
                );
                faces.extend_from_slice(&[a, d, c, a, c, b]);
            }
        }
        Mesh::from_flat(&pos, &faces, None).unwrap()
    }

    #[test]
    fn sphere_converts_without_folding_and_on_the_surface() {
        let mesh = uv_sphere(24, 48);
        let set = convert(&mesh, &ConvertOptions::default(), &|_, _| true).unwrap();
        let geo = MeshGeometry::new(&mesh);
        assert!(set.patches.len() >= 2);
        let mut seen = vec![0u32; mesh.faces.len()];
        for p in &set.patches {
            for &f in &p.faces {
                seen[f as usize] += 1;
                assert!(geo.face_normals[f as usize].dot(p.axes[2]) > 0.0);
            }
        }
        assert!(
            seen.iter().all(|&n| n == 1),
            "every face in exactly one chart"
        );
        // Texel points lie on the facets (inside the unit ball, outside the facets' inscribed
        // sphere), except where conservative coverage extrapolates a facet's plane by at most half
        // a texel diagonal: so 1 - sag <= r <= 1 + 0.71 texel.
        let chord_sag = 1.0 - (std::f64::consts::PI / 24.0).cos();
        let outside = 1.0 + 0.71 * set.texel_size;
        let (points, normals) = set.to_points();
        assert!(points.len() > 10_000);
        for (p, n) in points.iter().zip(&normals) {
            let r = glam::DVec3::from_array(*p).length();
            assert!(
                r <= outside + 1e-9 && r >= 1.0 - chord_sag - 1e-6,
                "radius {r}"
            );
            let radial = glam::DVec3::from_array(*p).normalize();
            assert!(radial.dot(glam::Vec3::from_array(*n).as_dvec3()) > 0.95);
        }
        assert_eq!(set.stats.get("folding_charts"), Some(0.0));
    }

    #[test]
    fn heights_never_round_onto_the_box_faces() {
        // A flat square seen from above and a sphere: with either code width the surface keeps
        // at least one code step from the top and bottom of every box (a ray entering there must
        // start strictly off the surface).
        let square = Mesh::from_flat(
            &[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.],
            &[0, 1, 2, 0, 2, 3],
            None,
        )
        .unwrap();
        for mesh in [square, uv_sphere(12, 24)] {
            for bits in crate::gtex::HEIGHT_BITS {
                let opts = ConvertOptions {
                    height_bits: bits,
                    ..Default::default()
                };
                let set = convert(&mesh, &opts, &|_, _| true).unwrap();
                for p in &set.patches {
                    let filled = p.heights.iter().filter(|&&q| q > 0);
                    assert!(
                        filled.clone().all(|&q| q >= 2 && q < p.code_max()),
                        "{bits} bits"
                    );
                    assert_eq!(p.height_bits, bits);
                }
            }
        }
    }

    #[test]
    fn cancel_and_bad_options_are_errors() {
        let mesh = uv_sphere(8, 16);
        let e = convert(&mesh, &ConvertOptions::default(), &|stage, _| {
            stage != "raster"
        });
        assert!(matches!(e, Err(GeomtexError::Cancelled(s)) if s == "raster"));
        let opts = ConvertOptions {
            max_resolution: Some(1),
            ..Default::default()
        };
        assert!(matches!(
            convert(&mesh, &opts, &|_, _| true),
            Err(GeomtexError::Parameter(_))
        ));
    }

    #[test]
    fn fixed_chart_count_is_met_before_repair() {
        let mesh = uv_sphere(16, 32);
        let opts = ConvertOptions {
            charts: Some(12),
            ..Default::default()
        };
        let set = convert(&mesh, &opts, &|_, _| true).unwrap();
        assert_eq!(set.stats.get("vsa_charts"), Some(12.0));
        let splits = set.stats.get("repair_splits").unwrap();
        assert_eq!(set.patches.len() as f64, 12.0 + splits);
    }
}
