//! Reconstruction error of a patch: how far its height field (bilinear in cells whose four
//! texels hold surface, decoded codes, src/heightfield.rs) lies from points sampled on the
//! chart's own triangles, measured along the patch's height axis.
//!
//! Space: world in (mesh positions, samples), patch-local (unit box) for the lookup; errors in
//! world units. A chart never folds over its height axis after repair, so each sample has exactly
//! one surface above or below it and the vertical gap bounds the distance to the surface.

use glam::DVec3;

use crate::gtex::Patch;
use crate::heightfield::height_at;
use crate::mesh::Mesh;

/// Points spread uniformly by area over `faces`: each triangle is cut into n² similar
/// sub-triangles (n from its area and `spacing`) and contributes their centroids, so the pattern
/// is deterministic. About 2 area / spacing² points, at most ~`cap` (spacing grows to fit).
pub fn surface_samples(mesh: &Mesh, faces: &[u32], spacing: f64, cap: usize) -> Vec<DVec3> {
    let corners = |f: u32| mesh.faces[f as usize].map(|v| mesh.positions[v as usize]);
    let area = |[a, b, c]: [DVec3; 3]| 0.5 * (b - a).cross(c - a).length();
    let total: f64 = faces.iter().map(|&f| area(corners(f))).sum();
    let spacing = spacing.max((2.0 * total / cap.max(1) as f64).sqrt());
    let mut out = Vec::new();
    for &f in faces {
        let [a, b, c] = corners(f);
        let n = ((2.0 * area([a, b, c])).sqrt() / spacing)
            .ceil()
            .clamp(1.0, 64.0) as usize;
        let (e1, e2) = ((b - a) / n as f64, (c - a) / n as f64);
        // Upward sub-triangles (i, j) and downward ones, centroids in grid units.
        for i in 0..n {
            for j in 0..n - i {
                let (fi, fj) = (i as f64, j as f64);
                out.push(a + e1 * (fi + 1.0 / 3.0) + e2 * (fj + 1.0 / 3.0));
                if i + j + 1 < n {
                    out.push(a + e1 * (fi + 2.0 / 3.0) + e2 * (fj + 2.0 / 3.0));
                }
            }
        }
    }
    out
}

/// Vertical gaps |surface − sample| (world units) at the samples under which the patch has a
/// surface; samples off the map or in a cell without four filled texels are skipped (the rim,
/// which conservative coverage and neighbouring patches account for).
pub fn gaps(p: &Patch, samples: &[DVec3]) -> Vec<f64> {
    samples
        .iter()
        .filter_map(|&s| {
            let l = p.world_to_local(s);
            if !(0.0..=1.0).contains(&l.x) || !(0.0..=1.0).contains(&l.y) {
                return None;
            }
            height_at(p, l.x, l.y).map(|h| (h - l.z).abs() * p.extent.z)
        })
        .collect()
}

/// The q-quantile (0..=1) of `values` (nearest rank); 0 for none.
pub fn quantile(values: &mut [f64], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let k = ((values.len() - 1) as f64 * q).round() as usize;
    *values.select_nth_unstable_by(k, f64::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_are_uniform_by_area_and_on_the_triangle() {
        let mesh = Mesh::from_flat(
            &[0., 0., 0., 2., 0., 0., 0., 2., 0., 2., 2., 0., 4., 0., 0.],
            &[0, 1, 2, 1, 3, 2, 1, 4, 3],
            None,
        )
        .unwrap();
        let s = surface_samples(&mesh, &[0, 1, 2], 0.1, 1_000_000);
        // Each triangle has area 2: n = ceil(sqrt(2 * 2) / 0.1) = 20, so 400 samples each.
        assert_eq!(s.len(), 3 * 400);
        assert!(s
            .iter()
            .all(|p| p.z == 0.0 && p.x >= 0.0 && p.y >= 0.0 && p.x + p.y <= 6.0));
        let left = s.iter().filter(|p| p.x + p.y < 2.0).count();
        assert_eq!(left, 400);
        // The cap coarsens the spacing instead of dropping triangles.
        let capped = surface_samples(&mesh, &[0, 1, 2], 0.1, 300);
        assert!(
            capped.len() <= 3 * 100 && capped.len() >= 3 * 49,
            "{}",
            capped.len()
        );
    }

    #[test]
    fn quantile_by_rank() {
        let mut v: Vec<f64> = (0..101).map(|i| i as f64).collect();
        assert_eq!(quantile(&mut v, 0.99), 99.0);
        assert_eq!(quantile(&mut v, 0.0), 0.0);
        assert_eq!(quantile(&mut [], 0.5), 0.0);
    }
}
