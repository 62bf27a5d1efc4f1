//! Which pixels' coverage (drawn or not) could differ from the source mesh's
//! (`Frame::coverage_uncertain`). Only a pixel beside a coverage transition can (a drawn pixel
//! with an undrawn 8-neighbour, or the other way round; the pixels just past the frame's edges
//! are traced for this, `Ring`), as long as the surfaces involved stand off the mesh by less
//! than a pixel. Around each such pixel's centre eight probe rays are cast at the distance the
//! drawn surface may stand off the mesh there (its error bound plus a tenth of a texel of outline
//! rounding, projected to pixels at its depth): the pixel is uncertain when a probe's hit or miss
//! differs from the pixel's own. Where that distance reaches a pixel or more (close-ups), every
//! pixel within it (and a pixel and a half more) of the transition probes too, as far as the
//! widest such distance reaching it: the mesh's outline may lie anywhere there. An undrawn pixel
//! whose ray passes the box of a hybrid set's patch probes at least as far as that patch's
//! outline allowance: where the patch meets the set's triangles, its outline may leave a crack
//! with no pixel of the patch beside it. The probes are one batched ray query of the renderer against the same scene
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

/// Pixels added to a stand-off of a pixel or more to find the pixels that probe for it: a
/// differing pixel's centre lies within the stand-off of the frame's true outline, which lies
/// within a pixel (and a little more, diagonally) of its transition pixels.
const WIDE_REACH_PX: f64 = 1.5;

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

