//! The keywords of `convert`: their one set of defaults, their validation, the names they go by
//! as strings, and `ConvertArgs`, the keywords as a caller (the Python binding) receives them.
//! Crate-level data: `charts` reads the partition keywords, and an inverse geometric texture's
//! options carry a set of them for its charts.
//!
//! Space: lengths (`texel_size`, `max_error`) are world units; `max_error_rel` is a fraction of
//! the mesh's bounding-box diagonal.

use std::str::FromStr;

use crate::error::{parse_choice, GeomtexError, Result};
pub use crate::mesh::{NormalRule, NormalSource};

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

/// How x/y are chosen inside the plane perpendicular to z.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InPlane {
    /// The principal axes of the projected vertices (the paper's 2D PCA).
    Pca,
    /// The sides of the minimum-area rectangle around the projected vertices.
    MinAreaRect,
}

/// `max_resolution` when none is given and the texel is one for the whole set.
pub const DEFAULT_MAX_RESOLUTION: u32 = 256;
/// `max_resolution` when none is given with `max_error`: the error sets each chart's texel and
/// the cap only bounds a chart's memory (10 MiB at 1024²).
pub const ERROR_DRIVEN_MAX_RESOLUTION: u32 = 1024;
/// The range `max_resolution` must lie in.
pub const MAX_RESOLUTION_RANGE: std::ops::RangeInclusive<u32> = 2..=crate::gtex::MAX_PATCH_SIDE;
/// VSA's target mean error when none is given.
pub const DEFAULT_CHART_ERROR: f64 = 0.1;
/// Partitions tried when `max_error` is given without `chart_error` or `charts`: with a texel
/// of its own, a chart no longer sets everyone's texel, so fewer, larger charts (fewer ring
/// faces drawn twice) often cost fewer bytes; sharp-creased CAD models still want the finest.
pub const ERROR_DRIVEN_CHART_ERRORS: [f64; 3] = [0.1, 0.2, 0.3];

/// The bound of a `convert` given no keyword that sets the resolution (`max_resolution`,
/// `texel_size`, `max_error`, `max_error_rel`, `max_bytes`), as a fraction of the diagonal, for
/// a mesh that shows no more outline for its area than the Stanford bunny: the reconstruction
/// p99 at which the bunny's default set renders as close to trimesh as the mesh itself would at
/// 512² (README "The default", bench/economy.py). A mesh with more outline gets a tighter bound
/// (`default_error_rel`).
pub const DEFAULT_MAX_ERROR_REL: f64 = 2e-4;

/// The outline ratio (`silhouette::outline_ratio`) of the Stanford bunny, on which
/// `DEFAULT_MAX_ERROR_REL` was chosen, rounded up to a half (it measures 10.35; fandisk 9.8,
/// spot 11.1, the teapot 11.3, the rocker arm 12.4, homer 15.9).
pub const REFERENCE_OUTLINE_RATIO: f64 = 10.5;

/// The tightest default bound, as a fraction of `DEFAULT_MAX_ERROR_REL`: a mesh of hair-thin
/// parts would otherwise be drawn at ever finer levels (its budget still stops it).
pub const MIN_BOUND_SCALE: f64 = 0.25;

/// The default bound for a mesh whose outline ratio is `outline`: `DEFAULT_MAX_ERROR_REL`
/// scaled by `REFERENCE_OUTLINE_RATIO / outline` where that is below 1. A set whose outline lies
/// `e` off the mesh loses about `e` times the outline's length over the projected area in IoU, so
/// this keeps a thin mesh's IoU loss at the bunny's.
pub fn default_error_rel(outline: Option<f64>) -> f64 {
    let scale = outline.map_or(1.0, |r| {
        (REFERENCE_OUTLINE_RATIO / r).clamp(MIN_BOUND_SCALE, 1.0)
    });
    DEFAULT_MAX_ERROR_REL * scale
}

