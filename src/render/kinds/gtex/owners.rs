//! Which patch a stretch of surface near a chart border belongs to, for the tiles' pieces. Each
//! chart's maps also hold its overlap rings (neighbouring faces, so that no crack opens between
//! charts), so near every border the same surface is stored twice, and a ray hitting it entered
//! both patches' pieces before its hit: two searches. Here a texel is left out of its patch's
//! pieces where another patch holds the same surface (same point within a few texels, normals on
//! the same side) further inside its own drawn region, by more than MARGIN: the band both keep
//! shrinks from twice the rings' width to about MARGIN, and no ray loses the surface, since
//! the other patch's pieces hold it (the surface stays in the maps; a search that started in a
//! kept piece still finds it).
//!
//! Spaces: world (the set's object space) for comparing patches, patch-local for each map.

use glam::DVec3;
use rayon::prelude::*;

use crate::gtex::{chamfer, GeometryTextureSet, Patch};

/// Chamfer distance units per texel (steps 3 across, 4 diagonally).
const UNIT: u32 = 3;

/// Texels a patch keeps past the middle of the band two patches share, in distance units.
const MARGIN: u32 = 3 * UNIT;

/// Texels deeper than this inside their drawn region (distance units) are always kept: rings
/// are narrower, and it spares the search for owners in most of a chart.
const DEEPEST: u32 = 96 * UNIT;

/// Per texel, the chamfer distance (UNIT per texel) to the nearest texel without surface, the
/// map's outside counting as without; 0 for texels without surface.
fn inside_distance(p: &Patch) -> Vec<u32> {
    let mut d: Vec<u32> = (0..p.texels())
        .map(|t| if p.is_surface(t) { u32::MAX / 2 } else { 0 })
        .collect();
    let (w, h) = (p.width as usize, p.height as usize);
    chamfer(&mut d, w, h, (UNIT, UNIT), 4, Some(0));
    d
}

/// Whether patch `b` (with inside distances `db`) shows world point `x` (normal `n`) further
/// inside its drawn region than `depth` + MARGIN.
fn shown_deeper(b: &Patch, db: &[u32], x: DVec3, n: DVec3, depth: u32, tolerance: f64) -> bool {
    let q = b.world_to_local(x);
    let slack = tolerance / b.extent.z.max(1e-300);
    if !(0.0..1.0).contains(&q.x)
        || !(0.0..1.0).contains(&q.y)
        || !(-slack..1.0 + slack).contains(&q.z)
    {
        return false;
    }
    let (i, j) = (
        (q.x * f64::from(b.width)) as u32,
        (q.y * f64::from(b.height)) as u32,
    );
    let t = (j.min(b.height - 1) * b.width + i.min(b.width - 1)) as usize;
    if !b.is_surface(t) || db[t] <= depth + MARGIN {
        return false;
    }
    let h = b.decode_height(f64::from(b.heights[t]));
    (q.z - h).abs() * b.extent.z <= tolerance && b.world_normal(t).dot(n) > 0.5
}

/// The texels of `a` (columns i0..i1, rows j0..j1) whose world points can lie in `b`'s box
/// widened by `tolerance` along its height (as `shown_deeper` accepts them): those within the
/// bounds of that box's corners seen from `a`, one texel wider each way for rounding.
fn texels_under(a: &Patch, b: &Patch, tolerance: f64) -> ((u32, u32), (u32, u32)) {
    let slack = tolerance / b.extent.z.max(1e-300);
    let corners = crate::render::cull::box_corners(
        DVec3::new(0.0, 0.0, -slack),
        DVec3::new(1.0, 1.0, 1.0 + slack),
    )
    .map(|c| a.world_to_local(b.local_to_world(c)));
    let range = |lo: f64, hi: f64, n: u32| {
        // Texel k's centre is at (k + 0.5) / n.
        let first = (lo * f64::from(n) - 0.5).floor() - 1.0;
        let last = (hi * f64::from(n) - 0.5).ceil() + 1.0;
        let clamp = |v: f64| v.clamp(0.0, f64::from(n)) as u32;
        (clamp(first), clamp(last + 1.0))
    };
    if !corners.iter().all(|c| c.is_finite()) {
        return ((0, a.width), (0, a.height)); // no bound to trust: every texel
    }
    let lo = corners.iter().fold(DVec3::INFINITY, |m, &c| m.min(c));
    let hi = corners.iter().fold(DVec3::NEG_INFINITY, |m, &c| m.max(c));
    (range(lo.x, hi.x, a.width), range(lo.y, hi.y, a.height))
}

