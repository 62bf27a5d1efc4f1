//! One chart drawn at one texel size and its reconstruction error measured: what the resolution
//! search does at every level it tries, and the final raster once more at the chosen one.
//!
//! Space: world (mesh, frames, texel sizes, errors); the maps are patch-local (see raster).

use super::accuracy::{self, AreaSample, WeightedError, ERROR_QUANTILE, SAMPLES_PER_CHART};
use super::bound;
use super::raster::{self, Maps};
use crate::charts::frame::ChartFrame;
use crate::charts::frame::PatchBox;
use crate::convert_options::ConvertOptions;
use crate::gtex::ErrorBoundMap;
use crate::profile::{timed, Phase};
use rayon::prelude::*;

use crate::mesh::{CornerNormals, Mesh};

/// A chart ready to draw: its own faces then its ring, its frame, and the longer side of its
/// bounds.
pub struct ChartJob<'a> {
    pub faces: Vec<u32>,
    pub chart_faces: usize,
    /// The outline of all the faces (`raster::boundary_edges`), the same at every texel size.
    pub outline: Vec<[u32; 2]>,
    pub frame: &'a ChartFrame,
    pub long_side: f64,
}

impl ChartJob<'_> {
    /// The texel size that gives the chart `resolution` texels on its longer side.
    pub fn texel_for(&self, resolution: u32) -> f64 {
        self.long_side / resolution as f64
    }
}

/// A chart drawn at one texel size: its box, its maps, and its reconstruction errors with the
/// area each stands for (see `accuracy`), whose `ERROR_QUANTILE` is `error`.
pub struct Drawn {
    pub bx: PatchBox,
    pub maps: Maps,
    pub errors: Vec<WeightedError>,
    pub error: f64,
    /// The cells' error bounds (`bound`): made by the final raster, and by every level the
    /// resolution search tries under `guarantee` (whose `error` is then their largest).
    pub bound: Option<ErrorBoundMap>,
}

/// What every chart is drawn with: the mesh, its corner normals, the options, and the set's one texel
/// size (the starting point when each chart gets its own).
pub struct ChartDrawer<'a> {
    pub mesh: &'a Mesh,
    /// Per face, its corners' normals under the conversion's normal rule.
    pub corner_normals: &'a CornerNormals,
    pub opts: &'a ConvertOptions,
    pub texel: f64,
    /// Whether each chart gets its own texel size (error-driven resolution).
    pub per_chart_texel: bool,
}

impl ChartDrawer<'_> {
    /// The jobs of charts with these faces, rings and frames.
    pub fn jobs<'f>(
        &self,
        charts: impl Iterator<Item = (&'f [u32], &'f [u32])>,
        frames: &'f [ChartFrame],
    ) -> Vec<ChartJob<'f>> {
        let mut jobs: Vec<ChartJob> = charts
            .zip(frames)
            .map(|((faces, ring), frame)| ChartJob {
                faces: faces.iter().chain(ring).copied().collect(),
                chart_faces: faces.len(),
                outline: Vec::new(),
                frame,
                long_side: frame.long_side().max(self.texel * 1e-3),
            })
            .collect();
        jobs.par_iter_mut()
            .for_each(|j| j.outline = raster::boundary_edges(self.mesh, &j.faces));
        jobs
    }

    /// Points on the chart's own faces to measure its error against: about a texel apart at
    /// the finest texel it can get.
    pub fn samples(&self, job: &ChartJob) -> Vec<AreaSample> {
        let spacing = if self.per_chart_texel {
            job.texel_for(self.opts.resolution_cap())
        } else {
            self.texel
        };
        timed(Phase::Samples, || {
            accuracy::surface_samples(
                self.mesh,
                &job.faces[..job.chart_faces],
                spacing,
                SAMPLES_PER_CHART,
            )
        })
    }

    /// Draws a chart (its own faces first, then its ring) at texel size `texel` and measures
    /// its reconstruction error against `samples` of its own faces and its lips.
    pub fn draw(&self, job: &ChartJob, texel: f64, samples: &[AreaSample]) -> Drawn {
        self.draw_maps(job, texel, samples, Some(self.corner_normals))
    }

    /// `draw` without the normal and color maps (left empty): what the resolution search
    /// measures at each level it tries, as the error and the bytes do not depend on them.
    pub fn measure(&self, job: &ChartJob, texel: f64, samples: &[AreaSample]) -> Drawn {
        self.draw_maps(job, texel, samples, None)
    }

    fn draw_maps(
        &self,
        job: &ChartJob,
        texel: f64,
        samples: &[AreaSample],
        corner_normals: Option<&CornerNormals>,
    ) -> Drawn {
        let opts = self.opts;
        let bx = job
            .frame
            .patch_box(texel, opts.resolution_cap(), opts.height_bits);
        let mut maps = timed(Phase::Rasterize, || {
            raster::rasterize(
                self.mesh,
                corner_normals,
                (&job.faces, job.chart_faces),
                &job.outline,
                &bx,
            )
        });
        // The height field as a patch for the error lookups; its heights go back to the maps.
        let probe = bx.into_patch(
            Maps {
                heights: std::mem::take(&mut maps.heights),
                outline: std::mem::take(&mut maps.outline),
                ..Default::default()
            },
            Vec::new(),
            Vec::new(),
        );
        let mut errors = timed(Phase::Gaps, || {
            accuracy::gaps(&probe, &accuracy::thinned(samples, texel))
        });
        let bound = (corner_normals.is_some() || opts.guarantee).then(|| {
            timed(Phase::Bound, || {
                bound::error_bound_map(self.mesh, &job.faces, &probe)
            })
        });
        maps.heights = probe.heights;
        maps.outline = probe.outline;
        let texel_len = ((bx.extent.x / bx.width as f64) * (bx.extent.y / bx.height as f64)).sqrt();
        timed(Phase::PastTheMesh, || {
            errors.extend(accuracy::past_the_mesh(&maps, texel_len))
        });
        let error = match &bound {
            Some(b) if opts.guarantee => f64::from(b.scale),
            _ => timed(Phase::Quantile, || {
                accuracy::quantile(&mut errors, ERROR_QUANTILE)
            }),
        };
        Drawn {
            bx,
            maps,
            errors,
            error,
            bound,
        }
    }
}
