//! Each cell's error bound: a bound on the world distance from any point of a patch's stored
//! surface in a cell to the faces it was drawn from, in closed form (no sampling).
//!
//! Where the drawn faces cover a cell (seen along the patch's z), every surface point has a face
//! right below or above it, so its distance to the mesh is at most the vertical gap to that
//! face. Over a face's part of the cell (the triangle clipped to the cell, a convex polygon) the
//! gap is a bilinear minus a linear function: bilinear again, with no interior extremum, so its
//! largest magnitude lies on the polygon's boundary, where along each side it is a quadratic
//! (ends or vertex). The bound is taken on the stored codes, so the heights' rounding is in it.
//! Where the cover is in doubt (the faces' outline crosses the cell: the outline's rounding may
//! draw surface past the faces) the surface over a rectangle lies in the convex hull of its four
//! corners, so its distance to one face is at most the largest of theirs; rectangles are split
//! until that is about as tight as the gap.
//!
//! Space: texel-centre coordinates in the patch plane (x, y: texel (i, j) at (i, j); cell (i, j)
//! spans [i, i + 1] x [j, j + 1], see heightfield.rs) with z the world height above the box
//! floor; metric coordinates (world units along the patch axes) for 3D distances. Bounds are
//! world units.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::gtex::{ErrorBoundMap, Patch};
use crate::heightfield::{cell_at, Cell};
use crate::mesh::Mesh;

/// Splits of a cell the hull bound may take where the outline crosses it (down to 1/4 texel):
/// deeper splits tighten the bunny's largest bound by a fifth at 16 times the raster time.
const MAX_SPLITS: u32 = 2;

/// A drawn face in the patch's frame: corners in texel-centre x, y and world height z, and
/// whether it faces the patch's z (its projection keeps its winding).
struct LocalFace {
    corners: [DVec3; 3],
    /// Corners in metric coordinates (world units along the patch axes), for 3D distances.
    metric: [DVec3; 3],
    front: bool,
}

/// What every cell's bound is computed from: the patch, its faces in its frame, and per cell
/// (row by row from cell (-1, -1)) the faces and outline edges whose bounds overlap it.
struct CellBounds<'a> {
    patch: &'a Patch,
    faces: Vec<LocalFace>,
    /// Segments (texel-centre x, y) where the front faces' cover may end: edges not shared by
    /// exactly two front faces.
    outline: Vec<[DVec2; 2]>,
    faces_in_cell: Vec<Vec<u32>>,
    outline_in_cell: Vec<Vec<u32>>,
    /// World size of a texel along x and y.
    texel: DVec2,
}

/// The error-bound map of `patch`, drawn from `faces` of `mesh` (its own and its ring).
pub fn error_bound_map(mesh: &Mesh, faces: &[u32], patch: &Patch) -> ErrorBoundMap {
    ErrorBoundMap::for_patch(patch, &cell_bounds(mesh, faces, patch))
}

/// Each cell's bound, (w + 1) x (h + 1) row by row from cell (-1, -1); 0 where a cell holds
/// no surface.
pub fn cell_bounds(mesh: &Mesh, faces: &[u32], patch: &Patch) -> Vec<f64> {
    let cells = CellBounds::new(mesh, faces, patch);
    let (cw, ch) = (patch.width as usize + 1, patch.height as usize + 1);
    (0..cw * ch)
        .into_par_iter()
        .with_min_len(256)
        .map(|c| cells.bound((c % cw) as i64 - 1, (c / cw) as i64 - 1))
        .collect()
}

