//! How much outline a mesh shows for its area: the default bound's scale.
//!
//! A set whose silhouette lies `e` off the mesh's on average covers about `e · L` wrongly in a
//! view whose outline is `L` long around a projected area `A`: its IoU against the mesh loses
//! about `e · L / A`. A bound that is a fixed fraction of the diagonal therefore costs a thin
//! mesh (limbs, handles, holes: long outlines around little area) more IoU than a compact one.
//! `outline_ratio` measures `L / A` times the diagonal (dimensionless) on the mesh's three axis
//! projections, drawn into a coarse grid so that bumps smaller than a cell (scan noise, the
//! noise of a rough isosurface) do not lengthen the outline as they would a curvature integral.
//!
//! Space: world (the mesh's coordinates); grid cells of `diagonal / GRID` world units.

use glam::DVec2;
use rayon::prelude::*;

use crate::mesh::Mesh;

/// Cells across the diagonal: the outline is measured at about the scale of a pixel of a
/// 512² view of the whole mesh (such a view spans the diagonal in 400-500 pixels) halved, so
/// one cell of noise does not count as outline.
const GRID: usize = 256;

/// Outline length over projected area, times the diagonal, pooled over the projections along
/// x, y and z (outline cells of all three over covered cells of all three, so a flat mesh seen
/// edge-on, a line of cells, weighs as little as it covers). `None` for a mesh with no area
/// in any projection (a point, or a segment).
pub fn outline_ratio(mesh: &Mesh) -> Option<f64> {
    let (lo, hi) = mesh.bounds();
    let diagonal = (hi - lo).length();
    if !(diagonal.is_finite() && diagonal > 0.0) || mesh.faces.is_empty() {
        return None;
    }
    let cell = diagonal / GRID as f64;
    let counts: Vec<(usize, usize)> = (0..3)
        .into_par_iter()
        .map(|axis| {
            let keep = |p: glam::DVec3| {
                let q = (p - lo) / cell;
                match axis {
                    0 => DVec2::new(q.y, q.z),
                    1 => DVec2::new(q.z, q.x),
                    _ => DVec2::new(q.x, q.y),
                }
            };
            let grid = Grid::drawn(mesh, keep);
            (grid.outline(), grid.covered())
        })
        .collect();
    let outline: usize = counts.iter().map(|c| c.0).sum();
    let covered: usize = counts.iter().map(|c| c.1).sum();
    (covered > 0).then(|| outline as f64 / covered as f64 * GRID as f64)
}

/// A projection's covered cells, with an empty cell of margin on every side.
struct Grid {
    side: usize,
    cells: Vec<bool>,
}

impl Grid {
    /// The cells the mesh's faces cover, projected by `to_cells` (cell units, from the mesh's
    /// lower bound), then closed by one cell (dilated, then eroded) so faces smaller than a
    /// cell, which may miss every cell centre, leave no pinholes that would count as outline.
    fn drawn(mesh: &Mesh, to_cells: impl Fn(glam::DVec3) -> DVec2) -> Grid {
        // The projection spans at most the diagonal: GRID cells, +1 for the last, +2 margins,
        // +2 so the closing never reaches the edge.
        let side = GRID + 5;
        let mut grid = Grid {
            side,
            cells: vec![false; side * side],
        };
        let at = |p: DVec2| p + DVec2::splat(2.0);
        for face in &mesh.faces {
            let [a, b, c] = face.map(|v| at(to_cells(mesh.positions[v as usize])));
            grid.fill_triangle(a, b, c);
        }
        grid.cells = grid.eroded(&grid.dilated());
        grid
    }

    fn index(&self, x: usize, y: usize) -> usize {
        y * self.side + x
    }

