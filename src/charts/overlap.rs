//! Overlap rings: each chart also draws k rings of neighbouring faces, so neighbouring patches
//! share a border and no crack opens between them.
//!
//! Space: none (topology only), plus normal tests in world space.

use std::collections::{HashMap, HashSet};

use glam::DVec3;

use super::frame::FOLD_COS;
use crate::mesh::{Mesh, MeshGeometry};

/// A ring face is drawn only if its normal lies within this angle (degrees) of a face it grows
/// from (one sharing a vertex with it). Across a sharper crease the bilinear cells between the
/// two faces' texels cut the crease's edge off (about a quarter texel times the change of slope:
/// half a texel at a 90 degree step seen at 45 degrees), and rays grazing the crease at a
/// silhouette fell through that cut onto the surface behind, or hit a ring that stood proud of
/// it (fandisk: 1% of pixels off by 90 degrees). There the chart ends at the crease instead:
/// its lips continue its own faces' plane to the outline, and the other chart does the same.
pub const RING_CREASE_DEG: f64 = 40.0;

/// A chart's overlap ring: the faces it also draws, and how many were left out for facing down
/// or lying across a crease sharper than `RING_CREASE_DEG`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Ring {
    pub faces: Vec<u32>,
    pub skipped: usize,
}

/// Faces within `rings` vertex-rings of the chart, not in it, not degenerate, facing up in the
/// chart's frame (a ring face with normal·z <= 0 would fold the patch) and within
/// `RING_CREASE_DEG` of a face they grow from.
pub fn ring_faces(mesh: &Mesh, geo: &MeshGeometry, chart: &[u32], z: DVec3, rings: usize) -> Ring {
    let crease_cos = RING_CREASE_DEG.to_radians().cos();
    let normal = |f: u32| geo.face_normals[f as usize];
    let mut seen: HashSet<u32> = chart.iter().copied().collect();
    let mut frontier: Vec<u32> = chart.to_vec();
    let mut kept = Vec::new();
    for _ in 0..rings {
        // Each new face with the largest cosine between its normal and a frontier face's it
        // shares a vertex with.
        let mut next: HashMap<u32, f64> = HashMap::new();
        for &f in &frontier {
            for &v in &mesh.faces[f as usize] {
                for &g in geo.vertex_faces.row(v as usize) {
                    if !seen.contains(&g) {
                        let c = normal(f).dot(normal(g));
                        let best = next.entry(g).or_insert(c);
                        *best = best.max(c);
                    }
                }
            }
        }
        let mut next: Vec<(u32, f64)> = next.into_iter().collect();
        next.sort_unstable_by_key(|&(g, _)| g);
        seen.extend(next.iter().map(|&(g, _)| g));
        // Grow only through faces that were kept: a ring must not wrap round a thin part.
        frontier = next
            .into_iter()
            .filter(|&(g, c)| normal(g).dot(z) > FOLD_COS && c >= crease_cos)
            .map(|(g, _)| g)
            .collect();
        kept.extend_from_slice(&frontier);
    }
    Ring {
        skipped: seen.len() - chart.len() - kept.len(),
        faces: kept,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit step seen from above: a floor strip (faces 0, 1) at z = 0, a wall (2, 3) at x = 1
    /// and a top strip (4, 5) at z = 1, joined at two 90 degree creases.
    fn step() -> Mesh {
        let v = [
            [0., 0., 0.],
            [1., 0., 0.],
            [1., 1., 0.],
            [0., 1., 0.],
            [1., 0., 1.],
            [1., 1., 1.],
            [2., 0., 1.],
            [2., 1., 1.],
        ];
        let flat: Vec<f64> = v.iter().flatten().copied().collect();
        Mesh::from_flat(
            &flat,
            &[0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 2, 4, 6, 7, 4, 7, 5],
            None,
        )
        .unwrap()
    }

    #[test]
    fn rings_stop_at_sharp_creases() {
        let m = step();
        let geo = MeshGeometry::new(&m);
        // The floor's ring would take the wall (normal -x, 90 degrees from the floor's +z).
        let ring = ring_faces(&m, &geo, &[0, 1], DVec3::new(-0.5, 0.0, 1.0).normalize(), 2);
        assert!(ring.faces.is_empty(), "{ring:?}");
        assert_eq!(ring.skipped, 2);
        // A gentle fold (10 degrees) keeps its ring.
        let t = 10f64.to_radians();
        let bent = Mesh::from_flat(
            &[
                0.,
                0.,
                0.,
                1.,
                0.,
                0.,
                1.,
                1.,
                0.,
                0.,
                1.,
                0.,
                2.,
                0.,
                t.sin(),
                2.,
                1.,
                t.sin(),
            ],
            &[0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 2],
            None,
        )
        .unwrap();
        let geo = MeshGeometry::new(&bent);
        let ring = ring_faces(&bent, &geo, &[0, 1], DVec3::Z, 1);
        assert_eq!(ring.faces, vec![2, 3]);
        assert_eq!(ring.skipped, 0);
    }
}