/// The byte budget of a `convert` given no keyword that sets the resolution is the mesh's own
/// bytes (float32 positions, uint32 faces) or an allowance, whichever is more. A rough mesh
/// (noise at the scale of its faces) never gets within the bound at any resolution a height map
/// can afford, so its set stops there. The allowance lets a small mesh reach the bound: this
/// many bytes for a mesh of no faces, shrinking linearly to none at `BUDGET_OWN_FACES`, and
/// scaled by `DEFAULT_MAX_ERROR_REL` over the mesh's bound (a height map's error goes as its
/// texel squared, so its bytes as one over the bound). Measured need within the bound
/// (bench/economy.py): the rocker arm (20k faces) 2.5 MB at its 1.69e-4, homer (12k) 2.1 MB
/// at 1.32e-4, spot (6k) 1.7 MB at 1.89e-4; at 1 MB they lost IoU (0.9958, 0.9971, 0.9985).
pub const DEFAULT_ALLOWANCE: f64 = 4e6;

/// Faces from which a default set's budget is the mesh's own bytes, the line for maps
/// no larger than the mesh.
pub const BUDGET_OWN_FACES: f64 = 50_000.0;

/// The default budget of a mesh of `mesh_bytes` bytes and `faces` faces under the bound `bound`
/// (a fraction of the diagonal).
pub fn default_budget(mesh_bytes: u64, faces: usize, bound: f64) -> u64 {
    let share = (1.0 - faces as f64 / BUDGET_OWN_FACES).max(0.0);
    let allowance = DEFAULT_ALLOWANCE * share * DEFAULT_MAX_ERROR_REL / bound;
    mesh_bytes.max(allowance.round() as u64)
}

/// How the mesh is cut into charts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartitionMethod {
    /// Charts as large as a normal cone of `cone_angle` and `chart_size` allow (`cone.rs`).
    Cone,
    /// The paper's Variational Shape Approximation, driven by `chart_error` or `charts`.
    Vsa,
}

/// Half-angle of a cone chart's normal cone when none is given, degrees.
pub const DEFAULT_CONE_ANGLE: f64 = 60.0;
/// Largest distance from a cone chart's seed, as a fraction of the diagonal, when none is given.
pub const DEFAULT_CHART_SIZE: f64 = 0.1;

/// Keywords of `convert`. `Default` gives the documented defaults, the only place they are set.
#[derive(Clone, Debug)]
pub struct ConvertOptions {
    /// Longest side of any patch, in texels. The texel size is one for the whole set, chosen so
    /// the largest chart just fits.
    /// `None`: `DEFAULT_MAX_RESOLUTION`, or `ERROR_DRIVEN_MAX_RESOLUTION` with `max_error`.
    pub max_resolution: Option<u32>,
    /// World size of a texel; grown if a chart would then exceed `max_resolution`.
    pub texel_size: Option<f64>,
    /// Error-driven resolution: each chart gets the coarsest texel that keeps its reconstruction
    /// error (the area-weighted p99, see `accuracy`) within this many world units, up to
    /// `max_resolution` texels on its longest side. `None`: one texel size for all charts.
    pub max_error: Option<f64>,
    /// `max_error` as a fraction of the mesh's bounding-box diagonal.
    pub max_error_rel: Option<f64>,
    /// Whose error `max_error` bounds.
    pub error_scope: ErrorScope,
    /// How the mesh is cut into charts. `None`: VSA at a fixed resolution or with a VSA keyword
    /// (`charts`, `chart_error`), else the cone partition (one partition, per-chart texels).
    pub partition: Option<PartitionMethod>,
    /// Cone partition: largest angle, in degrees, between a chart's face normal and its cone's
    /// axis; in (0, 85], below 90 so no face comes near inverting.
    pub cone_angle: f64,
    /// Cone partition: largest distance from a chart's seed to its faces, as a fraction of the
    /// bounding-box diagonal (the largest chart sets the texel without `max_error`).
    pub chart_size: f64,
    /// Exact chart count for VSA (before folding repair). `None`: driven by `chart_error`.
    pub charts: Option<usize>,
    /// Target area-weighted mean L2,1 error of VSA, sum(area |n - N|^2) / sum(area).
    /// `None`: `DEFAULT_CHART_ERROR`, or with `max_error` the cheapest of
    /// `ERROR_DRIVEN_CHART_ERRORS`.
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
    /// The normals that go into the normal map (crease-split by default).
    pub normals: NormalRule,
    /// Bits per height code, 8 or 16: 8 halves the height map's bytes and rounds heights to
    /// 1/254 of each patch's height range.
    pub height_bits: u8,
    /// Most bytes the maps may take: at a fixed resolution the texel is coarsened until they
    /// fit; with `max_error` the charts' levels are chosen within them (the bound is met if it
    /// fits, else the least area over it). `None`: no budget, or with no keyword that sets the
    /// resolution `default_budget`.
    pub max_bytes: Option<u64>,
    /// With `max_error`: each chart's level is chosen by its cells' error bounds (`bound`), so
    /// that every drawn point is within `max_error` of the mesh, not a sampled quantile.
    pub guarantee: bool,
    /// Hybrid sets: a chart stays the mesh's own triangles where no height map within the
    /// bound takes fewer bytes than those triangles (`gtex::triangles`). Needs the error-driven
    /// default or `max_error`; the bytes are then bounded by the mesh's own (no budget).
    /// `None`: wherever that holds and no `max_bytes` is given (`hybrid_on`).
    pub hybrid: Option<bool>,
}

