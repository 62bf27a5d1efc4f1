//! Filters on a set's surface (reshaping a model, as the Geometry Textures paper does with its
//! Gaussian and high-pass examples), and the seam gap they may open between patches.
//!
//! The paper filtered each height map on its own and saw seams open at 8 texels: two patches
//! that share a border smooth it along different height axes. Here the filter runs once in
//! world space over the texel points of all patches together (a Gaussian-weighted average of
//! the neighbours' offsets along each point's normal), so the same place gets the same
//! displacement whichever patch it is stored in; each displacement then goes back into its
//! patch as a height change (divided by the cosine between the normal and the patch's z axis).
//! Normal maps are rebuilt from the new heights by central differences.
//!
//! Space: world for the filter (points, normals, sigma), patch-local for the maps.

use glam::DVec3;
use rayon::prelude::*;

use crate::cancel::Cancel;
use crate::error::{parse_choice, GeomtexError, Result};
use crate::gtex::{
    decode_snorm8, encode_height, encode_snorm8, vertical_extent, GeometryTextureSet, Patch,
};
use crate::heightfield::{grid_normal, height_at};
use crate::mesh::{Mesh, MeshGeometry};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MapFilter {
    /// Gaussian low-pass: smooths.
    Gaussian,
    /// Unsharp masking, h + gain (h - gaussian(h)): exaggerates detail finer than sigma.
    HighPass { gain: f64 },
}

/// `gain` of a high-pass filter when none is given.
pub const DEFAULT_GAIN: f64 = 1.0;

impl MapFilter {
    /// The filter named `kind` ("gaussian" | "high_pass"); `gain` (default `DEFAULT_GAIN`) is
    /// the high-pass filter's and is checked when the filter runs.
    pub fn from_name(kind: &str, gain: Option<f64>) -> Result<MapFilter> {
        let high_pass = parse_choice("kind", kind, &[("gaussian", false), ("high_pass", true)])?;
        Ok(if high_pass {
            MapFilter::HighPass {
                gain: gain.unwrap_or(DEFAULT_GAIN),
            }
        } else {
            MapFilter::Gaussian
        })
    }
}

/// Most neighbour candidates (points in the 27 cells around a point's) a filter may weigh per
/// point on average: about 8 minutes for the bunny's 3 M texel points on 2 cores. A sigma beyond
/// it reaches across most of a model, which is no longer a filter of its detail.
pub const MAX_MEAN_CANDIDATES: f64 = 50_000.0;

/// Refuses a sigma whose 3-sigma cells would make each point weigh more than
/// `MAX_MEAN_CANDIDATES` neighbours, or more than half of all points, on average. `near` holds,
/// per occupied cell, (points in it, points in its 27 neighbouring cells).
fn check_reach(near: &[(usize, usize)], points: usize, sigma: f64) -> Result<()> {
    let pairs: f64 = near.iter().map(|&(n, m)| n as f64 * m as f64).sum();
    let mean = pairs / points.max(1) as f64;
    let limit = MAX_MEAN_CANDIDATES.min(0.5 * points as f64);
    if mean <= limit || points < 2 {
        return Ok(());
    }
    // On a surface the candidates grow as sigma squared.
    let fits = sigma * (limit / mean).sqrt();
    Err(GeomtexError::Parameter(format!(
        "sigma = {sigma} reaches too far: each of the {points} texel points would weigh {mean:.0} \
         neighbours on average (limit {limit:.0}, at most half the model); use sigma <= {fits:.3e}"
    )))
}

