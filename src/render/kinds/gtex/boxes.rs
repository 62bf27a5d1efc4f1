//! The boxes the tracer's hierarchy holds for a texture set: each patch's box cut into the nodes
//! of its min-max pyramid at one level (nodes about 2^BOX_LEVEL texels wide), each piece only as
//! tall as the heights under it, pieces with no surface left out. Thin pieces are what keep the
//! searches per pixel near one: a ray enters few of them before its hit, where it would enter
//! several whole boxes (neighbouring charts' boxes are thick where the surface curves).
//!
//! Spaces: pieces are stored in patch-local space (the unit cube; x/y texture u/v, z height);
//! `placed` puts one in the space a matrix maps patch-local space to.

use bytemuck::{Pod, Zeroable};
use glam::{DMat3, DMat4, DVec3};

use crate::bvh::Aabb;
use crate::gtex::Patch;
use crate::heightfield::code_at_texel;

/// The pyramid level the boxes are cut at (16 x 16 cells); a patch with fewer levels is one box.
pub(crate) const BOX_LEVEL: u32 = 4;

/// `PatchBox` in gtex_types.wgsl: a piece of patch `patch_index`'s box, in its patch-local space,
/// and the pyramid level its node is at (where the search inside it starts).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
pub(crate) struct PatchBoxGpu {
    pub lo: [f32; 3],
    pub patch_index: u32,
    pub hi: [f32; 3],
    pub level: u32,
}

/// The pieces of patch `index`, from the min-max pyramid (heightfield::min_max_pyramid) of
/// `heights` (the patch's heights, or fewer of them: those it owns, owners.rs), each node's
/// column shrunk to the texels with heights as the tiles' pieces are (`column`): a ray walked
/// through the hierarchy then meets the surface where one walked through tiles does.
pub(crate) fn patch_boxes(
    index: u32,
    p: &Patch,
    heights: &[u16],
    pyramid: &[(u32, u32, Vec<u32>)],
) -> Vec<PatchBoxGpu> {
    let level = BOX_LEVEL.min(pyramid.len().saturating_sub(1) as u32);
    let (nw, nh, values) = &pyramid[level as usize];
    let cells = f64::from(1u32 << level);
    let code_max = f64::from(p.code_max());
    let decode = |code: u32| (f64::from(code) - 1.0) / (code_max - 1.0);
    // Heights are known to half a code (the search's graze tolerance).
    let dz = 0.5 / (code_max - 1.0);
    let mut boxes = Vec::new();
    for r in 0..*nh {
        for c in 0..*nw {
            let value = values[(r * nw + c) as usize];
            let held = held_texels(p, heights, (i64::from(c), i64::from(r)), cells as i64);
            if value == 0 || held.is_empty() {
                continue;
            }
            let ((i0, i1), (j0, j1)) = held_range(&held);
            let (u0, u1) = column(i64::from(c), cells as i64, i64::from(p.width), (i0, i1));
            let (v0, v1) = column(i64::from(r), cells as i64, i64::from(p.height), (j0, j1));
            let (z0, z1) = (decode(value & 0xffff) - dz, decode(value >> 16) + dz);
            boxes.push(PatchBoxGpu {
                lo: [u0, v0, z0].map(|x| x as f32),
                patch_index: index,
                hi: [u1, v1, z1].map(|x| x as f32),
                level,
            });
        }
    }
    boxes
}