impl<'a> CellBounds<'a> {
    fn new(mesh: &Mesh, face_ids: &[u32], patch: &'a Patch) -> Self {
        let texel = DVec2::new(
            patch.extent.x / patch.width as f64,
            patch.extent.y / patch.height as f64,
        );
        let to_local = |v: u32| {
            let d = mesh.positions[v as usize] - patch.origin;
            DVec3::new(
                d.dot(patch.axes[0]) / texel.x - 0.5,
                d.dot(patch.axes[1]) / texel.y - 0.5,
                d.dot(patch.axes[2]),
            )
        };
        let faces: Vec<LocalFace> = face_ids
            .iter()
            .map(|&f| {
                let corners = mesh.faces[f as usize].map(to_local);
                let [a, b, c] = corners;
                let area = (b - a).truncate().perp_dot((c - a).truncate());
                LocalFace {
                    corners,
                    metric: corners.map(|p| metric(p, texel)),
                    front: area > 0.0,
                }
            })
            .collect();
        let outline = front_outline(mesh, face_ids, &faces);
        let (cw, ch) = (patch.width as usize + 1, patch.height as usize + 1);
        let mut faces_in_cell = vec![Vec::new(); cw * ch];
        let mut outline_in_cell = vec![Vec::new(); cw * ch];
        let bucket = |lists: &mut Vec<Vec<u32>>, k: usize, points: &[DVec2]| {
            let lo = points.iter().fold(DVec2::INFINITY, |a, &p| a.min(p));
            let hi = points.iter().fold(DVec2::NEG_INFINITY, |a, &p| a.max(p));
            // Cells i with [i, i + 1] meeting [lo, hi] (a point on a side belongs to both),
            // at index i + 1.
            let span = |lo: f64, hi: f64, n: usize| {
                let first = (lo.ceil() as i64).max(0);
                let last = (hi.floor() as i64 + 1).min(n as i64 - 1);
                (first, last)
            };
            let (x0, x1) = span(lo.x, hi.x, cw);
            let (y0, y1) = span(lo.y, hi.y, ch);
            for cy in y0..=y1 {
                for cx in x0..=x1 {
                    lists[cy as usize * cw + cx as usize].push(k as u32);
                }
            }
        };
        for (k, f) in faces.iter().enumerate() {
            bucket(&mut faces_in_cell, k, &f.corners.map(|p| p.truncate()));
        }
        for (k, e) in outline.iter().enumerate() {
            bucket(&mut outline_in_cell, k, e);
        }
        CellBounds {
            patch,
            faces,
            outline,
            faces_in_cell,
            outline_in_cell,
            texel,
        }
    }

    fn cell_index(&self, i: i64, j: i64) -> Option<usize> {
        let (cw, ch) = (
            i64::from(self.patch.width) + 1,
            i64::from(self.patch.height) + 1,
        );
        ((-1..cw - 1).contains(&i) && (-1..ch - 1).contains(&j))
            .then(|| ((j + 1) * cw + i + 1) as usize)
    }

    /// The bound of cell (i, j): 0 without surface, else `rect_bound` of the whole cell against
    /// the largest gap to its gentle faces.
    fn bound(&self, i: i64, j: i64) -> f64 {
        let Some(cell) = cell_at(self.patch, i, j) else {
            return 0.0;
        };
        let k = self
            .cell_index(i, j)
            .expect("a cell with surface is inside the map");
        let rect = Rect {
            lo: DVec2::new(i as f64, j as f64),
            hi: DVec2::new(i as f64 + 1.0, j as f64 + 1.0),
        };
        let surface = Surface {
            cell: &cell,
            origin: rect.lo,
            to_world: self.patch.extent.z / f64::from(self.patch.code_max() - 1),
        };
        let sampled = self.sampled_gap(&surface, &rect, k);
        // A vertical gap over half a texel is a steep stretch, where it overstates the distance:
        // there the hull bound gets its try.
        let texel = self.texel.x.min(self.texel.y);
        let reference = if sampled > 0.5 * texel { 0.0 } else { sampled };
        self.rect_bound(&surface, &rect, k, reference, 0)
    }

    /// The vertical gap to the nearest front face below or above, largest over the cell's
    /// corners, side midpoints and centre: what the bound aims at (a sample, never the bound).
    fn sampled_gap(&self, surface: &Surface, rect: &Rect, k: usize) -> f64 {
        let (lo, hi) = (rect.lo, rect.hi);
        let mid = rect.centre();
        [lo.x, mid.x, hi.x]
            .iter()
            .flat_map(|&x| [lo.y, mid.y, hi.y].map(|y| DVec2::new(x, y)))
            .map(|p| {
                self.front_faces(k)
                    .filter(|f| contains(f, p))
                    .map(|f| (surface.world_height(p) - Plane::through(&f.corners).at(p)).abs())
                    .fold(f64::INFINITY, f64::min)
            })
            .filter(|g| g.is_finite())
            .fold(0.0, f64::max)
    }

