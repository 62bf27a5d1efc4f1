//! Filters on a set's surface (reshaping a model, as the Geometry Textures paper does with its
//! Gaussian and high-pass examples), and the seam gap they may open between patches.
//!
//! The paper filtered each height map on its own and saw seams open at 8 texels: two patches
//! that share a border smooth it along different height axes. Here the filter runs once in
//! world space over the texel points of all patches together (a Gaussian-weighted average of
//! the neighbours' offsets along each point's normal), so the same place gets the same
//! displacement whichever patch it is stored in; each displacement then goes back into its
//! patch as a height change (divided by the cosine between the normal and the patch's z axis).
//! Normals are filtered by the same weights in world space (the mean neighbour normal, or for
//! high-pass the normal pushed away from it), so a place gets one normal whichever patch holds
//! it and a tiny sigma leaves normals as they were. Rebuilding them per patch from the new
//! heights by finite differences had given patch-shaped shading steps and, at sigma -> 0, a
//! median change of 3 degrees (differences of quantized heights are not the mesh's normals).
//!
//! Space: world for the filter (points, normals, sigma), patch-local for the maps.

use glam::DVec3;
use rayon::prelude::*;

use crate::cancel::Cancel;
use crate::error::{parse_choice, GeomtexError, Result};
use crate::gtex::{
    decode_normal, encode_height, encode_normal, vertical_extent, GeometryTextureSet, Patch,
};
use crate::heightfield::height_at;
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
        if let (false, Some(g)) = (high_pass, gain) {
            return Err(GeomtexError::Parameter(format!(
                "gain applies only to kind='high_pass' (a Gaussian has none), got gain={g} with kind='gaussian'"
            )));
        }
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

/// What a Gaussian of `sigma` (world units) makes of each texel point p with normal n: the
/// weighted means of q - p and of the normals over neighbours q within 3 sigma facing the same
/// way (the mean normal not normalized).
/// Neighbours come from a uniform grid of 3-sigma cells (sorted keys, no hash map needed). The
/// grid already is the spatial index a k-d tree would be (a sphere query would test ~3x fewer
/// candidates than 27 cells on a surface, the same order of work), so far reaches are refused
/// (`check_reach`) rather than made faster. `cancel` is polled once per point.
fn neighbour_means(
    points: &[DVec3],
    normals: &[DVec3],
    sigma: f64,
    cancel: &Cancel,
) -> Result<Vec<(DVec3, DVec3)>> {
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
    let per_cell: Vec<Vec<(u32, (DVec3, DVec3))>> = starts
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
                    let (p, n) = (points[k as usize], normals[k as usize]);
                    if cancel.is_cancelled() {
                        return (k, (DVec3::ZERO, n)); // a dense cell can take seconds; dropped below
                    }
                    let (mut offset_sum, mut den, mut normal_sum) = (DVec3::ZERO, 0.0, DVec3::ZERO);
                    for &q in &near {
                        let d = points[q as usize] - p;
                        let d2 = d.length_squared();
                        let nq = normals[q as usize];
                        if d2 <= r * r && nq.dot(n) > 0.5 {
                            let w = (-d2 / (2.0 * sigma * sigma)).exp();
                            offset_sum += w * d;
                            den += w;
                            normal_sum += w * nq;
                        }
                    }
                    // The point itself always counts (w = 1), so den >= 1.
                    (k, (offset_sum / den, normal_sum / den))
                })
                .collect()
        })
        .collect();
    cancel.check("filtering")?;
    let mut out = vec![(DVec3::ZERO, DVec3::ZERO); points.len()];
    for (k, m) in per_cell.into_iter().flatten() {
        out[k as usize] = m;
    }
    Ok(out)
}

/// Below this cosine between a texel's normal and its patch's z axis the texel is steep: its
/// vertical line runs nearly along the surface, and a move along the normal divided by the
/// cosine (exact for a plane) magnifies a curved rim's offset up to 5x into hair-like spikes.
/// A steep texel takes its neighbours' vertical moves instead.
const STEEP_COS: f64 = 0.5;

