//! One rendered image and the figures of the call that made it.
//!
//! Spaces: images are row-major with row 0 at the top; depth is measured along the camera's
//! forward axis in world units; normals are world-space.

use crate::gtex::StatValue;

use super::coverage::CoverageFigures;
use super::error_bound::BoundFigures;
use super::outputs::Outputs;
use super::search::{Method, Primary};

/// One rendered image, row-major with row 0 at the top. Each per-pixel output is `None` when the
/// render did not ask for it (`Outputs`).
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// RGBA8, shaded with a headlight; the background where nothing was hit.
    pub color: Option<Vec<u8>>,
    /// RGBA8 unshaded base color (the surface's own color, no light or shadow); transparent
    /// black (0) where nothing was hit.
    pub albedo: Option<Vec<u8>>,
    /// z-depth: distance along the camera's forward axis in world units; +inf on a miss.
    pub depth: Option<Vec<f32>>,
    /// World-space unit normals (xyz), 0 on a miss.
    pub normal: Option<Vec<f32>>,
    /// Patch index (0.. across the scene's texture sets in order), -1 on a miss, -2 - k for the
    /// k-th mesh of the scene.
    pub patch_id: Option<Vec<i32>>,
    pub gpu_ms: Option<f64>,
    pub cpu_ms: f64,
    pub patches_drawn: usize,
    /// Patches whose box lies wholly outside the view frustum, left out of the frame's tracing.
    pub patches_culled: usize,
    pub meshes_drawn: usize,
    /// Bytes the drawn texture sets' maps and pyramids take on the adapter.
    pub texture_bytes: u64,
    /// Milliseconds of this frame's `cpu_ms` spent making what a texture set's first frame
    /// needs (maps and pyramids uploaded, ownership, tile pieces; kinds/gtex): a one-off, 0 for
    /// sets drawn before.
    pub setup_ms: f64,
    pub near: f64,
    /// The height-map search the frame was drawn with.
    pub method: Method,
    /// How camera rays met the texture sets' boxes.
    pub primary: Primary,
    /// Height-map searches the tracer started (one per box a ray entered before its nearest hit).
    pub searches: u64,
    /// With `count_fetches`: height-map and pyramid reads.
    pub fetches: Option<u64>,
    /// With `count_fetches`: pieces whose slab the tiled walks tested (0 with boxes drawn).
    pub piece_tests: Option<u64>,
    /// With a light (shadow.rs): which pixels it cannot see, and the shadow pass's figures.
    pub shadow: Option<Shadows>,
    /// With surfel objects in the scene: what their passes drew.
    pub surfels: Option<SurfelCounts>,
    /// With an inverse geometric texture in the scene (kinds/igt.rs): per pixel the detailed
    /// face it shows, -1 where none.
    pub face_id: Option<Vec<i32>>,
    /// With `face_id`: the barycentric coordinates in that face, three per pixel (0 where none).
    pub barycentric: Option<Vec<f32>>,
    /// Per pixel a bound (world units) on the distance from the drawn point to the source mesh
    /// (error_bound.rs); NaN where nothing is drawn or no bound is known.
    pub error_bound: Option<Vec<f32>>,
    /// CPU backend: per pixel how far (z-depth units, rounded up) `depth` lies from the exact
    /// hit's z-depth it was rounded from, which error_bound.rs takes in place of half an f32
    /// step; None on the GPU backend (its depth's rounding is not known pixel by pixel).
    pub depth_rounding: Option<Vec<f32>>,
    /// With `error_bound`: its figures over the drawn pixels.
    pub bound_figures: Option<BoundFigures>,
    /// Per pixel, whether its coverage could differ from the source mesh's (coverage.rs).
    pub coverage_uncertain: Option<Vec<bool>>,
    /// With `coverage_uncertain`: the probes it cast and its time.
    pub coverage: Option<CoverageFigures>,
    /// With `lod`: drawn patches per level-of-detail stop level (0: exact), and whether the
    /// levels were picked by the node's pixel size or by the bound (`SearchOptions`).
    pub lod_levels: Option<(Vec<u64>, LodRule)>,
    /// The backend that drew it: "gpu" (wgpu) or "cpu" (render/cpu).
    pub device: &'static str,
}

