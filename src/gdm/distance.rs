//! The exact march through a tiled volume, and the 5D generalized displacement function built
//! from it: d(x, y, z, theta, phi), the distance from each voxel centre along each sampled
//! direction to the first solid voxel, with a miss (the ray leaves through the top or the bottom)
//! replaced by the distance to that boundary, as the paper does so the table stays smooth.
//!
//! Space: texture space in voxel units (gdm_data/volume.rs); directions are unit vectors there, theta the
//! polar angle from +z (the shell's outward normal), phi the azimuth from +x towards +y.

use glam::DVec3;
use rayon::prelude::*;

use crate::error::{GeomtexError, Result};
use crate::gdm_data::Volume;
use crate::progress::Progress;

/// The paper's direction counts: 16 polar angles by 32 azimuths.
pub const DEFAULT_DIRECTIONS: [usize; 2] = [16, 32];
/// Most entries one table may hold (1 GiB of f32).
pub const MAX_ENTRIES: usize = 1 << 28;
/// How far past a box face a march looks to find the next voxel (voxels).
const NUDGE: f64 = 1e-7;
/// Longest march (voxels), for rays that never leave the slab.
pub const MAX_MARCH: f64 = 1e5;

/// Polar angle `a` of `counts[0]` and azimuth `b` of `counts[1]` as a unit vector: polar angles
/// at the centres of equal intervals of [0, pi] (so none is horizontal: every ray leaves the
/// slab), azimuths at equal steps from 0.
pub fn direction(a: usize, b: usize, counts: [usize; 2]) -> DVec3 {
    use std::f64::consts::PI;
    let theta = (a as f64 + 0.5) * PI / counts[0] as f64;
    let phi = b as f64 * 2.0 * PI / counts[1] as f64;
    DVec3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

/// A volume ready to be marched: its grid and the empty-space radii that let a ray skip whole
/// empty boxes.
pub struct Marcher<'a> {
    pub volume: &'a Volume,
    pub radius: Vec<u8>,
}

/// Where a march ended: at `t` (voxels along the unit direction), on solid (`hit`) or where the
/// ray leaves the slab 0 <= z <= nz (or reaches the caller's limit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MarchEnd {
    pub t: f64,
    pub hit: bool,
}

impl<'a> Marcher<'a> {
    pub fn new(volume: &'a Volume) -> Self {
        Marcher {
            volume,
            radius: volume.empty_radius(),
        }
    }

    /// The first solid voxel along `origin + t * dir` (dir a unit vector), t in [0, max_t]:
    /// 0 when the origin is inside solid. Each step leaves the empty box around the current voxel
    /// that the radius grid guarantees, so the cost follows the free space, not the resolution.
    pub fn march(&self, origin: DVec3, dir: DVec3, max_t: f64) -> MarchEnd {
        let [nx, ny, nz] = self.volume.size.map(|n| n as i64);
        let top = nz as f64;
        let leave = if dir.z > 0.0 {
            (top - origin.z) / dir.z
        } else if dir.z < 0.0 {
            -origin.z / dir.z
        } else {
            f64::INFINITY
        };
        // A horizontal ray never leaves the slab: stop it after a few hundred tiles.
        let limit = leave.min(max_t).min(MAX_MARCH);
        let mut t = 0.0f64;
        while t < limit {
            let q = origin + dir * (t + NUDGE);
            let v = q.floor();
            let [i, j, k] = [v.x as i64, v.y as i64, v.z as i64];
            if !(0..nz).contains(&k) {
                break;
            }
            let (wi, wj) = (i.rem_euclid(nx) as usize, j.rem_euclid(ny) as usize);
            let r = self.radius[self.volume.index(wi, wj, k as usize)];
            if r == 0 {
                return MarchEnd { t, hit: true };
            }
            let exit = box_exit(origin, dir, v, f64::from(r) - 1.0);
            t = exit.max(t + NUDGE);
        }
        MarchEnd {
            t: limit.max(0.0),
            hit: false,
        }
    }
}

/// The 5D table: `distance` and `hit` in the order (x, y, z, theta, phi), x slowest.
pub struct DistanceFunction {
    pub size: [usize; 3],
    pub directions: [usize; 2],
    /// Voxels along each direction from each voxel centre (misses: to the slab's boundary).
    pub distance: Vec<f32>,
    /// Whether that ray met solid before leaving the slab.
    pub hit: Vec<bool>,
}

/// Checks direction counts against the volume's size and the table limit.
pub fn check_directions(volume: &Volume, directions: [usize; 2]) -> Result<()> {
    let [nt, np] = directions;
    if !(2..=64).contains(&nt) || !(2..=128).contains(&np) {
        return Err(GeomtexError::Parameter(format!(
            "directions must be (theta, phi) counts in 2..=64 and 2..=128, got ({nt}, {np})"
        )));
    }
    let entries = volume.solid.len() * nt * np;
    if entries > MAX_ENTRIES {
        return Err(GeomtexError::Parameter(format!(
            "a {:?} volume at {nt} x {np} directions needs {entries} entries; at most {MAX_ENTRIES}",
            volume.size
        )));
    }
    Ok(())
}

