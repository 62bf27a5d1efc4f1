//! Mesostructure volumes: an occupancy grid over one tile, periodic in x and y (the tile repeats
//! over the base surface) and bounded in z (z = 0 lies on the base surface, z = nz at the shell's
//! top). Built from a caller's grid (checked: shape, emptiness, seams) or from implicit shapes
//! (chain links, a weave, a lattice) sampled at voxel centres.
//!
//! Space: voxel units of the tile ("texture space"): voxel (i, j, k) is the unit cube
//! [i, i+1) x [j, j+1) x [k, k+1); the grid is stored x-major, `(i * ny + j) * nz + k`, as numpy's
//! C order of an (nx, ny, nz) array.

use crate::error::{GeomtexError, Result};

/// Smallest and largest side a tile may have, in voxels.
pub const MIN_SIDE: usize = 2;
pub const MAX_SIDE: usize = 512;

/// Share of the solid voxels on a tile's x (or y) faces that may fail to continue across the
/// seam before the grid is called not tileable.
pub const SEAM_TOLERANCE: f64 = 0.5;

/// An occupancy grid over one tile, with an optional RGBA color per voxel.
#[derive(Clone, Debug)]
pub struct Volume {
    /// Voxels along x, y, z.
    pub size: [usize; 3],
    /// True where the voxel is solid, x-major (see the module's note).
    pub solid: Vec<bool>,
    /// Per-voxel RGBA, same order; None: one color for the whole volume.
    pub colors: Option<Vec<[u8; 4]>>,
}

/// The built-in procedural tiles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pattern {
    /// Interlocking torus links in two rows, each link threaded through its neighbours.
    Chain,
    /// Two threads crossing over and under each other, as a plain weave.
    Weave,
    /// Rods along x and y on two levels, joined by vertical posts.
    Lattice,
}

pub const PATTERNS: [(&str, Pattern); 3] = [
    ("chain", Pattern::Chain),
    ("weave", Pattern::Weave),
    ("lattice", Pattern::Lattice),
];

/// Why a grid's size is unusable, or None.
fn size_problem(size: [usize; 3]) -> Option<String> {
    let bad = size.iter().any(|&n| !(MIN_SIDE..=MAX_SIDE).contains(&n));
    bad.then(|| {
        format!("a volume needs {MIN_SIDE} to {MAX_SIDE} voxels along each axis, got {size:?}")
    })
}

impl Volume {
    /// A volume over `solid` (x-major), checked: sizes, not empty, not full, and tileable in x
    /// and y (at most `SEAM_TOLERANCE` of the solid voxels on opposite faces disagree) unless
    /// `check_seams` is false.
    pub fn new(
        size: [usize; 3],
        solid: Vec<bool>,
        colors: Option<Vec<[u8; 4]>>,
        check_seams: bool,
    ) -> Result<Volume> {
        if let Some(problem) = size_problem(size) {
            return Err(GeomtexError::Parameter(problem));
        }
        let n = size.iter().product::<usize>();
        if solid.len() != n || colors.as_ref().is_some_and(|c| c.len() != n) {
            return Err(GeomtexError::Parameter(format!(
                "a {size:?} volume needs {n} voxels (and colors), got {}",
                solid.len()
            )));
        }
        let filled = solid.iter().filter(|&&s| s).count();
        if filled == 0 || filled == n {
            let what = if filled == 0 { "empty" } else { "full" };
            return Err(GeomtexError::Parameter(format!(
                "the volume is {what}: a mesostructure needs both solid and empty voxels"
            )));
        }
        let volume = Volume {
            size,
            solid,
            colors,
        };
        if check_seams {
            for axis in 0..2 {
                let mismatch = volume.seam_mismatch(axis);
                if mismatch > SEAM_TOLERANCE {
                    return Err(GeomtexError::Parameter(format!(
                        "the volume does not tile along {}: {:.0}% of the solid voxels on its \
                         faces {0} = 0 and {0} = {} have no solid neighbour across the seam \
                         (at most {:.0}% allowed; pass check_seams=False to accept it)",
                        ["x", "y"][axis],
                        100.0 * mismatch,
                        size[axis] - 1,
                        100.0 * SEAM_TOLERANCE
                    )));
                }
            }
        }
        Ok(volume)
    }