impl Default for ConvertOptions {
    fn default() -> Self {
        ConvertOptions {
            max_resolution: None,
            texel_size: None,
            max_error: None,
            max_error_rel: None,
            error_scope: ErrorScope::Set,
            partition: None,
            cone_angle: DEFAULT_CONE_ANGLE,
            chart_size: DEFAULT_CHART_SIZE,
            charts: None,
            chart_error: None,
            max_charts: 4096,
            compactness: 1.0,
            lloyd_iterations: 6,
            overlap_rings: 1,
            dilation: 2,
            in_plane: InPlane::MinAreaRect,
            normals: NormalRule::default(),
            height_bits: 16,
            max_bytes: None,
            guarantee: false,
            hybrid: None,
        }
    }
}

fn parameter<T>(message: String) -> Result<T> {
    Err(GeomtexError::Parameter(message))
}

/// `Err` unless `value`, when given, is a positive finite number.
fn positive_finite(name: &str, value: Option<f64>) -> Result<()> {
    match value {
        Some(v) if !(v.is_finite() && v > 0.0) => {
            parameter(format!("{name} must be a positive finite number, got {v}"))
        }
        _ => Ok(()),
    }
}

/// `Err` unless `value` is at most `max`.
fn at_most(name: &str, value: usize, max: usize) -> Result<()> {
    if value > max {
        return parameter(format!("{name} must be at most {max}, got {value}"));
    }
    Ok(())
}

impl ConvertOptions {
    pub fn error_driven(&self) -> bool {
        self.max_error.is_some() || self.max_error_rel.is_some()
    }

    /// Whether no keyword sets the resolution, so `convert` is error-driven at
    /// `DEFAULT_MAX_ERROR_REL`.
    pub fn default_bound(&self) -> bool {
        !self.error_driven()
            && self.max_resolution.is_none()
            && self.texel_size.is_none()
            && self.max_bytes.is_none()
    }

    /// The partition: the one given, or VSA at a fixed resolution or with a VSA keyword, else
    /// the cone partition.
    pub fn partition_method(&self) -> PartitionMethod {
        let vsa = self.charts.is_some() || self.chart_error.is_some();
        match self.partition {
            Some(p) => p,
            None if vsa || !(self.error_driven() || self.default_bound()) => PartitionMethod::Vsa,
            None => PartitionMethod::Cone,
        }
    }

    /// These options with the defaults that depend on other keywords made explicit: the
    /// default bound and budget when no keyword sets the resolution (`mesh_bytes`: the mesh's
    /// float32/uint32 bytes, and its faces; `outline`: its outline ratio, asked for only then),
    /// and the partition.
    pub fn resolved(
        &self,
        (mesh_bytes, faces): (u64, usize),
        outline: impl FnOnce() -> Option<f64>,
    ) -> ConvertOptions {
        let (max_error_rel, max_bytes) = if self.default_bound() {
            let bound = default_error_rel(outline());
            // A hybrid set's triangles bound its bytes by the mesh's own: no budget.
            let budget = (!self.hybrid_on()).then(|| default_budget(mesh_bytes, faces, bound));
            (Some(bound), budget)
        } else {
            (self.max_error_rel, self.max_bytes)
        };
        ConvertOptions {
            max_error_rel,
            max_bytes,
            // Decided before the default budget fills `max_bytes`.
            hybrid: Some(self.hybrid_on()),
            partition: Some(self.partition_method()),
            ..self.clone()
        }
    }

