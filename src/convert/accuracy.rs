//! Reconstruction error of a patch, both ways:
//! - mesh → patch: how far the height field (bilinear in cells whose four texels hold surface,
//!   decoded codes, src/heightfield.rs) lies from points sampled on the chart's own triangles;
//!   the vertical gap times the cosine of the field's local slope, the first-order distance to
//!   the field (a bare vertical gap would count a steep chart's error up to 1/cos too high);
//! - patch → mesh: how far the texels that conservative coverage extended past the triangles
//!   (the lips, src/convert/raster.rs) lie from the triangle they copy, and how far the texel
//!   corners where the field has surface but no triangle lies under them (a coarse map's
//!   cells and flat border reaching over a notch or past the outline) are from the nearest
//!   triangle. Without it a flat chart would look exact at any resolution while its 2×2 map
//!   covers its whole bounding box (the error-driven fandisk rendered with IoU 0.965).
//!
//! Every value carries the area it stands for, so quantiles are by area whatever the sample
//! spacing of each chart.
//!
//! Space: world in (mesh positions, samples), patch-local (unit box) for the lookup; errors and
//! areas in world units. A chart never folds over its height axis after repair, so each sample
//! has exactly one surface above or below it.

use glam::DVec3;

use super::raster::Maps;
use crate::gtex::Patch;
use crate::heightfield::height_and_slope;
use crate::mesh::Mesh;

/// Charts sample their surface at most this often to measure reconstruction error.
pub const SAMPLES_PER_CHART: usize = 20_000;
/// Reconstruction error is this quantile (by area) of the distances: the maximum would be set
/// by the few samples at creases and rims, where a bilinear map of any resolution rounds corners.
pub const ERROR_QUANTILE: f64 = 0.99;

/// An error (world units) and the surface area it stands for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeightedError {
    pub value: f64,
    pub area: f64,
}

/// A point on the mesh and the surface area it stands for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaSample {
    pub point: DVec3,
    pub area: f64,
}

/// Points spread uniformly by area over `faces`, each with the area it stands for: each triangle
/// is cut into n² similar sub-triangles (n from its area and `spacing`) and contributes their
/// centroids, so the pattern is deterministic. About 2 area / spacing² points, at most ~`cap`
/// (spacing grows to fit).
pub fn surface_samples(mesh: &Mesh, faces: &[u32], spacing: f64, cap: usize) -> Vec<AreaSample> {
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
        let each = area([a, b, c]) / (n * n) as f64;
        let (e1, e2) = ((b - a) / n as f64, (c - a) / n as f64);
        // Upward sub-triangles (i, j) and downward ones, centroids in grid units.
        for i in 0..n {
            for j in 0..n - i {
                let (fi, fj) = (i as f64, j as f64);
                out.push(AreaSample {
                    point: a + e1 * (fi + 1.0 / 3.0) + e2 * (fj + 1.0 / 3.0),
                    area: each,
                });
                if i + j + 1 < n {
                    out.push(AreaSample {
                        point: a + e1 * (fi + 2.0 / 3.0) + e2 * (fj + 2.0 / 3.0),
                        area: each,
                    });
                }
            }
        }
    }
    out
}

/// Samples a coarser level measures: about `SAMPLES_PER_TEXEL` per texel of area (as fixed
/// resolution samples), every k-th of `samples` with its area scaled so the total is kept, and
/// all of them where that is no fewer. The error search draws each chart at up to a few dozen
/// levels, mostly far coarser than the texel the samples were spaced for; thinning makes each
/// level cost about its texels.
pub fn thinned(samples: &[AreaSample], texel: f64) -> std::borrow::Cow<'_, [AreaSample]> {
    let area: f64 = samples.iter().map(|s| s.area).sum();
    let want = (SAMPLES_PER_TEXEL * area / (texel * texel)).max(MIN_SAMPLES as f64);
    let k = (samples.len() as f64 / want).floor() as usize;
    if k < 2 {
        return std::borrow::Cow::Borrowed(samples);
    }
    let kept: Vec<AreaSample> = samples.iter().step_by(k).copied().collect();
    let scale = area / kept.iter().map(|s| s.area).sum::<f64>();
    std::borrow::Cow::Owned(
        kept.into_iter()
            .map(|s| AreaSample {
                area: s.area * scale,
                ..s
            })
            .collect(),
    )
}

/// Samples per texel of area a level is measured with: `surface_samples` at a texel's spacing
/// gives about two.
pub const SAMPLES_PER_TEXEL: f64 = 2.0;
/// Fewest samples a level is measured with, however coarse.
const MIN_SAMPLES: usize = 256;

