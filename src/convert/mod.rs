//! Mesh → geometry textures, one call per stage:
//! geometry (winding, degenerate faces) → partition (cone or VSA) → folding repair → overlap rings →
//! frames → resolution (texel sizes) → raster (with reconstruction error) → dilation → stats.
//! The stages up to the frames are `charts`' (shared with igt); the rest are here.
//!
//! Space: world (the mesh's coordinates, f64) in, patch boxes in world out.

pub mod accuracy;
pub mod bound;
pub mod draw;
pub mod figures;
pub mod hybrid;
pub mod raster;
pub mod resolution;
pub mod silhouette;

use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;

pub use crate::convert_options::{
    ConvertArgs, ConvertOptions, ErrorScope, InPlane, NormalRule, NormalSource, PartitionMethod,
};

use crate::charts::frame::ChartFrame;
use crate::charts::repair::Folding;
use crate::charts::{chart_stages, prepare, Charted, Prepared};
use crate::convert_options::ERROR_DRIVEN_CHART_ERRORS;
use crate::error::{GeomtexError, Result};
use crate::gtex::{GeometryTextureSet, Patch};
use crate::mesh::{CornerNormals, EdgeCounts, Mesh, MeshGeometry};
use crate::profile;
use crate::progress::{each_chart, Progress, Stages};
use accuracy::SetError;
use draw::{ChartDrawer, Drawn};
use figures::StageFigures;

/// Converts a mesh to geometry textures. With the VSA partition, `max_error` and neither
/// `chart_error` nor `charts`, each of `ERROR_DRIVEN_CHART_ERRORS` partitions the mesh once and
/// the set within the bound with the fewest bytes wins (or the most accurate, if none is); the
/// progress of those runs is reported as one stage, "partition", that only moves forward.
pub fn convert(
    mesh: &Mesh,
    opts: &ConvertOptions,
    progress: Progress,
) -> Result<GeometryTextureSet> {
    opts.validate()?;
    let outline = std::cell::Cell::new(None);
    let bytes = 12 * (mesh.positions.len() + mesh.faces.len()) as u64;
    let opts = &opts.resolved((bytes, mesh.faces.len()), || {
        outline.set(silhouette::outline_ratio(mesh));
        outline.get()
    });
    let mut set = convert_any(mesh, opts, progress)?;
    if opts.guarantee {
        check_guarantee(&set, opts.max_bytes)?;
    }
    if let Some(ratio) = outline.get() {
        set.stats.set("outline_ratio", ratio);
    }
    match opts.max_bytes {
        Some(limit) if !opts.error_driven() => fit_bytes(mesh, opts, progress, set, limit),
        Some(limit) => {
            // The levels were chosen within the budget; it binds when the bound was not met.
            let stat = |n: &str| set.stats.get(n).unwrap_or(0.0);
            let binding = stat("reconstruction_error_p99") > stat("max_error");
            set.stats.set("max_bytes", limit as f64);
            set.stats.set("max_bytes_binding", binding as u8 as f64);
            Ok(set)
        }
        None => Ok(set),
    }
}

/// Under `guarantee`, the set's bound within `max_error` everywhere and its bytes within
/// `max_bytes`, or a ParameterError saying which failed and what would meet it.
fn check_guarantee(set: &GeometryTextureSet, max_bytes: Option<u64>) -> Result<()> {
    let stat = |n: &str| set.stats.get(n).unwrap_or(f64::NAN);
    let (bound, max_error) = (stat("error_bound_max"), stat("max_error"));
    if bound.is_nan() || bound > max_error {
        let over: Vec<String> = set
            .patches
            .iter()
            .enumerate()
            .filter_map(|(k, p)| {
                let worst = p.error_bound.as_ref()?.decoded().fold(0.0, f64::max);
                (worst > max_error).then(|| format!("{k} ({worst:.3e})"))
            })
            .collect();
        let listed = over.iter().take(5).cloned().collect::<Vec<_>>().join(", ");
        let more = if over.len() > 5 { ", ..." } else { "" };
        // Not "a larger max_resolution meets it": where a chart folds or drops off a cliff the
        // height field cannot follow, the bound stays (the bunny's largest stays near 2.7e-3 of
        // its diagonal at 1,500 texels per diagonal).
        return Err(GeomtexError::Parameter(format!(
            "guarantee=True cannot bound every point by max_error={max_error:.6e}: {} patch(es) \
             stay over it at max_resolution (largest bound {bound:.6e}; patch (bound): \
             {listed}{more}); a larger max_error meets it, a larger max_resolution only where \
             the bound shrinks with the texel (not at folds or cliffs of a chart)",
            over.len()
        )));
    }
    let bytes = set.bytes() as u64;
    match max_bytes {
        Some(limit) if bytes > limit => Err(GeomtexError::Parameter(format!(
            "guarantee=True at max_error={max_error:.6e} needs {bytes} bytes, over \
             max_bytes={limit}; a larger max_bytes or a larger max_error meets it"
        ))),
        _ => Ok(()),
    }
}

