use std::sync::Arc;

use glam::DVec2;

use super::*;
use crate::grids::{from_grids, HeightGrid};

/// A paraboloid cap over a 45 x 37 grid with a hole of missing samples, cut into 16-texel patches.
fn curved_set() -> GeometryTextureSet {
    let (w, h) = (45usize, 37usize);
    let z = (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| {
            let (x, y) = (i as f64 / 10.0 - 2.2, j as f64 / 10.0 - 1.8);
            if (x - 0.5).powi(2) + y * y < 0.1 {
                f64::NAN
            } else {
                0.3 * (x * x + y * y)
            }
        })
        .collect();
    let grid = HeightGrid {
        width: w,
        height: h,
        origin: DVec2::ZERO,
        spacing: DVec2::splat(0.1),
        z,
        colors: None,
    };
    from_grids(&[grid], Some(16), None).unwrap()
}

fn flat_set() -> GeometryTextureSet {
    let grid = HeightGrid {
        width: 20,
        height: 20,
        origin: DVec2::ZERO,
        spacing: DVec2::splat(0.05),
        z: vec![1.0; 400],
        colors: None,
    };
    from_grids(&[grid], Some(32), None).unwrap()
}

#[test]
fn finest_level_is_every_surface_texel() {
    let set = Arc::new(curved_set());
    let h = SurfelHierarchy::build(set.clone(), 8).unwrap();
    let (points, _) = set.to_points();
    assert_eq!(h.levels, 4);
    assert_eq!(h.per_level()[0], points.len());
    assert!(h.surfels.iter().all(|s| s.radius > 0.0));
    let mut ours: Vec<[u64; 3]> = h
        .surfels
        .iter()
        .filter(|s| s.level == 0)
        .map(|s| s.position.to_array().map(f64::to_bits))
        .collect();
    let mut theirs: Vec<[u64; 3]> = points.iter().map(|p| p.map(f64::to_bits)).collect();
    ours.sort_unstable();
    theirs.sort_unstable();
    assert_eq!(ours, theirs);
}

#[test]
fn levels_merge_four_to_one_and_cover_their_children() {
    let h = SurfelHierarchy::build(Arc::new(curved_set()), 8).unwrap();
    let mut children = vec![0usize; h.surfels.len()];
    for s in &h.surfels {
        if s.parent != u32::MAX {
            let p = &h.surfels[s.parent as usize];
            assert_eq!(p.level, s.level + 1);
            children[s.parent as usize] += 1;
            let reach = p.position.distance(s.position) + s.radius;
            assert!(reach <= p.radius * (1.0 + 1e-12), "{reach} > {}", p.radius);
        } else {
            assert_eq!(s.level as u32, h.levels - 1);
        }
    }
    for (s, &n) in h.surfels.iter().zip(&children) {
        assert!(s.level == 0 || (1..=4).contains(&n), "{n} children");
    }
    // One top surfel per tile; each level has at most a quarter (rounded up per tile) of the one
    // below, and interior tiles merge exactly 4:1.
    let counts = h.per_level();
    assert_eq!(counts[3], h.tiles.len());
    for l in 1..4 {
        assert!(
            counts[l] * 4 >= counts[l - 1] && counts[l] < counts[l - 1],
            "{counts:?}"
        );
    }
    for t in &h.tiles {
        let per: Vec<u32> = t.start.windows(2).map(|w| w[1] - w[0]).collect();
        if per[0] == 64 {
            assert_eq!(per, vec![64, 16, 4, 1]);
        }
    }
}

