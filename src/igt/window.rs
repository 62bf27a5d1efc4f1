//! What the ray lookup of a simplified face searches (shaders/igt_functions.wgsl,
//! `igt_ray_lookup`): a window on either side of the face's plane, and the grids whose lists it
//! walks. Both are measured on the CPU with the projection lookup (lookup.rs): the face is
//! sampled, each sample projected into every grid whose detailed faces' bounding box holds it,
//! and the detailed point found inside a listed triangle gives the distance of the detailed
//! surface from the face's plane there. A face's window is the largest such distance (the
//! nearest grid's, per sample) over the faces sharing a vertex with it, since a ray crosses into
//! them; its further grids are the other grids that saw the detailed surface within that
//! window, most samples first. A face spanning charts thus finds the triangles of each.
//!
//! Spaces: world (the detailed and simplified meshes' own, f64); windows in the same units.

use glam::DVec3;
use rayon::prelude::*;

use super::InverseGeometricTexture;
use crate::mesh::Mesh;

/// Grids the ray lookup walks besides the face's own. On the bunny simplified to 0.5% (346
/// faces), the pixels of a face show the triangles of up to 8 grids (median 4; embree, front
/// view); its 4 most shown cover all but 1.3% of the pixels.
pub const MORE_GRIDS: usize = 8;
/// No grid (an unused slot of `MORE_GRIDS`).
pub const NO_GRID: u32 = u32::MAX;
/// Barycentric lattice order of the samples a face is measured at (15 points).
const SAMPLES: u32 = 4;
/// The window is the measured distance times this, plus a cell: samples miss the peaks between
/// them.
const SLACK: f64 = 1.25;

/// What one simplified face's samples saw: the largest distance to the detailed surface, and
/// per grid (own first) the samples that found it within `SLACK` times that.
struct Seen {
    parted: f64,
    grids: Vec<(u32, u32)>,
}

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

fn seen(
    igt: &InverseGeometricTexture,
    boxes: &[(DVec3, DVec3)],
    corners: [DVec3; 3],
    own: u32,
) -> Seen {
    let [a, b, c] = corners;
    let normal = (b - a).cross(c - a).normalize_or_zero();
    // A grid farther than the face's extent from a sample cannot list what lies under it.
    let reach = (b - a).length().max((c - b).length()).max((a - c).length());
    let n = SAMPLES;
    // Per sample: (grid, distance) of every grid that found it inside a listed triangle.
    let mut found: Vec<(u32, f64)> = Vec::new();
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
                let d = (q - p).dot(normal).abs();
                nearest = nearest.min(d);
                found.push((g as u32, d));
            }
            if nearest.is_finite() {
                parted = parted.max(nearest);
            }
        }
    }
    let mut grids: Vec<(u32, u32)> = vec![(own, 0)];
    for (g, d) in found {
        if d > parted * SLACK {
            continue;
        }
        match grids.iter_mut().find(|(h, _)| *h == g) {
            Some(slot) => slot.1 += 1,
            None => grids.push((g, 1)),
        }
    }
    Seen { parted, grids }
}

/// Per face of `mesh` (projected into grid `face_grid[f]`): its window and further grids.
pub fn windows(
    igt: &InverseGeometricTexture,
    mesh: &Mesh,
    face_grid: &[u32],
) -> (Vec<f32>, Vec<[u32; MORE_GRIDS]>) {
    let boxes = grid_boxes(igt);
    let seen: Vec<Seen> = (mesh.faces.par_iter().zip(face_grid))
        .map(|(t, &g)| seen(igt, &boxes, t.map(|v| mesh.positions[v as usize]), g))
        .collect();
    let mut faces_at: Vec<Vec<u32>> = vec![Vec::new(); mesh.positions.len()];
    for (f, t) in mesh.faces.iter().enumerate() {
        for &v in t {
            faces_at[v as usize].push(f as u32);
        }
    }
    (mesh.faces.par_iter().zip(face_grid))
        .map(|(t, &own)| {
            let mut near: Vec<u32> = t
                .iter()
                .flat_map(|&v| faces_at[v as usize].clone())
                .collect();
            near.sort_unstable();
            near.dedup();
            let parted = near
                .iter()
                .fold(0.0f64, |d, &f| d.max(seen[f as usize].parted));
            let mut counts: Vec<(u32, u32)> = Vec::new();
            for &f in &near {
                for &(g, k) in &seen[f as usize].grids {
                    match counts.iter_mut().find(|(h, _)| *h == g) {
                        Some(slot) => slot.1 += k,
                        None => counts.push((g, k)),
                    }
                }
            }
            counts.retain(|&(g, k)| g != own && k > 0);
            counts.sort_by_key(|&(g, k)| (std::cmp::Reverse(k), g));
            let mut more = [NO_GRID; MORE_GRIDS];
            for (slot, (g, _)) in more.iter_mut().zip(counts) {
                *slot = g;
            }
            let cell = igt.grids[own as usize].cell.max_element();
            ((parted * SLACK + cell) as f32, more)
        })
        .collect()
}
