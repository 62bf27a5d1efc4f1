//! The primary parameterization of an inverse geometric texture: grids of cells, each with a
//! projection of world points into its 2D cell units, and the conservative triangle/cell overlap
//! test that fills the lists.
//!
//! Spaces: world (f64) in. Primary space is per grid, in cell units: cell (i, j) covers
//! [i, i + 1] x [j, j + 1], i along u (0..width), j along v (0..height).
//! - charts: u, v = (p - origin)·x, ·y over the cell size: the chart's orthographic projection
//!   along its z, fold-free for its faces by construction (charts/repair.rs).
//! - spherical: direction d = p - origin in the grid's axes; u = longitude (atan2(d_y, d_x)) over
//!   2π times width, wrapping; v = colatitude (acos(d_z / |d|)) over π times height. Bijective
//!   for meshes star-shaped about the origin.
//! - cylindrical: u as spherical, v = d_z over the cell size along the axis. Bijective for meshes
//!   whose every ray out from the axis leaves them once.

use std::str::FromStr;

use glam::{DVec2, DVec3};

use crate::error::{parse_choice, GeomtexError};

/// The primary parameterization's kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Primary {
    Charts,
    Spherical,
    Cylindrical,
}

impl FromStr for Primary {
    type Err = GeomtexError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        parse_choice(
            "primary",
            s,
            &[
                ("charts", Primary::Charts),
                ("spherical", Primary::Spherical),
                ("cylindrical", Primary::Cylindrical),
            ],
        )
    }
}

impl Primary {
    pub fn name(self) -> &'static str {
        match self {
            Primary::Charts => "charts",
            Primary::Spherical => "spherical",
            Primary::Cylindrical => "cylindrical",
        }
    }

    /// The code files store (and the shader switches on).
    pub fn code(self) -> u32 {
        self as u32
    }

    pub fn from_code(code: u32) -> Option<Primary> {
        [Primary::Charts, Primary::Spherical, Primary::Cylindrical]
            .get(code as usize)
            .copied()
    }

    /// Whether u wraps around (longitude).
    pub fn wraps(self) -> bool {
        self != Primary::Charts
    }
}

/// One grid of cells in the primary space: a chart's plane, or the whole spherical or
/// cylindrical map. Its cells are `first_cell .. first_cell + width * height` of the cell
/// arrays, row-major (v rows of u cells).
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    pub origin: DVec3,
    /// Right-handed orthonormal x, y, z (charts: z is the projection direction; spherical and
    /// cylindrical: z is the pole / axis).
    pub axes: [DVec3; 3],
    /// World units per cell along u and v (charts); along v only (cylindrical); unused (spherical).
    pub cell: DVec2,
    pub width: u32,
    pub height: u32,
    pub first_cell: u32,
}

impl Grid {
    pub fn cells(&self) -> u32 {
        self.width * self.height
    }

    /// `p` in this grid's primary space (cell units); u in [0, width) when the primary wraps.
    pub fn project(&self, primary: Primary, p: DVec3) -> DVec2 {
        let d = p - self.origin;
        let l = DVec3::new(
            d.dot(self.axes[0]),
            d.dot(self.axes[1]),
            d.dot(self.axes[2]),
        );
        let longitude = || {
            let turn = (l.y.atan2(l.x) / std::f64::consts::TAU).rem_euclid(1.0);
            // rem_euclid can round up to exactly 1.
            (turn * self.width as f64).min(self.width as f64 * (1.0 - f64::EPSILON))
        };
        match primary {
            Primary::Charts => DVec2::new(l.x / self.cell.x, l.y / self.cell.y),
            Primary::Spherical => {
                let r = l.length().max(f64::MIN_POSITIVE);
                let colatitude = (l.z / r).clamp(-1.0, 1.0).acos();
                DVec2::new(
                    longitude(),
                    colatitude / std::f64::consts::PI * self.height as f64,
                )
            }
            Primary::Cylindrical => DVec2::new(longitude(), l.z / self.cell.y),
        }
    }

    /// A triangle's corners in primary space; with wrapping, unwrapped so the triangle is
    /// contiguous (each corner within half a turn of the first) and its smallest u in [0, width).
    pub fn triangle(&self, primary: Primary, corners: [DVec3; 3]) -> [DVec2; 3] {
        let mut t = corners.map(|p| self.project(primary, p));
        if primary.wraps() {
            let w = self.width as f64;
            // A corner on the axis has no longitude of its own: it takes its edges' mean.
            let on_axis = corners.map(|p| {
                let d = p - self.origin;
                let radial = d - self.axes[2] * d.dot(self.axes[2]);
                radial.length() <= 1e-9 * d.length()
            });
            let first = on_axis.iter().position(|&a| !a).unwrap_or(0);
            for k in 0..3 {
                t[k].x += w * ((t[first].x - t[k].x) / w).round();
            }
            let off: Vec<f64> = (0..3).filter(|&k| !on_axis[k]).map(|k| t[k].x).collect();
            if !off.is_empty() {
                let mean = off.iter().sum::<f64>() / off.len() as f64;
                for k in (0..3).filter(|&k| on_axis[k]) {
                    t[k].x = mean;
                }
            }
            let min_u = t.iter().map(|c| c.x).fold(f64::INFINITY, f64::min);
            let shift = -w * (min_u / w).floor();
            for c in &mut t {
                c.x += shift;
            }
        }
        t
    }