/// Offsets along the normal that a Gaussian of `sigma` (world units) would move each texel
/// point by: the weighted mean of (q - p)·n over neighbours q within 3 sigma facing the same way.
/// Neighbours come from a uniform grid of 3-sigma cells (sorted keys, no hash map needed). The
/// grid already is the spatial index a k-d tree would be (a sphere query would test ~3x fewer
/// candidates than 27 cells on a surface, the same order of work), so far reaches are refused
/// (`check_reach`) rather than made faster. `cancel` is polled once per point.
fn normal_offsets(
    points: &[DVec3],
    normals: &[DVec3],
    sigma: f64,
    cancel: &Cancel,
) -> Result<Vec<f64>> {
    let r = 3.0 * sigma;
    let cell = |p: DVec3| (p / r).floor().as_i64vec3().to_array();
    // Keys computed once and sorted on all cores: a sequential sort by a computed key took
    // seconds on 3 M points, too long to wait for Ctrl-C.
    let mut keyed: Vec<([i64; 3], u32)> = points
        .par_iter()
        .enumerate()
        .map(|(k, &p)| (cell(p), k as u32))
        .collect();
    keyed.par_sort_unstable();
    cancel.check("filtering")?;
    let (keys, order): (Vec<[i64; 3]>, Vec<u32>) = keyed.into_iter().unzip();
    let range = |key: [i64; 3]| {
        let lo = keys.partition_point(|k| *k < key);
        let hi = keys.partition_point(|k| *k <= key);
        lo..hi
    };
    // Runs of equal keys are the occupied cells; each gathers its 27 neighbours' points once.
    let mut starts: Vec<usize> = (0..keys.len())
        .filter(|&i| i == 0 || keys[i] != keys[i - 1])
        .collect();
    starts.push(keys.len());
    let around = |c: [i64; 3]| {
        (-1..=1).flat_map(move |dz| {
            (-1..=1).flat_map(move |dy| (-1..=1).map(move |dx| [c[0] + dx, c[1] + dy, c[2] + dz]))
        })
    };
    let counts: Vec<(usize, usize)> = starts
        .par_windows(2)
        .map(|w| {
            (
                w[1] - w[0],
                around(keys[w[0]]).map(|c| range(c).len()).sum(),
            )
        })
        .collect();
    check_reach(&counts, points.len(), sigma)?;
    cancel.check("filtering")?;
    let per_cell: Vec<Vec<(u32, f64)>> = starts
        .par_windows(2)
        .map(|w| {
            if cancel.is_cancelled() {
                return Vec::new(); // reported below
            }
            let mut near: Vec<u32> = Vec::new();
            for c in around(keys[w[0]]) {
                near.extend_from_slice(&order[range(c)]);
            }
            order[w[0]..w[1]]
                .iter()
                .map(|&k| {
                    if cancel.is_cancelled() {
                        return (k, 0.0); // a dense cell can take seconds; dropped below
                    }
                    let (p, n) = (points[k as usize], normals[k as usize]);
                    let (mut num, mut den) = (0.0, 0.0);
                    for &q in &near {
                        let d = points[q as usize] - p;
                        let d2 = d.length_squared();
                        if d2 <= r * r && normals[q as usize].dot(n) > 0.5 {
                            let w = (-d2 / (2.0 * sigma * sigma)).exp();
                            num += w * d.dot(n);
                            den += w;
                        }
                    }
                    (k, if den > 0.0 { num / den } else { 0.0 })
                })
                .collect()
        })
        .collect();
    cancel.check("filtering")?;
    let mut out = vec![0.0; points.len()];
    for (k, d) in per_cell.into_iter().flatten() {
        out[k as usize] = d;
    }
    Ok(out)
}

/// The set with its surface filtered (`sigma` in world units): every patch's heights moved by
/// the world-space filter, boxes refitted to the new height range, normals rebuilt; colors and
/// faces kept. `cancel` stops it (Interrupted) within a point's work.
pub fn filtered(
    set: &GeometryTextureSet,
    filter: MapFilter,
    sigma: f64,
    cancel: &Cancel,
) -> Result<GeometryTextureSet> {
    if !(sigma.is_finite() && sigma > 0.0) {
        return Err(GeomtexError::Parameter(format!(
            "sigma must be a positive finite length (world units), got {sigma}"
        )));
    }
    let gain = match filter {
        MapFilter::Gaussian => -1.0,
        MapFilter::HighPass { gain } => {
            if !(gain.is_finite() && gain > 0.0 && gain <= 100.0) {
                return Err(GeomtexError::Parameter(format!(
                    "gain must be in (0, 100], got {gain}"
                )));
            }
            gain
        }
    };
    // Every filled texel (outline maps carried as they are) as a world point with its normal.
    let mut points = Vec::new();
    let mut normals = Vec::new();
    let mut slots = Vec::new();
    for (k, p) in set.patches.iter().enumerate() {
        for (t, point, normal) in p.filled_texels() {
            let normal = if normal == DVec3::ZERO {
                p.axes[2]
            } else {
                normal
            };
            points.push(point);
            normals.push(normal);
            slots.push((k as u32, t as u32, normal.dot(p.axes[2])));
        }
    }
    // Gaussian: move each point onto its neighbours' average (offset d); high-pass: away from it.
    cancel.check("filtering")?;
    let offsets = normal_offsets(&points, &normals, sigma, cancel)?;
    let mut moved: Vec<Vec<f64>> = set
        .patches
        .iter()
        .map(|p| {
            p.heights
                .iter()
                .map(|&q| p.decode_height(q as f64) * p.extent.z)
                .collect()
        })
        .collect();
    for (&(k, t, cos), &d) in slots.iter().zip(&offsets) {
        // Along the normal by -gain * d is along the patch's z by that over cos (kept >= 0.2
        // so a point on a steep part cannot be thrown out of its patch).
        moved[k as usize][t as usize] += -gain * d / cos.max(0.2);
    }
    let patches = set
        .patches
        .iter()
        .zip(moved)
        .map(|(p, z)| refit(p, &z))
        .collect();
    let mut out = GeometryTextureSet {
        patches,
        texel_size: set.texel_size,
        stats: set.stats.clone(),
    };
    out.stats.set("filter_sigma", sigma);
    out.stats.set("bytes", out.map_bytes() as f64);
    out.validate()
        .map_err(|e| GeomtexError::Internal(format!("filtering made an impossible set: {e}")))?;
    Ok(out)
}