    fn front_faces(&self, k: usize) -> impl Iterator<Item = &LocalFace> + '_ {
        self.faces_in_cell[k]
            .iter()
            .map(|&f| &self.faces[f as usize])
            .filter(|f| f.front)
    }

    /// A bound from vertical gaps over `rect`, or infinity where the front faces' cover is in
    /// doubt: the least gap of a face holding all of `rect`, and where the faces cover it, the
    /// largest gap to any of them.
    fn gap_bound(&self, surface: &Surface, rect: &Rect, k: usize) -> f64 {
        let corners = rect.corners();
        let single = self
            .front_faces(k)
            .filter(|f| corners.iter().all(|&c| contains(f, c)))
            .map(|f| surface.largest_gap(f, rect))
            .fold(f64::INFINITY, f64::min);
        let crossed = self.outline_in_cell[k]
            .iter()
            .any(|&e| rect.meets_segment(self.outline[e as usize]));
        let union = if !crossed && self.covers(k, rect.centre()) {
            self.front_faces(k)
                .map(|f| surface.largest_gap(f, rect))
                .fold(0.0, f64::max)
        } else {
            f64::INFINITY
        };
        single.min(union)
    }

    /// The bound over `rect` (inside cell `k`): the gap bound, or the hull bound where that is
    /// smaller (a steep face's vertical gap overstates its distance) or the cover is in doubt.
    /// Split while that stays over `reference` (the sampled gap) by a quarter: a split's parts
    /// lie inside single faces, away from a far layer's faces and from the outline.
    fn rect_bound(
        &self,
        surface: &Surface,
        rect: &Rect,
        k: usize,
        reference: f64,
        splits: u32,
    ) -> f64 {
        if !surface.may_be_drawn(rect) {
            return 0.0;
        }
        let gap = self.gap_bound(surface, rect, k);
        let good_enough = |b: f64| b <= reference * 2.0;
        if good_enough(gap) {
            return gap;
        }
        let bound = gap.min(self.hull_bound(surface, rect, k));
        if splits >= MAX_SPLITS || good_enough(bound) {
            return bound;
        }
        let split = rect
            .quarters()
            .iter()
            .map(|q| self.rect_bound(surface, q, k, reference, splits + 1))
            .fold(0.0, f64::max);
        split.min(bound)
    }

    /// Whether a front face of cell `k` covers point `p` (sides included).
    fn covers(&self, k: usize, p: DVec2) -> bool {
        self.faces_in_cell[k]
            .iter()
            .map(|&f| &self.faces[f as usize])
            .any(|f| f.front && contains(f, p))
    }

    /// The least, over faces near the cell, of the largest distance from the surface's corners
    /// over `rect` to that face: the surface over `rect` lies in their convex hull, and the
    /// distance to a triangle is convex.
    fn hull_bound(&self, surface: &Surface, rect: &Rect, k: usize) -> f64 {
        let corners = rect
            .corners()
            .map(|c| metric(c.extend(surface.world_height(c)), self.texel));
        let farthest = |f: &LocalFace| {
            corners
                .iter()
                .map(|&c| distance_to_triangle(c, f.metric))
                .fold(0.0, f64::max)
        };
        let (ci, cj) = (
            k % (self.patch.width as usize + 1),
            k / (self.patch.width as usize + 1),
        );
        // Faces of the cell and its neighbours, then farther out while none is found.
        for reach in [1i64, 3, i64::MAX] {
            let near = self.faces_near(ci as i64, cj as i64, reach);
            let best = near
                .map(|f| farthest(&self.faces[f]))
                .fold(f64::INFINITY, f64::min);
            if best.is_finite() {
                return best;
            }
        }
        f64::INFINITY
    }

    /// Faces bucketed in cells within `reach` cells of cell index (ci, cj) (all faces when
    /// `reach` is i64::MAX).
    fn faces_near(&self, ci: i64, cj: i64, reach: i64) -> Box<dyn Iterator<Item = usize> + '_> {
        if reach == i64::MAX {
            return Box::new(0..self.faces.len());
        }
        let cw = i64::from(self.patch.width) + 1;
        let ch = i64::from(self.patch.height) + 1;
        Box::new(
            ((cj - reach).max(0)..=(cj + reach).min(ch - 1))
                .flat_map(move |y| {
                    ((ci - reach).max(0)..=(ci + reach).min(cw - 1)).map(move |x| (x, y))
                })
                .flat_map(move |(x, y)| self.faces_in_cell[(y * cw + x) as usize].iter())
                .map(|&f| f as usize),
        )
    }
}

