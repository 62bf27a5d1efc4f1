//! Filters on a set's surface (reshaping a model, as the Geometry Textures paper does with its
//! Gaussian and high-pass examples), and the seam gap they may open between patches.
//!
//! The paper filtered each height map on its own and saw seams open at 8 texels: two patches
//! that share a border smooth it along different height axes. Here the filtered surface is a
//! function of world position alone, made from the texel points of all patches together: the
//! zero set of f(y) = nbar(y) . (y - pbar(y)), with pbar and nbar the Gaussian-weighted means
//! of the points and normals within 3 sigma of y (a point-set surface). Every texel's new height
//! is where its vertical line crosses that surface (Newton steps from its old point), so two
//! patches holding the same place find the same surface there and their seams cannot open by
//! more than a cell's interpolation. Moving each point along its mean normal and resampling the
//! moved grid per patch (the previous filter) left seam gaps of 0.8 texel (p99) at sigma = 4
//! texels and shading steps of 4 degrees (p95) where the moved grid left its patch's cells.
//! Normals are the weighted mean normal at the texel's new point (for high-pass the normal pushed
//! away from it), so a tiny sigma leaves normals as they were. Rebuilding them per patch from the
//! new heights by finite differences had given patch-shaped shading steps and, at sigma -> 0, a
//! median change of 3 degrees (differences of quantized heights are not the mesh's normals).
//!
//! Where patches meet, their texels often stand steeply on their own patch's z (a chart's border
//! faces lean away from its mean normal). The 1% of seam points that stepped by 4-20 degrees
//! (bunny, sigma = 1-8 texels) were almost all next to such texels whose search failed: Newton
//! steps overshot on the steep line, or the line passed the surface without crossing it, and the
//! texel took its neighbours' vertical move but kept the mean normal of wherever its search had
//! stopped, up to 3 sigma away. Now the weights fall off continuously (in distance and in the
//! side faced), the search brackets the crossing and closes in by regula falsi, a line passing
//! within a tenth of a texel meets the surface at its nearest approach, and a texel that moves
//! by its neighbours takes the mean normal at the point where it ends up.
//!
//! What remained at 4 and 8 texels (seam steps p99 3.8 and 11.7 degrees, gaps 0.69 and 1.96
//! texels) was at texels whose line grazes or misses the smoothed surface: no height on that
//! line lies on it, and a texel that borrows its neighbours' moves stands off it. Near chart
//! borders the overlap rings hold that place on a neighbouring patch too, so such a texel
//! (farther than `CUT_OFF` texel from the smoothed surface) is cut off by the outline map where
//! another patch shows the surface around it from texels that are on it: the neighbour shows
//! there instead. Seams then measured p99 steps of 1.0-1.4 degrees and gaps of 0.08-0.11 texel
//! at 1-4 texels, 7.7 degrees and 0.35 texel at 8.
//!
//! The tail at 8 texels was not off-surface texels: at its seam points both patches' texels lay
//! on the surface their own search had found, with that surface's normal, yet the two surfaces
//! differed (steps of 20-47 degrees, gaps of 1-3 texels, on the ears and the open base). Each
//! texel weighs the points by the side its own normal faces, and the texels of two patches that
//! meet after moving 2-6 texels along their different z axes came from places whose normals
//! differ by some degrees; the facing weight then rose over normals 41-75 degrees from the
//! texel's, where an ear's rim holds many points, so a few degrees of facing turned the mean
//! normal at one world point by a median 9 degrees at those seam points. The weight now rises
//! over normals 90-120 degrees away (`FACING`): it still leaves out the other side of a thin
//! part, whose normals face opposite, but no longer depends on small differences of facing.
//!
//! Space: world for the filter (points, normals, sigma), patch-local for the maps.

use glam::DVec3;
use rayon::prelude::*;

use crate::cancel::Cancel;
use crate::error::{parse_choice, GeomtexError, Result};
use crate::gtex::{
    decode_normal, encode_height, encode_normal, vertical_extent, GeometryTextureSet, Patch,
    OUTLINE_INSIDE,
};
use crate::heightfield::height_at;
use crate::mesh::{Mesh, MeshGeometry};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MapFilter {
    /// Gaussian low-pass: smooths.
    Gaussian,
    /// Unsharp masking, h + gain (h - gaussian(h)): exaggerates detail finer than sigma.
    HighPass { gain: f64 },
}

impl MapFilter {
    /// -1 for a Gaussian (onto the smoothed surface), the gain of a high-pass filter (h + gain
    /// (h - gaussian h)), checked.
    fn signed_gain(self) -> Result<f64> {
        match self {
            MapFilter::Gaussian => Ok(-1.0),
            MapFilter::HighPass { gain } if gain.is_finite() && gain > 0.0 && gain <= 100.0 => {
                Ok(gain)
            }
            MapFilter::HighPass { gain } => Err(GeomtexError::Parameter(format!(
                "gain must be in (0, 100], got {gain}"
            ))),
        }
    }
}

/// `gain` of a high-pass filter when none is given.
pub const DEFAULT_GAIN: f64 = 1.0;

impl MapFilter {
    /// The filter named `kind` ("gaussian" | "high_pass"); `gain` (default `DEFAULT_GAIN`) is
    /// the high-pass filter's and is checked when the filter runs.
    pub fn from_name(kind: &str, gain: Option<f64>) -> Result<MapFilter> {
        let high_pass = parse_choice("kind", kind, &[("gaussian", false), ("high_pass", true)])?;
        if let (false, Some(g)) = (high_pass, gain) {
            return Err(GeomtexError::Parameter(format!(
                "gain applies only to kind='high_pass' (a Gaussian has none), got gain={g} with kind='gaussian'"
            )));
        }
        Ok(if high_pass {
            MapFilter::HighPass {
                gain: gain.unwrap_or(DEFAULT_GAIN),
            }
        } else {
            MapFilter::Gaussian
        })
    }
}

