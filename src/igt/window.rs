//! What the ray lookup of a simplified face searches (shaders/igt_functions.wgsl,
//! `igt_ray_lookup`): a window on either side of the face's plane (outside, the side its
//! normal points to, and inside), and the grids whose lists it walks. Both are measured on the
//! CPU. First with the projection lookup (igt_data/lookup.rs): the face is sampled, each sample
//! projected into every grid whose detailed faces' bounding box holds it, and the detailed point
//! found inside a listed triangle gives the distance of the detailed surface from the face's
//! plane there; the largest such distance (the nearest grid's, per sample) over the faces
//! sharing a vertex with it, since a ray crosses into them, is the base of both windows. Then
//! each side grows to the highest detailed point a ray through the face at a moderate slant
//! could meet first (`reach`): seen from the side, detailed surface that the decimation cut off
//! a neighbouring face stands in front of this one. Its further grids are those owning detailed faces near it (centroids within the window
//! of its plane and `LATERAL` windows of its edges), nearest first: a face spanning charts thus
//! finds the triangles of each. (Choosing them from the samples' projections instead missed
//! small charts: on the bunny at 0.5%, nearly every pixel whose face the ray lookup got wrong
//! showed a grid outside the face's set.)
//!
//! Spaces: world (the detailed and simplified meshes' own, f64); windows in the same units.

use glam::DVec3;
use rayon::prelude::*;

use crate::cancel::Cancel;
use crate::error::Result;
use crate::igt_data::InverseGeometricTexture;
use crate::mesh::Mesh;

/// Grids the ray lookup walks for one face at most (its own and the nearest others). On the
/// bunny simplified to 0.5% (346 faces), the pixels of a face show the triangles of up to 8
/// grids (median 4; embree, front view).
pub const MAX_GRIDS: usize = 32;
/// Barycentric lattice order of the samples a face is measured at: about one every
/// `SAMPLE_CELLS` cells along its longest edge, within these bounds (15 to 153 points).
const SAMPLES: (u32, u32) = (4, 16);
const SAMPLE_CELLS: f64 = 2.0;
/// The window is the measured distance times this, plus a cell: samples miss the peaks between
/// them.
const SLACK: f64 = 1.25;

/// How far beyond a face's edges (in windows) a detailed face still counts as near it: a ray
/// within the window travels sideways too.
const LATERAL: f64 = 2.0;
/// A detailed point counts toward a face's windows within this many times its height of the
/// face's edges: rays meeting the face at 18 degrees or more (cosine 0.32) reach it. On the
/// bunny at 0.5% (views +x and -x), 80% and 94% of the pixels whose face the ray lookup got
/// wrong had the detailed hit in front of the simplified face, beyond its window (1.3-2x it,
/// median), on detailed surface nearest to another simplified face (half of them not even
/// sharing a vertex with it); their rays met the face at cosines 0.23-0.72 (10th to 90th
/// percentile).
const CONE: f64 = 3.0;
/// And within this many of the face's grid's cells of its plane (the shader walks 64 at most)
/// and of its longest edges (small faces need not look far; this bounds the build's time).
const CAP_CELLS: f64 = 32.0;
const CAP_EDGES: f64 = 2.0;
/// Buckets of detailed points along the bounding box's longest side.
const BUCKETS: f64 = 64.0;

/// Per grid, the bounding box of the detailed faces it lists (own and ring).
fn grid_boxes(igt: &InverseGeometricTexture) -> Vec<(DVec3, DVec3)> {
    let mut boxes = vec![(DVec3::INFINITY, DVec3::NEG_INFINITY); igt.grids.len()];
    for e in &igt.entries {
        let b = &mut boxes[e.grid as usize];
        for &v in &igt.faces[e.face as usize] {
            let p = igt.positions[v as usize];
            *b = (b.0.min(p), b.1.max(p));
        }
    }
    boxes
}

/// The largest distance from the plane of the face with `corners` of the detailed points its
/// samples project onto in the grids whose boxes hold them (the nearest, per sample).
fn parted(
    igt: &InverseGeometricTexture,
    boxes: &[(DVec3, DVec3)],
    corners: [DVec3; 3],
    own: u32,
) -> f64 {
    let [a, b, c] = corners;
    let normal = (b - a).cross(c - a).normalize_or_zero();
    // A grid farther than the face's extent from a sample cannot list what lies under it.
    let reach = (b - a).length().max((c - b).length()).max((a - c).length());
    let cell = igt.grids[own as usize].cell.max_element();
    let n = ((reach / (SAMPLE_CELLS * cell)).ceil() as u32).clamp(SAMPLES.0, SAMPLES.1);
    let mut parted: f64 = 0.0;
    for i in 0..=n {
        for j in 0..=n - i {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            let p = a * (1.0 - u - v) + b * u + c * v;
            let mut nearest = f64::INFINITY;
            for (g, (lo, hi)) in boxes.iter().enumerate() {
                if g as u32 != own && (p.cmplt(*lo - reach).any() || p.cmpgt(*hi + reach).any()) {
                    continue;
                }
                let hit = igt.lookup(g, p);
                if hit.face < 0 || !hit.inside {
                    continue;
                }
                let t = igt.faces[hit.face as usize].map(|v| igt.positions[v as usize]);
                let q = t[0] * hit.bary[0] + t[1] * hit.bary[1] + t[2] * hit.bary[2];
                nearest = nearest.min((q - p).dot(normal).abs());
            }
            if nearest.is_finite() {
                parted = parted.max(nearest);
            }
        }
    }
    parted
}