/// Distances from the samples to the patch's height field; samples off the map are skipped.
/// A sample under no surface (the outline map cut it away: a chart narrower than its texels)
/// counts as a hole a texel deep, so a resolution too coarse to hold the chart's shape is not
/// mistaken for an accurate one.
pub fn gaps(p: &Patch, samples: &[AreaSample]) -> Vec<WeightedError> {
    let texel_len = ((p.extent.x / p.width as f64) * (p.extent.y / p.height as f64)).sqrt();
    samples
        .iter()
        .filter_map(|&AreaSample { point, area }| {
            let l = p.world_to_local(point);
            if !(0.0..=1.0).contains(&l.x) || !(0.0..=1.0).contains(&l.y) {
                return None;
            }
            let Some((h, [du, dv])) = height_and_slope(p, l.x, l.y) else {
                return Some(WeightedError {
                    value: texel_len,
                    area,
                });
            };
            // World rise per world run along x and y.
            let (sx, sy) = (du * p.extent.z / p.extent.x, dv * p.extent.z / p.extent.y);
            let gap = (h - l.z).abs() * p.extent.z;
            Some(WeightedError {
                value: gap / (1.0 + sx * sx + sy * sy).sqrt(),
                area,
            })
        })
        .collect()
}

/// Surface reaching past the mesh, as errors: the lips and overhanging corners of `maps`, drawn
/// with texels `texel_len` wide (the geometric mean of their sides).
///
/// Surface reaching `d` past the mesh over a texel's width stands for about d × texel of area (a
/// texel at most). A chart's box is padded by up to half a texel, so its flat border often
/// reaches a little past the outline; counted as a whole texel each, such slivers alone would
/// set the p99 of a map a few hundred texels wide.
pub fn past_the_mesh(maps: &Maps, texel_len: f64) -> impl Iterator<Item = WeightedError> + '_ {
    let weighted = move |d: f64| WeightedError {
        value: d,
        area: texel_len * d.min(texel_len),
    };
    let lips = maps.lips.iter().map(move |lip| weighted(lip.distance));
    lips.chain(maps.overhangs.iter().map(move |&d| weighted(d)))
}

/// The `q`-quantile (0..=1) of the values, each counted by its area; 0 for none.
pub fn quantile(values: &mut [WeightedError], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_unstable_by(|a, b| a.value.total_cmp(&b.value));
    let total: f64 = values.iter().map(|v| v.area).sum();
    let mut acc = 0.0;
    for v in values.iter() {
        acc += v.area;
        if acc >= q * total {
            return v.value;
        }
    }
    values[values.len() - 1].value
}

/// A whole set's reconstruction error: its `ERROR_QUANTILE` by area and its largest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SetError {
    pub quantile: f64,
    pub max: f64,
}

impl SetError {
    /// Of all the charts' errors together.
    pub fn of(mut errors: Vec<WeightedError>) -> SetError {
        let max = errors.iter().map(|e| e.value).fold(0.0, f64::max);
        SetError {
            quantile: quantile(&mut errors, ERROR_QUANTILE),
            max,
        }
    }
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
            .map(|s| s.point)
            .all(|p| p.z == 0.0 && p.x >= 0.0 && p.y >= 0.0 && p.x + p.y <= 6.0));
        let left = s.iter().filter(|s| s.point.x + s.point.y < 2.0).count();
        assert_eq!(left, 400);
        // Each stands for its share of the area: 6 in all.
        assert!((s.iter().map(|s| s.area).sum::<f64>() - 6.0).abs() < 1e-9);
        // The cap coarsens the spacing instead of dropping triangles.
        let capped = surface_samples(&mesh, &[0, 1, 2], 0.1, 300);
        assert!(
            capped.len() <= 3 * 100 && capped.len() >= 3 * 49,
            "{}",
            capped.len()
        );
    }

    #[test]
    fn thinning_keeps_the_area_and_about_two_samples_a_texel() {
        let mesh = Mesh::from_flat(
            &[0., 0., 0., 2., 0., 0., 0., 2., 0., 2., 2., 0.],
            &[0, 1, 2, 1, 3, 2],
            None,
        )
        .unwrap();
        let s = surface_samples(&mesh, &[0, 1], 0.01, 1_000_000);
        // 4 units of area at a texel of 0.1: 800 samples wanted of ~80,000 (every k-th, k
        // rounded down: measured 820).
        let t = thinned(&s, 0.1);
        assert!((800..=840).contains(&t.len()), "{}", t.len());
        assert!((t.iter().map(|s| s.area).sum::<f64>() - 4.0).abs() < 1e-9);
        assert!(t.iter().any(|s| s.point.x > 1.8) && t.iter().any(|s| s.point.x < 0.2));
        // As fine as the samples themselves: all of them.
        assert_eq!(thinned(&s, 0.01).len(), s.len());
        // However coarse, at least MIN_SAMPLES.
        assert!(thinned(&s, 10.0).len() >= MIN_SAMPLES);
    }

    #[test]
    fn quantile_by_area() {
        let weighted = |value: f64, area: f64| WeightedError { value, area };
        let mut v: Vec<WeightedError> = (0..100).map(|i| weighted(i as f64, 1.0)).collect();
        assert_eq!(quantile(&mut v, 0.99), 98.0);
        assert_eq!(quantile(&mut v, 0.0), 0.0);
        assert_eq!(quantile(&mut [], 0.5), 0.0);
        // One value standing for as much area as all the others: it is the median.
        v.push(weighted(1000.0, 100.0));
        assert_eq!(quantile(&mut v, 0.51), 1000.0);
        assert_eq!(quantile(&mut v, 0.49), 97.0);
    }
}