/// Most neighbour candidates (points in the 27 cells around a point's) a filter may weigh per
/// point on average: about 8 minutes per Newton step for the bunny's 3 M texel points on 2
/// cores. A sigma beyond it reaches across most of a model, no longer a filter of its detail.
pub const MAX_MEAN_CANDIDATES: f64 = 50_000.0;

/// Refuses a sigma whose 3-sigma cells would make each point weigh more than
/// `MAX_MEAN_CANDIDATES` neighbours, or more than half of all points, on average. `near` holds,
/// per occupied cell, (points in it, points in its 27 neighbouring cells).
fn check_reach(near: &[(usize, usize)], points: usize, sigma: f64) -> Result<()> {
    let pairs: f64 = near.iter().map(|&(n, m)| n as f64 * m as f64).sum();
    let mean = pairs / points.max(1) as f64;
    let limit = MAX_MEAN_CANDIDATES.min(0.5 * points as f64);
    if mean <= limit || points < 2 {
        return Ok(());
    }
    // On a surface the candidates grow as sigma squared.
    let fits = sigma * (limit / mean).sqrt();
    Err(GeomtexError::Parameter(format!(
        "sigma = {sigma} reaches too far: each of the {points} texel points would weigh {mean:.0} \
         neighbours on average (limit {limit:.0}, at most half the model); use sigma <= {fits:.3e}"
    )))
}

/// The texel points of all patches (world space) with their normals, in a uniform grid of
/// cells of side 3 sigma (sorted keys, no hash map needed). The grid already is the spatial
/// index a k-d tree would be (a sphere query would test ~3x fewer candidates than 27 cells on a
/// surface, the same order of work), so far reaches are refused (`check_reach`) rather than
/// made faster.
struct PointGrid<'a> {
    points: &'a [DVec3],
    normals: &'a [DVec3],
    sigma: f64,
    /// Newton steps shorter than this (world units) end the search for a crossing.
    tolerance: f64,
    /// Cell keys, sorted, and the point each belongs to.
    keys: Vec<[i64; 3]>,
    order: Vec<u32>,
}