    /// Whether charts may stay triangles: `hybrid` as given, or by default wherever the
    /// conversion is error-driven (the default bound, `max_error` or `max_error_rel`) with no
    /// byte budget.
    pub fn hybrid_on(&self) -> bool {
        let possible = self.error_driven() || self.default_bound();
        self.hybrid.unwrap_or(possible && self.max_bytes.is_none())
    }

    /// `max_resolution`, or its default.
    pub fn resolution_cap(&self) -> u32 {
        self.max_resolution.unwrap_or(if self.error_driven() {
            ERROR_DRIVEN_MAX_RESOLUTION
        } else {
            DEFAULT_MAX_RESOLUTION
        })
    }

    /// VSA's target mean error: `chart_error`, or its default.
    pub fn chart_error_target(&self) -> f64 {
        self.chart_error.unwrap_or(DEFAULT_CHART_ERROR)
    }

    pub fn validate(&self) -> Result<()> {
        match self.max_bytes {
            Some(0) => return parameter("max_bytes must be >= 1, got 0".into()),
            Some(b) if self.error_driven() && self.error_scope == ErrorScope::Chart => {
                return parameter(format!(
                    "max_bytes ({b}) cannot be combined with error_scope='chart': each chart's \
                     bound sets its bytes"
                ))
            }
            _ => {}
        }
        if let (Some(true), Some(b)) = (self.hybrid, self.max_bytes) {
            return parameter(format!(
                "hybrid=True bounds the bytes by the mesh's own; max_bytes ({b}) cannot be \
                 combined with it yet"
            ));
        }
        if self.hybrid == Some(true) && !(self.error_driven() || self.default_bound()) {
            return parameter(
                "hybrid=True weighs each chart's height map within the error bound against its \
                 triangles: give max_error or max_error_rel, or no keyword that sets the \
                 resolution (the default bound)"
                    .into(),
            );
        }
        if self.guarantee && !self.error_driven() {
            return parameter(
                "guarantee=True bounds every drawn point by max_error: give max_error or \
                 max_error_rel"
                    .into(),
            );
        }
        self.validate_resolution()?;
        self.validate_partition()?;
        at_most("overlap_rings", self.overlap_rings, 16)?;
        at_most("dilation", self.dilation, 64)?;
        if !crate::gtex::HEIGHT_BITS.contains(&self.height_bits) {
            return parameter(format!(
                "height_bits must be 8 or 16, got {}",
                self.height_bits
            ));
        }
        at_most("lloyd_iterations", self.lloyd_iterations, 1000)
    }

    /// The keywords that choose the texel size.
    fn validate_resolution(&self) -> Result<()> {
        if !MAX_RESOLUTION_RANGE.contains(&self.resolution_cap()) {
            return parameter(format!(
                "max_resolution must be in [2, {}], got {}",
                MAX_RESOLUTION_RANGE.end(),
                self.resolution_cap()
            ));
        }
        positive_finite("texel_size", self.texel_size)?;
        positive_finite("max_error", self.max_error)?;
        positive_finite("max_error_rel", self.max_error_rel)?;
        if self.max_error.is_some() && self.max_error_rel.is_some() {
            return parameter("give max_error or max_error_rel, not both".into());
        }
        if self.texel_size.is_some() && self.error_driven() {
            return parameter(
                "texel_size fixes the texel while max_error chooses it per chart: give one".into(),
            );
        }
        Ok(())
    }