#[test]
fn errors_are_monotone_and_bound_every_finest_surfel() {
    let h = SurfelHierarchy::build(Arc::new(curved_set()), 8).unwrap();
    for t in &h.tiles {
        assert_eq!(t.error[0], 0.0);
        assert!(t.error.windows(2).all(|e| e[0] <= e[1]), "{:?}", t.error);
        for f in &h.surfels[t.start[0] as usize..t.start[1] as usize] {
            let mut a = f;
            for l in 1..h.levels as usize {
                a = &h.surfels[a.parent as usize];
                let d = (f.position - a.position).dot(a.normal).abs();
                assert!(d <= t.error[l] + 1e-12);
            }
        }
        for (l, (axis, angle)) in t.cone.iter().enumerate() {
            for s in &h.surfels[t.start[l] as usize..t.start[l + 1] as usize] {
                assert!(s.normal.dot(*axis).clamp(-1.0, 1.0).acos() <= angle + 1e-9);
            }
        }
        for s in &h.surfels[t.start[0] as usize..*t.start.last().unwrap() as usize] {
            assert!(s.position.distance(t.centre) + s.radius <= t.bound * (1.0 + 1e-12));
        }
    }
    // A curved cap strays from its coarse discs; a plane does not.
    let worst = h.tiles.iter().map(|t| t.error[3]).fold(0.0, f64::max);
    assert!(worst > 1e-4, "{worst}");
    let flat = SurfelHierarchy::build(Arc::new(flat_set()), 8).unwrap();
    let worst = flat.tiles.iter().map(|t| t.error[3]).fold(0.0, f64::max);
    assert!(worst < 1e-9, "{worst}");
}

#[test]
fn tile_must_be_a_power_of_two_within_range() {
    for bad in [0, 3, 12, 128, -8] {
        let e = check_tile(bad).unwrap_err().to_string();
        assert!(
            e.contains("power of two") && e.contains(&bad.to_string()),
            "{e}"
        );
    }
    for good in [1, 2, 8, 64] {
        assert_eq!(check_tile(good).unwrap(), good as u32);
    }
    let one = SurfelHierarchy::build(Arc::new(flat_set()), 1).unwrap();
    assert_eq!(one.levels, 1);
    assert_eq!(one.tiles.len(), one.surfels.len());
}

#[test]
fn files_round_trip_and_corruption_is_refused() {
    let h = SurfelHierarchy::build(Arc::new(curved_set()), 4).unwrap();
    let bytes = file::encode(&h);
    let back = file::decode(&bytes).unwrap();
    assert_eq!(back.tile, 4);
    assert_eq!(back.tiles, h.tiles);
    assert_eq!(back.surfels, h.surfels);
    let mut flipped = bytes.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 1;
    assert!(file::decode(&flipped).unwrap_err().contains("checksum"));
    assert!(file::decode(&bytes[..bytes.len() - 3])
        .unwrap_err()
        .contains("truncated"));
    assert!(file::decode(b"GTEX\r\n\x1a\n0000000000000000000000000000")
        .unwrap_err()
        .contains("not a surfel file"));
    let mut version = bytes.clone();
    version[8] = 9;
    assert!(file::decode(&version).unwrap_err().contains("version 9"));
    let mut tile = bytes;
    tile[12] = 8;
    assert!(file::decode(&tile).unwrap_err().contains("checksum"));
}

/// The surfels of one tile level (`top`: the tiles' top level, else the finest) below a node:
/// those of every tile whose chain of parents reaches it.
fn below(h: &SurfelHierarchy, node: usize, top: bool) -> Vec<&Surfel> {
    let reaches = |mut n: u32| loop {
        if n == node as u32 {
            return true;
        }
        if n == u32::MAX {
            return false;
        }
        n = h.nodes[n as usize].parent;
    };
    let l = if top { h.levels as usize - 1 } else { 0 };
    (h.tiles.iter().filter(|t| reaches(t.parent)))
        .flat_map(|t| &h.surfels[t.start[l] as usize..t.start[l + 1] as usize])
        .collect()
}