/// Re-conversions `max_bytes` may take before it gives up (and says so in the stats).
const MAX_BYTES_TRIES: usize = 6;

/// Coarsens the texel of a fixed-resolution set until its maps take at most `limit` bytes: the
/// bytes go as 1 / texel², so each try scales the texel by the square root of the excess (3%
/// more, as charts do not shrink smoothly). Stats: `max_bytes`, `max_bytes_coarsenings` and
/// `max_bytes_exceeded` (1 when even the last try did not fit: a cap that was hit).
fn fit_bytes(
    mesh: &Mesh,
    opts: &ConvertOptions,
    progress: Progress,
    mut set: GeometryTextureSet,
    limit: u64,
) -> Result<GeometryTextureSet> {
    let mut tries = 0;
    while set.bytes() as u64 > limit && tries < MAX_BYTES_TRIES {
        let scale = (set.bytes() as f64 / limit as f64).sqrt() * 1.03;
        let coarser = ConvertOptions {
            texel_size: Some(set.texel_size * scale),
            ..opts.clone()
        };
        set = convert_any(mesh, &coarser, progress)?;
        tries += 1;
    }
    let exceeded = set.bytes() as u64 > limit;
    set.stats.set("max_bytes", limit as f64);
    set.stats.set("max_bytes_coarsenings", tries as f64);
    set.stats.set("max_bytes_exceeded", exceeded as u8 as f64);
    Ok(set)
}

/// A conversion with one partition, or (error-driven, no partition target) the best of several.
fn convert_any(
    mesh: &Mesh,
    opts: &ConvertOptions,
    progress: Progress,
) -> Result<GeometryTextureSet> {
    if opts.partition_method() != PartitionMethod::Vsa
        || !opts.error_driven()
        || opts.chart_error.is_some()
        || opts.charts.is_some()
    {
        return convert_once(mesh, opts, progress);
    }
    let start = Instant::now();
    let mut best: Option<GeometryTextureSet> = None;
    let runs = ERROR_DRIVEN_CHART_ERRORS.len();
    let reported = Mutex::new(0.0);
    for (run, tolerance) in ERROR_DRIVEN_CHART_ERRORS.into_iter().enumerate() {
        let o = ConvertOptions {
            chart_error: Some(tolerance),
            ..opts.clone()
        };
        let share = |stage: &str, fraction: f64| {
            share_of_runs(&progress, &reported, (run, runs), stage, fraction)
        };
        let set = convert_once(mesh, &o, Progress::new(&share, progress.cancel))?;
        if best
            .as_ref()
            .is_none_or(|b| preference(&set) < preference(b))
        {
            best = Some(set);
        }
    }
    let mut best = best.expect("at least one partition");
    best.stats
        .set("partitions_tried", ERROR_DRIVEN_CHART_ERRORS.len() as f64);
    best.stats
        .seconds
        .push(("all_partitions".into(), start.elapsed().as_secs_f64()));
    progress.report("done", 1.0)?;
    Ok(best)
}