/// The tiles' pieces of patch `index` (gtex_tiles_functions.wgsl): for each node of its min-max
/// pyramid at `level` (the pyramid's top if it has fewer) with surface in `heights` (the patch's
/// heights, or fewer of them, owners.rs), the node's column of u/v and, across it, a slab along
/// the plane z = a u + b v fitted to those heights: lo.z <= z - a u - b v <= hi.z, with (a, b)
/// as two f16 in `level` (the walk searches whole patches, so no piece needs a level). A box cut
/// to the heights is as tall as the surface rises across the node; a slab along its slope is as
/// thick as it curves, so a ray enters far fewer pieces it does not hit. Each slab is at least
/// `min_thickness` of the node's world width thick: one as thin as a flat chart's few codes,
/// entered from a far origin in patch-local units (where one unit is the box's height), would
/// lose the surface to f32 rounding. Beside each piece: whether its surface spans its whole
/// column (`spans_column`).
pub(crate) fn tile_pieces(
    index: u32,
    p: &Patch,
    heights: &[u16],
    pyramid: &[(u32, u32, Vec<u32>)],
    level: u32,
    min_thickness: f64,
) -> Vec<(PatchBoxGpu, bool)> {
    let level = level.min(pyramid.len().saturating_sub(1) as u32);
    let (nw, nh, values) = &pyramid[level as usize];
    let cells = 1i64 << level;
    let code_max = f64::from(p.code_max());
    let (w, h) = (i64::from(p.width), i64::from(p.height));
    let node_width = cells as f64 * (p.extent.x / w as f64).max(p.extent.y / h as f64);
    let thick = min_thickness * node_width / p.extent.z.max(1e-300);
    let dz = 0.5 / (code_max - 1.0);
    let mut pieces = Vec::new();
    for r in 0..i64::from(*nh) {
        for c in 0..i64::from(*nw) {
            if values[(r * i64::from(*nw) + c) as usize] == 0 {
                continue;
            }
            let held = held_texels(p, heights, (c, r), cells);
            if held.is_empty() {
                continue;
            }
            let texels: Vec<DVec3> = held.iter().map(|t| t.2).collect();
            let (a, b) = fit_slope(&texels);
            // Bilinear cells minus a plane stay bilinear: their extremes are at their corners,
            // the texels, and the map's sides for the cells there (whose far corners continue
            // the map past its edge, heightfield::code_at_texel).
            let sides =
                |k: i64, last: i64| [Some(0), (k == 0).then_some(-1), (k == last).then_some(1)];
            let across = held.iter().flat_map(|&(i, j, t)| {
                let (us, vs) = (sides(i, w - 1), sides(j, h - 1));
                us.into_iter().flatten().flat_map(move |si| {
                    vs.into_iter().flatten().filter_map(move |sj| {
                        let z = side_height(p, i, j, si, sj)?;
                        let u = if si == 0 {
                            t.x
                        } else {
                            f64::from((si + 1) / 2)
                        };
                        let v = if sj == 0 {
                            t.y
                        } else {
                            f64::from((sj + 1) / 2)
                        };
                        Some(z - a * u - b * v)
                    })
                })
            });
            let lo = across.clone().fold(f64::INFINITY, f64::min) - dz;
            let hi = across.fold(f64::NEG_INFINITY, f64::max) + dz;
            let grow = (0.5 * (thick - (hi - lo))).max(0.0);
            let ((i0, i1), (j0, j1)) = held_range(&held);
            let (u0, u1) = column(c, cells, w, (i0, i1));
            let (v0, v1) = column(r, cells, h, (j0, j1));
            let piece = PatchBoxGpu {
                lo: [u0, v0, lo - grow].map(|x| x as f32),
                patch_index: index,
                hi: [u1, v1, hi + grow].map(|x| x as f32),
                level: u32::from(half::f16::from_f64(a).to_bits())
                    | (u32::from(half::f16::from_f64(b).to_bits()) << 16),
            };
            pieces.push((piece, spans_column(p, heights, (c, r), cells)));
        }
    }
    pieces
}

/// The corner texels of pyramid node `(c, r)`'s cells (`cells` a side; cell k spans texels
/// k - 1 and k) that have a height in `heights`: (i, j, patch-local point).
fn held_texels(
    p: &Patch,
    heights: &[u16],
    (c, r): (i64, i64),
    cells: i64,
) -> Vec<(i64, i64, DVec3)> {
    let (w, h) = (i64::from(p.width), i64::from(p.height));
    (r * cells - 1..(r + 1) * cells)
        .filter(|&j| (0..h).contains(&j))
        .flat_map(|j| {
            (c * cells - 1..(c + 1) * cells)
                .filter(|&i| (0..w).contains(&i))
                .map(move |i| (i, j))
        })
        .filter_map(|(i, j)| {
            let q = heights[(j * w + i) as usize];
            (q != 0).then(|| (i, j, p.texel_local(i as u32, j as u32, q)))
        })
        .collect()
}

