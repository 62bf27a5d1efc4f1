//! How far the points a level-of-detail search draws may lie from the source mesh, per pyramid
//! level of a patch. At its stop level L the max-pyramid search (heightfield_functions.wgsl,
//! `node_hit`) intersects the bilinear surface through a node's corner texels instead of the
//! exact cells inside it; that surface and the stored one both lie between the node's lowest and
//! highest code, so a drawn point is within (max - min) x extent.z of the stored surface, which
//! is within the largest cell bound inside the node (gtex::bound) of the mesh.
//!
//! Spaces: pyramid nodes in the cell grid (level-0 node (c, r) is cell (c - 1, r - 1) in
//! texel-centre coordinates, heightfield.rs); heights patch-local; bounds in the units of the
//! set's own space (placements scale them).

use crate::gtex::Patch;
use crate::heightfield::min_max_pyramid;

/// Per pyramid level, a bound on the distance from a point drawn at that level to the source
/// mesh: level 0 (exact search) the largest cell bound of the patch, level L > 0 the largest
/// over its nodes of the node's height range plus its largest cell bound; never less than the
/// level below (a node whose corners are empty is searched at finer levels). Without a bound map
/// only the height ranges (the distance to the stored surface).
pub(crate) fn level_bounds(p: &Patch) -> Vec<f64> {
    let pyramid = min_max_pyramid(p);
    let code_step = p.extent.z / f64::from(p.code_max() - 1);
    let mut cells = cell_bound_grid(p);
    let mut bounds = Vec::with_capacity(pyramid.len());
    for (level, (nw, nh, nodes)) in pyramid.iter().enumerate() {
        if level > 0 {
            cells = halved(&cells, nw, nh);
        }
        let worst = (nodes.iter().zip(&cells.1))
            .filter(|(&v, _)| v != 0)
            .map(|(&v, &cell)| {
                let range = if level == 0 {
                    0.0
                } else {
                    f64::from((v >> 16) - (v & 0xffff)) * code_step
                };
                range + cell
            })
            .fold(0.0, f64::max);
        let below = bounds.last().copied().unwrap_or(0.0);
        bounds.push(worst.max(below));
    }
    bounds
}

/// The bound of every cell, laid out as the pyramid's level 0 ((w + 1) x (h + 1), row by row from
/// cell (-1, -1)); zeros without a bound map.
fn cell_bound_grid(p: &Patch) -> (u32, Vec<f64>) {
    let (cw, ch) = (p.width + 1, p.height + 1);
    let cells = (0..ch as i64)
        .flat_map(|r| (0..cw as i64).map(move |c| (c - 1, r - 1)))
        .map(|(i, j)| {
            (p.error_bound.as_ref()).map_or(0.0, |m| m.at_cell(p.width, p.height, i, j))
        })
        .collect();
    (cw, cells)
}

/// The next level of a max grid `(width, values)`: each node the largest of its (up to four)
/// children, `nw` x `nh` nodes, as min_max_pyramid halves.
fn halved((pw, prev): &(u32, Vec<f64>), nw: &u32, nh: &u32) -> (u32, Vec<f64>) {
    let ph = prev.len() as u32 / pw.max(&1);
    let mut next = vec![0.0f64; (nw * nh) as usize];
    for r in 0..*nh {
        for c in 0..*nw {
            let children = [(0, 0), (1, 0), (0, 1), (1, 1)]
                .map(|(dc, dr)| (2 * c + dc, 2 * r + dr))
                .into_iter()
                .filter(|&(x, y)| x < *pw && y < ph)
                .map(|(x, y)| prev[(y * pw + x) as usize]);
            next[(r * nw + c) as usize] = children.fold(0.0, f64::max);
        }
    }
    (*nw, next)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gtex::ErrorBoundMap;
    use crate::heightfield::test_patch;

    #[test]
    fn level_bounds_add_the_node_height_range_to_the_cell_bounds() {
        // A ramp along x, 8 x 8 texels over a unit cube: heights 0, 1/7, ..., 1.
        let mut p = test_patch(8, 8, 16, |i, _| Some(f64::from(i) / 7.0));
        let bare = level_bounds(&p);
        assert_eq!(bare[0], 0.0);
        // Level-1 nodes span two cells, three texels of the ramp: a range of two steps of 1/7.
        let step = 1.0 / 7.0 * p.extent.z;
        assert!((bare[1] - 2.0 * step).abs() < 1e-3, "{bare:?}");
        assert!(bare.windows(2).all(|w| w[0] <= w[1]), "{bare:?}");
        let cells: Vec<f64> = (0..81).map(|k| if k == 40 { 0.5 } else { 0.01 }).collect();
        p.error_bound = Some(ErrorBoundMap::from_cells(8, 8, crate::gtex::bound::BLOCK, &cells));
        let with_map = level_bounds(&p);
        // The map's top code decodes to 0.5 exactly (it is the map's scale).
        assert_eq!(with_map[0], 0.5);
        assert!((with_map[1] - (0.5 + 2.0 * step)).abs() < 1e-3, "{with_map:?}");
        assert_eq!(with_map.len(), bare.len());
    }
}