    /// The built-in tile `pattern` at `size` voxels.
    pub fn procedural(pattern: Pattern, size: [usize; 3]) -> Result<Volume> {
        if let Some(problem) = size_problem(size) {
            return Err(GeomtexError::Parameter(problem));
        }
        let [nx, ny, nz] = size;
        let mut solid = Vec::with_capacity(nx * ny * nz);
        for i in 0..nx {
            for j in 0..ny {
                for k in 0..nz {
                    // The voxel's centre in the unit tile [0, 1)^3.
                    let p = [
                        (i as f64 + 0.5) / nx as f64,
                        (j as f64 + 0.5) / ny as f64,
                        (k as f64 + 0.5) / nz as f64,
                    ];
                    solid.push(inside(pattern, p));
                }
            }
        }
        Volume::new(size, solid, None, false)
    }

    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (i * self.size[1] + j) * self.size[2] + k
    }

    /// Whether voxel (i, j, k) is solid, the tile repeated in x and y; empty outside z.
    pub fn solid_at(&self, i: i64, j: i64, k: i64) -> bool {
        let [nx, ny, nz] = self.size.map(|n| n as i64);
        if !(0..nz).contains(&k) {
            return false;
        }
        let (i, j) = (i.rem_euclid(nx) as usize, j.rem_euclid(ny) as usize);
        self.solid[self.index(i, j, k as usize)]
    }

    /// Share of solid voxels on the two faces normal to `axis` (0: x, 1: y) whose neighbour
    /// across the seam is empty.
    pub fn seam_mismatch(&self, axis: usize) -> f64 {
        let [nx, ny, nz] = self.size;
        let (last, across) = if axis == 0 { (nx, ny) } else { (ny, nx) };
        let (mut solid, mut lonely) = (0usize, 0usize);
        for a in 0..across {
            for k in 0..nz {
                let at = |s: usize| {
                    let (i, j) = if axis == 0 { (s, a) } else { (a, s) };
                    self.solid[self.index(i, j, k)]
                };
                let (low, high) = (at(0), at(last - 1));
                solid += usize::from(low) + usize::from(high);
                lonely += usize::from(low != high);
            }
        }
        if solid == 0 {
            0.0
        } else {
            lonely as f64 / solid as f64
        }
    }

    /// Chebyshev distance (in voxels, capped at 255) from each voxel to the nearest solid one,
    /// the tile repeated in x and y and empty beyond z: 0 on solid voxels, and every voxel within
    /// r - 1 of a voxel holding r is empty. The exact march skips those boxes whole.
    pub fn empty_radius(&self) -> Vec<u8> {
        let [nx, ny, nz] = self.size;
        let far = 255u32;
        let mut d: Vec<u32> = self
            .solid
            .iter()
            .map(|&s| if s { 0 } else { far })
            .collect();
        // Separable: along x (periodic), then y (periodic), then z (bounded), each pass the
        // max-min composition the L-infinity metric allows.
        let lines: [(usize, usize, bool); 3] =
            [(nx, ny * nz, true), (ny, nz, true), (nz, 1, false)];
        for (axis, &(len, stride, periodic)) in lines.iter().enumerate() {
            let starts: Vec<usize> = (0..d.len())
                .filter(|&s| match axis {
                    0 => s < ny * nz,
                    1 => (s / nz) % ny == 0,
                    _ => s % nz == 0,
                })
                .collect();
            for start in starts {
                let line: Vec<u32> = (0..len).map(|t| d[start + t * stride]).collect();
                for t in 0..len {
                    let mut best = line[t];
                    for (s, &v) in line.iter().enumerate() {
                        let gap = s.abs_diff(t);
                        let gap = if periodic { gap.min(len - gap) } else { gap };
                        best = best.min(v.max(gap as u32));
                    }
                    d[start + t * stride] = best;
                }
            }
        }
        d.into_iter().map(|v| v.min(far) as u8).collect()
    }
}