/// Points (the detailed faces' centroids, or its vertices too) in buckets of a uniform grid.
struct Buckets {
    lo: DVec3,
    size: f64,
    /// Buckets a side, and each bucket's points (dense: x fastest).
    dims: [i64; 3],
    cells: Vec<Vec<u32>>,
    points: Vec<DVec3>,
}

impl Buckets {
    /// `points`, those for which `keep` holds in the buckets.
    fn new(points: Vec<DVec3>, keep: impl Fn(usize) -> bool) -> Buckets {
        let (lo, hi) = (points.iter())
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &c| {
                (l.min(c), h.max(c))
            });
        let size = ((hi - lo).max_element() / BUCKETS).max(f64::MIN_POSITIVE);
        let dims = if points.is_empty() {
            [0; 3]
        } else {
            ((hi - lo) / size)
                .floor()
                .as_i64vec3()
                .to_array()
                .map(|d| d + 1)
        };
        let mut cells = vec![Vec::new(); (dims[0] * dims[1] * dims[2]) as usize];
        let mut buckets = Buckets {
            lo,
            size,
            dims,
            cells: Vec::new(),
            points: Vec::new(),
        };
        for (k, c) in points.iter().enumerate() {
            if keep(k) {
                cells[buckets.index(buckets.key(*c))].push(k as u32);
            }
        }
        buckets.cells = cells;
        buckets.points = points;
        buckets
    }

    /// The bucket of `p`, clamped to the grid.
    fn key(&self, p: DVec3) -> [i64; 3] {
        let k = ((p - self.lo) / self.size).floor().as_i64vec3().to_array();
        [0, 1, 2].map(|a| k[a].clamp(0, (self.dims[a] - 1).max(0)))
    }

    fn index(&self, k: [i64; 3]) -> usize {
        ((k[2] * self.dims[1] + k[1]) * self.dims[0] + k[0]) as usize
    }

    /// The kept points in the buckets that the box (lo, hi) overlaps: index and position.
    fn within(&self, lo: DVec3, hi: DVec3) -> impl Iterator<Item = (u32, DVec3)> + '_ {
        let (lo, hi) = (self.key(lo), self.key(hi));
        let empty = self.cells.is_empty();
        (lo[2]..=hi[2])
            .filter(move |_| !empty)
            .flat_map(move |k| (lo[1]..=hi[1]).map(move |j| (j, k)))
            .flat_map(move |(j, k)| (lo[0]..=hi[0]).map(move |i| [i, j, k]))
            .flat_map(|key| &self.cells[self.index(key)])
            .map(|&k| (k, self.points[k as usize]))
    }

    /// The grids owning detailed faces whose centroids (the points) lie within `window` of the
    /// plane of the face with `corners` and `LATERAL` windows of its edges, nearest first (by
    /// their nearest centroid's distance from the plane plus its distance outside the edges).
    fn near_grids(
        &self,
        igt: &InverseGeometricTexture,
        corners: [DVec3; 3],
        window: f64,
    ) -> Vec<u32> {
        let plane = Plane::new(corners);
        let side = window * LATERAL;
        let [a, b, c] = corners;
        let mut nearest: Vec<(u32, f64)> = Vec::new();
        for (f, p) in self.within(a.min(b).min(c) - side, a.max(b).max(c) + side) {
            let (height, outside) = plane.place(p);
            if height.abs() > window || outside > side {
                continue;
            }
            let g = igt.face_grid[f as usize];
            let d = height.abs() + outside;
            match nearest.iter_mut().find(|(h, _)| *h == g) {
                Some(slot) => slot.1 = slot.1.min(d),
                None => nearest.push((g, d)),
            }
        }
        nearest.sort_by(|x, y| x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)));
        nearest.into_iter().map(|(g, _)| g).collect()
    }
}

/// A simplified face's plane and edges.
struct Plane {
    corners: [DVec3; 3],
    normal: DVec3,
    /// Inward edge normals in the plane (zero for a degenerate face: only heights count).
    inward: [DVec3; 3],
}