    /// Marks the cells whose centres lie in triangle abc (either winding) and the cells of its
    /// corners.
    fn fill_triangle(&mut self, a: DVec2, b: DVec2, c: DVec2) {
        let last = (self.side - 1) as f64;
        for p in [a, b, c] {
            let i = self.index(p.x.clamp(0.0, last) as usize, p.y.clamp(0.0, last) as usize);
            self.cells[i] = true;
        }
        let area = (b - a).perp_dot(c - a);
        if area == 0.0 || !area.is_finite() {
            return;
        }
        let (min, max) = (a.min(b).min(c), a.max(b).max(c));
        let (x0, y0) = ((min.x - 0.5).ceil().max(0.0), (min.y - 0.5).ceil().max(0.0));
        let (x1, y1) = (
            (max.x - 0.5).floor().min(last),
            (max.y - 0.5).floor().min(last),
        );
        let sign = area.signum();
        let inside = |p: DVec2| {
            [(a, b), (b, c), (c, a)]
                .iter()
                .all(|&(u, v)| sign * (v - u).perp_dot(p - u) >= 0.0)
        };
        let mut y = y0;
        while y <= y1 {
            let mut x = x0;
            while x <= x1 {
                if inside(DVec2::new(x + 0.5, y + 0.5)) {
                    let i = self.index(x as usize, y as usize);
                    self.cells[i] = true;
                }
                x += 1.0;
            }
            y += 1.0;
        }
    }

    /// `cells` with each cell set where it or one of its 8 neighbours is (`any`), or where it
    /// and all of them are (`!any`); the outermost ring of cells stays empty.
    fn neighbourhood(&self, cells: &[bool], any: bool) -> Vec<bool> {
        let s = self.side;
        let mut out = vec![false; s * s];
        for y in 1..s - 1 {
            for x in 1..s - 1 {
                let mut around = (y - 1..=y + 1).flat_map(|v| (x - 1..=x + 1).map(move |u| (u, v)));
                out[self.index(x, y)] = if any {
                    around.any(|(u, v)| cells[self.index(u, v)])
                } else {
                    around.all(|(u, v)| cells[self.index(u, v)])
                };
            }
        }
        out
    }

    fn dilated(&self) -> Vec<bool> {
        self.neighbourhood(&self.cells, true)
    }

    fn eroded(&self, cells: &[bool]) -> Vec<bool> {
        self.neighbourhood(cells, false)
    }

    fn covered(&self) -> usize {
        self.cells.iter().filter(|&&c| c).count()
    }

    /// Covered cells with an empty 4-neighbour: the outline, in cells.
    fn outline(&self) -> usize {
        let s = self.side;
        (1..s - 1)
            .flat_map(|y| (1..s - 1).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                self.cells[self.index(x, y)]
                    && [(x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)]
                        .iter()
                        .any(|&(u, v)| !self.cells[self.index(u, v)])
            })
            .count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn mesh(positions: Vec<DVec3>, faces: Vec<[u32; 3]>) -> Mesh {
        let flat: Vec<f64> = positions.iter().flat_map(|p| p.to_array()).collect();
        let idx: Vec<i64> = faces.iter().flat_map(|f| f.map(i64::from)).collect();
        Mesh::from_flat(&flat, &idx, None).unwrap()
    }

    /// A closed box of sides `s`, two triangles a side.
    fn cuboid(s: DVec3) -> Mesh {
        let p: Vec<DVec3> = (0..8)
            .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, (i >> 2) as f64) * s)
            .collect();
        let quads = [
            [0, 1, 3, 2],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ];
        let faces = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        mesh(p, faces)
    }

    #[test]
    fn a_thin_bar_shows_more_outline_for_its_area_than_a_cube() {
        // A cube: each projection a square of side d/√3 (d the diagonal): outline 4 d/√3 over
        // area d²/3, times d: 4√3 = 6.9 (the pixel count of the outline runs a little short).
        let cube = outline_ratio(&cuboid(DVec3::ONE)).unwrap();
        assert!((6.0..7.2).contains(&cube), "{cube}");
        // A 1 x 0.1 x 0.1 bar: two projections are 1 x 0.1 rectangles (outline 2.2 around
        // 0.1), one a 0.1 square: far more outline per area, ~ 22 d.
        let bar = outline_ratio(&cuboid(DVec3::new(1.0, 0.1, 0.1))).unwrap();
        assert!(bar > 2.5 * cube, "bar {bar}, cube {cube}");
        // Scale-free.
        let big = outline_ratio(&cuboid(DVec3::splat(1000.0))).unwrap();
        assert!((big - cube).abs() < 1e-9 * cube, "{big} {cube}");
    }

    #[test]
    fn a_point_has_no_ratio() {
        let p = mesh(vec![DVec3::ZERO; 3], vec![[0, 1, 2]]);
        assert_eq!(outline_ratio(&p), None);
    }
}
