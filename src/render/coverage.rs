//! Which pixels' coverage (drawn or not) could differ from the source mesh's
//! (`Frame::coverage_uncertain`). Only a pixel beside a coverage transition can (a drawn pixel
//! with an undrawn 8-neighbour, or the other way round), as long as the surfaces involved stand
//! off the mesh by less than a pixel. Around each such pixel's centre eight probe rays are cast
//! at the distance the drawn surface may stand off the mesh there (its error bound plus a tenth
//! of a texel of outline rounding, projected to pixels at its depth): the pixel is uncertain when
//! a probe's hit or miss differs from the pixel's own. An undrawn pixel whose ray passes the box
//! of a hybrid set's patch probes at least as far as that patch's outline allowance: where the
//! patch meets the set's triangles, its outline may leave a crack with no pixel of the patch
//! beside it. The probes are one batched ray query of the renderer against the same scene
//! (query.rs).
//!
//! Spaces: pixels row-major from the top, sub-pixel offsets in pixels; rays in world space.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::camera::{Camera, Lens};
use super::error_bound::{pixel_size, DrawnPixels, PixelSources};
use super::{RayBackend, Scene, SearchOptions};
use crate::error::Result;

/// Pixels added to every probe distance: the probe rays are traced in f32.
const PROBE_MARGIN_PX: f64 = 1e-3;

/// Probes per uncertain-candidate pixel: the eight compass directions.
const PROBES: usize = 8;

/// A frame's coverage figures.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CoverageFigures {
    /// Probe rays cast.
    pub probes: u64,
    /// Milliseconds the coverage step took (transitions, probes, their query).
    pub ms: f64,
}

/// Pixels of a `w` x `h` image (`drawn` per pixel) that have an 8-neighbour of the other state,
/// rows on every core (serial, through `neighbours`, this pass took an eighth of the step).
pub(crate) fn transitions(drawn: &[bool], w: usize, h: usize) -> Vec<usize> {
    let differs = |x: usize, y: usize| {
        let me = drawn[y * w + x];
        let (x0, x1) = (x.saturating_sub(1), (x + 1).min(w - 1));
        (y.saturating_sub(1)..=(y + 1).min(h - 1))
            .any(|ny| drawn[ny * w + x0..=ny * w + x1].iter().any(|&d| d != me))
    };
    (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            (0..w)
                .filter(move |&x| differs(x, y))
                .map(move |x| y * w + x)
        })
        .collect()
}

/// The in-image 8-neighbours of pixel (x, y).
fn neighbours(x: i64, y: i64, w: usize, h: usize) -> impl Iterator<Item = usize> {
    (-1..=1)
        .flat_map(move |dy| (-1..=1).map(move |dx| (x + dx, y + dy)))
        .filter(move |&(nx, ny)| {
            (nx, ny) != (x, y) && nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h
        })
        .map(move |(nx, ny)| ny as usize * w + nx as usize)
}

/// What the probe distance of a pixel is made from.
pub(crate) struct CoverageInputs<'a> {
    pub pixels: &'a DrawnPixels<'a>,
    pub height: u32,
    pub bounds: &'a [f32],
    pub sources: &'a PixelSources,
    pub lens: &'a Lens,
}

impl CoverageInputs<'_> {
    fn drawn(&self, i: usize) -> bool {
        self.pixels.drawn(i)
    }

    /// How far (pixels) drawn pixel `i`'s surface may stand off the mesh's outline: its bound and
    /// outline allowance projected at its depth, NaN where unknown.
    fn stand_off(&self, i: usize) -> f64 {
        let world =
            f64::from(self.bounds[i]) + self.sources.outline_allowance(self.pixels.patch_id[i]);
        world / pixel_size(self.lens, f64::from(self.pixels.depth[i]))
    }

    /// The probe distance (pixels) of transition pixel `i`: its own stand-off where drawn, else
    /// the largest of its drawn neighbours' and of the seams its ray passes; NaN where one
    /// involved is unknown.
    fn probe_distance(&self, i: usize) -> f64 {
        let w = self.pixels.width as usize;
        let d = if self.drawn(i) {
            self.stand_off(i)
        } else {
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            neighbours(x, y, w, self.height as usize)
                .filter(|&j| self.drawn(j))
                .map(|j| self.stand_off(j))
                .fold(self.seam_stand_off(i), |m, d| {
                    if m.is_nan() || d.is_nan() {
                        f64::NAN
                    } else {
                        m.max(d)
                    }
                })
        };
        d + PROBE_MARGIN_PX
    }

    /// How far (pixels) a crack between a hybrid set's patch and its triangles may reach into
    /// undrawn pixel `i` (`PixelSources::seam_allowance`), projected where its ray first meets
    /// such a patch's box (no nearer than the lens's near plane).
    fn seam_stand_off(&self, i: usize) -> f64 {
        let (o, d) = self.pixels.ray(i);
        let (allowance, t) = self.sources.seam_allowance(o, d);
        if allowance <= 0.0 {
            return 0.0;
        }
        let depth = (t * d.dot(self.pixels.forward)).max(self.lens.near);
        allowance / pixel_size(self.lens, depth)
    }
}