impl Plane {
    fn new(corners: [DVec3; 3]) -> Plane {
        let [a, b, c] = corners;
        let normal = (b - a).cross(c - a).normalize_or_zero();
        let inward = [(a, b), (b, c), (c, a)].map(|(p, q)| normal.cross(q - p).normalize_or_zero());
        Plane {
            corners,
            normal,
            inward,
        }
    }

    /// `p`'s height above the plane (along the winding's normal) and its distance outside the
    /// edges (0 over the face).
    fn place(&self, p: DVec3) -> (f64, f64) {
        let height = (p - self.corners[0]).dot(self.normal);
        let outside = (self.corners.iter().zip(&self.inward))
            .fold(0.0f64, |o, (e, inward)| o.max(-(p - *e).dot(*inward)));
        (height, outside)
    }
}

/// The point of triangle `t` nearest to `p`: its squared distance.
fn distance2_to_triangle(t: [DVec3; 3], p: DVec3) -> f64 {
    let [a, b, c] = t;
    let n = (b - a).cross(c - a);
    let area2 = n.length_squared();
    if area2 > 0.0 {
        // Inside the prism over the triangle: the distance to its plane.
        let w = [
            (c - b).cross(p - b),
            (a - c).cross(p - c),
            (b - a).cross(p - a),
        ];
        if w.iter().all(|w| w.dot(n) >= 0.0) {
            let h = (p - a).dot(n);
            return h * h / area2;
        }
    }
    [(a, b), (b, c), (c, a)]
        .iter()
        .map(|&(p0, p1)| {
            let e = p1 - p0;
            let s = if e.length_squared() > 0.0 {
                ((p - p0).dot(e) / e.length_squared()).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (p0 + e * s - p).length_squared()
        })
        .fold(f64::INFINITY, f64::min)
}

/// The simplified mesh's faces in the buckets of a uniform grid that their bounding boxes
/// overlap, for nearest-face queries.
struct FaceBuckets<'a> {
    mesh: &'a Mesh,
    lo: DVec3,
    size: f64,
    dims: [i64; 3],
    map: std::collections::HashMap<[i64; 3], Vec<u32>>,
}

impl<'a> FaceBuckets<'a> {
    fn new(mesh: &'a Mesh) -> Self {
        let (lo, hi) = (mesh.positions.iter())
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &p| {
                (l.min(p), h.max(p))
            });
        // About two faces' bounding boxes per bucket a side.
        let side = (mesh.faces.len() as f64).sqrt().max(1.0);
        let size = ((hi - lo).max_element() / side).max(f64::MIN_POSITIVE);
        let dims = ((hi - lo) / size)
            .floor()
            .as_i64vec3()
            .to_array()
            .map(|d| d + 1);
        let mut map: std::collections::HashMap<[i64; 3], Vec<u32>> = Default::default();
        for (f, t) in mesh.faces.iter().enumerate() {
            let c = t.map(|v| mesh.positions[v as usize]);
            let k0 = ((c[0].min(c[1]).min(c[2]) - lo) / size)
                .floor()
                .as_i64vec3();
            let k1 = ((c[0].max(c[1]).max(c[2]) - lo) / size)
                .floor()
                .as_i64vec3();
            for i in k0.x..=k1.x {
                for j in k0.y..=k1.y {
                    for k in k0.z..=k1.z {
                        map.entry([i, j, k]).or_default().push(f as u32);
                    }
                }
            }
        }
        FaceBuckets {
            mesh,
            lo,
            size,
            dims,
            map,
        }
    }

    /// The face nearest to `p` (ties: the lower index); None for a mesh without faces.
    fn nearest(&self, p: DVec3) -> Option<u32> {
        let key = ((p - self.lo) / self.size).floor().as_i64vec3().to_array();
        let mut best: (f64, Option<u32>) = (f64::INFINITY, None);
        // Far enough to reach every bucket from any point near the mesh.
        let rings = (0..3)
            .map(|a| key[a].abs().max((key[a] - self.dims[a]).abs()))
            .max()
            .unwrap_or(0)
            + 1;
        for r in 0..=rings {
            // Faces first met in ring r lie at least (r - 1) buckets away.
            if r > 0 && best.0.sqrt() <= (r - 1) as f64 * self.size {
                break;
            }
            for i in key[0] - r..=key[0] + r {
                for j in key[1] - r..=key[1] + r {
                    for k in key[2] - r..=key[2] + r {
                        let shell = (i - key[0])
                            .abs()
                            .max((j - key[1]).abs())
                            .max((k - key[2]).abs());
                        if shell != r {
                            continue;
                        }
                        for &f in self.map.get(&[i, j, k]).into_iter().flatten() {
                            let t = self.mesh.faces[f as usize]
                                .map(|v| self.mesh.positions[v as usize]);
                            let d = distance2_to_triangle(t, p);
                            if d < best.0 || (d == best.0 && Some(f) < best.1) {
                                best = (d, Some(f));
                            }
                        }
                    }
                }
            }
        }
        best.1
    }
}