/// How a frame with `lod` picked each patch's stop level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LodRule {
    /// Nodes about a pixel wide.
    Pixel,
    /// The coarsest level whose error bound projects to at most `max_pixel_error` pixels.
    Bound,
}

impl LodRule {
    pub fn as_str(self) -> &'static str {
        match self {
            LodRule::Pixel => "pixel",
            LodRule::Bound => "bound",
        }
    }
}

/// What `error_bound_search` says of a search that may step over a thin feature (linear steps).
const DRAWN_POINTS_ONLY: &str = "none for sets (NaN): a linear search's hits stop within its \
     last step, off the stored surface, and it can step over a thin feature";

/// A frame's shadows (shadow.rs), made in one piece after its pixels are read back.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Shadows {
    /// Per pixel, true where the light cannot see the surface.
    pub mask: Vec<bool>,
    /// Milliseconds the shadow pass took.
    pub ms: f64,
    /// Of `ms`, the tracing (upload, dispatches and read-back of the rays); the rest is building
    /// the rays and darkening the frame on the CPU.
    pub trace_ms: f64,
    /// Pixels shadowed without a ray, their surface facing away from the light.
    pub attached: u64,
    /// Shadow rays traced on the device (those some caster's test kept: the rest pass beside
    /// every caster, or are attached).
    pub traced: u64,
}

/// Names of the per-level surfel counts in `Frame::stats`.
const SURFEL_LEVELS: [&str; crate::surfel_data::MAX_LEVELS] = [
    "surfels_level_0",
    "surfels_level_1",
    "surfels_level_2",
    "surfels_level_3",
    "surfels_level_4",
    "surfels_level_5",
    "surfels_level_6",
];

/// A frame's surfel figures, summed over the scene's surfel objects.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfelCounts {
    /// Finest-level surfels of the tiles in view: what drawing the finest level would splat.
    pub considered: u64,
    /// Surfels splatted, at the levels chosen.
    pub drawn: u64,
    /// Tiles not culled by the frustum.
    pub tiles: u64,
    /// Surfels splatted per level, finest first.
    pub per_level: [u64; crate::surfel_data::MAX_LEVELS],
    /// Surfels splatted from the nodes above the tiles (every level there).
    pub nodes: u64,
}

impl SurfelCounts {
    /// The counts the surfel passes left in their tallies (kinds/surfels.rs), summed; None when
    /// there are none.
    pub(crate) fn read(
        gpu: &super::Gpu,
        tallies: &[wgpu::Buffer],
    ) -> crate::error::Result<Option<Self>> {
        if tallies.is_empty() {
            return Ok(None);
        }
        let refs: Vec<&wgpu::Buffer> = tallies.iter().collect();
        let mut sum = SurfelCounts::default();
        for bytes in super::targets::read_buffers(&gpu.device, &refs)? {
            let t: &[u32] = bytemuck::cast_slice(&bytes);
            let at = super::kinds::surfels::TALLY_DRAWN;
            sum.drawn += t[at] as u64;
            sum.tiles += t[at + 1] as u64;
            sum.considered += t[at + 2] as u64;
            for (acc, v) in sum.per_level.iter_mut().zip(&t[at + 3..]) {
                *acc += *v as u64;
            }
            sum.nodes += t[super::kinds::surfels::TALLY_NODES] as u64;
        }
        Ok(Some(sum))
    }
}

impl Frame {
    /// Pixels showing a geometry texture; `None` without the patch ids.
    pub fn covered_pixels(&self) -> Option<usize> {
        let ids = self.patch_id.as_ref()?;
        Some(ids.iter().filter(|&&id| id >= 0).count())
    }