/// The edges where the front faces' cover may end: used by other than exactly two of them.
fn front_outline(mesh: &Mesh, face_ids: &[u32], faces: &[LocalFace]) -> Vec<[DVec2; 2]> {
    let mut edges: Vec<([u32; 2], DVec2, DVec2)> = face_ids
        .iter()
        .zip(faces)
        .filter(|(_, f)| f.front)
        .flat_map(|(&id, f)| {
            let v = mesh.faces[id as usize];
            let c = f.corners.map(|p| p.truncate());
            [(0, 1), (1, 2), (2, 0)].map(|(a, b)| ([v[a].min(v[b]), v[a].max(v[b])], c[a], c[b]))
        })
        .collect();
    edges.sort_unstable_by_key(|e| e.0);
    let mut outline = Vec::new();
    let mut k = 0;
    while k < edges.len() {
        let run = edges[k..].iter().take_while(|e| e.0 == edges[k].0).count();
        if run != 2 {
            outline.extend(edges[k..k + run].iter().map(|e| [e.1, e.2]));
        }
        k += run;
    }
    outline
}

/// Texel-centre (x, y) and world height z to metric coordinates along the patch axes.
fn metric(p: DVec3, texel: DVec2) -> DVec3 {
    DVec3::new((p.x + 0.5) * texel.x, (p.y + 0.5) * texel.y, p.z)
}

/// The stored surface over one cell: its corner codes and outline distances.
struct Surface<'c> {
    cell: &'c Cell,
    /// The cell's corner (i, j).
    origin: DVec2,
    /// World height per code step.
    to_world: f64,
}

impl Surface<'_> {
    /// World height above the box floor at texel-centre point `p` (bilinear in the codes).
    fn world_height(&self, p: DVec2) -> f64 {
        let f = p - self.origin;
        let q = self.cell.codes;
        let code = (q[0] * (1.0 - f.x) + q[1] * f.x) * (1.0 - f.y)
            + (q[2] * (1.0 - f.x) + q[3] * f.x) * f.y;
        (code - 1.0) * self.to_world
    }

    /// Whether any of `rect` may be drawn: the outline blend is bilinear, so its largest value
    /// over a rectangle is at a corner (a hair of slack for the GPU's f32).
    fn may_be_drawn(&self, rect: &Rect) -> bool {
        rect.corners().iter().any(|&c| {
            let f = c - self.origin;
            self.cell.outline_at(f.x, f.y) >= -1e-4
        })
    }

    /// The largest vertical gap between the surface and face `f` over their common part of
    /// `rect` (0 where they share none).
    fn largest_gap(&self, f: &LocalFace, rect: &Rect) -> f64 {
        let polygon = rect.clip(f.corners.map(|p| p.truncate()));
        let plane = Plane::through(&f.corners);
        let gap = |p: DVec2| self.world_height(p) - plane.at(p);
        let mut largest = 0.0f64;
        for (k, &a) in polygon.iter().enumerate() {
            let b = polygon[(k + 1) % polygon.len()];
            // Along a side the gap is a quadratic in s: through its ends and middle.
            let (g0, gm, g1) = (gap(a), gap((a + b) * 0.5), gap(b));
            largest = largest.max(g0.abs());
            let quad = 2.0 * (g0 + g1) - 4.0 * gm;
            let lin = g1 - g0 - quad;
            if quad.abs() > 0.0 {
                let s = -lin / (2.0 * quad);
                if s > 0.0 && s < 1.0 {
                    largest = largest.max((g0 + s * (lin + s * quad)).abs());
                }
            }
        }
        largest
    }
}