/// The first and last column (i) and row (j) of non-empty `held` texels.
fn held_range(held: &[(i64, i64, DVec3)]) -> ((i64, i64), (i64, i64)) {
    let range = |k: fn(&(i64, i64, DVec3)) -> i64| {
        held.iter()
            .fold((i64::MAX, i64::MIN), |(l, u), t| (l.min(k(t)), u.max(k(t))))
    };
    (range(|t| t.0), range(|t| t.1))
}

/// Whether the surface of patch `p` is one sheet across the whole column of the pyramid node
/// `(c, r)` (`cells` cells a side) and a texel past it (the column is a hair wider than the
/// node): every texel from one before the node's first corner texel to one past its last has a
/// height in `heights` (so the piece's slab was fitted to all of them) and lies inside the
/// outline (so every bilinear cell there is surface). A ray that crosses such a piece's slab from
/// one face to the other then crosses the surface: an any-hit walk needs no search to know it
/// (gtex_tiles_functions.wgsl). Nodes at the map's sides never span (their cells reach past it).
fn spans_column(p: &Patch, heights: &[u16], (c, r): (i64, i64), cells: i64) -> bool {
    let (w, h) = (i64::from(p.width), i64::from(p.height));
    let (i0, i1) = (c * cells - 2, (c + 1) * cells);
    let (j0, j1) = (r * cells - 2, (r + 1) * cells);
    if i0 < 0 || j0 < 0 || i1 >= w || j1 >= h {
        return false;
    }
    (j0..=j1).all(|j| {
        (i0..=i1).all(|i| {
            let t = (j * w + i) as usize;
            heights[t] != 0 && p.outline[t] >= 0
        })
    })
}

/// Patch-local height of the surface at texel (i, j) (si = sj = 0), or where its cell meets the
/// map's side (si, sj = -1 or 1 past the first or last texel): the blend of the texel and the
/// map continued past its edge; None where a corner is empty (no surface there).
fn side_height(p: &Patch, i: i64, j: i64, si: i32, sj: i32) -> Option<f64> {
    let codes = [(0, 0), (si, 0), (0, sj), (si, sj)]
        .map(|(di, dj)| code_at_texel(p, i + i64::from(di), j + i64::from(dj)));
    if codes.contains(&0.0) {
        return None;
    }
    Some(p.decode_height(codes.iter().sum::<f64>() / 4.0))
}

/// The u (or v) range of tile piece `n` (nodes of `cells` cells on a map `texels` wide) whose
/// texels with heights run from index `held.0` to `held.1`: the node's span, shrunk to those
/// texels' centres (a piece at the chart's outline, or cut by another patch's ownership, covers
/// only the part with surface), and out to the map's side where they reach it (cells there
/// repeat the side's texels); a hair wider, so that a ray along a shared side enters one of two.
fn column(n: i64, cells: i64, texels: i64, held: (i64, i64)) -> (f64, f64) {
    let duv = 1e-6;
    let node = |k: i64| (((k * cells) as f64 - 0.5) / texels as f64).clamp(0.0, 1.0);
    let centre = |k: i64| (k as f64 + 0.5) / texels as f64;
    let lo = if held.0 == 0 { 0.0 } else { centre(held.0) };
    let hi = if held.1 == texels - 1 {
        1.0
    } else {
        centre(held.1)
    };
    (node(n).max(lo) - duv, node(n + 1).min(hi) + duv)
}