    /// The outputs the frame holds.
    pub fn outputs(&self) -> Outputs {
        Outputs {
            color: self.color.is_some(),
            albedo: self.albedo.is_some(),
            depth: self.depth.is_some(),
            normal: self.normal.is_some(),
            patch_id: self.patch_id.is_some(),
            error_bound: self.error_bound.is_some(),
            coverage_uncertain: self.coverage_uncertain.is_some(),
        }
    }

    /// Drops the outputs not in `keep` (read only because shadows needed them).
    pub fn keep_only(&mut self, keep: Outputs) {
        if !keep.color {
            self.color = None;
        }
        if !keep.albedo {
            self.albedo = None;
        }
        if !keep.depth {
            self.depth = None;
        }
        if !keep.normal {
            self.normal = None;
        }
        if !keep.patch_id {
            self.patch_id = None;
        }
        if !keep.error_bound {
            self.error_bound = None;
            self.bound_figures = None;
        }
        if !keep.coverage_uncertain {
            self.coverage_uncertain = None;
            self.coverage = None;
        }
    }

    /// The frame's figures by name, in a stable order; the fetch figures only when counted.
    /// Per-pixel figures divide by the covered pixels (at least one); without the patch ids
    /// neither is known (`Absent`).
    pub fn stats(&self) -> Vec<(&'static str, StatValue)> {
        let count = |n: usize| StatValue::Int(n as i64);
        let covered = self.covered_pixels();
        let per_pixel = |n: u64| {
            covered.map_or(StatValue::Absent, |c| {
                StatValue::Float(n as f64 / c.max(1) as f64)
            })
        };
        let mut stats = vec![
            (
                "gpu_ms",
                self.gpu_ms.map_or(StatValue::Absent, StatValue::Float),
            ),
            ("cpu_ms", StatValue::Float(self.cpu_ms)),
            ("device", StatValue::Text(self.device)),
            ("patches_drawn", count(self.patches_drawn)),
            ("patches_culled", count(self.patches_culled)),
            ("meshes_drawn", count(self.meshes_drawn)),
            ("texture_bytes", StatValue::Int(self.texture_bytes as i64)),
            ("setup_ms", StatValue::Float(self.setup_ms)),
            ("near", StatValue::Float(self.near)),
            ("method", StatValue::Text(self.method.as_str())),
            ("primary", StatValue::Text(self.primary.as_str())),
            ("covered_pixels", covered.map_or(StatValue::Absent, count)),
            ("searches", StatValue::Int(self.searches as i64)),
            ("searches_per_pixel", per_pixel(self.searches)),
        ];
        stats.extend(self.bound_stats());
        if let Some(s) = &self.shadow {
            let shadowed = s.mask.iter().filter(|&&s| s).count();
            stats.extend([
                ("shadow_ms", StatValue::Float(s.ms)),
                ("shadow_trace_ms", StatValue::Float(s.trace_ms)),
                ("shadowed_pixels", count(shadowed)),
                ("shadow_attached_pixels", count(s.attached as usize)),
                ("shadow_rays_traced", count(s.traced as usize)),
            ]);
        }
        if let Some(s) = &self.surfels {
            let n = |v: u64| StatValue::Int(v as i64);
            stats.extend([
                ("surfels_considered", n(s.considered)),
                ("surfels_drawn", n(s.drawn)),
                ("surfel_tiles_drawn", n(s.tiles)),
                ("surfels_above_tiles", n(s.nodes)),
            ]);
            stats.extend(
                SURFEL_LEVELS
                    .iter()
                    .zip(s.per_level)
                    .map(|(k, v)| (*k, n(v))),
            );
        }
        if let Some(fetches) = self.fetches {
            stats.extend([
                ("fetches", StatValue::Int(fetches as i64)),
                ("fetches_per_pixel", per_pixel(fetches)),
                (
                    "fetches_per_search",
                    StatValue::Float(fetches as f64 / self.searches.max(1) as f64),
                ),
                (
                    "piece_tests_per_pixel",
                    per_pixel(self.piece_tests.unwrap_or(0)),
                ),
            ]);
        }
        stats
    }

