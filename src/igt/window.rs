//! What the ray lookup of a simplified face searches (shaders/igt_functions.wgsl,
//! `igt_ray_lookup`): a window on either side of the face's plane, and the grids whose lists it
//! walks. Both are measured on the CPU with the projection lookup (lookup.rs): the face is
//! sampled, each sample projected into every grid whose detailed faces' bounding box holds it,
//! and the detailed point found inside a listed triangle gives the distance of the detailed
//! surface from the face's plane there. A face's window is the largest such distance (the
//! nearest grid's, per sample) over the faces sharing a vertex with it, since a ray crosses into
//! them. Its further grids are those owning detailed faces near it (centroids within the window
//! of its plane and `LATERAL` windows of its edges), nearest first: a face spanning charts thus
//! finds the triangles of each. (Choosing them from the samples' projections instead missed
//! small charts: on the bunny at 0.5%, nearly every pixel whose face the ray lookup got wrong
//! showed a grid outside the face's set.)
//!
//! Spaces: world (the detailed and simplified meshes' own, f64); windows in the same units.

use glam::DVec3;
use rayon::prelude::*;

use super::InverseGeometricTexture;
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
/// Buckets of detailed face centroids along the bounding box's longest side.
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

/// The detailed faces' centroids in buckets of a uniform grid.
struct Buckets {
    lo: DVec3,
    size: f64,
    map: std::collections::HashMap<[i64; 3], Vec<u32>>,
    centroids: Vec<DVec3>,
}

impl Buckets {
    fn new(igt: &InverseGeometricTexture) -> Buckets {
        let centroids: Vec<DVec3> = (igt.faces.iter())
            .map(|t| t.iter().map(|&v| igt.positions[v as usize]).sum::<DVec3>() / 3.0)
            .collect();
        let (lo, hi) = (centroids.iter())
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &c| {
                (l.min(c), h.max(c))
            });
        let size = ((hi - lo).max_element() / BUCKETS).max(f64::MIN_POSITIVE);
        let mut map: std::collections::HashMap<[i64; 3], Vec<u32>> = Default::default();
        for (f, c) in centroids.iter().enumerate() {
            if igt.face_grid[f] != u32::MAX {
                map.entry(Self::key(lo, size, *c))
                    .or_default()
                    .push(f as u32);
            }
        }
        Buckets {
            lo,
            size,
            map,
            centroids,
        }
    }

    fn key(lo: DVec3, size: f64, p: DVec3) -> [i64; 3] {
        ((p - lo) / size).floor().as_i64vec3().to_array()
    }

    /// The grids owning detailed faces whose centroids lie within `window` of the plane of the
    /// face with `corners` and `LATERAL` windows of its edges, nearest first (by their nearest
    /// centroid's distance from the plane plus its distance outside the edges).
    fn near_grids(
        &self,
        igt: &InverseGeometricTexture,
        corners: [DVec3; 3],
        window: f64,
    ) -> Vec<u32> {
        let [a, b, c] = corners;
        let normal = (b - a).cross(c - a).normalize_or_zero();
        let side = window * LATERAL;
        // Inward edge normals in the plane (a degenerate face keeps only the slab test).
        let edges =
            [(a, b), (b, c), (c, a)].map(|(p, q)| (p, normal.cross(q - p).normalize_or_zero()));
        let lo = Self::key(self.lo, self.size, a.min(b).min(c) - side);
        let hi = Self::key(self.lo, self.size, a.max(b).max(c) + side);
        let mut nearest: Vec<(u32, f64)> = Vec::new();
        for i in lo[0]..=hi[0] {
            for j in lo[1]..=hi[1] {
                for k in lo[2]..=hi[2] {
                    for &f in self.map.get(&[i, j, k]).into_iter().flatten() {
                        let p = self.centroids[f as usize];
                        let height = (p - a).dot(normal).abs();
                        let outside = (edges.iter())
                            .fold(0.0f64, |o, (e, inward)| o.max(-(p - *e).dot(*inward)));
                        if height > window || outside > side {
                            continue;
                        }
                        let g = igt.face_grid[f as usize];
                        match nearest.iter_mut().find(|(h, _)| *h == g) {
                            Some(slot) => slot.1 = slot.1.min(height + outside),
                            None => nearest.push((g, height + outside)),
                        }
                    }
                }
            }
        }
        nearest.sort_by(|x, y| x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)));
        nearest.into_iter().map(|(g, _)| g).collect()
    }
}

/// Per face of `mesh` (projected into grid `face_grid[f]`): its window and the grids it walks
/// (its own first).
pub fn windows(
    igt: &InverseGeometricTexture,
    mesh: &Mesh,
    face_grid: &[u32],
) -> (Vec<f32>, Vec<Vec<u32>>) {
    let boxes = grid_boxes(igt);
    let corners = |t: &[u32; 3]| t.map(|v| mesh.positions[v as usize]);
    let parted: Vec<f64> = (mesh.faces.par_iter().zip(face_grid))
        .map(|(t, &g)| parted(igt, &boxes, corners(t), g))
        .collect();
    let mut faces_at: Vec<Vec<u32>> = vec![Vec::new(); mesh.positions.len()];
    for (f, t) in mesh.faces.iter().enumerate() {
        for &v in t {
            faces_at[v as usize].push(f as u32);
        }
    }
    let buckets = Buckets::new(igt);
    (mesh.faces.par_iter().zip(face_grid))
        .map(|(t, &own)| {
            let near = t.iter().flat_map(|&v| &faces_at[v as usize]);
            let d = near.fold(0.0f64, |d, &f| d.max(parted[f as usize]));
            let cell = igt.grids[own as usize].cell.max_element();
            let window = d * SLACK + cell;
            let others = buckets.near_grids(igt, corners(t), window).into_iter();
            let others = others.filter(|&g| g != own);
            let grids = std::iter::once(own).chain(others).take(MAX_GRIDS).collect();
            (window as f32, grids)
        })
        .collect()
}