/// Farthest (Chebyshev, texels) a steep texel looks for neighbours that are not steep.
const STEEP_REACH: usize = 3;

/// What the filter does to one filled texel: its move along the direction of the move (world
/// units) and its new world unit normal, with the cosine between that direction and the patch's
/// z axis.
#[derive(Clone, Copy, Debug)]
struct TexelMove {
    along_normal: f64,
    /// The direction of the move (world unit vector).
    direction: DVec3,
    normal: DVec3,
    cos: f64,
}

/// The set with its surface filtered (`sigma` in world units): every patch's heights moved by
/// the world-space filter, boxes refitted to the new height range, normals filtered in world
/// space too; colors and faces kept. `cancel` stops it (Interrupted) within a point's work.
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
            slots.push((k, t));
        }
    }
    cancel.check("filtering")?;
    let means = neighbour_means(&points, &normals, sigma, cancel)?;
    let mut moves: Vec<Vec<Option<TexelMove>>> =
        set.patches.iter().map(|p| vec![None; p.texels()]).collect();
    for ((&(k, t), &n), &(mean_offset, mean_normal)) in slots.iter().zip(&normals).zip(&means) {
        // The move is along the neighbours' mean normal, smooth across creases (a crease-split
        // shading normal would move two patches' texels at a crease apart).
        let direction = mean_normal.normalize_or(n);
        let offset = mean_offset.dot(direction);
        // Gaussian (gain -1): onto the neighbours' mean; high-pass: away from it, by gain.
        let normal = (n - gain * (mean_normal - n)).normalize_or(n);
        moves[k][t] = Some(TexelMove {
            along_normal: -gain * offset,
            direction,
            normal,
            cos: direction.dot(set.patches[k].axes[2]),
        });
    }
    let patches = set
        .patches
        .par_iter()
        .zip(&moves)
        .map(|(p, m)| refit(p, m))
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

/// The mean of `value` over the smallest square window around texel `t` of a `w` x `h` map
/// (reach 1, 2, ... `reach` texels) where it gives any, or None.
fn nearest_window_mean(
    (w, h): (usize, usize),
    t: usize,
    reach: usize,
    value: impl Fn(usize) -> Option<f64>,
) -> Option<f64> {
    let (i, j) = (t % w, t / w);
    (1..=reach).find_map(|r| {
        let (i0, j0) = (i.saturating_sub(r), j.saturating_sub(r));
        let (i1, j1) = ((i + r).min(w - 1), (j + r).min(h - 1));
        let found: Vec<f64> = (j0..=j1)
            .flat_map(|y| (i0..=i1).map(move |x| y * w + x))
            .filter_map(&value)
            .collect();
        (!found.is_empty()).then(|| found.iter().sum::<f64>() / found.len() as f64)
    })
}

/// Vertical moves (world units along the patch's z) of a patch's filled texels: a move along
/// the normal over the cosine where the texel is not steep; where it is, the mean of the nearest
/// window (up to `STEEP_REACH`) of such moves, or the move over `STEEP_COS` if none is near.
fn vertical_moves(p: &Patch, moves: &[Option<TexelMove>]) -> Vec<f64> {
    let size = (p.width as usize, p.height as usize);
    let direct = |m: &TexelMove| m.along_normal / m.cos.max(STEEP_COS);
    let steady = |t: usize| moves[t].filter(|m| m.cos >= STEEP_COS).map(|m| direct(&m));
    (0..moves.len())
        .map(|t| match moves[t] {
            None => 0.0,
            Some(m) if m.cos >= STEEP_COS => direct(&m),
            Some(m) => {
                nearest_window_mean(size, t, STEEP_REACH, steady).unwrap_or_else(|| direct(&m))
            }
        })
        .collect()
}

