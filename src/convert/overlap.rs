//! Overlap rings: each chart also draws k rings of neighbouring faces, so neighbouring patches
//! share a border and no crack opens between them.
//!
//! Space: none (topology only), plus a normal·z test in world space.

use glam::DVec3;

use super::frame::FOLD_COS;
use crate::mesh::{Mesh, MeshGeometry};

/// A chart's overlap ring: the faces it also draws, and how many were left out for facing down.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Ring {
    pub faces: Vec<u32>,
    pub skipped: usize,
}

/// Faces within `rings` vertex-rings of the chart, not in it, not degenerate, and facing up in
/// the chart's frame (a ring face with normal·z <= 0 would fold the patch).
pub fn ring_faces(mesh: &Mesh, geo: &MeshGeometry, chart: &[u32], z: DVec3, rings: usize) -> Ring {
    if rings == 0 {
        return Ring::default();
    }
    let mut seen: std::collections::HashSet<u32> = chart.iter().copied().collect();
    let mut frontier: Vec<u32> = chart.to_vec();
    let mut kept = Vec::new();
    let mut skipped = 0;
    for _ in 0..rings {
        let mut next = Vec::new();
        for &f in &frontier {
            for &v in &mesh.faces[f as usize] {
                for &g in geo.vertex_faces.row(v as usize) {
                    if seen.insert(g) {
                        next.push(g);
                    }
                }
            }
        }
        next.sort_unstable();
        for &g in &next {
            if geo.face_normals[g as usize].dot(z) > FOLD_COS {
                kept.push(g);
            } else {
                skipped += 1;
            }
        }
        // Grow only through faces that were kept: a ring must not wrap round a thin part.
        frontier = next
            .into_iter()
            .filter(|&g| geo.face_normals[g as usize].dot(z) > FOLD_COS)
            .collect();
    }
    Ring {
        faces: kept,
        skipped,
    }
}