    /// The figures of the error bounds, coverage and level of detail, where the frame has them.
    fn bound_stats(&self) -> Vec<(&'static str, StatValue)> {
        let float = |v: Option<f64>| v.map_or(StatValue::Absent, StatValue::Float);
        let mut stats = Vec::new();
        if let Some(b) = &self.bound_figures {
            let search = match self.method {
                Method::MaxMip => "exact",
                Method::LinearBinary => DRAWN_POINTS_ONLY,
            };
            stats.extend([
                ("error_bound_max", float(b.max)),
                ("error_bound_median", float(b.median)),
                (
                    "error_bound_unknown_pixels",
                    StatValue::Int(b.unknown_pixels as i64),
                ),
                ("error_bound_search", StatValue::Text(search)),
            ]);
        }
        if let Some(c) = &self.coverage {
            stats.extend([
                ("coverage_probes", StatValue::Int(c.probes as i64)),
                ("coverage_ms", StatValue::Float(c.ms)),
            ]);
        }
        if let Some((_, rule)) = &self.lod_levels {
            stats.push(("lod_rule", StatValue::Text(rule.as_str())));
        }
        stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(fetches: Option<u64>) -> Frame {
        Frame {
            width: 1,
            height: 1,
            color: Some(vec![0; 4]),
            albedo: Some(vec![0; 4]),
            depth: Some(vec![f32::INFINITY]),
            normal: Some(vec![0.0; 3]),
            patch_id: Some(vec![-1]),
            gpu_ms: None,
            cpu_ms: 2.5,
            patches_drawn: 3,
            patches_culled: 1,
            meshes_drawn: 0,
            texture_bytes: 0,
            setup_ms: 0.0,
            near: 0.25,
            method: Method::MaxMip,
            primary: Primary::Tiles,
            searches: 0,
            fetches,
            piece_tests: fetches.map(|_| 60),
            shadow: None,
            surfels: None,
            face_id: None,
            barycentric: None,
            error_bound: None,
            depth_rounding: None,
            bound_figures: None,
            coverage_uncertain: None,
            coverage: None,
            lod_levels: None,
            device: "gpu",
        }
    }

    #[test]
    fn stats_keep_their_names_order_and_types() {
        let names = |f: &Frame| f.stats().iter().map(|(k, _)| *k).collect::<Vec<_>>();
        let plain = [
            "gpu_ms",
            "cpu_ms",
            "device",
            "patches_drawn",
            "patches_culled",
            "meshes_drawn",
            "texture_bytes",
            "setup_ms",
            "near",
            "method",
            "primary",
            "covered_pixels",
            "searches",
            "searches_per_pixel",
        ];
        assert_eq!(names(&frame(None)), plain);
        let counted = frame(Some(30));
        assert_eq!(
            names(&counted)[14..],
            [
                "fetches",
                "fetches_per_pixel",
                "fetches_per_search",
                "piece_tests_per_pixel"
            ]
        );
        let stats = counted.stats();
        assert_eq!(stats[0].1, StatValue::Absent);
        assert_eq!(stats[1 + 2].1, StatValue::Int(3));
        assert_eq!(stats[2].1, StatValue::Text("gpu"));
        assert_eq!(stats[9].1, StatValue::Text("maxmip"));
        // Nothing covered and no searches: the figures divide by one, not zero.
        assert_eq!(stats[15].1, StatValue::Float(30.0));
        assert_eq!(stats[16].1, StatValue::Float(30.0));
        assert_eq!(stats[17].1, StatValue::Float(60.0));
        // Without the patch ids the per-pixel figures are not known, not zero.
        let mut depth_only = frame(Some(30));
        depth_only.keep_only(Outputs::parse(&["depth"]).unwrap());
        let stats = depth_only.stats();
        assert_eq!(stats[11], ("covered_pixels", StatValue::Absent));
        assert_eq!(stats[15].1, StatValue::Absent);
    }
}