/// The stages of one conversion in the order they run ("resolution" only with `max_error`).
const STAGE_ORDER: [&str; 8] = [
    "geometry",
    "partition",
    "repair",
    "overlap",
    "frame",
    "resolution",
    "raster",
    "dilate",
];

/// Passes on a report of run `run` of `runs` whole conversions (the partitions an error-driven
/// VSA conversion tries) to `outer` as stage "partition" at (run + position within the run) /
/// runs, so the caller's bar only moves forward; a report that would move it back (worker
/// threads report out of order) is not passed on. `reported` holds the last fraction passed on.
fn share_of_runs(
    outer: &Progress,
    reported: &Mutex<f64>,
    (run, runs): (usize, usize),
    stage: &str,
    fraction: f64,
) -> bool {
    let position = match STAGE_ORDER.iter().position(|&s| s == stage) {
        Some(k) => (k as f64 + fraction.clamp(0.0, 1.0)) / STAGE_ORDER.len() as f64,
        None => 1.0, // "done"
    };
    let overall = (run as f64 + position) / runs as f64;
    let mut last = reported.lock().unwrap_or_else(|p| p.into_inner());
    if overall < *last {
        return true;
    }
    *last = overall;
    (outer.callback)("partition", overall)
}

/// Orders error-driven sets, best first: those within the bound by bytes, then the others by
/// their error.
fn preference(set: &GeometryTextureSet) -> (bool, f64) {
    let stat = |n: &str| set.stats.get(n).unwrap_or(f64::INFINITY);
    let error = if stat("guarantee") == 1.0 {
        "error_bound_max"
    } else {
        "reconstruction_error_p99"
    };
    let within = stat(error) <= stat("max_error");
    let measure = if within { "bytes" } else { error };
    (!within, stat(measure))
}

/// Every chart drawn at its texel size (None: a hybrid set keeps its triangles), the set's
/// texel size, and with `hybrid` each chart's triangles' bytes.
struct Rastered {
    drawn: Vec<Option<Drawn>>,
    texel: f64,
    triangle_bytes: Option<Vec<f64>>,
}

/// Bytes of each chart's own faces as a mesh stores them (`triangles::mesh_bytes`, each vertex
/// once), or None where a
/// hybrid set cannot hold triangles: a face-colored or textured mesh (its triangles would lose
/// what the maps keep).
fn chart_triangle_bytes(mesh: &Mesh, charted: &Charted, opts: &ConvertOptions) -> Option<Vec<f64>> {
    let plain = mesh.appearance.face_colors.is_none() && mesh.appearance.texture.is_none();
    if !(opts.hybrid_on() && plain) {
        return None;
    }
    let colored = mesh.colors.is_some();
    let bytes = (charted.charts.par_iter())
        .map(|c| {
            let mut vertices: Vec<u32> = (c.faces.iter())
                .flat_map(|&f| mesh.faces[f as usize])
                .collect();
            vertices.sort_unstable();
            vertices.dedup();
            crate::gtex::triangles::mesh_bytes(vertices.len(), c.faces.len(), colored) as f64
        })
        .collect();
    Some(bytes)
}

/// The frame stage's output: what drawing needs, and what the stats need of the mesh's
/// geometry, which is dropped here.
struct Framed {
    frames: Vec<ChartFrame>,
    corner_normals: CornerNormals,
    duplicate_vertices: usize,
    edge_counts: EdgeCounts,
    diagonal: f64,
    /// Charts whose faces do not all face their frame's z.
    folding_after: Folding,
}