/// A face's plane as height over texel-centre (x, y).
struct Plane {
    origin: DVec3,
    slope: DVec2,
}

impl Plane {
    fn through(c: &[DVec3; 3]) -> Plane {
        let (e1, e2) = (c[1] - c[0], c[2] - c[0]);
        let det = e1.x * e2.y - e1.y * e2.x;
        // A face seen edge-on has no height over its (empty) shadow: level, never used to cover.
        let slope = if det.abs() > 0.0 {
            DVec2::new(
                (e1.z * e2.y - e2.z * e1.y) / det,
                (e2.z * e1.x - e1.z * e2.x) / det,
            )
        } else {
            DVec2::ZERO
        };
        Plane {
            origin: c[0],
            slope,
        }
    }

    fn at(&self, p: DVec2) -> f64 {
        self.origin.z + self.slope.dot(p - self.origin.truncate())
    }
}

/// An axis-aligned rectangle in texel-centre coordinates.
#[derive(Clone, Copy, Debug)]
struct Rect {
    lo: DVec2,
    hi: DVec2,
}

impl Rect {
    fn corners(&self) -> [DVec2; 4] {
        [
            self.lo,
            DVec2::new(self.hi.x, self.lo.y),
            DVec2::new(self.lo.x, self.hi.y),
            self.hi,
        ]
    }

    fn centre(&self) -> DVec2 {
        (self.lo + self.hi) * 0.5
    }

    fn quarters(&self) -> [Rect; 4] {
        let m = self.centre();
        [
            Rect { lo: self.lo, hi: m },
            Rect {
                lo: DVec2::new(m.x, self.lo.y),
                hi: DVec2::new(self.hi.x, m.y),
            },
            Rect {
                lo: DVec2::new(self.lo.x, m.y),
                hi: DVec2::new(m.x, self.hi.y),
            },
            Rect { lo: m, hi: self.hi },
        ]
    }

    /// The triangle clipped to the rectangle (Sutherland-Hodgman): a convex polygon, empty
    /// where they do not meet.
    fn clip(&self, triangle: [DVec2; 3]) -> Vec<DVec2> {
        let mut poly = triangle.to_vec();
        // Each side as (axis, bound, keep the side above it).
        for (axis, bound, above) in [
            (0, self.lo.x, true),
            (0, self.hi.x, false),
            (1, self.lo.y, true),
            (1, self.hi.y, false),
        ] {
            let inside = |p: DVec2| {
                let v = if axis == 0 { p.x } else { p.y };
                if above {
                    v >= bound
                } else {
                    v <= bound
                }
            };
            let mut out = Vec::with_capacity(poly.len() + 1);
            for (k, &a) in poly.iter().enumerate() {
                let b = poly[(k + 1) % poly.len()];
                if inside(a) {
                    out.push(a);
                }
                if inside(a) != inside(b) {
                    let (va, vb) = if axis == 0 { (a.x, b.x) } else { (a.y, b.y) };
                    let s = (bound - va) / (vb - va);
                    let mut p = a + (b - a) * s;
                    // Exactly on the side, whatever the rounding of s.
                    if axis == 0 {
                        p.x = bound;
                    } else {
                        p.y = bound;
                    }
                    out.push(p);
                }
            }
            poly = out;
            if poly.is_empty() {
                break;
            }
        }
        poly
    }