/// How far outside (the side its normal points to) and inside the plane of the face with
/// `corners` a view ray through the face may first meet the detailed surface: the largest
/// heights of the detailed points (vertices and face centroids) that lie within `CONE` times
/// their height of its edges (rays at least that steep reach them) and `cap` of the plane;
/// inside only of points whose nearest simplified face is one of `ring`'s (else the model's far
/// side would count). A detailed bump the decimation cut off a neighbouring face stands in
/// front of this one when seen from the side.
fn reach(
    points: &Buckets,
    nearest: &[u32],
    ring: &[u32],
    corners: [DVec3; 3],
    cap: f64,
) -> (f64, f64) {
    let plane = Plane::new(corners);
    let [a, b, c] = corners;
    let side = cap * CONE;
    let (mut outside, mut inside) = (0.0f64, 0.0f64);
    for (k, p) in points.within(a.min(b).min(c) - side, a.max(b).max(c) + side) {
        let (height, off) = plane.place(p);
        if height.abs() > cap || off > CONE * height.abs() {
            continue;
        }
        if height > 0.0 {
            outside = outside.max(height);
        } else if ring.contains(&nearest[k as usize]) {
            inside = inside.max(-height);
        }
    }
    (outside, inside)
}

/// Per face: its windows (outside, inside) and the grids it walks (its own first).
pub type FaceWindows = (Vec<[f32; 2]>, Vec<Vec<u32>>);

/// Per face of `mesh` (projected into grid `face_grid[f]`): its windows and grids. `cancel` is
/// polled per face (Ctrl-C stops a search that a mesh far from the detailed one
/// makes long): Interrupted once set.
pub fn windows(
    igt: &InverseGeometricTexture,
    mesh: &Mesh,
    face_grid: &[u32],
    cancel: &Cancel,
) -> Result<FaceWindows> {
    let boxes = grid_boxes(igt);
    let corners = |t: &[u32; 3]| t.map(|v| mesh.positions[v as usize]);
    let parted: Vec<f64> = (mesh.faces.par_iter().zip(face_grid))
        .map(|(t, &g)| {
            if cancel.is_cancelled() {
                return 0.0;
            }
            parted(igt, &boxes, corners(t), g)
        })
        .collect();
    cancel.check("measuring the faces' windows")?;
    let mut faces_at: Vec<Vec<u32>> = vec![Vec::new(); mesh.positions.len()];
    for (f, t) in mesh.faces.iter().enumerate() {
        for &v in t {
            faces_at[v as usize].push(f as u32);
        }
    }
    let centroids: Vec<DVec3> = (igt.faces.iter())
        .map(|t| t.iter().map(|&v| igt.positions[v as usize]).sum::<DVec3>() / 3.0)
        .collect();
    let points = Buckets::new([igt.positions.as_slice(), &centroids].concat(), |_| true);
    let buckets = Buckets::new(centroids, |f| igt.face_grid[f] != u32::MAX);
    let simplified = FaceBuckets::new(mesh);
    let nearest: Vec<u32> = (points.points.par_iter())
        .map(|&p| {
            if cancel.is_cancelled() {
                return u32::MAX;
            }
            simplified.nearest(p).unwrap_or(u32::MAX)
        })
        .collect();
    cancel.check("measuring the faces' windows")?;
    let windows = (mesh.faces.par_iter().zip(face_grid))
        .map(|(t, &own)| {
            if cancel.is_cancelled() {
                return ([0.0; 2], Vec::new());
            }
            let mut ring: Vec<u32> = t
                .iter()
                .flat_map(|&v| faces_at[v as usize].clone())
                .collect();
            ring.sort_unstable();
            ring.dedup();
            let d = ring.iter().fold(0.0f64, |d, &f| d.max(parted[f as usize]));
            let cell = igt.grids[own as usize].cell.max_element();
            let base = d * SLACK + cell;
            let [a, b, c] = corners(t);
            let longest = (b - a).length().max((c - b).length()).max((a - c).length());
            let cap = (CAP_CELLS * cell).min(CAP_EDGES * longest);
            let (outside, inside) = reach(&points, &nearest, &ring, corners(t), cap);
            let window = [outside, inside].map(|h| base.max(h * SLACK + cell));
            let others = buckets.near_grids(igt, corners(t), window[0].max(window[1]));
            let others = others.into_iter().filter(|&g| g != own);
            let grids = std::iter::once(own).chain(others).take(MAX_GRIDS).collect();
            (window.map(|w| w as f32), grids)
        })
        .collect();
    cancel.check("measuring the faces' windows")?;
    Ok(windows)
}