#[test]
fn nodes_above_the_tiles_nest_and_their_errors_never_fall() {
    let h = SurfelHierarchy::build(Arc::new(curved_set()), 4).unwrap();
    assert!(!h.nodes.is_empty());
    // One root per patch with more than one tile; every tile of such a patch has a parent.
    let roots = h.nodes.iter().filter(|n| n.parent == u32::MAX).count();
    let mut tiles_per_patch = vec![0usize; h.source.patches.len()];
    for t in &h.tiles {
        tiles_per_patch[t.patch as usize] += 1;
    }
    assert_eq!(roots, tiles_per_patch.iter().filter(|&&n| n > 1).count());
    for t in &h.tiles {
        assert_eq!(t.parent == u32::MAX, tiles_per_patch[t.patch as usize] == 1);
        if t.parent != u32::MAX {
            let p = &h.nodes[t.parent as usize];
            assert!(p.error >= *t.error.last().unwrap());
            assert!(p.centre.distance(t.centre) + t.bound <= p.bound * (1.0 + 1e-12));
            assert_eq!(p.surfel.level as u32, h.levels);
        }
    }
    for (k, n) in h.nodes.iter().enumerate() {
        if n.parent != u32::MAX {
            let p = &h.nodes[n.parent as usize];
            assert!(p.error >= n.error && p.surfel.level == n.surfel.level + 1);
            assert!(p.centre.distance(n.centre) + n.bound <= p.bound * (1.0 + 1e-12));
        }
        // The node's error bounds every finest surfel below against its disc; its texel box
        // holds theirs; its cone holds the tiles' top normals below and its own.
        let finest = below(&h, k, false);
        assert!(!finest.is_empty());
        let d = &n.surfel;
        let inside =
            |normal: DVec3| normal.dot(n.cone.0).clamp(-1.0, 1.0).acos() <= n.cone.1 + 1e-9;
        assert!(inside(d.normal));
        assert!(below(&h, k, true).iter().all(|s| inside(s.normal)));
        for f in finest {
            let off = (f.position - d.position).dot(d.normal).abs();
            assert!(off <= n.error + 1e-12, "{off} > {}", n.error);
            let (b, t) = (d.texels, f.texels);
            assert!(b[0] <= t[0] && b[1] <= t[1] && b[2] >= t[2] && b[3] >= t[3]);
        }
    }
    // Four to one, rounded up per patch: each level holds fewer nodes than the one below and at
    // least a quarter of them.
    let per = h.nodes_per_level();
    assert!(
        per.windows(2).all(|w| w[1] * 4 >= w[0] && w[1] < w[0]),
        "{per:?}"
    );
    assert!(per[0] * 4 >= h.tiles.len() - tiles_per_patch.iter().filter(|&&n| n == 1).count());
}

/// Pieces of whole patches hold, between them, exactly the hierarchy's tiles, surfels and nodes,
/// each within the cap, with every index pointing at the same record it did before the cut.
#[test]
fn pieces_partition_the_hierarchy_by_patch() {
    let h = SurfelHierarchy::build(Arc::new(curved_set()), 8).unwrap();
    assert!(h.source.patches.len() >= 4, "{}", h.source.patches.len());
    let whole = h.surfels.len() + h.nodes.len();
    let cap = whole / 3;
    let pieces = h.pieces(cap).unwrap();
    assert!(pieces.len() >= 3, "{} pieces", pieces.len());
    let (mut tiles, mut surfels, mut nodes) = (Vec::new(), Vec::new(), Vec::new());
    for piece in &pieces {
        assert!(piece.surfels.len() + piece.nodes.len() <= cap);
        let (s0, n0) = (surfels.len() as u32, nodes.len() as u32);
        let back = |i: u32, by: u32| if i == u32::MAX { i } else { i + by };
        tiles.extend(piece.tiles.iter().map(|t| Tile {
            start: t.start.iter().map(|s| s + s0).collect(),
            parent: back(t.parent, n0),
            ..t.clone()
        }));
        surfels.extend(piece.surfels.iter().map(|s| Surfel {
            parent: back(s.parent, s0),
            ..*s
        }));
        nodes.extend(piece.nodes.iter().map(|n| Node {
            parent: back(n.parent, n0),
            ..n.clone()
        }));
    }
    assert_eq!(tiles, h.tiles);
    assert_eq!(surfels, h.surfels);
    assert_eq!(nodes, h.nodes);
    // One piece when everything fits; an error when one patch alone does not.
    assert_eq!(h.pieces(whole).unwrap().len(), 1);
    let err = h.pieces(3).unwrap_err().to_string();
    assert!(err.contains("patch 0 alone holds"), "{err}");
}