/// Pixels of a `w` x `h` image (`drawn` per pixel, `outside(x, y)` for the pixels just past its
/// edges) that have an 8-neighbour of the other state, rows on every core (serial, through
/// `neighbours`, this pass took an eighth of the step).
pub(crate) fn transitions(
    drawn: &[bool],
    w: usize,
    h: usize,
    outside: impl Fn(i64, i64) -> bool + Sync,
) -> Vec<usize> {
    let state = |x: i64, y: i64| {
        let inside = x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h;
        if inside {
            drawn[y as usize * w + x as usize]
        } else {
            outside(x, y)
        }
    };
    let differs = |x: usize, y: usize| {
        let me = drawn[y * w + x];
        if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
            return around(x as i64, y as i64).any(|(nx, ny)| state(nx, ny) != me);
        }
        (y - 1..=y + 1).any(|ny| {
            drawn[ny * w + x - 1..=ny * w + x + 1]
                .iter()
                .any(|&d| d != me)
        })
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

/// Every pixel of a `w` x `h` image within reach of one of `sources` (pixel, reach in pixels,
/// stand-off in pixels), with the largest stand-off among the sources that reach it: found by
/// stepping out one 8-neighbour at a time while reach is left (a diagonal step counts one, so
/// at least the Euclidean disc is covered).
fn within_reach(sources: &[(usize, f64, f64)], w: usize, h: usize) -> Vec<(usize, f64)> {
    if sources.is_empty() {
        return Vec::new();
    }
    // Per pixel reached: the largest reach left on arriving and the largest stand-off arriving
    // (a map, not two images: the pixels reached are few beside a 16384² frame's).
    let mut at: std::collections::HashMap<usize, (f64, f64)> = std::collections::HashMap::new();
    let mut frontier: Vec<(usize, f64, f64)> = Vec::with_capacity(sources.len());
    for &(i, reach, stand_off) in sources {
        let entry = at.entry(i).or_insert((0.0, 0.0));
        *entry = (entry.0.max(reach), entry.1.max(stand_off));
        frontier.push((i, reach, stand_off));
    }
    while !frontier.is_empty() {
        let mut next = Vec::new();
        for (i, reach, stand_off) in frontier {
            let left = reach - 1.0;
            if left <= 0.0 {
                continue;
            }
            for n in neighbours((i % w) as i64, (i / w) as i64, w, h) {
                // Stepped on where it brings more reach or a larger stand-off than arrived so far.
                let entry = at.entry(n).or_insert((0.0, 0.0));
                if left > entry.0 || stand_off > entry.1 {
                    *entry = (entry.0.max(left), entry.1.max(stand_off));
                    next.push((n, left, stand_off));
                }
            }
        }
        frontier = next;
    }
    let mut reached: Vec<(usize, f64)> = (at.into_iter())
        .filter(|(_, (reach, _))| *reach > 0.0)
        .map(|(i, (_, stand_off))| (i, stand_off))
        .collect();
    reached.sort_unstable_by_key(|p| p.0);
    reached
}

/// The 8-neighbours of pixel (x, y), in the image or not.
fn around(x: i64, y: i64) -> impl Iterator<Item = (i64, i64)> {
    (-1..=1)
        .flat_map(move |dy| (-1..=1).map(move |dx| (x + dx, y + dy)))
        .filter(move |&p| p != (x, y))
}

/// The in-image 8-neighbours of pixel (x, y).
fn neighbours(x: i64, y: i64, w: usize, h: usize) -> impl Iterator<Item = usize> {
    around(x, y)
        .filter(move |&(nx, ny)| nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h)
        .map(move |(nx, ny)| ny as usize * w + nx as usize)
}

/// The pixels just outside a `w` x `h` frame (x from -1 to w, y from -1 to h, on its border),
/// traced like its own: a border pixel then sees whether the surface goes on past the frame's
/// edge beside it, and how far that surface may stand off. Without them an undrawn border pixel
/// beside surface just out of view was no transition, and its coverage could differ unflagged
/// (3 pixels of a close-up a random test draw found).
struct Ring {
    width: i64,
    height: i64,
    /// Per ring pixel (`index`): its surface's stand-off in pixels (NaN where unknown), None
    /// where it shows nothing.
    stand_off: Vec<Option<f64>>,
}

impl Ring {
    /// Ring pixel (x, y)'s index: the rows above and below (x from -1 to w), then the columns
    /// left and right (y from 0 to h - 1); None for a pixel not on the ring.
    fn index(&self, x: i64, y: i64) -> Option<usize> {
        let (w, h) = (self.width, self.height);
        let k = if y == -1 && (-1..=w).contains(&x) {
            x + 1
        } else if y == h && (-1..=w).contains(&x) {
            w + 2 + x + 1
        } else if x == -1 && (0..h).contains(&y) {
            2 * (w + 2) + y
        } else if x == w && (0..h).contains(&y) {
            2 * (w + 2) + h + y
        } else {
            return None;
        };
        Some(k as usize)
    }

    /// Every ring pixel's (x, y), in `index` order.
    fn pixels(w: i64, h: i64) -> Vec<(i64, i64)> {
        let rows = [-1, h]
            .into_iter()
            .flat_map(|y| (-1..=w).map(move |x| (x, y)));
        let columns = [-1, w]
            .into_iter()
            .flat_map(|x| (0..h).map(move |y| (x, y)));
        rows.chain(columns).collect()
    }

    /// Ring pixel (x, y)'s stand-off, None where it shows nothing or is not on the ring.
    fn at(&self, x: i64, y: i64) -> Option<f64> {
        self.index(x, y).and_then(|k| self.stand_off[k])
    }

    /// The ring of the frame `inputs` describes, traced by `backend` (or, where it does not
    /// trace every object, drawn everywhere with an unknown stand-off).
    fn traced(
        backend: &mut impl RayBackend,
        (scene, search, traced): (&Scene, &SearchOptions, bool),
        inputs: &CoverageInputs,
    ) -> Result<Ring> {
        let (w, h) = (i64::from(inputs.pixels.width), i64::from(inputs.height));
        let pixels = Ring::pixels(w, h);
        let mut ring = Ring {
            width: w,
            height: h,
            stand_off: vec![Some(f64::NAN); pixels.len()],
        };
        if !traced {
            return Ok(ring);
        }
        let forward = inputs.pixels.forward;
        let rays: Vec<(DVec3, DVec3)> = (pixels.iter())
            .map(|&(x, y)| {
                let (o, d) = inputs.pixels.lines.at(x as f64 + 0.5, y as f64 + 0.5);
                (o, d.normalize())
            })
            .collect();
        let near = inputs.lens.near;
        let ranges: Vec<(f64, f64)> = (rays.iter())
            .map(|(_, d)| (near / d.dot(forward), f64::from(f32::MAX)))
            .collect();
        let (distance, ids) = backend.hits(scene, &rays, &ranges, search, false)?;
        for (k, ((o, d), (t, id))) in rays.iter().zip(distance.into_iter().zip(ids)).enumerate() {
            ring.stand_off[k] = (id != -1).then(|| {
                let point = *o + *d * t;
                let world =
                    inputs.sources.bound_at(point, id, 0.0) + inputs.sources.outline_allowance(id);
                world / pixel_size(inputs.lens, t * d.dot(forward))
            });
        }
        Ok(ring)
    }
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
    /// the largest of its drawn neighbours' (`ring`'s past the frame's edges) and of the seams
    /// its ray passes; NaN where one involved is unknown.
    fn probe_distance(&self, i: usize, ring: &Ring) -> f64 {
        let w = self.pixels.width as usize;
        let d = if self.drawn(i) {
            self.stand_off(i)
        } else {
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            let outside = around(x, y).filter_map(|(nx, ny)| ring.at(nx, ny));
            neighbours(x, y, w, self.height as usize)
                .filter(|&j| self.drawn(j))
                .map(|j| self.stand_off(j))
                .chain(outside)
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
    let ring = Ring::traced(backend, (scene, search, traced), inputs)?;
    let mut probed = Vec::new();
    let found = transitions(&drawn, w, h, |x, y| ring.at(x, y).is_some());
    let distances: Vec<f64> = found
        .par_iter()
        .map(|&i| inputs.probe_distance(i, &ring))
        .collect();
    let mut wide = Vec::new();
    let mut transition = vec![false; w * h];
    for (i, d) in found.into_iter().zip(distances) {
        transition[i] = true;
        if d.is_nan() || !traced {
            uncertain[i] = true;
            continue;
        }
        if d >= 1.0 {
            wide.push((i, d + WIDE_REACH_PX, d));
        }
        probed.push((i, d));
    }
    // The pixels within reach of a wide stand-off probe as far as the widest reaching them.
    for (i, d) in within_reach(&wide, w, h) {
        if !transition[i] {
            probed.push((i, d));
        }
    }
    let (rays, ranges) = probe_rays(camera, inputs.lens, &probed, w);
    if !rays.is_empty() {
        let (_, hits) = backend.hits(scene, &rays, &ranges, search, true)?;
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

    /// A source reaching 2.5 pixels takes its 5 x 5 square (Chebyshev distance 2) and no more;
    /// two sources take the union, each pixel with the larger stand-off reaching it; a reach
    /// under a pixel takes the source alone; the image's edges clip.
    #[test]
    fn a_reach_takes_the_pixels_within_it() {
        let (w, h) = (9, 7);
        let at = |x: usize, y: usize| y * w + x;
        let pixels = |found: Vec<(usize, f64)>| found.into_iter().map(|p| p.0).collect::<Vec<_>>();
        let square = |cx: usize, cy: usize, r: usize| {
            let mut v: Vec<usize> = (cy - r..=cy + r)
                .flat_map(|y| (cx - r..=cx + r).map(move |x| y * w + x))
                .collect();
            v.sort_unstable();
            v
        };
        assert_eq!(
            pixels(within_reach(&[(at(4, 3), 2.5, 1.0)], w, h)),
            square(4, 3, 2)
        );
        assert_eq!(
            within_reach(&[(at(4, 3), 0.5, 1.0)], w, h),
            vec![(at(4, 3), 1.0)]
        );
        let both = within_reach(&[(at(2, 2), 1.8, 1.0), (at(4, 2), 2.0, 3.0)], w, h);
        let mut union = square(2, 2, 1);
        union.extend(square(4, 2, 1));
        union.sort_unstable();
        union.dedup();
        assert_eq!(pixels(both.clone()), union);
        let stand_off = |i: usize| both.iter().find(|p| p.0 == i).unwrap().1;
        assert_eq!(
            (
                stand_off(at(1, 2)),
                stand_off(at(3, 2)),
                stand_off(at(5, 2))
            ),
            (1.0, 3.0, 3.0)
        );
        assert_eq!(
            pixels(within_reach(&[(at(0, 0), 2.0, 1.0)], w, h)),
            vec![at(0, 0), at(1, 0), at(0, 1), at(1, 1)]
        );
    }

    #[test]
    fn transitions_are_the_pixels_beside_the_other_state() {
        // A 5 x 4 image with a 2 x 2 block drawn at (1, 1).
        let mut drawn = vec![false; 20];
        for i in [6, 7, 11, 12] {
            drawn[i] = true;
        }
        let t = transitions(&drawn, 5, 4, |_, _| false);
        // Every pixel of columns 0..=3 is beside the block; column 4 is not.
        assert_eq!(
            t,
            vec![0, 1, 2, 3, 5, 6, 7, 8, 10, 11, 12, 13, 15, 16, 17, 18]
        );
    }
}