/// Largest miss (texels, in the patch plane) of a warped texel accepted by `moved_heights`.
const WARP_TOLERANCE: f64 = 0.05;

/// New heights (world units above the box floor) of a patch's texels once every filled texel's
/// point has moved by its displacement. The moved points form a warped grid; the height over
/// texel centre c is found where that grid passes over c: the source point s with
/// s + move(s) = c (fixed-point iteration on the bilinear blend of the texels' moves, as the
/// surface rule blends heights). This stays right on curved parts, where a move along the normal
/// divided by the cosine (`vertical_moves`, exact only for a plane) opens seams between patches;
/// that is the fallback where the warped point leaves the filled cells or does not settle.
fn moved_heights(p: &Patch, moves: &[Option<TexelMove>]) -> Vec<f64> {
    let (w, h) = (p.width as usize, p.height as usize);
    let texel = DVec3::new(p.extent.x / w as f64, p.extent.y / h as f64, 1.0);
    // Per filled texel: (move in texel units x, y and world z, old height in world units).
    let field: Vec<Option<glam::DVec4>> = p
        .heights
        .iter()
        .zip(moves)
        .map(|(&q, m)| {
            m.map(|m| {
                let d = m.along_normal * m.direction;
                let local = DVec3::new(d.dot(p.axes[0]), d.dot(p.axes[1]), d.dot(p.axes[2]));
                (local / texel).extend(p.decode_height(q as f64) * p.extent.z)
            })
        })
        .collect();
    let blend = |x: f64, y: f64| -> Option<glam::DVec4> {
        let (i, j) = (x.floor(), y.floor());
        let (fx, fy) = (x - i, y - j);
        let at = |di: f64, dj: f64| {
            let (ti, tj) = (
                (i + di).clamp(0.0, w as f64 - 1.0),
                (j + dj).clamp(0.0, h as f64 - 1.0),
            );
            field[tj as usize * w + ti as usize]
        };
        Some(
            at(0.0, 0.0)? * ((1.0 - fx) * (1.0 - fy))
                + at(1.0, 0.0)? * (fx * (1.0 - fy))
                + at(0.0, 1.0)? * ((1.0 - fx) * fy)
                + at(1.0, 1.0)? * (fx * fy),
        )
    };
    let fallback = vertical_moves(p, moves);
    (0..w * h)
        .map(|t| {
            let old = field[t].map_or(0.0, |f| f.w);
            let Some(f) = field[t] else {
                return old;
            };
            let target = glam::DVec2::new((t % w) as f64, (t / w) as f64);
            let mut source = target - f.truncate().truncate();
            for _ in 0..4 {
                match blend(source.x, source.y) {
                    Some(g) => source = target - g.truncate().truncate(),
                    None => return old + fallback[t],
                }
            }
            match blend(source.x, source.y) {
                Some(g)
                    if (source + g.truncate().truncate() - target).length() < WARP_TOLERANCE =>
                {
                    g.w + g.z
                }
                _ => old + fallback[t],
            }
        })
        .collect()
}

/// A patch with its filled texels moved (`moves`, indexed by texel; None where empty): the box
/// refitted to the new height range, heights re-encoded, normals replaced by the filtered ones.
fn refit(p: &Patch, moves: &[Option<TexelMove>]) -> Patch {
    let new = moved_heights(p, moves);
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
    // Only filled texels: the surface exists where a cell's four texels are filled, so the
    // dilated normals around it are never blended into what is shown.
    for (stored, m) in q.normals.iter_mut().zip(moves) {
        if let Some(m) = m {
            let n = m.normal;
            let local = DVec3::new(n.dot(p.axes[0]), n.dot(p.axes[1]), n.dot(p.axes[2]));
            *stored = encode_normal(local);
        }
    }
    q
}