/// A patch with new heights `z` (world units above its box's bottom; only filled texels count):
/// the box refitted to their range, heights re-encoded, normals rebuilt.
fn refit(p: &Patch, new: &[f64]) -> Patch {
    let (w, h) = (p.width as usize, p.height as usize);
    let texel = (p.extent.x / w as f64, p.extent.y / h as f64);
    let mask: Vec<bool> = p.heights.iter().map(|&q| q > 0).collect();
    let filled = || new.iter().zip(&mask).filter(|(_, &m)| m).map(|(&v, _)| v);
    let lo = filled().fold(f64::INFINITY, f64::min);
    let hi = filled().fold(f64::NEG_INFINITY, f64::max);
    let mut q = p.clone();
    if lo > hi {
        return q; // an empty patch stays empty
    }
    let (thickness, bits) = vertical_extent(hi - lo, p.texel_size(), p.height_bits);
    let bottom = lo - 0.5 * (thickness - (hi - lo));
    q.origin = p.origin + p.axes[2] * bottom;
    q.extent.z = thickness;
    q.height_bits = bits;
    q.heights = new
        .iter()
        .zip(&mask)
        .map(|(&v, &m)| {
            if m {
                encode_height((v - bottom) / thickness, bits)
            } else {
                0
            }
        })
        .collect();
    // Normals by central differences of the filtered heights (one-sided next to empty texels).
    let at = |i: usize, j: usize| mask[j * w + i].then(|| new[j * w + i]);
    for j in 0..h {
        for i in 0..w {
            if mask[j * w + i] {
                q.normals[j * w + i] = encode_snorm8(grid_normal(at, (w, h), (i, j), texel));
            }
        }
    }
    q
}

/// The texel (column, row) holding patch-local (u, v).
fn texel_at(p: &Patch, u: f64, v: f64) -> (usize, usize) {
    let i = ((u * p.width as f64) as usize).min(p.width as usize - 1);
    let j = ((v * p.height as f64) as usize).min(p.height as usize - 1);
    (i, j)
}