    /// The keywords of the partitions.
    fn validate_partition(&self) -> Result<()> {
        if !(self.cone_angle.is_finite() && self.cone_angle > 0.0 && self.cone_angle <= 85.0) {
            return parameter(format!(
                "cone_angle must be in (0, 85] degrees, got {}",
                self.cone_angle
            ));
        }
        if !(self.chart_size.is_finite() && self.chart_size > 0.0 && self.chart_size <= 10.0) {
            return parameter(format!(
                "chart_size must be in (0, 10] (a fraction of the diagonal), got {}",
                self.chart_size
            ));
        }
        if self.charts == Some(0) {
            return parameter("charts must be at least 1".into());
        }
        if let Some(c) = self.chart_error {
            if !(c.is_finite() && (0.0..=4.0).contains(&c)) {
                return parameter(format!("chart_error must be in [0, 4], got {c}"));
            }
        }
        if !(self.compactness.is_finite() && (0.0..=100.0).contains(&self.compactness)) {
            return parameter(format!(
                "compactness must be in [0, 100], got {}",
                self.compactness
            ));
        }
        if self.max_charts == 0 {
            return parameter("max_charts must be at least 1".into());
        }
        Ok(())
    }
}

impl FromStr for ErrorScope {
    type Err = GeomtexError;

    /// "set" | "chart".
    fn from_str(s: &str) -> Result<Self> {
        parse_choice(
            "error_scope",
            s,
            &[("set", ErrorScope::Set), ("chart", ErrorScope::Chart)],
        )
    }
}

impl FromStr for PartitionMethod {
    type Err = GeomtexError;

    /// "cone" | "vsa".
    fn from_str(s: &str) -> Result<Self> {
        parse_choice(
            "partition",
            s,
            &[
                ("cone", PartitionMethod::Cone),
                ("vsa", PartitionMethod::Vsa),
            ],
        )
    }
}

impl FromStr for InPlane {
    type Err = GeomtexError;

    /// "min_area" | "pca" (the keyword is `frame`).
    fn from_str(s: &str) -> Result<Self> {
        parse_choice(
            "frame",
            s,
            &[("min_area", InPlane::MinAreaRect), ("pca", InPlane::Pca)],
        )
    }
}

/// The keywords of `convert` as a caller (the Python binding) receives them: every one optional,
/// integers as signed 64-bit. `into_options` fills the defaults and checks the ranges.
#[derive(Clone, Debug, Default)]
pub struct ConvertArgs {
    pub max_resolution: Option<i64>,
    pub texel_size: Option<f64>,
    pub max_error: Option<f64>,
    pub max_error_rel: Option<f64>,
    pub error_scope: Option<ErrorScope>,
    pub partition: Option<PartitionMethod>,
    pub cone_angle: Option<f64>,
    pub chart_size: Option<f64>,
    pub charts: Option<i64>,
    pub chart_error: Option<f64>,
    pub max_charts: Option<i64>,
    pub compactness: Option<f64>,
    pub lloyd_iterations: Option<i64>,
    pub overlap_rings: Option<i64>,
    pub dilation: Option<i64>,
    pub frame: Option<InPlane>,
    pub normals: Option<NormalSource>,
    /// Degrees, with `normals` "crease" (the default).
    pub crease_angle: Option<f64>,
    pub height_bits: Option<i64>,
    pub max_bytes: Option<i64>,
    pub guarantee: Option<bool>,
    pub hybrid: Option<bool>,
}

/// A count that must not be negative.
fn count(name: &str, value: i64) -> Result<usize> {
    usize::try_from(value).or_else(|_| parameter(format!("{name} must be >= 0, got {value}")))
}

/// `count` of a given value, or `default`.
fn count_or(name: &str, value: Option<i64>, default: usize) -> Result<usize> {
    value.map_or(Ok(default), |v| count(name, v))
}