/// Whether the unit-tile point `p` lies inside `pattern`'s implicit shape. Every shape is
/// periodic in x and y by construction (distances taken to the nearest copy).
fn inside(pattern: Pattern, [x, y, z]: [f64; 3]) -> bool {
    use std::f64::consts::PI;
    let wrap = |t: f64| t - t.round();
    match pattern {
        Pattern::Chain => {
            // Links along x, alternating flat (in the xy plane) and upright (in the xz plane),
            // two per tile, each threaded through its neighbours; a second chain offset in y.
            let (major, minor) = (0.2, 0.06);
            let link = |cx: f64, cy: f64, upright: bool| {
                let (dx, dy, dz) = (wrap(x - cx), wrap(y - cy), z - 0.5);
                // Stretched along x: a stadium of half-length 0.08.
                let sx = (dx.abs() - 0.08).max(0.0);
                let (a, b, c) = if upright { (sx, dz, dy) } else { (sx, dy, dz) };
                let ring = (a * a + b * b).sqrt() - major * 0.6;
                ring * ring + c * c < minor * minor
            };
            link(0.0, 0.25, false)
                || link(0.5, 0.25, true)
                || link(0.0, 0.75, true)
                || link(0.5, 0.75, false)
        }
        Pattern::Weave => {
            // Threads along x at y = 1/4, 3/4 and along y at x = 1/4, 3/4, each going over and
            // under the crossing ones (height a cosine of the position along the thread).
            let radius = 0.11;
            let height = |along: f64, phase: f64| 0.5 + 0.22 * (2.0 * PI * along + phase).cos();
            let thread = |across: f64, along: f64, centre: f64, phase: f64| {
                let d = wrap(across - centre);
                let h = z - height(along, phase);
                d * d + h * h < radius * radius
            };
            thread(y, x, 0.25, 0.0)
                || thread(y, x, 0.75, PI)
                || thread(x, y, 0.25, PI)
                || thread(x, y, 0.75, 0.0)
        }
        Pattern::Lattice => {
            let r = 0.08;
            let rod = |a: f64, b: f64| a * a + b * b < r * r;
            rod(wrap(y), z - 0.25)
                || rod(wrap(x), z - 0.75)
                || (rod(wrap(x), wrap(y)) && (0.25..=0.75).contains(&z))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn procedural_tiles_are_tileable_and_nonempty() {
        for (name, pattern) in PATTERNS {
            let v = Volume::procedural(pattern, [32, 32, 16]).unwrap();
            let filled = v.solid.iter().filter(|&&s| s).count() as f64 / v.solid.len() as f64;
            assert!((0.01..0.6).contains(&filled), "{name}: {filled}");
            for axis in 0..2 {
                assert!(v.seam_mismatch(axis) < 0.2, "{name} axis {axis}");
            }
        }
    }

    #[test]
    fn bad_grids_are_refused() {
        assert!(Volume::new([4, 4, 4], vec![false; 64], None, true).is_err());
        assert!(Volume::new([4, 4, 4], vec![true; 64], None, true).is_err());
        assert!(Volume::new([4, 4, 4], vec![true; 63], None, true).is_err());
        assert!(Volume::new([1, 4, 4], vec![true; 16], None, true).is_err());
        // Half a slab cut at the x seam: solid on face x = 3, empty on x = 0.
        let mut solid = vec![false; 64];
        let v = Volume::new([4, 4, 4], solid.clone(), None, false);
        assert!(v.is_err());
        for j in 0..4 {
            for k in 0..2 {
                solid[(3 * 4 + j) * 4 + k] = true;
            }
        }
        let e = Volume::new([4, 4, 4], solid.clone(), None, true).unwrap_err();
        assert!(e.to_string().contains("does not tile along x"), "{e}");
        assert!(Volume::new([4, 4, 4], solid, None, false).is_ok());
    }

    #[test]
    fn empty_radius_matches_brute_force() {
        let v = Volume::procedural(Pattern::Weave, [12, 10, 6]).unwrap();
        let r = v.empty_radius();
        let [nx, ny, nz] = v.size.map(|n| n as i64);
        for i in 0..nx {
            for j in 0..ny {
                for k in 0..nz {
                    let mut best = 255i64;
                    for a in -nx..2 * nx {
                        for b in -ny..2 * ny {
                            for c in 0..nz {
                                if v.solid_at(a, b, c) {
                                    let d = (a - i).abs().max((b - j).abs()).max((c - k).abs());
                                    best = best.min(d);
                                }
                            }
                        }
                    }
                    let got = r[v.index(i as usize, j as usize, k as usize)] as i64;
                    assert_eq!(got, best, "voxel {i} {j} {k}");
                }
            }
        }
    }
}
