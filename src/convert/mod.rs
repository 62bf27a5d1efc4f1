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
use crate::gtex::{GeometryTextureSet, Patch, Stats};
use crate::mesh::{Mesh, MeshGeometry};
use frame::FOLD_COS;
use raster::PatchBox;
use vsa::{ChartTarget, FaceSet, NONE};

/// Keywords of `convert`. `Default` gives the documented defaults.
#[derive(Clone, Debug)]
pub struct ConvertOptions {
    /// Longest side of any patch, in texels. The texel size is one for the whole set, chosen so
    /// the largest chart just fits.
    pub max_resolution: u32,
    /// World size of a texel; grown if a chart would then exceed `max_resolution`.
    pub texel_size: Option<f64>,
    /// Exact chart count for VSA (before folding repair). `None`: driven by `chart_error`.
    pub charts: Option<usize>,
    /// Target area-weighted mean L2,1 error of VSA, sum(area |n - N|^2) / sum(area).
    pub chart_error: f64,
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
            max_resolution: 256,
            texel_size: None,
            charts: None,
            chart_error: 0.1,
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
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(GeomtexError::Parameter(m));
        if !(2..=16384).contains(&self.max_resolution) {
            return bad(format!(
                "max_resolution must be in [2, 16384], got {}",
                self.max_resolution
            ));
        }
        if let Some(t) = self.texel_size {
            if !(t.is_finite() && t > 0.0) {
                return bad(format!(
                    "texel_size must be a positive finite number, got {t}"
                ));
            }
        }
        if self.charts == Some(0) {
            return bad("charts must be at least 1".into());
        }
        if !(self.chart_error.is_finite() && (0.0..=4.0).contains(&self.chart_error)) {
            return bad(format!(
                "chart_error must be in [0, 4], got {}",
                self.chart_error
            ));
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
/// Reconstruction error is this quantile of the vertical gaps: the maximum would be set by
/// the few samples at creases and rims, where a bilinear map of any resolution rounds corners.
const ERROR_QUANTILE: f64 = 0.99;

/// A box's thickness and height bits for a surface spanning `height` at texel size `texel`.
///
/// At least a texel thick, flat surfaces centred: a box of (near) zero height would turn
/// patch-local z into huge numbers that f32 on the GPU cannot resolve. A margin above and below
/// the surface keeps a ray entering through the box's top or bottom strictly off the surface, so
/// its first sample knows which side it is on. The margin is also at least one height code step,
/// so rounding never puts the surface on the box's top or bottom (8-bit codes would, with 0.02
/// texel alone). 8-bit codes only where their rounding (half a code step) stays within half a
/// texel, so the map is never coarser across than along: a surface more than ~250 texels tall
/// keeps 16 bits.
pub(crate) fn vertical_extent(height: f64, texel: f64, requested_bits: u8) -> (f64, u8) {
    let base = height.max(texel);
    let thickness = |bits: u8| {
        let code_max = crate::gtex::code_max(bits) as f64;
        base + 2.0 * (0.02 * texel).max(base / (code_max - 3.0))
    };
    let bits =
        if requested_bits == 8 && thickness(8) / (crate::gtex::code_max(8) - 1) as f64 > texel {
            16
        } else {
            requested_bits
        };
    (thickness(bits), bits)
}

/// The box of a chart (its frame: axes, reference point, local bounds) at texel size `texel`.
fn patch_box(
    frame: &([DVec3; 3], DVec3, DVec3, DVec3),
    texel: f64,
    opts: &ConvertOptions,
) -> PatchBox {
    let (axes, reference, lo, hi) = frame;
    let size = *hi - *lo;
    let res = |s: f64| ((s / texel).ceil() as u32).clamp(2, opts.max_resolution.max(2));
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

pub fn convert(
    mesh: &Mesh,
    opts: &ConvertOptions,
    progress: Progress,
) -> Result<GeometryTextureSet> {
    opts.validate()?;
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
            tolerance: opts.chart_error,
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
    let longest = frames
        .iter()
        .map(|f| (f.3 - f.2).x.max((f.3 - f.2).y))
        .fold(0.0, f64::max);
    let fit = longest / opts.max_resolution as f64;
    let mut texel = opts.texel_size.map_or(fit, |t| t.max(fit));
    if texel <= 0.0 {
        texel = geo.diagonal.max(f64::MIN_POSITIVE) * 1e-6; // every chart is a point
    }

    let boxes: Vec<PatchBox> = frames.iter().map(|fr| patch_box(fr, texel, opts)).collect();
    timer.lap("frame");

    // Raster.
    report(progress, "raster", 0.0)?;
    let done = AtomicUsize::new(0);
    let cancelled = AtomicBool::new(false);
    let n = charts.len();
    let mut maps: Vec<raster::Maps> = charts
        .par_iter()
        .zip(&rings)
        .zip(&boxes)
        .map(|((c, (ring, _)), bx)| {
            if cancelled.load(Ordering::Relaxed) {
                return raster::Maps::default();
            }
            let faces: Vec<u32> = c.faces.iter().chain(ring).copied().collect();
            let m = raster::rasterize(mesh, &geo, &faces, c.faces.len(), bx, opts.normals);
            let k = done.fetch_add(1, Ordering::Relaxed) + 1;
            if k % 16 == 0 && !progress("raster", k as f64 / n as f64) {
                cancelled.store(true, Ordering::Relaxed);
            }
            m
        })
        .collect();
    if cancelled.load(Ordering::Relaxed) {
        return Err(GeomtexError::Cancelled("raster".into()));
    }
    timer.lap("raster");

    report(progress, "dilate", 0.0)?;
    maps.par_iter_mut()
        .zip(&boxes)
        .for_each(|(m, bx)| raster::dilate(m, bx.width, bx.height, opts.dilation));
    timer.lap("dilate");

    let patches: Vec<Patch> = charts
        .into_iter()
        .zip(rings)
        .zip(boxes)
        .zip(maps)
        .map(|(((c, (ring, _)), bx), m)| Patch {
            origin: bx.origin,
            axes: bx.axes,
            extent: bx.extent,
            width: bx.width,
            height: bx.height,
            height_bits: bx.height_bits,
            heights: m.heights,
            normals: m.normals,
            colors: m.colors,
            faces: c.faces,
            ring_faces: ring,
        })
        .collect();

    // Each patch's reconstruction error against points sampled on its own triangles, about a
    // texel apart (fewer on large charts, see the cap).
    let mut gaps: Vec<Vec<f64>> = patches
        .par_iter()
        .map(|p| {
            let samples = error::surface_samples(mesh, &p.faces, texel, ERROR_SAMPLES_PER_CHART);
            error::gaps(p, &samples)
        })
        .collect();
    let patch_errors: Vec<f64> = gaps
        .iter_mut()
        .map(|g| error::quantile(g, ERROR_QUANTILE))
        .collect();
    let mut all_gaps: Vec<f64> = gaps.into_iter().flatten().collect();
    let reconstruction_max = all_gaps.iter().copied().fold(0.0, f64::max);
    let reconstruction_p99 = error::quantile(&mut all_gaps, ERROR_QUANTILE);
    drop(all_gaps);
    timer.lap("error");

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
    stats.per_patch = vec![
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
            max_resolution: 1,
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