impl<'a> PointGrid<'a> {
    fn new(
        points: &'a [DVec3],
        normals: &'a [DVec3],
        sigma: f64,
        texel_size: f64,
        cancel: &Cancel,
    ) -> Result<PointGrid<'a>> {
        let r = 3.0 * sigma;
        // Keys computed once and sorted on all cores: a sequential sort by a computed key took
        // seconds on 3 M points, too long to wait for Ctrl-C.
        let mut keyed: Vec<([i64; 3], u32)> = points
            .par_iter()
            .enumerate()
            .map(|(k, &p)| ((p / r).floor().as_i64vec3().to_array(), k as u32))
            .collect();
        keyed.par_sort_unstable();
        cancel.check("filtering")?;
        let (keys, order) = keyed.into_iter().unzip();
        let grid = PointGrid {
            points,
            normals,
            sigma,
            tolerance: CROSSING_TOLERANCE * texel_size,
            keys,
            order,
        };
        let counts: Vec<(usize, usize)> = grid
            .cells()
            .par_windows(2)
            .map(|w| {
                (
                    w[1] - w[0],
                    grid.around(grid.keys[w[0]])
                        .map(|c| grid.range(c).len())
                        .sum(),
                )
            })
            .collect();
        check_reach(&counts, points.len(), sigma)?;
        cancel.check("filtering")?;
        Ok(grid)
    }

    fn cell(&self, p: DVec3) -> [i64; 3] {
        (p / (3.0 * self.sigma)).floor().as_i64vec3().to_array()
    }

    /// Positions in `order` of the points in cell `key`.
    fn range(&self, key: [i64; 3]) -> std::ops::Range<usize> {
        let lo = self.keys.partition_point(|k| *k < key);
        let hi = self.keys.partition_point(|k| *k <= key);
        lo..hi
    }

    /// Starts of the runs of equal keys (the occupied cells), and the end.
    fn cells(&self) -> Vec<usize> {
        let keys = &self.keys;
        let mut starts: Vec<usize> = (0..keys.len())
            .filter(|&i| i == 0 || keys[i] != keys[i - 1])
            .collect();
        starts.push(keys.len());
        starts
    }

    /// Cell `c` and its 26 neighbours.
    fn around(&self, c: [i64; 3]) -> impl Iterator<Item = [i64; 3]> {
        (-1..=1).flat_map(move |dz| {
            (-1..=1).flat_map(move |dy| (-1..=1).map(move |dx| [c[0] + dx, c[1] + dy, c[2] + dz]))
        })
    }

    /// Every point within 3 sigma of any point of cell `c` (and more): those of its 27 cells.
    fn gather(&self, c: [i64; 3], near: &mut Vec<u32>) {
        near.clear();
        for c in self.around(c) {
            near.extend_from_slice(&self.order[self.range(c)]);
        }
    }

    /// The Gaussian-weighted means of position and of normal (not normalized) over the points
    /// of `near` within 3 sigma of world point `y`, each weighed also by how much its normal
    /// faces the same way as `facing` (the other side of a thin part is left out); None if no
    /// point weighs anything. Both weights fall to zero continuously (the Gaussian less its
    /// value at 3 sigma; the facing weight a smooth step over cosines `FACING`), so the means
    /// move continuously with `y` and with `facing`: two patches whose texels at one place face
    /// a little differently find the same surface there.
    fn means_at(&self, y: DVec3, facing: DVec3, near: &[u32]) -> Option<(DVec3, DVec3)> {
        let r2 = 9.0 * self.sigma * self.sigma;
        let inv = -0.5 / (self.sigma * self.sigma);
        let floor = (-4.5f64).exp();
        let (mut position, mut normal, mut den) = (DVec3::ZERO, DVec3::ZERO, 0.0);
        for &q in near {
            let (pq, nq) = (self.points[q as usize], self.normals[q as usize]);
            let d2 = (pq - y).length_squared();
            let s = ((nq.dot(facing) - FACING.0) / (FACING.1 - FACING.0)).clamp(0.0, 1.0);
            if d2 < r2 && s > 0.0 {
                let w = ((d2 * inv).exp() - floor) * s * s * (3.0 - 2.0 * s);
                position += w * pq;
                normal += w * nq;
                den += w;
            }
        }
        (den > 0.0).then(|| (position / den, normal / den))
    }

    /// The means at world point `at` (see `means_at`), gathering its cell's candidates into
    /// `scratch` unless it lies in cell `home`, whose candidates are `near`.
    fn means_near(
        &self,
        at: DVec3,
        facing: DVec3,
        (home, near): ([i64; 3], &[u32]),
        scratch: &mut Vec<u32>,
    ) -> Option<(DVec3, DVec3)> {
        let cell = self.cell(at);
        if cell == home {
            return self.means_at(at, facing, near);
        }
        self.gather(cell, scratch);
        self.means_at(at, facing, scratch)
    }

    /// f at `t` on `line` from the means there (see `crossing`), or None off every point.
    fn probe(&self, line: &Line<'_>, t: f64, scratch: &mut Vec<u32>) -> Option<Probe> {
        let y = line.p + line.up * t;
        let means = self.means_near(y, line.n, (line.home, line.near), scratch)?;
        let f = means.1.normalize_or(line.n).dot(y - means.0);
        Some(Probe { t, f, means })
    }

    /// Steps along `line` from `at` toward f = 0: Newton steps (each within 3 sigma of the
    /// texel) until f changes sign, then regula falsi (Illinois) inside that bracket, `other`
    /// being its far end when one is known. Every probe that comes closer updates `best`.
    /// Returns whether a step shorter than the tolerance ended it, `at` then being the last probe.
    fn search(
        &self,
        line: &Line<'_>,
        at: &mut Probe,
        mut other: Option<(f64, f64)>,
        best: &mut Probe,
        scratch: &mut Vec<u32>,
    ) -> bool {
        let r = 3.0 * self.sigma;
        for _ in 0..CROSSING_STEPS {
            let next = match other {
                Some((tb, fb)) => at.t - at.f * (tb - at.t) / (fb - at.f),
                None => {
                    let slope = at.means.1.normalize_or(line.n).dot(line.up);
                    if slope.abs() <= 1e-6 {
                        return false; // the line runs along the surface here
                    }
                    (at.t - at.f / slope).clamp(-r, r)
                }
            };
            if (next - at.t).abs() <= self.tolerance {
                at.t = next; // the means this close stand for those there
                return true;
            }
            let Some(probe) = self.probe(line, next, scratch) else {
                return false; // stepped off every point
            };
            match other {
                _ if probe.f.signum() != at.f.signum() => other = Some((at.t, at.f)),
                Some((tb, fb)) => other = Some((tb, 0.5 * fb)), // Illinois: no stalled end
                None => {}
            }
            *at = probe;
            if at.f.abs() < best.f.abs() {
                *best = *at;
            }
        }
        false
    }

    /// Where the Gaussian-smoothed surface crosses the line through point `k` along `up` (its
    /// patch's z axis). That surface is the zero set of f(y) = n(y) . (y - pbar(y)), n the unit
    /// mean normal, the weighted means taken at y: a function of world position (and, across
    /// thin parts, of the side faced), so every patch that holds a place finds the same surface
    /// there. Newton steps from the point (`search`); where they wander (a line meeting the
    /// surface steeply, or crossing where the smoothed normal turns away), the line is scanned
    /// at `SCAN` steps per 3 sigma for the sign change nearest the point, then searched from
    /// there. A line that passes the surface within `NEAR_MISS` texel meets it at its nearest
    /// approach. A crossing beyond the points' support (farther than `SUPPORT` sigma from their
    /// weighted mean, as past a rim that smoothing pulled in) is none; its rise is the line's
    /// nearest approach. `near` holds the candidates of the point's cell.
    fn crossing(&self, k: usize, up: DVec3, near: &[u32], scratch: &mut Vec<u32>) -> Crossing {
        let (p, n) = (self.points[k], self.normals[k]);
        let r = 3.0 * self.sigma;
        let line = Line {
            p,
            n,
            up,
            home: self.cell(p),
            near,
        };
        // The point itself is within reach, so the first means exist.
        let mut at = self.probe(&line, 0.0, scratch).unwrap_or(Probe {
            t: 0.0,
            f: 0.0,
            means: (p, n),
        });
        let (mut best, offset) = (at, at.f.abs());
        let mut converged = self.search(&line, &mut at, None, &mut best, scratch);
        if !converged || at.t.abs() >= 0.999 * r {
            if let Some((from, other)) = self.scan(&line, &mut best, scratch) {
                at = from;
                converged = self.search(&line, &mut at, Some(other), &mut best, scratch);
            }
        }
        if !converged {
            at = best;
            converged = best.f.abs() <= NEAR_MISS * self.tolerance / CROSSING_TOLERANCE;
        }
        let y = p + up * at.t;
        let unit = at.means.1.normalize_or(n);
        let off = (y - at.means.0) - unit * unit.dot(y - at.means.0);
        // A plane at the point's offset, met at the crossing's slope, is crossed within
        // offset / cos; a crossing half again as far, or farther than `GRAZE` times the
        // offset, lies on a part of the surface the line only grazes (at a rim: a hair-like
        // spike).
        let reach = 1.5 * offset / unit.dot(up).abs().max(1.5 / GRAZE) + self.tolerance;
        Crossing {
            rise: at.t,
            found: converged
                && at.t.abs() < reach.min(0.999 * r)
                && off.length() <= SUPPORT * self.sigma,
            mean_normal: at.means.1,
            cos: unit.dot(up),
        }
    }

    /// The sign change of f on `line` nearest its point, probing at `SCAN` steps per 3 sigma
    /// outward both ways: the probe beyond it and the far end (t, f) of the bracket. Every
    /// probe that comes closer updates `best`.
    fn scan(
        &self,
        line: &Line<'_>,
        best: &mut Probe,
        scratch: &mut Vec<u32>,
    ) -> Option<(Probe, (f64, f64))> {
        let step = 3.0 * self.sigma / SCAN as f64;
        let mut last = [self.probe(line, 0.0, scratch)?; 2];
        for i in 1..=SCAN {
            for (side, sign) in [(0, 1.0), (1, -1.0)] {
                let Some(probe) = self.probe(line, sign * step * i as f64, scratch) else {
                    continue;
                };
                if probe.f.abs() < best.f.abs() {
                    *best = probe;
                }
                let before = last[side];
                if probe.f.signum() != before.f.signum() {
                    return Some((probe, (before.t, before.f)));
                }
                last[side] = probe;
            }
        }
        None
    }
}