impl ConvertArgs {
    /// The options these arguments give, `ConvertOptions::default()` for each one not given,
    /// validated.
    pub fn into_options(self) -> Result<ConvertOptions> {
        let default = ConvertOptions::default();
        let max_resolution = self
            .max_resolution
            .map(|r| {
                u32::try_from(r).or_else(|_| {
                    parameter(format!(
                        "max_resolution must be in [2, {}], got {r}",
                        MAX_RESOLUTION_RANGE.end()
                    ))
                })
            })
            .transpose()?;
        let height_bits = match self.height_bits {
            None => default.height_bits,
            Some(b @ (8 | 16)) => b as u8,
            Some(other) => return parameter(format!("height_bits must be 8 or 16, got {other}")),
        };
        let opts = ConvertOptions {
            max_resolution,
            texel_size: self.texel_size,
            max_error: self.max_error,
            max_error_rel: self.max_error_rel,
            error_scope: self.error_scope.unwrap_or(default.error_scope),
            partition: self.partition,
            cone_angle: self.cone_angle.unwrap_or(default.cone_angle),
            chart_size: self.chart_size.unwrap_or(default.chart_size),
            charts: self.charts.map(|c| count("charts", c)).transpose()?,
            chart_error: self.chart_error,
            max_charts: count_or("max_charts", self.max_charts, default.max_charts)?,
            compactness: self.compactness.unwrap_or(default.compactness),
            lloyd_iterations: count_or(
                "lloyd_iterations",
                self.lloyd_iterations,
                default.lloyd_iterations,
            )?,
            overlap_rings: count_or("overlap_rings", self.overlap_rings, default.overlap_rings)?,
            dilation: count_or("dilation", self.dilation, default.dilation)?,
            in_plane: self.frame.unwrap_or(default.in_plane),
            normals: NormalRule::from_keywords(self.normals, self.crease_angle)?,
            height_bits,
            max_bytes: self
                .max_bytes
                .map(|b| {
                    u64::try_from(b)
                        .or_else(|_| parameter(format!("max_bytes must be >= 1, got {b}")))
                })
                .transpose()?,
            guarantee: self.guarantee.unwrap_or(default.guarantee),
            hybrid: self.hybrid,
        };
        opts.validate()?;
        Ok(opts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn message(e: GeomtexError) -> String {
        match e {
            GeomtexError::Parameter(m) => m,
            other => panic!("not a Parameter error: {other:?}"),
        }
    }

    #[test]
    fn names_parse_and_bad_names_say_the_choices() {
        assert_eq!("chart".parse::<ErrorScope>().unwrap(), ErrorScope::Chart);
        assert_eq!("min_area".parse::<InPlane>().unwrap(), InPlane::MinAreaRect);
        assert_eq!("flat".parse::<NormalSource>().unwrap(), NormalSource::Flat);
        assert_eq!(
            message("x".parse::<ErrorScope>().unwrap_err()),
            "error_scope must be 'set' or 'chart', got \"x\""
        );
        assert_eq!(
            message("diagonal".parse::<InPlane>().unwrap_err()),
            "frame must be 'min_area' or 'pca', got \"diagonal\""
        );
        assert_eq!(
            message("bumpy".parse::<NormalSource>().unwrap_err()),
            "normals must be 'crease', 'smooth' or 'flat', got \"bumpy\""
        );
    }

    #[test]
    fn no_arguments_give_the_defaults() {
        let opts = ConvertArgs::default().into_options().unwrap();
        let default = ConvertOptions::default();
        assert_eq!(format!("{opts:?}"), format!("{default:?}"));
        assert_eq!(opts.resolution_cap(), 256);
        assert_eq!(opts.error_scope, ErrorScope::Set);
        assert_eq!((opts.max_charts, opts.lloyd_iterations), (4096, 6));
        assert_eq!(
            (opts.overlap_rings, opts.dilation, opts.height_bits),
            (1, 2, 16)
        );
        assert_eq!(opts.compactness, 1.0);
        assert_eq!(
            (opts.in_plane, opts.normals),
            (InPlane::MinAreaRect, NormalRule::default())
        );
    }

    #[test]
    fn no_resolution_keyword_resolves_to_the_default_bound_and_budget() {
        let bunny = || Some(10.0);
        // By default hybrid, with no budget: the triangles bound the bytes.
        let hybrid = ConvertOptions::default().resolved((5_000_000, 50_000), bunny);
        assert_eq!((hybrid.hybrid, hybrid.max_bytes), (Some(true), None));
        assert_eq!(hybrid.max_error_rel, Some(DEFAULT_MAX_ERROR_REL));
        // All height maps: within a budget.
        let default = ConvertOptions {
            hybrid: Some(false),
            ..Default::default()
        };
        // 50k faces or more: the mesh's bytes.
        let resolved = default.resolved((5_000_000, 50_000), bunny);
        assert_eq!(resolved.max_error_rel, Some(DEFAULT_MAX_ERROR_REL));
        assert_eq!(resolved.max_bytes, Some(5_000_000));
        assert_eq!(resolved.partition, Some(PartitionMethod::Cone));
        assert_eq!(resolved.resolution_cap(), ERROR_DRIVEN_MAX_RESOLUTION);
        let at_line = default.resolved((900_000, 50_000), bunny);
        assert_eq!(at_line.max_bytes, Some(900_000));
        // A small mesh's budget is the allowance, the more the smaller the mesh.
        let small = default.resolved((1000, 10_000), bunny);
        assert_eq!(small.max_bytes, Some(3_200_000));
        // Twice the bunny's outline for its area: half the bound, twice the allowance.
        let thin = default.resolved((1000, 10_000), || Some(21.0));
        assert_eq!(thin.max_error_rel, Some(DEFAULT_MAX_ERROR_REL / 2.0));
        assert_eq!(thin.max_bytes, Some(6_400_000));
        // Hair-thin: the tightest bound; no outline (a point): the bunny's.
        let hair = default.resolved((1000, 10_000), || Some(1e6));
        assert_eq!(
            hair.max_error_rel,
            Some(DEFAULT_MAX_ERROR_REL * MIN_BOUND_SCALE)
        );
        let point = default.resolved((1000, 10_000), || None);
        assert_eq!(point.max_error_rel, Some(DEFAULT_MAX_ERROR_REL));
        // Any resolution keyword: as before, VSA at one texel.
        for opts in [
            ConvertOptions {
                max_resolution: Some(64),
                ..Default::default()
            },
            ConvertOptions {
                max_bytes: Some(10),
                ..Default::default()
            },
        ] {
            let r = opts.resolved((5_000_000, 90_000), || panic!("asked for the outline"));
            assert!(!r.error_driven(), "{r:?}");
            assert_eq!(r.partition, Some(PartitionMethod::Vsa));
        }
        // A VSA keyword keeps VSA under the default bound; an explicit partition is kept.
        let charts = ConvertOptions {
            charts: Some(12),
            ..Default::default()
        };
        let r = charts.resolved((5_000_000, 90_000), bunny);
        assert!(r.error_driven() && r.partition == Some(PartitionMethod::Vsa));
        let bound = ConvertOptions {
            max_error_rel: Some(1e-3),
            ..Default::default()
        };
        let r = bound.resolved((5_000_000, 90_000), || panic!("asked for the outline"));
        assert_eq!(
            (r.max_bytes, r.partition),
            (None, Some(PartitionMethod::Cone))
        );
    }

    #[test]
    fn out_of_range_arguments_are_parameter_errors() {
        let bad = |args: ConvertArgs| message(args.into_options().unwrap_err());
        assert_eq!(
            bad(ConvertArgs {
                max_resolution: Some(-5),
                ..Default::default()
            }),
            "max_resolution must be in [2, 4096], got -5"
        );
        assert_eq!(
            bad(ConvertArgs {
                max_resolution: Some(1),
                ..Default::default()
            }),
            "max_resolution must be in [2, 4096], got 1"
        );
        assert_eq!(
            bad(ConvertArgs {
                charts: Some(-3),
                ..Default::default()
            }),
            "charts must be >= 0, got -3"
        );
        assert_eq!(
            bad(ConvertArgs {
                overlap_rings: Some(99),
                ..Default::default()
            }),
            "overlap_rings must be at most 16, got 99"
        );
        assert_eq!(
            bad(ConvertArgs {
                height_bits: Some(12),
                ..Default::default()
            }),
            "height_bits must be 8 or 16, got 12"
        );
        let given = ConvertArgs {
            max_resolution: Some(64),
            height_bits: Some(8),
            normals: Some(NormalSource::Flat),
            ..Default::default()
        };
        let opts = given.into_options().unwrap();
        assert_eq!((opts.max_resolution, opts.height_bits), (Some(64), 8));
        assert_eq!(opts.normals.source, NormalSource::Flat);
        let crease = ConvertArgs {
            crease_angle: Some(45.0),
            ..Default::default()
        };
        let rule = crease.into_options().unwrap().normals;
        assert_eq!(
            (rule.source, rule.crease_angle),
            (NormalSource::Crease, 45.0)
        );
        assert_eq!(
            bad(ConvertArgs {
                crease_angle: Some(0.0),
                ..Default::default()
            }),
            "crease_angle must be in (0, 180] degrees, got 0"
        );
    }
}