/// Each patch's heights with the texels another patch shows further inside its own region set
/// to empty (module doc); only for cutting pieces, never drawn.
pub(crate) fn owned_heights(set: &GeometryTextureSet) -> Vec<Vec<u16>> {
    let inside: Vec<Vec<u32>> = set.patches.par_iter().map(inside_distance).collect();
    let bounds: Vec<(DVec3, DVec3)> = set
        .patches
        .iter()
        .map(|p| {
            let corners = crate::render::cull::box_corners(DVec3::ZERO, DVec3::ONE)
                .map(|c| p.local_to_world(c));
            let lo = corners.iter().fold(DVec3::INFINITY, |a, &c| a.min(c));
            let hi = corners.iter().fold(DVec3::NEG_INFINITY, |a, &c| a.max(c));
            (lo, hi)
        })
        .collect();
    // Two samplings of one surface differ by a texel's slope across half a texel; 4 texels
    // also covers steep stretches, and stays far below the gap between two sheets (normals
    // pointing apart rule those out anyway).
    let tolerance = 4.0 * set.texel_size;
    (0..set.patches.len())
        .into_par_iter()
        .map(|a| {
            let pa = &set.patches[a];
            let (lo, hi) = bounds[a];
            let others: Vec<usize> = (0..set.patches.len())
                .filter(|&b| {
                    b != a
                        && (bounds[b].0 - tolerance).cmple(hi).all()
                        && (bounds[b].1 + tolerance).cmpge(lo).all()
                })
                .collect();
            // World point and normal of each texel in the band that may be owned elsewhere.
            let band: Vec<Option<(DVec3, DVec3)>> = (0..pa.texels())
                .map(|t| {
                    let depth = inside[a][t];
                    let (i, j) = (t as u32 % pa.width, t as u32 / pa.width);
                    (depth != 0 && depth <= DEEPEST).then(|| {
                        let x = pa.local_to_world(pa.texel_local(i, j, pa.heights[t]));
                        (x, pa.world_normal(t))
                    })
                })
                .collect();
            let mut heights = pa.heights.clone();
            // Each other patch is asked only about the texels under its box: the same answers
            // as asking it about every texel, for a third of the tests on a rough scan.
            for &b in &others {
                let pb = &set.patches[b];
                let ((i0, i1), (j0, j1)) = texels_under(pa, pb, tolerance);
                for j in j0..j1 {
                    for i in i0..i1 {
                        let t = (j * pa.width + i) as usize;
                        let Some((x, n)) = band[t] else { continue };
                        if heights[t] != 0
                            && shown_deeper(pb, &inside[b], x, n, inside[a][t], tolerance)
                        {
                            heights[t] = 0;
                        }
                    }
                }
            }
            heights
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::heightfield::test_patch;

    /// A 100 x 100 flat patch at height 0.5 of a unit box placed at `origin`.
    fn flat_at(origin: DVec3) -> Patch {
        Patch {
            origin,
            ..test_patch(100, 100, 16, |_, _| Some(0.5))
        }
    }

    /// Two patches sharing a 20-texel band of one plane each give up the half of it nearer
    /// their own outline, less MARGIN (3 texels), and every texel of the band stays in one of
    /// them; a sheet 0.3 above, far beyond the tolerance, takes nothing.
    #[test]
    fn a_shared_band_is_split_between_its_patches() {
        let set = GeometryTextureSet {
            patches: vec![
                flat_at(DVec3::ZERO),
                flat_at(DVec3::new(0.8, 0.0, 0.0)),
                flat_at(DVec3::new(0.0, 0.0, 0.3)),
            ],
            texel_size: 0.01,
            ..Default::default()
        };
        let owned = owned_heights(&set);
        let row = |k: usize| &owned[k][50 * 100..51 * 100];
        // A's texel i and B's texel i - 80 lie over the same point: A is 100 - i texels from
        // its outline there, B i - 79; A gives it up from i = 92, B below i = 88.
        let a_kept: Vec<bool> = row(0).iter().map(|&q| q != 0).collect();
        let b_kept: Vec<bool> = row(1).iter().map(|&q| q != 0).collect();
        assert!(a_kept[..92].iter().all(|&k| k) && a_kept[92..].iter().all(|&k| !k));
        assert!(b_kept[..8].iter().all(|&k| !k) && b_kept[8..].iter().all(|&k| k));
        assert_eq!(owned[2], set.patches[2].heights);
    }
}