/// The world unit normal patch `p` shows at patch-local (u, v): its normal map blended
/// bilinearly between texel centres (clamped at the border). The renderer leaves out texels
/// across a crease from the nearest one; on the smooth-normal sets this measures, that is the
/// same blend.
fn normal_at(p: &Patch, u: f64, v: f64) -> DVec3 {
    let (w, h) = (p.width as i64, p.height as i64);
    let (x, y) = (u * w as f64 - 0.5, v * h as f64 - 0.5);
    let (i, j) = (x.floor(), y.floor());
    let (fx, fy) = (x - i, y - j);
    let at = |di: i64, dj: i64| {
        let (ti, tj) = (
            (i as i64 + di).clamp(0, w - 1),
            (j as i64 + dj).clamp(0, h - 1),
        );
        decode_normal(p.normals[(tj * w + ti) as usize])
    };
    let local = at(0, 0) * (1.0 - fx) * (1.0 - fy)
        + at(1, 0) * fx * (1.0 - fy)
        + at(0, 1) * (1.0 - fx) * fy
        + at(1, 1) * fx * fy;
    (p.axes[0] * local.x + p.axes[1] * local.y + p.axes[2] * local.z).normalize_or_zero()
}

/// What neighbouring patches do where they meet, measured at points on each edge of the source
/// mesh shared by faces of two different patches.
#[derive(Clone, Debug, Default)]
pub struct Seams {
    /// World distance from one patch's surface point to the other patch's surface (its tangent
    /// plane there), both ways.
    pub gaps: Vec<f64>,
    /// Angle (degrees) between the normals the two patches show there: a shading step.
    pub normal_steps: Vec<f64>,
}

/// Where patch `p`'s surface passes over world point `x`: its patch-local (u, v, h).
fn surface_over(p: &Patch, x: DVec3) -> Option<DVec3> {
    let l = p.world_to_local(x);
    ((0.0..=1.0).contains(&l.x) && (0.0..=1.0).contains(&l.y))
        .then(|| height_at(p, l.x, l.y).map(|h| DVec3::new(l.x, l.y, h)))
        .flatten()
}

impl Seams {
    /// Adds the figures of patch `pa` against `pb` at world point `x` on their shared edge
    /// (nothing where either patch has no surface there: none, on a clean conversion).
    fn measure(&mut self, pa: &Patch, pb: &Patch, x: DVec3) {
        let Some(a) = surface_over(pa, x) else {
            return;
        };
        let on_a = pa.local_to_world(a);
        let Some(b) = surface_over(pb, on_a) else {
            return;
        };
        let (na, nb) = (normal_at(pa, a.x, a.y), normal_at(pb, b.x, b.y));
        // Vertical gap times the cosine of b's surface slope: the distance to b's tangent plane
        // (a vertical gap alone grows without bound on steep parts).
        let slope_cos = nb.dot(pb.axes[2]).abs();
        self.gaps
            .push((b.z - pb.world_to_local(on_a).z).abs() * pb.extent.z * slope_cos);
        self.normal_steps
            .push(na.dot(nb).clamp(-1.0, 1.0).acos().to_degrees());
    }
}

/// Gaps and normal steps between neighbouring patches along their charts' shared edges: at a
/// quarter, half and three quarters of each edge shared by faces of two different patches, both
/// ways. `mesh` must be the set's source (a patch listing a face it lacks is refused). `cancel`
/// is polled every 4096 faces.
pub fn seams(set: &GeometryTextureSet, mesh: &Mesh, cancel: &Cancel) -> Result<Seams> {
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
    let mut seams = Seams::default();
    for f in 0..mesh.faces.len() {
        if f % 4096 == 0 {
            cancel.check("measuring seams")?;
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
            let (pa, pb) = (&set.patches[a as usize], &set.patches[b as usize]);
            for t in [0.25, 0.5, 0.75] {
                let x = e0.lerp(e1, t);
                seams.measure(pa, pb, x);
                seams.measure(pb, pa, x);
            }
        }
    }
    Ok(seams)
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