/// A texel's vertical line: its point, normal (the side faced), direction (its patch's z) and
/// the candidates of the point's cell.
struct Line<'a> {
    p: DVec3,
    n: DVec3,
    up: DVec3,
    home: [i64; 3],
    near: &'a [u32],
}

/// f on a texel's line at distance `t` (world units), and the means there.
#[derive(Clone, Copy, Debug)]
struct Probe {
    t: f64,
    f: f64,
    means: (DVec3, DVec3),
}

/// Farthest a crossing may lie along a texel's line, in multiples of the texel's distance from
/// the smoothed surface. At 6 texels on the 64-texel bunny 3 keeps the largest move of any
/// texel 3.2x the p99 move; 4.5 let spikes grow at the ears' rims (4.2x), and so did crossings
/// allowed twice as far as a plane met at the crossing's slope, however steep (7.0x).
const GRAZE: f64 = 3.0;

/// Probes per 3 sigma each way when Newton steps wander.
const SCAN: usize = 12;

/// Most evaluations of the means per texel line (usually one or two Newton steps suffice; a
/// steep line needs a bracket and a few regula falsi steps more).
const CROSSING_STEPS: usize = 8;

/// A step shorter than this many texels ends the search (heights are stored to about 1/300
/// texel).
const CROSSING_TOLERANCE: f64 = 1e-2;

/// Texels: a line passing this close to the smoothed surface without crossing it meets it
/// there (heights are stored to about 1/300 texel; seams measure within a tenth).
const NEAR_MISS: f64 = 0.1;

/// The facing weight rises smoothly from 0 to 1 between these cosines of a point's normal to
/// the side faced: points facing within 90 degrees count fully, those facing more than 120
/// degrees away (the other side of a thin part) not at all. Over (0.25, 0.75) the weight hung on
/// normals that the rims of thin parts hold in number, so texels of two patches at one place
/// whose own normals differed by a few degrees found surfaces with normals tens of degrees apart
/// (bunny, sigma = 8 texels: seam step p99 7.3 degrees, now 1.4).
const FACING: (f64, f64) = (-0.5, 0.0);

/// A crossing lies on the smoothed surface only within this many sigma (tangentially) of the
/// weighted mean of the points around it: at the edge of a half-plane of points the mean lies
/// 0.8 sigma in, and it falls farther behind past the edge.
const SUPPORT: f64 = 1.0;

/// The Gaussian-smoothed surface on one texel's vertical line.
#[derive(Clone, Copy, Debug)]
struct Crossing {
    /// World distance from the texel's point to the smoothed surface along its patch's z.
    rise: f64,
    /// Whether the search found the surface within its reach.
    found: bool,
    /// The weighted mean normal there (not normalized).
    mean_normal: DVec3,
    /// Cosine between that normal and the patch's z axis.
    cos: f64,
}

/// The crossing of every texel point's line (`up[k]`: its patch's z axis). `cancel` is polled
/// once per point.
fn crossings(grid: &PointGrid<'_>, up: &[DVec3], cancel: &Cancel) -> Result<Vec<Crossing>> {
    let per_cell: Vec<Vec<(u32, Crossing)>> = grid
        .cells()
        .par_windows(2)
        .map(|w| {
            if cancel.is_cancelled() {
                return Vec::new(); // reported below
            }
            let (mut near, mut scratch) = (Vec::new(), Vec::new());
            grid.gather(grid.keys[w[0]], &mut near);
            grid.order[w[0]..w[1]]
                .iter()
                .map_while(|&k| {
                    // A dense cell can take seconds: stop within a point's work.
                    (!cancel.is_cancelled()).then(|| {
                        let c = grid.crossing(k as usize, up[k as usize], &near, &mut scratch);
                        (k, c)
                    })
                })
                .collect()
        })
        .collect();
    cancel.check("filtering")?;
    let still = Crossing {
        rise: 0.0,
        found: true,
        mean_normal: DVec3::Z,
        cos: 1.0,
    };
    let mut out = vec![still; grid.points.len()];
    for (k, c) in per_cell.into_iter().flatten() {
        out[k as usize] = c;
    }
    Ok(out)
}