    /// Whether segment `e` touches the rectangle (Liang-Barsky; a hair of slack keeps a segment
    /// along a side in).
    fn meets_segment(&self, e: [DVec2; 2]) -> bool {
        let slack = 1e-9;
        let (lo, hi) = (self.lo - slack, self.hi + slack);
        let d = e[1] - e[0];
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (p, q) in [
            (-d.x, e[0].x - lo.x),
            (d.x, hi.x - e[0].x),
            (-d.y, e[0].y - lo.y),
            (d.y, hi.y - e[0].y),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return false;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
        t0 <= t1
    }
}

/// Whether front face `f` covers point `p` in the plane (sides included).
fn contains(f: &LocalFace, p: DVec2) -> bool {
    let c = f.corners.map(|c| c.truncate());
    let side = |a: DVec2, b: DVec2| (b - a).perp_dot(p - a);
    side(c[0], c[1]) >= 0.0 && side(c[1], c[2]) >= 0.0 && side(c[2], c[0]) >= 0.0
}

/// Distance from `p` to triangle `t` (Ericson, Real-Time Collision Detection 5.1.5: closest
/// point by Voronoi region). Written here as the one exact point-triangle distance the core
/// needs; the geometry crates that have it (parry) would bring a whole collision library.
pub(crate) fn distance_to_triangle(p: DVec3, t: [DVec3; 3]) -> f64 {
    let [a, b, c] = t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return p.distance(a);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return p.distance(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return p.distance(a + ab * v);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return p.distance(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return p.distance(a + ac * w);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return p.distance(b + (c - b) * w);
    }
    let denom = va + vb + vc;
    if denom.abs() < f64::MIN_POSITIVE {
        // A degenerate face: the nearest of its sides.
        let seg = |a: DVec3, b: DVec3| {
            let d = b - a;
            let s = if d.length_squared() > 0.0 {
                ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            p.distance(a + d * s)
        };
        return seg(a, b).min(seg(b, c)).min(seg(c, a));
    }
    let (v, w) = (vb / denom, vc / denom);
    p.distance(a + ab * v + ac * w)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::convert::{convert, ConvertOptions};
    use crate::heightfield::{height_at, test_patch};
    use crate::progress::Progress;
    use crate::test_shapes::uv_sphere;

    /// Exact distance from `p` to the mesh (every face).
    fn distance_to_mesh(mesh: &Mesh, p: DVec3) -> f64 {
        mesh.faces
            .iter()
            .map(|f| distance_to_triangle(p, f.map(|v| mesh.positions[v as usize])))
            .fold(f64::INFINITY, f64::min)
    }

    /// A bumpy sphere: radius 1 + 0.08 sin(5 theta) cos(4 phi), a surface no texel grid follows.
    fn bumpy_sphere() -> Mesh {
        let mut mesh = uv_sphere(20, 40);
        for p in &mut mesh.positions {
            let (theta, phi) = (p.z.clamp(-1.0, 1.0).acos(), p.y.atan2(p.x));
            *p *= 1.0 + 0.08 * (5.0 * theta).sin() * (4.0 * phi).cos();
        }
        mesh
    }

    /// Points on the stored surface of a converted bumpy sphere, a dense grid in every patch,
    /// are each within their cell's bound of the mesh (exact point-triangle distance, every
    /// face), and the bound is tight: its median over the points within a small factor of the
    /// median distance (measured 6.6x: 4.0x of it is a cell's largest gap against a typical
    /// point's on this coarse 24-texel sphere, 1.65x the 2 x 2 blocks).
    #[test]
    fn every_surface_point_lies_within_its_cells_bound() {
        let mesh = bumpy_sphere();
        let opts = ConvertOptions {
            max_resolution: Some(24),
            ..Default::default()
        };
        let set = convert(&mesh, &opts, Progress::silent()).unwrap();
        let (mut ratios, mut distances, mut bounds) = (Vec::new(), Vec::new(), Vec::new());
        for p in &set.patches {
            let map = p
                .error_bound
                .as_ref()
                .expect("conversion makes a bound map");
            let steps = 3 * p.width.max(p.height);
            for sj in 0..=steps {
                for si in 0..=steps {
                    let (u, v) = (si as f64 / steps as f64, sj as f64 / steps as f64);
                    let Some(h) = height_at(p, u, v) else {
                        continue;
                    };
                    let point = p.local_to_world(DVec3::new(u, v, h));
                    let d = distance_to_mesh(&mesh, point);
                    let (x, y) = (u * p.width as f64 - 0.5, v * p.height as f64 - 0.5);
                    let b = map.at_cell(p.width, p.height, x.floor() as i64, y.floor() as i64);
                    assert!(
                        d <= b * (1.0 + 1e-9) + 1e-12,
                        "point ({u}, {v}) of a patch: distance {d} over its bound {b}"
                    );
                    ratios.push(d / b.max(1e-300));
                    distances.push(d);
                    bounds.push(b);
                }
            }
        }
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        assert!(distances.len() > 2000, "{} points", distances.len());
        let tightness = median(&mut bounds) / median(&mut distances);
        assert!(
            tightness <= 8.0,
            "median bound / median distance {tightness}"
        );
    }

    /// A flat stored surface over a shallow dent whose lowest vertex lies inside one cell, away
    /// from its corners and centre: the texel samples never see the dent, so a bound from sample
    /// points (the cell's corners and centre) says 0, while the surface above the dent's vertex
    /// is the dent's depth from the mesh. The closed form takes the vertex as a corner of the
    /// triangle-cell overlap and bounds it.
    #[test]
    fn a_dent_between_the_samples_is_bounded_where_sampling_sees_none() {
        // A 4 x 4 texel flat patch at height 0.5 of a unit box (texel = 0.25 world).
        let patch = test_patch(4, 4, 16, |_, _| Some(0.5));
        let depth = 0.004;
        // The mesh: a grid on the plane z = 0.5 over [-0.5, 1.5]^2 (spacing 1/80), its vertex at
        // texel-centre point (1.3, 1.3) (world (0.45, 0.45), inside cell (1, 1) and away from
        // its corners and centre) pulled down by `depth`.
        let n = 160;
        let spacing = 2.0 / n as f64;
        let dent = DVec3::new(0.45, 0.45, 0.5 - depth);
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (-0.5 + i as f64 * spacing, -0.5 + j as f64 * spacing);
                let at_dent = (x - dent.x).abs() < 1e-9 && (y - dent.y).abs() < 1e-9;
                positions.extend_from_slice(&[x, y, if at_dent { dent.z } else { 0.5 }]);
            }
        }
        let mesh = Mesh::from_flat(&positions, &crate::mesh::grid_faces(n, n), None).unwrap();
        assert!(
            mesh.positions.iter().any(|p| p.z < 0.5),
            "the dent is on a vertex"
        );
        let all: Vec<u32> = (0..mesh.faces.len() as u32).collect();
        let bounds = cell_bounds(&mesh, &all, &patch);
        let cell = bounds[(1 + 1) * 5 + 1 + 1];
        // Cell (1, 1) spans texel-centre [1, 2]^2, world [0.375, 0.625]^2: the dent's inside.
        // The surface point above the dent's vertex is this far from the mesh (its nearest
        // point lies on the dent's gentle walls: a hair nearer than the depth).
        let above = distance_to_mesh(&mesh, dent.truncate().extend(0.5));
        assert!(above > 0.9 * depth, "{above}");
        assert!(
            cell >= above,
            "cell bound {cell} under the distance {above}"
        );
        assert!(
            cell <= 1.01 * depth + 1e-6,
            "cell bound {cell}, depth {depth}"
        );
        // What sampling the cell's corners and centre would give: nothing (the dent is between).
        let sampled = [(1.0, 1.0), (2.0, 1.0), (1.0, 2.0), (2.0, 2.0), (1.5, 1.5)]
            .iter()
            .map(|&(x, y)| {
                let p = DVec3::new((x + 0.5) * 0.25, (y + 0.5) * 0.25, 0.5);
                distance_to_mesh(&mesh, p)
            })
            .fold(0.0, f64::max);
        assert!(sampled < 0.01 * depth, "sampling sees {sampled}");
    }
}
