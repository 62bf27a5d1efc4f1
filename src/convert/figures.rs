//! The stats table of a conversion: figures recomputed from the output where they can be, and
//! those the stages counted on their way.
//!
//! Space: world units for lengths and errors; counts otherwise.

use super::accuracy::SetError;
use crate::charts::repair::Folding;
use crate::convert_options::{ConvertOptions, PartitionMethod};
use crate::gtex::{GeometryTextureSet, Patch, Stats};
use crate::mesh::{EdgeCounts, Mesh};

/// What the stages counted on their way, for the stats table.
pub struct StageFigures {
    pub inconsistent_edges: usize,
    pub flipped_faces: usize,
    pub degenerate_faces: usize,
    /// Vertices that repeat an earlier vertex's position (`MeshGeometry`).
    pub duplicate_vertices: usize,
    pub edge_counts: EdgeCounts,
    pub vsa_charts: usize,
    pub vsa_mean_error: f64,
    /// The chart cap stopped the partition before its target.
    pub charts_capped: bool,
    pub repair_splits: usize,
    /// Of those, charts split because they lay in two sheets (`sheets`), not because they folded.
    pub sheet_splits: usize,
    pub folding_before: Folding,
    /// Counted in the charts' frames, as the patches keep them.
    pub folding_after: Folding,
    pub ring_faces_skipped: usize,
    pub reconstruction: SetError,
    /// Each patch's reconstruction error.
    pub patch_errors: Vec<f64>,
    /// The bound on reconstruction error, in world units, when there was one.
    pub max_error: Option<f64>,
}

/// The stats of `set`, converted from `mesh` (wound consistently; `diagonal` is its bounding
/// box's).
pub fn stats(
    mesh: &Mesh,
    opts: &ConvertOptions,
    set: &GeometryTextureSet,
    figures: StageFigures,
    diagonal: f64,
) -> Stats {
    let mut stats = Stats::default();
    if let Some(e) = figures.max_error {
        // Charts that stayed over the bound at max_resolution.
        let over = figures.patch_errors.iter().filter(|&&p| p > e).count();
        stats.set("max_error", e);
        stats.set("charts_over_max_error", over as f64);
    }
    if let Some(b) = set.error_bound_figures() {
        b.write(&mut stats);
    }
    stats.set("guarantee", opts.guarantee as u8 as f64);
    for (name, v) in mesh_figures(mesh, &figures)
        .into_iter()
        .chain(chart_figures(opts, set, &figures))
        .chain(map_figures(opts, set, &figures, diagonal))
    {
        stats.set(name, v);
    }
    stats.per_patch = vec![
        (
            "patch_texel".into(),
            set.patches.iter().map(Patch::texel_size).collect(),
        ),
        ("patch_error".into(), figures.patch_errors),
        (
            "patch_resolution".into(),
            set.patches
                .iter()
                .map(|p| p.width.max(p.height) as f64)
                .collect(),
        ),
    ];
    stats
}

/// What the input mesh was like.
fn mesh_figures(mesh: &Mesh, figures: &StageFigures) -> [(&'static str, f64); 8] {
    [
        ("faces", mesh.faces.len() as f64),
        ("vertices", mesh.positions.len() as f64),
        ("degenerate_faces", figures.degenerate_faces as f64),
        ("duplicate_vertices", figures.duplicate_vertices as f64),
        ("boundary_edges", figures.edge_counts.boundary as f64),
        ("nonmanifold_edges", figures.edge_counts.nonmanifold as f64),
        ("inconsistent_edges", figures.inconsistent_edges as f64),
        ("flipped_faces", figures.flipped_faces as f64),
    ]
}

/// The partition, its repair and its rings.
fn chart_figures(
    opts: &ConvertOptions,
    set: &GeometryTextureSet,
    figures: &StageFigures,
) -> [(&'static str, f64); 16] {
    let (before, after) = (figures.folding_before, figures.folding_after);
    let cone = opts.partition_method() == PartitionMethod::Cone;
    let ring_faces: usize = set.patches.iter().map(|p| p.ring_faces.len()).sum();
    [
        ("charts", set.patches.len() as f64),
        // Which partition cut the charts (1: cone, 0: VSA); "vsa_charts" counts its charts
        // either way, and "chart_error" applies to VSA only.
        ("cone_partition", f64::from(u8::from(cone))),
        ("vsa_charts", figures.vsa_charts as f64),
        ("vsa_mean_error", figures.vsa_mean_error),
        ("chart_error", opts.chart_error_target()),
        ("charts_capped", f64::from(u8::from(figures.charts_capped))),
        ("cone_angle", opts.cone_angle),
        ("chart_size", opts.chart_size),
        ("repair_splits", figures.repair_splits as f64),
        ("sheet_splits", figures.sheet_splits as f64),
        ("folding_charts", after.charts as f64),
        ("inverted_triangles", after.inverted_faces as f64),
        ("folding_charts_before_repair", before.charts as f64),
        (
            "inverted_triangles_before_repair",
            before.inverted_faces as f64,
        ),
        ("ring_faces", ring_faces as f64),
        ("ring_faces_skipped", figures.ring_faces_skipped as f64),
    ]
}

/// The maps: their size, their rounding and their reconstruction error (and the mesh's
/// diagonal, its yardstick).
fn map_figures(
    opts: &ConvertOptions,
    set: &GeometryTextureSet,
    figures: &StageFigures,
    diagonal: f64,
) -> [(&'static str, f64); 11] {
    let (texels, empty) = (set.texels(), set.empty_texels());
    let kept_at_16 = set
        .patches
        .iter()
        .filter(|p| p.height_bits > opts.height_bits)
        .count();
    let quantization = set
        .patches
        .iter()
        .map(Patch::quantization_error)
        .fold(0.0, f64::max);
    [
        ("texels", texels as f64),
        ("empty_texels", empty as f64),
        ("empty_fraction", empty as f64 / texels.max(1) as f64),
        ("bytes", set.bytes() as f64),
        ("height_bits", opts.height_bits as f64),
        ("patches_kept_at_16_bits", kept_at_16 as f64),
        ("max_quantization_error", quantization),
        ("texel_size", set.texel_size),
        ("reconstruction_error_p99", figures.reconstruction.quantile),
        ("reconstruction_error_max", figures.reconstruction.max),
        ("diagonal", diagonal),
    ]
}