/// Below this cosine between the smoothed surface's normal and a texel's patch z axis the texel
/// is steep: its vertical line runs nearly along the surface, where a small change of the
/// surface moves the crossing far, so even a crossing found within `GRAZE` is taken from its
/// neighbours' vertical moves instead. (The reach of the search already keeps lines meeting the
/// surface at a cosine below 1/2 to 3 times their offset, so few texels are this steep.)
const STEEP_COS: f64 = 0.1;

/// Farthest (Chebyshev, texels) a steep texel looks for neighbours that are not steep.
const STEEP_REACH: usize = 3;

/// The set with its surface filtered (`sigma` in world units): every patch's heights moved to
/// the world-space filtered surface along the patch's z, boxes refitted to the new height range,
/// normals filtered in world space too; colors and faces kept, outline maps kept but where a
/// texel standing off the filtered surface is cut (`covered_elsewhere`). `cancel` stops it
/// (Interrupted) within a point's work.
pub fn filtered(
    set: &GeometryTextureSet,
    filter: MapFilter,
    sigma: f64,
    cancel: &Cancel,
) -> Result<GeometryTextureSet> {
    if !(sigma.is_finite() && sigma > 0.0) {
        return Err(GeomtexError::Parameter(format!(
            "sigma must be a positive finite length (world units), got {sigma}"
        )));
    }
    let gain = filter.signed_gain()?;
    // Every filled texel (outline maps carried as they are) as a world point with its normal.
    let (mut points, mut normals, mut up, mut slots) = (vec![], vec![], vec![], vec![]);
    for (k, p) in set.patches.iter().enumerate() {
        for (t, point, normal) in p.filled_texels() {
            points.push(point);
            normals.push(if normal == DVec3::ZERO {
                p.axes[2]
            } else {
                normal
            });
            up.push(p.axes[2]);
            slots.push((k, t));
        }
    }
    cancel.check("filtering")?;
    let grid = PointGrid::new(&points, &normals, sigma, set.texel_size, cancel)?;
    let found = crossings(&grid, &up, cancel)?;
    let mut moves: Vec<Vec<Option<TexelMove>>> =
        set.patches.iter().map(|p| vec![None; p.texels()]).collect();
    for ((&(k, t), &n), c) in slots.iter().zip(&normals).zip(&found) {
        // Gaussian (gain -1): onto the smoothed surface; high-pass: h + gain (h - gaussian h),
        // its normal pushed away from the smoothed one alike.
        moves[k][t] = Some(TexelMove {
            rise: -gain * c.rise,
            steady: c.found && c.cos >= STEEP_COS,
            found: c.found,
            normal: (n - gain * (c.mean_normal - n)).normalize_or(n),
        });
    }
    let rises: Vec<Vec<f64>> = set
        .patches
        .par_iter()
        .zip(&moves)
        .map(|(p, m)| vertical_moves(p, m))
        .collect();
    cancel.check("filtering")?;
    // A texel that did not keep its own crossing takes the mean normal where it ends up, so
    // its normal too is the world-space field's at its point.
    let ended: Vec<Option<(DVec3, f64)>> = (0..points.len())
        .into_par_iter()
        .map_init(Vec::new, |scratch, i| {
            let (k, t) = slots[i];
            let m = moves[k][t].filter(|m| !m.steady)?;
            let y = points[i] + up[i] * (rises[k][t] / -gain);
            grid.gather(grid.cell(y), scratch);
            let Some((mean_point, mean_normal)) = grid.means_at(y, normals[i], scratch) else {
                return Some((m.normal, f64::INFINITY));
            };
            let off = mean_normal
                .normalize_or(normals[i])
                .dot(y - mean_point)
                .abs();
            let n = (normals[i] - gain * (mean_normal - normals[i])).normalize_or(m.normal);
            Some((n, off))
        })
        .collect();
    let mut off_surface = Vec::new();
    for (&(k, t), ended) in slots.iter().zip(ended) {
        if let (Some(m), Some((n, off))) = (moves[k][t].as_mut(), ended) {
            m.normal = n;
            if off > CUT_OFF * set.texel_size {
                off_surface.push((k, t, off.min(3.0 * sigma)));
            }
        }
    }
    let mut patches: Vec<Patch> = set
        .patches
        .par_iter()
        .zip(&moves)
        .zip(&rises)
        .map(|((p, m), r)| refit(p, m, r))
        .collect();
    let cut = covered_elsewhere(&patches, &moves, &off_surface, set.texel_size);
    for &(k, t) in &cut {
        // The most negative code: the cut ends half way to a neighbour inside by 2 texels.
        patches[k].outline[t] = -OUTLINE_INSIDE;
    }
    let mut out = GeometryTextureSet {
        patches,
        texel_size: set.texel_size,
        stats: set.stats.clone(),
        // Filters smooth height maps; a set's triangles are the source's own faces and pass
        // through unfiltered.
        triangles: set.triangles.clone(),
    };
    // A filtered surface has no bound to the mesh (see refit): its figures go with it.
    out.sync_error_bound_stats();
    out.stats.set("filter_sigma", sigma);
    out.stats.set("filter_texels_cut", cut.len() as f64);
    out.stats.set("bytes", out.bytes() as f64);
    out.validate()
        .map_err(|e| GeomtexError::Internal(format!("filtering made an impossible set: {e}")))?;
    Ok(out)
}

/// Texels (in texels) that end up farther than this from the filtered surface (their line
/// missed or grazed it, so they took their neighbours' moves) are cut off by the outline map
/// where another patch shows the surface there. 0.25 left p99 steps of 2.7 degrees at 4 texels
/// (bunny), 0.05 2.6 when the covering cells had to be steady; with covering cells only off
/// the cut set 1.4.
const CUT_OFF: f64 = 0.05;