/// The least-squares slopes (a, b) of z = a x + b y + c through `points`, rounded to f16 as the
/// shader reads them (the slab's bounds are then taken with the rounded slopes); (0, 0) where
/// the points do not fix a plane.
fn fit_slope(points: &[DVec3]) -> (f64, f64) {
    let n = points.len() as f64;
    let mean = points.iter().fold(DVec3::ZERO, |s, &q| s + q) / n.max(1.0);
    let (mut sxx, mut sxy, mut syy, mut sxz, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for q in points {
        let d = *q - mean;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
        sxz += d.x * d.z;
        syz += d.y * d.z;
    }
    let det = sxx * syy - sxy * sxy;
    if !det.is_finite() || det <= 1e-12 * (sxx * syy).max(1e-300) {
        return (0.0, 0.0);
    }
    let a = (sxz * syy - syz * sxy) / det;
    let b = (syz * sxx - sxz * sxy) / det;
    // The shader decodes normal f16 only (no f16 capability needed): smaller slopes are 0.
    let round = |v: f64| {
        let v = half::f16::from_f64(v.clamp(-6e4, 6e4));
        if v.is_normal() {
            v.to_f64()
        } else {
            0.0
        }
    };
    (round(a), round(b))
}

/// The slopes (a, b) of tile piece `b`'s slab (`tile_pieces`).
fn tile_piece_slopes(b: &PatchBoxGpu) -> (f64, f64) {
    let slope = |bits: u32| half::f16::from_bits(bits as u16).to_f64();
    (slope(b.level & 0xffff), slope(b.level >> 16))
}

/// The eight corners of tile piece `b` (`tile_pieces`) in patch-local space.
pub(crate) fn tile_piece_corners(b: &PatchBoxGpu) -> [DVec3; 8] {
    let (a, s) = tile_piece_slopes(b);
    std::array::from_fn(|k| {
        let u = f64::from(if k & 1 == 0 { b.lo[0] } else { b.hi[0] });
        let v = f64::from(if k & 2 == 0 { b.lo[1] } else { b.hi[1] });
        let c = f64::from(if k & 4 == 0 { b.lo[2] } else { b.hi[2] });
        DVec3::new(u, v, a * u + s * v + c)
    })
}

/// The axis-aligned bounds of a piece placed by `to_space` (from patch-local space).
pub(crate) fn placed(b: &PatchBoxGpu, to_space: &DMat4) -> Aabb {
    let lo = DVec3::from(b.lo.map(f64::from));
    let hi = DVec3::from(b.hi.map(f64::from));
    let centre = to_space.transform_point3(0.5 * (lo + hi));
    let linear = DMat3::from_mat4(*to_space);
    let abs = DMat3::from_cols(
        linear.x_axis.abs(),
        linear.y_axis.abs(),
        linear.z_axis.abs(),
    );
    let half = abs * (0.5 * (hi - lo));
    Aabb {
        lo: centre - half,
        hi: centre + half,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::heightfield::{height_at, min_max_pyramid, test_patch};

    /// A w x h patch of waves over the unit square, empty in one corner.
    fn wavy_patch(w: u32, h: u32) -> Patch {
        test_patch(w, h, 16, |i, j| {
            let (x, y) = (i as f64 / w as f64, j as f64 / h as f64);
            (x + y > 0.3).then(|| 0.5 + 0.4 * (9.0 * x).sin() * (7.0 * y).cos())
        })
    }

    /// Every surface point of a patch lies in one of its pieces, and the pieces are thinner
    /// than the whole box.
    #[test]
    fn pieces_hold_the_surface() {
        let p = wavy_patch(200, 150);
        let boxes = patch_boxes(3, &p, &p.heights, &min_max_pyramid(&p));
        assert!(boxes
            .iter()
            .all(|b| b.patch_index == 3 && b.level == BOX_LEVEL));
        let mean_height: f32 =
            boxes.iter().map(|b| b.hi[2] - b.lo[2]).sum::<f32>() / boxes.len() as f32;
        // The surface spans heights 0.1..0.9; 16-cell pieces of these waves measure 0.19.
        assert!(
            mean_height < 0.3,
            "pieces are thin: mean height {mean_height}"
        );
        for k in 0..4000 {
            let (u, v) = ((k % 97) as f64 / 96.0, (k / 97) as f64 / 41.0);
            let Some(h) = height_at(&p, u, v) else {
                continue;
            };
            let inside = boxes.iter().any(|b| {
                let q = [u, v, h];
                (0..3).all(|a| f64::from(b.lo[a]) <= q[a] && q[a] <= f64::from(b.hi[a]))
            });
            assert!(inside, "surface point ({u}, {v}, {h}) in no piece");
        }
    }

    /// A tile piece said to span its column has surface at every point of the column (a hair
    /// wider than its node), inside its slab, so a ray through the slab from face to face
    /// crosses it; the pieces by the empty corner and by a cut in the outline (texels with
    /// heights outside it) do not span.
    #[test]
    fn spanning_pieces_have_surface_across_their_columns() {
        let mut p = wavy_patch(200, 150);
        for j in 0..150 {
            for i in 100..103 {
                p.outline[j * 200 + i] = -20;
            }
        }
        let pyramid = min_max_pyramid(&p);
        let pieces = tile_pieces(3, &p, &p.heights, &pyramid, BOX_LEVEL, 0.0);
        let spanning: Vec<&PatchBoxGpu> = pieces.iter().filter(|x| x.1).map(|x| &x.0).collect();
        // Measured: 77 of 127 pieces span (none at the map's sides, the corner or the cut).
        assert!(
            (60..=90).contains(&spanning.len()),
            "{} of {} pieces span",
            spanning.len(),
            pieces.len()
        );
        for b in spanning {
            let (a, s) = tile_piece_slopes(b);
            for k in 0..=24 {
                for l in 0..=24 {
                    let at = |axis: usize, f: f64| {
                        f64::from(b.lo[axis]) + f * f64::from(b.hi[axis] - b.lo[axis])
                    };
                    let (u, v) = (at(0, f64::from(k) / 24.0), at(1, f64::from(l) / 24.0));
                    let h = height_at(&p, u, v)
                        .unwrap_or_else(|| panic!("no surface at ({u}, {v}) of a spanning piece"));
                    let across = h - a * u - s * v;
                    assert!(
                        f64::from(b.lo[2]) - 1e-6 <= across && across <= f64::from(b.hi[2]) + 1e-6,
                        "surface at ({u}, {v}) leaves the slab"
                    );
                }
            }
        }
    }

    /// Every surface point of a patch lies in one of its tile pieces (columns with slabs along
    /// fitted slopes), and the slabs are thinner than boxes cut to the heights at that level.
    #[test]
    fn tile_pieces_hold_the_surface() {
        let p = wavy_patch(200, 150);
        let pyramid = min_max_pyramid(&p);
        let pieces: Vec<PatchBoxGpu> = tile_pieces(3, &p, &p.heights, &pyramid, BOX_LEVEL, 0.0)
            .into_iter()
            .map(|(piece, _)| piece)
            .collect();
        let boxes = patch_boxes(3, &p, &p.heights, &pyramid);
        let thickness = |b: &PatchBoxGpu| f64::from(b.hi[2] - b.lo[2]);
        let mean =
            |list: &[PatchBoxGpu]| list.iter().map(thickness).sum::<f64>() / list.len() as f64;
        // Measured: slabs 0.052 thick on average against boxes 0.22 (the waves' slopes).
        assert!(
            mean(&pieces) < 0.5 * mean(&boxes),
            "{} {}",
            mean(&pieces),
            mean(&boxes)
        );
        for k in 0..4000 {
            let (u, v) = ((k % 97) as f64 / 96.0, (k / 97) as f64 / 41.0);
            let Some(h) = height_at(&p, u, v) else {
                continue;
            };
            let inside = pieces.iter().any(|b| {
                let (a, s) = tile_piece_slopes(b);
                let across = h - a * u - s * v;
                (0..2).all(|i| f64::from(b.lo[i]) <= [u, v][i] && [u, v][i] <= f64::from(b.hi[i]))
                    && f64::from(b.lo[2]) - 1e-6 <= across
                    && across <= f64::from(b.hi[2]) + 1e-6
            });
            assert!(inside, "surface point ({u}, {v}, {h}) in no tile piece");
        }
    }
}