/// Per pixel, whether its coverage could differ from the source mesh's, with the figures, the
/// probes traced by `backend`. Objects it does not trace (surfels, IGT meshes) leave every
/// transition pixel uncertain, as does a pixel whose bound is unknown.
pub(crate) fn coverage_uncertain(
    backend: &mut impl RayBackend,
    scene: &Scene,
    camera: &Camera,
    search: &SearchOptions,
    inputs: &CoverageInputs,
) -> Result<(Vec<bool>, CoverageFigures)> {
    let start = Instant::now();
    let (w, h) = (inputs.pixels.width as usize, inputs.height as usize);
    let drawn: Vec<bool> = (0..w * h)
        .into_par_iter()
        .map(|i| inputs.drawn(i))
        .collect();
    let mut uncertain = vec![false; w * h];
    let traced = all_traced(backend, scene)?;
    let mut probed = Vec::new();
    let found = transitions(&drawn, w, h);
    let distances: Vec<f64> = found
        .par_iter()
        .map(|&i| inputs.probe_distance(i))
        .collect();
    for (i, d) in found.into_iter().zip(distances) {
        if d.is_nan() || !traced {
            uncertain[i] = true;
        } else {
            probed.push((i, d));
        }
    }
    let (rays, ranges) = probe_rays(camera, inputs.lens, &probed, w);
    if !rays.is_empty() {
        let hits = backend.probe(scene, &rays, &ranges, search)?;
        for (k, &(i, _)) in probed.iter().enumerate() {
            let probes = &hits[k * PROBES..(k + 1) * PROBES];
            uncertain[i] = probes.iter().any(|&id| (id != -1) != drawn[i]);
        }
    }
    let figures = CoverageFigures {
        probes: rays.len() as u64,
        ms: start.elapsed().as_secs_f64() * 1e3,
    };
    Ok((uncertain, figures))
}

/// Whether `backend` traces every object of `scene`.
fn all_traced(backend: &impl RayBackend, scene: &Scene) -> Result<bool> {
    for placed in &scene.objects {
        if !backend.traces(&placed.object)? {
            return Ok(false);
        }
    }
    Ok(true)
}

/// Eight probe rays per pixel (index, distance in pixels) of a `w`-wide image, each with the
/// stretch that counts: from the near plane on, as the frame draws.
#[allow(clippy::type_complexity)] // rays and their stretches, as trace_rays takes them
fn probe_rays(
    camera: &Camera,
    lens: &Lens,
    probed: &[(usize, f64)],
    w: usize,
) -> (Vec<(DVec3, DVec3)>, Vec<(f64, f64)>) {
    let lines = camera.pixel_lines(lens);
    let forward = camera.forward();
    let mut rays = Vec::with_capacity(PROBES * probed.len());
    let mut ranges = Vec::with_capacity(rays.capacity());
    for &(i, d) in probed {
        let (x, y) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
        for k in 0..PROBES {
            let angle = k as f64 * std::f64::consts::TAU / PROBES as f64;
            let (o, dir) = lines.at(x + d * angle.cos(), y + d * angle.sin());
            let unit = dir.normalize();
            rays.push((o, unit));
            ranges.push((lens.near / unit.dot(forward), f64::from(f32::MAX)));
        }
    }
    (rays, ranges)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transitions_are_the_pixels_beside_the_other_state() {
        // A 5 x 4 image with a 2 x 2 block drawn at (1, 1).
        let mut drawn = vec![false; 20];
        for i in [6, 7, 11, 12] {
            drawn[i] = true;
        }
        let t = transitions(&drawn, 5, 4);
        // Every pixel of columns 0..=3 is beside the block; column 4 is not.
        assert_eq!(
            t,
            vec![0, 1, 2, 3, 5, 6, 7, 8, 10, 11, 12, 13, 15, 16, 17, 18]
        );
    }
}