/// Of the texels `off_surface` ((patch, texel, distance from the filtered surface)), those
/// another patch covers: at the texel's point and half way to each filled neighbour's (where
/// the cut outline ends its cells), some other patch's cell whose texels are not off the surface
/// themselves, facing within 60 degrees, within twice the texel's offset plus a texel along
/// its z. Cutting those leaves the neighbour's surface to show there, so no step or gap is seen
/// and no crack opens. (Emptying the texel's four cells instead, checked at the neighbours'
/// points, cut fewer: p99 steps of 2.0 degrees at 4 texels against 1.4.)
fn covered_elsewhere(
    patches: &[Patch],
    moves: &[Vec<Option<TexelMove>>],
    off_surface: &[(usize, usize, f64)],
    texel_size: f64,
) -> Vec<(usize, usize)> {
    let candidate: std::collections::HashSet<(usize, usize)> =
        off_surface.iter().map(|&(k, t, _)| (k, t)).collect();
    off_surface
        .par_iter()
        .filter(|&&(k, t, off)| {
            let p = &patches[k];
            let Some(m) = moves[k][t] else { return false };
            let (w, h) = (p.width as i64, p.height as i64);
            let (i, j) = ((t % p.width as usize) as i64, (t / p.width as usize) as i64);
            let tolerance = 2.0 * off + texel_size;
            let here = p.local_to_world(p.texel_local(i as u32, j as u32, p.heights[t]));
            (-1..=1).all(|dj| {
                (-1..=1).all(|di| {
                    let (x, y) = (i + di, j + dj);
                    if x < 0 || y < 0 || x >= w || y >= h {
                        return true;
                    }
                    let s = (y * w + x) as usize;
                    let q = p.heights[s];
                    if q == 0 {
                        return true;
                    }
                    let there = p.local_to_world(p.texel_local(x as u32, y as u32, q));
                    let point = 0.5 * (here + there);
                    shown_by_another(patches, moves, &candidate, k, point, m.normal, tolerance)
                })
            })
        })
        .map(|&(k, t, _)| (k, t))
        .collect()
}

/// Whether a patch other than `k` shows the surface within `tolerance` (along its z) of world
/// point `x`, facing within 60 degrees of `normal`, in a cell whose four texels kept their own
/// crossings and are not to be cut.
fn shown_by_another(
    patches: &[Patch],
    moves: &[Vec<Option<TexelMove>>],
    candidate: &std::collections::HashSet<(usize, usize)>,
    k: usize,
    x: DVec3,
    normal: DVec3,
    tolerance: f64,
) -> bool {
    patches.iter().enumerate().any(|(o, p)| {
        if o == k {
            return false;
        }
        let l = p.world_to_local(x);
        if !(0.0..=1.0).contains(&l.x) || !(0.0..=1.0).contains(&l.y) {
            return false;
        }
        let margin = tolerance / p.extent.z;
        if l.z < -margin || l.z > 1.0 + margin {
            return false;
        }
        let Some(hh) = height_at(p, l.x, l.y) else {
            return false;
        };
        if (hh - l.z).abs() * p.extent.z > tolerance || normal_at(p, l.x, l.y).dot(normal) < 0.5 {
            return false;
        }
        let (w, h) = (p.width as i64, p.height as i64);
        let (ci, cj) = (
            (l.x * w as f64 - 0.5).floor() as i64,
            (l.y * h as f64 - 0.5).floor() as i64,
        );
        [(0, 0), (1, 0), (0, 1), (1, 1)].iter().all(|&(di, dj)| {
            let s = ((cj + dj).clamp(0, h - 1) * w + (ci + di).clamp(0, w - 1)) as usize;
            moves[o][s].is_some() && !candidate.contains(&(o, s))
        })
    })
}

/// What the filter does to one filled texel: its height change (world units along its patch's
/// z) and its new world unit normal.
#[derive(Clone, Copy, Debug)]
struct TexelMove {
    rise: f64,
    /// Whether the rise is the texel's own to keep: a crossing found, not steep.
    steady: bool,
    /// Whether a crossing was found within reach.
    found: bool,
    normal: DVec3,
}

/// The mean of `value` over the smallest square window around texel `t` of a `w` x `h` map
/// (reach 1, 2, ... `reach` texels) where it gives any, or None.
fn nearest_window_mean(
    (w, h): (usize, usize),
    t: usize,
    reach: usize,
    value: impl Fn(usize) -> Option<f64>,
) -> Option<f64> {
    let (i, j) = (t % w, t / w);
    (1..=reach).find_map(|r| {
        let (i0, j0) = (i.saturating_sub(r), j.saturating_sub(r));
        let (i1, j1) = ((i + r).min(w - 1), (j + r).min(h - 1));
        let found: Vec<f64> = (j0..=j1)
            .flat_map(|y| (i0..=i1).map(move |x| y * w + x))
            .filter_map(&value)
            .collect();
        (!found.is_empty()).then(|| found.iter().sum::<f64>() / found.len() as f64)
    })
}

/// Height changes (world units along the patch's z) of a patch's filled texels: its own where
/// it is steady (found, not steep); elsewhere the mean of the nearest window (up to
/// `STEEP_REACH`) of steady changes, its own if steep but found, or none (the texel stays: a
/// line that misses the smoothed surface must not become a spike of 3 sigma).
fn vertical_moves(p: &Patch, moves: &[Option<TexelMove>]) -> Vec<f64> {
    let size = (p.width as usize, p.height as usize);
    let steady = |t: usize| moves[t].filter(|m| m.steady).map(|m| m.rise);
    (0..moves.len())
        .map(|t| match moves[t] {
            None => 0.0,
            Some(m) if m.steady => m.rise,
            Some(m) => nearest_window_mean(size, t, STEEP_REACH, steady).unwrap_or(if m.found {
                m.rise
            } else {
                0.0
            }),
        })
        .collect()
}

