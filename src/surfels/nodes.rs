//! Levels above the tile: per patch, a quadtree over its grid of tiles whose nodes each hold one
//! surfel merged from their 2x2 children (tiles' top surfels, then nodes), up to a single node
//! per patch. A renderer draws a cut of it (render/kinds/surfels.rs): a node when its projected
//! error is within the budget and its parent's is not, a tile's level when its parent node's is
//! not. Errors never fall going up and a node's sphere holds its children's, so a node within the
//! budget has every descendant within it and the cut is chosen per node in parallel.
//!
//! Spaces: world (f64), and the patch's grid of tiles (column, row) for grouping only.

use std::collections::BTreeMap;

use glam::DVec3;

use super::{disc_error, Disc, Reach};
use crate::surfel_data::{Node, Surfel, Tile};

/// A tile or node while the level above it is merged.
struct Item {
    disc: Disc,
    error: f64,
    cone: (DVec3, f64),
    centre: DVec3,
    bound: f64,
    /// The patch's tiles below it.
    tiles: Vec<usize>,
    /// Its cell in its level's grid.
    cell: (u32, u32),
    /// Its node index (local to the patch), None for a tile.
    node: Option<usize>,
}

fn disc_of(s: &Surfel) -> Disc {
    Disc {
        position: s.position,
        normal: s.normal,
        radius: s.radius,
        color: s.color.map(f64::from),
        texels: s.texels,
    }
}

/// The cone holding every child's cone.
fn merged_cone(cones: &[(DVec3, f64)]) -> (DVec3, f64) {
    let sum: DVec3 = cones.iter().map(|c| c.0).sum();
    let axis = sum.try_normalize().unwrap_or(cones[0].0);
    let angle = cones
        .iter()
        .map(|(a, half)| a.dot(axis).clamp(-1.0, 1.0).acos() + half)
        .fold(0.0, f64::max)
        .min(std::f64::consts::PI);
    (axis, angle)
}

/// The node over `children`, its surfel at `level`; `tiles` are the patch's tiles (surfel
/// indices local to each tile).
fn merge(
    children: &[&Item],
    tiles: &[(Tile, Vec<Surfel>)],
    level: u8,
    reach: &Reach,
) -> (Node, Vec<usize>) {
    let discs: Vec<Disc> = children.iter().map(|c| c.disc).collect();
    let disc = Disc::merge(&discs);
    let below: Vec<usize> = children.iter().flat_map(|c| c.tiles.clone()).collect();
    let mut error = (children.iter().map(|c| c.error)).fold(reach.over(disc.texels), f64::max);
    for &k in &below {
        let (t, local) = &tiles[k];
        for f in &local[t.start[0] as usize..t.start[1] as usize] {
            error = error.max(disc_error(f, disc.position, disc.normal));
        }
    }
    let cones: Vec<(DVec3, f64)> = children.iter().map(|c| c.cone).collect();
    let (lo, hi) = children.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), c| (lo.min(c.centre), hi.max(c.centre)),
    );
    let centre = 0.5 * (lo + hi);
    let bound = children
        .iter()
        .map(|c| c.centre.distance(centre) + c.bound)
        .fold(disc.position.distance(centre) + disc.radius, f64::max);
    let surfel = Surfel {
        position: disc.position,
        normal: disc.normal,
        radius: disc.radius,
        color: disc.color.map(|c| c.round().clamp(0.0, 255.0) as u8),
        parent: u32::MAX,
        level,
        texels: disc.texels,
    };
    let node = Node {
        surfel,
        parent: u32::MAX,
        error,
        cone: merged_cone(&cones),
        centre,
        bound,
        patch: tiles[below[0]].0.patch,
    };
    (node, below)
}

/// The nodes above one patch's tiles (indices local to the patch, lowest level first); sets
/// each tile's `parent` to its node (local index).
pub(super) fn patch_nodes(
    tiles: &mut [(Tile, Vec<Surfel>)],
    tile: u32,
    levels: u32,
    reach: &Reach,
) -> Vec<Node> {
    let top = levels as usize - 1;
    let mut items: Vec<Item> = tiles
        .iter()
        .enumerate()
        .map(|(k, (t, local))| Item {
            disc: disc_of(&local[t.start[top] as usize]),
            error: t.error[top],
            cone: (local[t.start[top] as usize].normal, 0.0),
            centre: t.centre,
            bound: t.bound,
            tiles: vec![k],
            cell: (t.texel[0] / tile, t.texel[1] / tile),
            node: None,
        })
        .collect();
    let mut nodes: Vec<Node> = Vec::new();
    let mut level = levels as u8;
    while items.len() > 1 {
        let mut groups: BTreeMap<(u32, u32), Vec<&Item>> = BTreeMap::new();
        for item in &items {
            let cell = (item.cell.0 / 2, item.cell.1 / 2);
            groups.entry((cell.1, cell.0)).or_default().push(item);
        }
        let mut above = Vec::with_capacity(groups.len());
        let mut links: Vec<(Option<usize>, usize, usize)> = Vec::new();
        for ((row, column), children) in groups {
            let (node, below) = merge(&children, tiles, level, reach);
            let index = nodes.len();
            for c in &children {
                links.push((c.node, c.tiles[0], index));
            }
            above.push(Item {
                disc: disc_of(&node.surfel),
                error: node.error,
                cone: node.cone,
                centre: node.centre,
                bound: node.bound,
                tiles: below,
                cell: (column, row),
                node: Some(index),
            });
            nodes.push(node);
        }
        for (child_node, first_tile, parent) in links {
            match child_node {
                Some(n) => nodes[n].parent = parent as u32,
                None => tiles[first_tile].0.parent = parent as u32,
            }
        }
        items = above;
        level += 1;
    }
    nodes
}