/// The 5D distance function of `volume` at `directions` (theta, phi counts), rows of x in
/// parallel, reporting stage "distance function" after each.
pub fn distance_function(
    volume: &Volume,
    directions: [usize; 2],
    progress: Progress,
) -> Result<DistanceFunction> {
    check_directions(volume, directions)?;
    let [nt, np] = directions;
    let marcher = Marcher::new(volume);
    let dirs: Vec<DVec3> = (0..nt * np)
        .map(|d| direction(d / np, d % np, directions))
        .collect();
    tabulate(
        volume,
        directions,
        "distance function",
        progress,
        |origin, d| {
            let end = marcher.march(origin, dirs[d], f64::INFINITY);
            (end.t as f32, end.hit)
        },
    )
}

/// The t at which `origin + t * dir` leaves the box of voxel `v` (its lower corner) grown by
/// `margin` voxels on every side; infinite along no axis the ray moves on. Serves the march and
/// the lower-bound sweep (bound.rs), which both jump from box to box of guaranteed free space.
pub(crate) fn box_exit(origin: DVec3, dir: DVec3, v: DVec3, margin: f64) -> f64 {
    (0..3)
        .filter(|&axis| dir[axis] != 0.0)
        .map(|axis| {
            let d = dir[axis];
            let face = if d > 0.0 {
                v[axis] + 1.0 + margin
            } else {
                v[axis] - margin
            };
            (face - origin[axis]) / d
        })
        .fold(f64::INFINITY, f64::min)
}

/// A table in `distance_function`'s layout (x, y, z, then direction index theta * np + phi):
/// `sample(voxel centre, direction index)` gives each entry and whether a surface bounds it.
/// Rows of x run in parallel, reporting `stage` after each; serves the plain table and the
/// lower-bound one (bound.rs).
pub(crate) fn tabulate(
    volume: &Volume,
    directions: [usize; 2],
    stage: &str,
    progress: Progress,
    sample: impl Fn(DVec3, usize) -> (f32, bool) + Sync,
) -> Result<DistanceFunction> {
    let [nx, ny, nz] = volume.size;
    let count = directions[0] * directions[1];
    let per_row = ny * nz * count;
    let finished = crate::progress::Finished::new(progress, stage, nx, 1);
    progress.report(stage, 0.0)?;
    let rows: Vec<(Vec<f32>, Vec<bool>)> = (0..nx)
        .into_par_iter()
        .map(|i| {
            progress.check(stage)?;
            let mut distance = Vec::with_capacity(per_row);
            let mut hit = Vec::with_capacity(per_row);
            for j in 0..ny {
                for k in 0..nz {
                    let centre = DVec3::new(i as f64, j as f64, k as f64) + 0.5;
                    for d in 0..count {
                        let (t, h) = sample(centre, d);
                        distance.push(t);
                        hit.push(h);
                    }
                }
            }
            finished.one()?;
            Ok((distance, hit))
        })
        .collect::<Result<_>>()?;
    let (distance, hit): (Vec<Vec<f32>>, Vec<Vec<bool>>) = rows.into_iter().unzip();
    Ok(DistanceFunction {
        size: volume.size,
        directions,
        distance: distance.concat(),
        hit: hit.concat(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gdm_data::Pattern;

    /// A plain voxel-by-voxel walk in small steps: the reference for the skipping march.
    fn walk(v: &Volume, o: DVec3, d: DVec3) -> (f64, bool) {
        let step = 1e-3;
        let mut t = 0.0;
        loop {
            let p = o + d * t;
            if p.z < 0.0 || p.z >= v.size[2] as f64 {
                return (t, false);
            }
            let q = p.floor();
            if v.solid_at(q.x as i64, q.y as i64, q.z as i64) {
                return (t, true);
            }
            t += step;
        }
    }

    #[test]
    fn skipping_march_agrees_with_small_steps() {
        let v = Volume::procedural(Pattern::Weave, [24, 24, 8]).unwrap();
        let m = Marcher::new(&v);
        let counts = [8, 12];
        let mut hits = 0;
        for n in 0..200usize {
            let o = DVec3::new(
                (n * 7 % 24) as f64 + 0.31,
                (n * 11 % 24) as f64 + 0.62,
                (n % 8) as f64 + 0.5,
            );
            let d = direction(n % 8, n % 12, counts);
            let end = m.march(o, d, f64::INFINITY);
            let (t, hit) = walk(&v, o, d);
            assert_eq!(end.hit, hit, "ray {n}");
            // The walk overshoots by up to one step.
            assert!((end.t - t).abs() < 2e-3, "ray {n}: {} vs {t}", end.t);
            hits += usize::from(hit);
        }
        assert!(hits > 20 && hits < 190, "{hits} hits");
    }

    #[test]
    fn table_is_zero_inside_and_straight_down_to_the_floor() {
        let v = Volume::procedural(Pattern::Lattice, [16, 16, 8]).unwrap();
        let f = distance_function(&v, [4, 8], Progress::silent()).unwrap();
        let [nt, np] = f.directions;
        for (cell, &solid) in v.solid.iter().enumerate() {
            let row = &f.distance[cell * nt * np..(cell + 1) * nt * np];
            if solid {
                assert!(row.iter().all(|&d| d == 0.0));
            }
        }
        // Every miss ends on the slab's boundary.
        for (e, (&d, &hit)) in f.distance.iter().zip(&f.hit).enumerate() {
            if !hit {
                let cell = e / (nt * np);
                let k = cell % 8;
                let dir = direction((e / np) % nt, e % np, f.directions);
                let z = k as f64 + 0.5 + dir.z * f64::from(d);
                assert!(z.abs() < 1e-4 || (z - 8.0).abs() < 1e-4, "entry {e}: z {z}");
            }
        }
    }
}