    /// Cell index (within the grid) of column `i` (wrapped, or clamped onto the grid) and row
    /// `j` (clamped).
    pub fn cell_index(&self, primary: Primary, i: i64, j: i64) -> u32 {
        let (w, h) = (self.width as i64, self.height as i64);
        let i = if primary.wraps() {
            i.rem_euclid(w)
        } else {
            i.clamp(0, w - 1)
        };
        (j.clamp(0, h - 1) * w + i) as u32
    }

    /// The cells (grid-relative) triangle `t` overlaps, each once: closed triangle against closed
    /// cell, by separating axes (the cell's two and the triangle's three edge normals), widened
    /// by `SLACK` cell units so round-off never drops a touching cell.
    pub fn overlapped_cells(&self, primary: Primary, t: &[DVec2; 3], out: &mut Vec<u32>) {
        let lo = t[0].min(t[1]).min(t[2]) - SLACK;
        let hi = t[0].max(t[1]).max(t[2]) + SLACK;
        let (w, h) = (self.width as i64, self.height as i64);
        let (mut i0, mut i1) = (lo.x.floor() as i64, hi.x.floor() as i64);
        if !primary.wraps() {
            i0 = i0.max(0);
            i1 = i1.min(w - 1);
        } else {
            i1 = i1.min(i0 + w - 1);
        }
        let (j0, j1) = (
            (lo.y.floor() as i64).max(0),
            (hi.y.floor() as i64).min(h - 1),
        );
        for j in j0..=j1 {
            for i in i0..=i1 {
                if triangle_overlaps_cell(t, DVec2::new(i as f64, j as f64)) {
                    out.push(self.cell_index(primary, i, j));
                }
            }
        }
    }
}

/// Widening of the overlap test, in cell units.
pub const SLACK: f64 = 1e-6;

/// Whether triangle `t` and the cell [c, c + 1]² overlap (touching counts), up to `SLACK`.
pub fn triangle_overlaps_cell(t: &[DVec2; 3], c: DVec2) -> bool {
    let box_corners = [c, c + DVec2::X, c + DVec2::Y, c + DVec2::ONE];
    for k in 0..3 {
        let e = t[(k + 1) % 3] - t[k];
        let n = DVec2::new(-e.y, e.x);
        let scale = n.length();
        if scale == 0.0 {
            continue;
        }
        let range = |pts: &[DVec2]| {
            pts.iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                    let d = n.dot(*p) / scale;
                    (a.min(d), b.max(d))
                })
        };
        let (tlo, thi) = range(t);
        let (blo, bhi) = range(&box_corners);
        if thi < blo - SLACK || bhi < tlo - SLACK {
            return false;
        }
    }
    // The cell's own axes: the caller iterates over the triangle's widened bounds only.
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlap_is_exact_on_simple_cases() {
        let t = [
            DVec2::new(0.5, 0.5),
            DVec2::new(2.5, 0.5),
            DVec2::new(0.5, 2.5),
        ];
        assert!(triangle_overlaps_cell(&t, DVec2::new(0.0, 0.0)));
        assert!(
            triangle_overlaps_cell(&t, DVec2::new(1.0, 1.0)),
            "the hypotenuse touches"
        );
        assert!(!triangle_overlaps_cell(&t, DVec2::new(1.6, 1.6)));
        let grid = Grid {
            origin: DVec3::ZERO,
            axes: [DVec3::X, DVec3::Y, DVec3::Z],
            cell: DVec2::ONE,
            width: 4,
            height: 4,
            first_cell: 0,
        };
        let mut cells = vec![];
        grid.overlapped_cells(Primary::Charts, &t, &mut cells);
        // Columns and rows 0..=2 but cell (2, 2), whose nearest corner has x + y = 4 > 3 (the
        // hypotenuse); cells (2, 1) and (1, 2) touch it at a corner and count.
        assert_eq!(cells, vec![0, 1, 2, 4, 5, 6, 8, 9]);
    }

    #[test]
    fn wrapping_triangles_are_contiguous() {
        let grid = Grid {
            origin: DVec3::ZERO,
            axes: [DVec3::X, DVec3::Y, DVec3::Z],
            cell: DVec2::ONE,
            width: 64,
            height: 32,
            first_cell: 0,
        };
        // A triangle straddling longitude 0 (the +x direction).
        let t = grid.triangle(
            Primary::Spherical,
            [
                DVec3::new(1.0, -0.05, 0.0),
                DVec3::new(1.0, 0.05, 0.0),
                DVec3::new(1.0, 0.0, 0.1),
            ],
        );
        let span = t.iter().map(|c| c.x).fold(f64::NEG_INFINITY, f64::max)
            - t.iter().map(|c| c.x).fold(f64::INFINITY, f64::min);
        assert!(span < 2.0, "{t:?}");
        let mut cells = vec![];
        grid.overlapped_cells(Primary::Spherical, &t, &mut cells);
        assert!(cells.iter().any(|&c| c % 64 == 63) && cells.iter().any(|&c| c % 64 == 0));
    }
}