/// The frame stage: axes and the tight box of everything each chart draws, relative to a chart
/// vertex, and the corner normals. Takes the mesh's geometry and drops it: nothing after needs
/// its per-face arrays (most of a large mesh's memory), so the maps are drawn without them.
fn frame_stage(
    mesh: &Mesh,
    geo: MeshGeometry,
    charted: &Charted,
    opts: &ConvertOptions,
    stages: &mut Stages,
) -> Result<Framed> {
    stages.begin("frame")?;
    let (charts, rings) = (&charted.charts, &charted.rings);
    let frames: Vec<ChartFrame> = charts
        .par_iter()
        .zip(rings)
        .map(|(c, ring)| ChartFrame::new(mesh, &c.faces, &ring.faces, c.z, opts.in_plane))
        .collect();
    let folding_after = Folding::count(
        &geo,
        charts
            .iter()
            .zip(&frames)
            .map(|(c, f)| (c.faces.as_slice(), f.axes[2])),
    );
    let (duplicate_vertices, edge_counts, diagonal) =
        (geo.duplicate_vertices, geo.edge_counts, geo.diagonal);
    let corner_normals = geo.into_corner_normals(mesh, opts.normals);
    stages.end("frame");
    Ok(Framed {
        frames,
        corner_normals,
        duplicate_vertices,
        edge_counts,
        diagonal,
        folding_after,
    })
}

/// The resolution, raster and dilation stages.
fn raster_stages(
    mesh: &Mesh,
    charted: &Charted,
    framed: &Framed,
    opts: &ConvertOptions,
    max_error: Option<f64>,
    stages: &mut Stages,
) -> Result<Rastered> {
    let (charts, rings, frames) = (&charted.charts, &charted.rings, &framed.frames);
    let drawer = ChartDrawer {
        mesh,
        corner_normals: &framed.corner_normals,
        opts,
        texel: resolution::common_texel(frames, opts, framed.diagonal),
        per_chart_texel: max_error.is_some(),
    };
    let own_and_ring = charts
        .iter()
        .zip(rings)
        .map(|(c, r)| (c.faces.as_slice(), r.faces.as_slice()));
    let jobs = drawer.jobs(own_and_ring, frames);
    profile::memory("jobs");
    let triangle_bytes = chart_triangle_bytes(mesh, charted, opts);
    let texels: Vec<Option<f64>> = match max_error {
        None => vec![Some(drawer.texel); jobs.len()],
        Some(e) => {
            stages.begin("resolution")?;
            let caps = triangle_bytes.as_deref();
            let texels = resolution::chart_texels(&jobs, &drawer, e, caps, stages.progress)?;
            stages.end("resolution");
            texels
        }
    };
    // Drawn once more at the chosen texel: keeping the maps of every level measured would hold
    // a few times the finest maps in memory.
    stages.begin("raster")?;
    let jobs_texels: Vec<_> = jobs.iter().zip(texels).collect();
    let mut drawn = each_chart(&jobs_texels, stages.progress, "raster", |&(j, t)| {
        t.map(|t| drawer.draw(j, t, &drawer.samples(j)))
    })?;
    stages.end("raster");

    stages.begin("dilate")?;
    drawn
        .par_iter_mut()
        .flatten()
        .for_each(|d| raster::dilate(&mut d.maps, d.bx.width, d.bx.height, opts.dilation));
    stages.end("dilate");
    Ok(Rastered {
        drawn,
        texel: drawer.texel,
        triangle_bytes,
    })
}