/// A patch with its filled texels moved (`moves`, indexed by texel; None where empty): the box
/// refitted to the new height range, heights re-encoded, normals replaced by the filtered ones.
fn refit(p: &Patch, moves: &[Option<TexelMove>], rises: &[f64]) -> Patch {
    let new: Vec<f64> = p
        .heights
        .iter()
        .zip(rises)
        .map(|(&q, r)| {
            if q > 0 {
                p.decode_height(q as f64) * p.extent.z + r
            } else {
                0.0
            }
        })
        .collect();
    let mask: Vec<bool> = p.heights.iter().map(|&q| q > 0).collect();
    let filled = || new.iter().zip(&mask).filter(|(_, &m)| m).map(|(&v, _)| v);
    let lo = filled().fold(f64::INFINITY, f64::min);
    let hi = filled().fold(f64::NEG_INFINITY, f64::max);
    let mut q = p.clone();
    // The bound was of the unfiltered surface to the mesh; the filter moves it (and has no mesh).
    q.error_bound = None;
    if lo > hi {
        return q; // an empty patch stays empty
    }
    let (thickness, bits) = vertical_extent(hi - lo, p.texel_size(), p.height_bits);
    let bottom = lo - 0.5 * (thickness - (hi - lo));
    q.origin = p.origin + p.axes[2] * bottom;
    q.extent.z = thickness;
    q.height_bits = bits;
    q.heights = new
        .iter()
        .zip(&mask)
        .map(|(&v, &m)| {
            if m {
                encode_height((v - bottom) / thickness, bits)
            } else {
                0
            }
        })
        .collect();
    // Only filled texels: the surface exists where a cell's four texels are filled, so the
    // dilated normals around it are never blended into what is shown.
    for (stored, m) in q.normals.iter_mut().zip(moves) {
        if let Some(m) = m {
            let n = m.normal;
            let local = DVec3::new(n.dot(p.axes[0]), n.dot(p.axes[1]), n.dot(p.axes[2]));
            *stored = encode_normal(local);
        }
    }
    q
}

/// The world unit normal patch `p` shows at patch-local (u, v): its normal map blended
/// bilinearly between texel centres (clamped at the border). The renderer leaves out texels
/// across a crease from the nearest one; on the smooth-normal sets this measures, that is the
/// same blend.
fn normal_at(p: &Patch, u: f64, v: f64) -> DVec3 {
    let (w, h) = (p.width as i64, p.height as i64);
    let (x, y) = (u * w as f64 - 0.5, v * h as f64 - 0.5);
    let (i, j) = (x.floor(), y.floor());
    let (fx, fy) = (x - i, y - j);
    let at = |di: i64, dj: i64| {
        let (ti, tj) = (
            (i as i64 + di).clamp(0, w - 1),
            (j as i64 + dj).clamp(0, h - 1),
        );
        decode_normal(p.normals[(tj * w + ti) as usize])
    };
    let local = at(0, 0) * (1.0 - fx) * (1.0 - fy)
        + at(1, 0) * fx * (1.0 - fy)
        + at(0, 1) * (1.0 - fx) * fy
        + at(1, 1) * fx * fy;
    (p.axes[0] * local.x + p.axes[1] * local.y + p.axes[2] * local.z).normalize_or_zero()
}

/// What neighbouring patches do where they meet, measured at points on each edge of the source
/// mesh shared by faces of two different patches.
#[derive(Clone, Debug, Default)]
pub struct Seams {
    /// World distance from one patch's surface point to the other patch's surface (its tangent
    /// plane there), both ways.
    pub gaps: Vec<f64>,
    /// Angle (degrees) between the normals the two patches show there: a shading step.
    pub normal_steps: Vec<f64>,
}

/// Where patch `p`'s surface passes over world point `x`: its patch-local (u, v, h).
fn surface_over(p: &Patch, x: DVec3) -> Option<DVec3> {
    let l = p.world_to_local(x);
    ((0.0..=1.0).contains(&l.x) && (0.0..=1.0).contains(&l.y))
        .then(|| height_at(p, l.x, l.y).map(|h| DVec3::new(l.x, l.y, h)))
        .flatten()
}

impl Seams {
    /// Adds the figures of patch `pa` against `pb` at world point `x` on their shared edge
    /// (nothing where either patch has no surface there: none, on a clean conversion).
    fn measure(&mut self, pa: &Patch, pb: &Patch, x: DVec3) {
        let Some(a) = surface_over(pa, x) else {
            return;
        };
        let on_a = pa.local_to_world(a);
        let Some(b) = surface_over(pb, on_a) else {
            return;
        };
        let (na, nb) = (normal_at(pa, a.x, a.y), normal_at(pb, b.x, b.y));
        // Vertical gap times the cosine of b's surface slope: the distance to b's tangent plane
        // (a vertical gap alone grows without bound on steep parts).
        let slope_cos = nb.dot(pb.axes[2]).abs();
        self.gaps
            .push((b.z - pb.world_to_local(on_a).z).abs() * pb.extent.z * slope_cos);
        self.normal_steps
            .push(na.dot(nb).clamp(-1.0, 1.0).acos().to_degrees());
    }
}