/// Gaps between neighbouring patches along their charts' shared edges (world units): at points
/// on each edge shared by faces of two different patches, the distance from the first patch's
/// surface point to the second patch's surface (its tangent plane there), both ways. Points
/// where either patch has no surface are skipped (none, on a clean conversion). `cancel` is
/// polled every 4096 faces.
pub fn seam_gaps(set: &GeometryTextureSet, mesh: &Mesh, cancel: &Cancel) -> Result<Vec<f64>> {
    let mut owner = vec![u32::MAX; mesh.faces.len()];
    for (k, p) in set.patches.iter().enumerate() {
        for &f in &p.faces {
            let slot = owner.get_mut(f as usize).ok_or_else(|| {
                GeomtexError::Parameter(format!(
                    "patch {k} lists face {f}, but the mesh has {} faces: not the mesh it was converted from",
                    mesh.faces.len()
                ))
            })?;
            *slot = k as u32;
        }
    }
    let geo = MeshGeometry::new(mesh);
    let surface_point = |p: &Patch, x: DVec3| -> Option<(f64, f64, f64)> {
        let l = p.world_to_local(x);
        ((0.0..=1.0).contains(&l.x) && (0.0..=1.0).contains(&l.y))
            .then(|| height_at(p, l.x, l.y).map(|h| (l.x, l.y, h)))
            .flatten()
    };
    let mut gaps = Vec::new();
    for f in 0..mesh.faces.len() {
        if f % 4096 == 0 {
            cancel.check("measuring seam gaps")?;
        }
        let a = owner[f];
        if a == u32::MAX {
            continue;
        }
        for &g in geo.face_neighbors.row(f) {
            let b = owner[g as usize];
            if b == u32::MAX || b == a || (g as usize) < f {
                continue;
            }
            let tf = mesh.faces[f].map(|v| geo.weld[v as usize]);
            let shared: Vec<u32> = mesh.faces[g as usize]
                .iter()
                .map(|&v| geo.weld[v as usize])
                .filter(|v| tf.contains(v))
                .collect();
            if shared.len() < 2 {
                continue;
            }
            let (e0, e1) = (
                mesh.positions[shared[0] as usize],
                mesh.positions[shared[1] as usize],
            );
            for t in [0.25, 0.5, 0.75] {
                let x = e0.lerp(e1, t);
                for (pa, pb) in [(a, b), (b, a)] {
                    let (pa, pb) = (&set.patches[pa as usize], &set.patches[pb as usize]);
                    let Some((u, v, h)) = surface_point(pa, x) else {
                        continue;
                    };
                    let on_a = pa.local_to_world(DVec3::new(u, v, h));
                    let Some((ub, vb, hb)) = surface_point(pb, on_a) else {
                        continue;
                    };
                    let hb_of_a = pb.world_to_local(on_a).z;
                    // Vertical gap times the cosine of b's surface slope: the distance to b's
                    // tangent plane (a vertical gap alone grows without bound on steep parts).
                    let (i, j) = texel_at(pb, ub, vb);
                    let n = decode_snorm8(pb.normals[j * pb.width as usize + i]);
                    let slope_cos = n.normalize_or_zero().z.abs();
                    gaps.push((hb - hb_of_a).abs() * pb.extent.z * slope_cos);
                }
            }
        }
    }
    Ok(gaps)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 40 x 40 sample sheet z = sin(x) with unit spacing, as one patch.
    fn sheet() -> GeometryTextureSet {
        let grid = crate::grids::HeightGrid {
            width: 40,
            height: 40,
            origin: glam::DVec2::ZERO,
            spacing: glam::DVec2::ONE,
            z: (0..1600).map(|t| ((t % 40) as f64 * 0.3).sin()).collect(),
            colors: None,
        };
        crate::grids::from_grids(&[grid], None, None).unwrap()
    }

    #[test]
    fn far_reaching_sigma_is_refused_and_a_set_token_interrupts() {
        let set = sheet();
        let cancel = Cancel::new();
        assert!(filtered(&set, MapFilter::Gaussian, 1.0, &cancel).is_ok());
        // 3 sigma = 30 samples: every point would weigh most of the 1600.
        let e = filtered(&set, MapFilter::Gaussian, 10.0, &cancel).unwrap_err();
        assert!(matches!(&e, GeomtexError::Parameter(_)));
        assert!(e.to_string().contains("reaches too far"), "{e}");
        cancel.cancel();
        let e = filtered(&set, MapFilter::Gaussian, 1.0, &cancel).unwrap_err();
        assert!(matches!(e, GeomtexError::Interrupted(_)));
    }

    #[test]
    fn filters_by_name() {
        assert_eq!(
            MapFilter::from_name("gaussian", None).unwrap(),
            MapFilter::Gaussian
        );
        assert_eq!(
            MapFilter::from_name("high_pass", None).unwrap(),
            MapFilter::HighPass { gain: 1.0 }
        );
        assert_eq!(
            MapFilter::from_name("high_pass", Some(2.5)).unwrap(),
            MapFilter::HighPass { gain: 2.5 }
        );
        let e = MapFilter::from_name("x", None).unwrap_err();
        assert!(matches!(&e, GeomtexError::Parameter(_)));
        assert_eq!(
            e.to_string(),
            "kind must be 'gaussian' or 'high_pass', got \"x\""
        );
    }
}