/// One conversion with one partition target.
fn convert_once(
    mesh: &Mesh,
    opts: &ConvertOptions,
    progress: Progress,
) -> Result<GeometryTextureSet> {
    let mut stages = Stages::new(progress);
    stages.begin("geometry")?;
    let prepared = prepare(mesh, progress)?;
    stages.end("geometry");

    let charted = chart_stages(&prepared, opts, &mut stages)?;
    let max_error = opts
        .max_error
        .or(opts.max_error_rel.map(|r| r * prepared.geo.diagonal));
    let Prepared {
        mesh,
        geo,
        active,
        inconsistent_edges,
        flipped_faces,
    } = prepared;
    let degenerate_faces = mesh.faces.len() - active.len();
    drop(active);
    let framed = frame_stage(&mesh, geo, &charted, opts, &mut stages)?;
    let Rastered {
        drawn,
        texel,
        triangle_bytes,
    } = raster_stages(&mesh, &charted, &framed, opts, max_error, &mut stages)?;
    let charts: Vec<_> = (charted.charts.into_iter()).zip(charted.rings).collect();
    let ring_faces_skipped = charts.iter().map(|(_, r)| r.skipped).sum();
    let split = hybrid::split(
        &mesh,
        opts.normals,
        charts,
        drawn,
        triangle_bytes.as_deref(),
    );
    let reconstruction = SetError::of(split.errors);
    let figures = StageFigures {
        inconsistent_edges,
        flipped_faces,
        degenerate_faces,
        duplicate_vertices: framed.duplicate_vertices,
        edge_counts: framed.edge_counts,
        folding_after: framed.folding_after,
        vsa_charts: charted.vsa_charts,
        vsa_mean_error: charted.vsa_mean_error,
        charts_capped: charted.charts_capped,
        repair_splits: charted.repair_splits,
        sheet_splits: charted.sheet_splits,
        folding_before: charted.folding_before,
        ring_faces_skipped,
        reconstruction,
        patch_errors: split.patch_errors,
        max_error,
    };
    let patches = split.patches;
    // The set's texel size: the one texel, or the finest chart's when each has its own (the
    // one texel where every chart stayed triangles).
    let texel_size = match max_error {
        Some(_) if !patches.is_empty() => patches
            .iter()
            .map(Patch::texel_size)
            .fold(f64::INFINITY, f64::min),
        _ => texel,
    };
    let mut set = GeometryTextureSet {
        patches,
        texel_size,
        stats: Default::default(),
        triangles: split.triangles,
    };
    profile::memory("patches");
    set.stats = figures::stats(&mesh, opts, &set, figures, framed.diagonal);
    if opts.hybrid_on() {
        for (name, v) in hybrid::figures(&mesh, &set) {
            set.stats.set(name, v);
        }
    }
    set.stats.seconds = stages.into_seconds();
    set.validate()
        .map_err(|e| GeomtexError::Internal(format!("conversion made an impossible set: {e}")))?;
    profile::memory("stats");
    profile::report();
    progress.report("done", 1.0)?;
    Ok(set)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_shapes::uv_sphere;

    #[test]
    fn sphere_converts_without_folding_and_on_the_surface() {
        let mesh = uv_sphere(24, 48);
        // One texel for the set, so every point is within its reach of the sphere.
        let opts = ConvertOptions {
            max_resolution: Some(256),
            ..Default::default()
        };
        let set = convert(&mesh, &opts, Progress::silent()).unwrap();
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
        let face_patch = set.face_patch();
        assert_eq!(face_patch.len(), mesh.faces.len());
        for (k, p) in set.patches.iter().enumerate() {
            assert!(p.faces.iter().all(|&f| face_patch[f as usize] == k as i32));
        }
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
                    hybrid: Some(false),
                    ..Default::default()
                };
                let set = convert(&mesh, &opts, Progress::silent()).unwrap();
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
        let stop_at_raster = |stage: &str, _| stage != "raster";
        let progress = Progress::new(&stop_at_raster, &crate::cancel::NEVER);
        let e = convert(&mesh, &ConvertOptions::default(), progress);
        assert!(matches!(e, Err(GeomtexError::Cancelled(s)) if s == "raster"));
        // A token set before the call stops it at the first poll.
        let token = crate::cancel::Cancel::new();
        token.cancel();
        let e = convert(
            &mesh,
            &ConvertOptions::default(),
            Progress::new(&|_, _| true, &token),
        );
        assert!(matches!(e, Err(GeomtexError::Interrupted(_))));
        let opts = ConvertOptions {
            max_resolution: Some(1),
            ..Default::default()
        };
        assert!(matches!(
            convert(&mesh, &opts, Progress::silent()),
            Err(GeomtexError::Parameter(_))
        ));
    }

    #[test]
    fn fixed_chart_count_is_met_before_repair() {
        let mesh = uv_sphere(16, 32);
        let opts = ConvertOptions {
            charts: Some(12),
            hybrid: Some(false),
            ..Default::default()
        };
        let set = convert(&mesh, &opts, Progress::silent()).unwrap();
        assert_eq!(set.stats.get("vsa_charts"), Some(12.0));
        let splits = set.stats.get("repair_splits").unwrap();
        assert_eq!(set.patches.len() as f64, 12.0 + splits);
    }
}