/// Gaps and normal steps between neighbouring patches along their charts' shared edges: at a
/// quarter, half and three quarters of each edge shared by faces of two different patches, both
/// ways. `mesh` must be the set's source (a patch listing a face it lacks is refused). `cancel`
/// is polled every 4096 faces.
pub fn seams(set: &GeometryTextureSet, mesh: &Mesh, cancel: &Cancel) -> Result<Seams> {
    let mut owner = vec![u32::MAX; mesh.faces.len()];
    for (k, p) in set.patches.iter().enumerate() {
        for &f in &p.faces {
            let slot = owner.get_mut(f as usize).ok_or_else(|| {
                GeomtexError::Parameter(format!(
                    "patch {k} lists face {f}, but the mesh has {} faces: not the mesh it was converted from",
                    mesh.faces.len()
                ))
            })?;
            *slot = k as u32;
        }
    }
    let geo = MeshGeometry::new(mesh);
    let mut seams = Seams::default();
    for f in 0..mesh.faces.len() {
        if f % 4096 == 0 {
            cancel.check("measuring seams")?;
        }
        let a = owner[f];
        if a == u32::MAX {
            continue;
        }
        for &g in geo.face_neighbors.row(f) {
            let b = owner[g as usize];
            if b == u32::MAX || b == a || (g as usize) < f {
                continue;
            }
            let tf = mesh.faces[f].map(|v| geo.weld[v as usize]);
            let shared: Vec<u32> = mesh.faces[g as usize]
                .iter()
                .map(|&v| geo.weld[v as usize])
                .filter(|v| tf.contains(v))
                .collect();
            if shared.len() < 2 {
                continue;
            }
            let (e0, e1) = (
                mesh.positions[shared[0] as usize],
                mesh.positions[shared[1] as usize],
            );
            let (pa, pb) = (&set.patches[a as usize], &set.patches[b as usize]);
            for t in [0.25, 0.5, 0.75] {
                let x = e0.lerp(e1, t);
                seams.measure(pa, pb, x);
                seams.measure(pb, pa, x);
            }
        }
    }
    Ok(seams)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 40 x 40 sample sheet z = sin(x) with unit spacing, as one patch.
    fn sheet() -> GeometryTextureSet {
        let grid = crate::grids::HeightGrid {
            width: 40,
            height: 40,
            origin: glam::DVec2::ZERO,
            spacing: glam::DVec2::ONE,
            z: (0..1600).map(|t| ((t % 40) as f64 * 0.3).sin()).collect(),
            colors: None,
        };
        crate::grids::from_grids(&[grid], None, None).unwrap()
    }

    #[test]
    fn far_reaching_sigma_is_refused_and_a_set_token_interrupts() {
        let set = sheet();
        let cancel = Cancel::new();
        assert!(filtered(&set, MapFilter::Gaussian, 1.0, &cancel).is_ok());
        // 3 sigma = 30 samples: every point would weigh most of the 1600.
        let e = filtered(&set, MapFilter::Gaussian, 10.0, &cancel).unwrap_err();
        assert!(matches!(&e, GeomtexError::Parameter(_)));
        assert!(e.to_string().contains("reaches too far"), "{e}");
        cancel.cancel();
        let e = filtered(&set, MapFilter::Gaussian, 1.0, &cancel).unwrap_err();
        assert!(matches!(e, GeomtexError::Interrupted(_)));
    }

    /// Two texels at one place whose own normals differ (neighbouring patches' texels that
    /// moved there from different places) must find one surface with one normal there. On a
    /// cylinder of radius 2 sigma, the mean normal at a point on it, weighed as facing 15
    /// degrees to either side of the true normal: measured 0.06 degree apart with facing
    /// weights over cosines (-0.5, 0); 6.4 with the earlier (0.25, 0.75), which left seam steps
    /// of 7.7 degrees (p99) on the bunny at sigma = 8 texels.
    #[test]
    fn the_side_faced_barely_moves_the_mean_normal() {
        // Long enough that 3 sigma reaches under half its points (`check_reach`).
        let (radius, sigma, spacing) = (2.0, 1.0, 0.1);
        let around = (std::f64::consts::TAU * radius / spacing).round() as usize;
        let (mut points, mut normals) = (vec![], vec![]);
        for k in 0..=240 {
            for a in 0..around {
                let angle = std::f64::consts::TAU * a as f64 / around as f64;
                let n = DVec3::new(angle.cos(), angle.sin(), 0.0);
                points.push(n * radius + DVec3::Z * (k as f64 * spacing - 12.0));
                normals.push(n);
            }
        }
        let grid = PointGrid::new(&points, &normals, sigma, spacing, &Cancel::new()).unwrap();
        let y = DVec3::new(radius, 0.0, 0.0);
        let mut near = Vec::new();
        grid.gather(grid.cell(y), &mut near);
        let turned = |deg: f64| {
            let facing = DVec3::new(deg.to_radians().cos(), deg.to_radians().sin(), 0.0);
            grid.means_at(y, facing, &near).unwrap().1.normalize()
        };
        let apart = turned(15.0).angle_between(turned(-15.0)).to_degrees();
        assert!(apart < 0.2, "{apart} degrees");
    }

    #[test]
    fn filters_by_name() {
        assert_eq!(
            MapFilter::from_name("gaussian", None).unwrap(),
            MapFilter::Gaussian
        );
        assert_eq!(
            MapFilter::from_name("high_pass", None).unwrap(),
            MapFilter::HighPass { gain: 1.0 }
        );
        assert_eq!(
            MapFilter::from_name("high_pass", Some(2.5)).unwrap(),
            MapFilter::HighPass { gain: 2.5 }
        );
        let e = MapFilter::from_name("x", None).unwrap_err();
        assert!(matches!(&e, GeomtexError::Parameter(_)));
        assert_eq!(
            e.to_string(),
            "kind must be 'gaussian' or 'high_pass', got \"x\""
        );
    }
}
