//! Whether a chart is one sheet over its projection, and splitting it where it is not.
//!
//! A chart whose faces all face its z cannot fold locally, but two parts of it can still lie one
//! above the other (a hand's fingers, a chart wrapped round a handle). One height map holds only
//! the upper one, and the bilinear cells between the two become a wall that rays hit between
//! the parts. A height field has one height per point, so two faces whose projections overlap,
//! at clearly different heights there, are two sheets. Such a chart is split along the geodesic
//! midline between those two faces, which separates sheets joined round a bend (their normals
//! may agree, so VSA's normal-driven split would not).
//!
//! Space: world (positions, the chart's z).

use std::collections::BinaryHeap;

use glam::{DVec2, DVec3};

use super::frame::perpendicular;
use super::vsa::{Candidate, NONE};
use crate::mesh::{Mesh, MeshGeometry};

/// Heights closer than this (in typical edge lengths of the chart) are one sheet: rounding, and
/// meshes that touch themselves.
const SAME_SHEET_EDGES: f64 = 0.05;
/// Strictly inside a triangle: barycentric coordinates above this, so faces meeting at a vertex
/// or along an edge do not count as overlapping.
const INSIDE: f64 = 1e-9;

/// A face projected on the plane across the chart's z: corners in typical edge lengths, with
/// their heights (world units).
type Flat = [(DVec2, f64); 3];

/// Two faces of `faces` (mesh indices) whose projections on the plane across `z` overlap, with
/// heights more than a twentieth of a typical edge apart there; None if the chart is one sheet.
/// Exact: faces are bucketed by the grid cells (one typical edge wide) their bounds touch, and
/// each pair in a bucket is tested.
pub fn overlapping_faces(
    mesh: &Mesh,
    geo: &MeshGeometry,
    faces: &[u32],
    z: DVec3,
) -> Option<(u32, u32)> {
    if faces.len() < 2 {
        return None;
    }
    let area: f64 = faces.iter().map(|&f| geo.face_areas[f as usize]).sum();
    let edge = (2.0 * area / faces.len() as f64).sqrt();
    if edge <= 0.0 || !edge.is_finite() {
        return None;
    }
    let (x, y) = (perpendicular(z), z.cross(perpendicular(z)));
    let flat: Vec<Flat> = faces
        .iter()
        .map(|&f| {
            mesh.faces[f as usize].map(|v| {
                let p = mesh.positions[v as usize];
                (DVec2::new(p.dot(x), p.dot(y)) / edge, p.dot(z))
            })
        })
        .collect();
    // (cell, face) sorted by cell, so one cell's faces are adjacent; cells counted from the
    // chart's lowest corner so a cell packs into one u64.
    let origin = flat
        .iter()
        .flat_map(|t| t.iter().map(|c| c.0))
        .fold(DVec2::INFINITY, DVec2::min)
        .floor();
    let mut buckets: Vec<(u64, u32)> = Vec::with_capacity(3 * faces.len());
    for (k, t) in flat.iter().enumerate() {
        let (lo, hi) = bounds(t);
        let (lo, hi) = ((lo - origin).floor(), (hi - origin).floor());
        for j in lo.y as u64..=hi.y as u64 {
            for i in lo.x as u64..=hi.x as u64 {
                buckets.push(((i << 32) | j, k as u32));
            }
        }
    }
    buckets.sort_unstable_by_key(|b| b.0);
    let tolerance = SAME_SHEET_EDGES * edge;
    let corners = |k: u32| mesh.faces[faces[k as usize] as usize].map(|v| geo.weld[v as usize]);
    buckets.chunk_by(|a, b| a.0 == b.0).find_map(|run| {
        run.iter().enumerate().find_map(|(n, &(_, a))| {
            let (ta, ca) = (&flat[a as usize], corners(a));
            run[n + 1..].iter().find_map(|&(_, b)| {
                let tb = &flat[b as usize];
                // Faces across an edge, both facing up, lie on its two sides.
                let cb = corners(b);
                if ca.iter().filter(|v| cb.contains(v)).count() >= 2 || !bounds_overlap(ta, tb) {
                    return None;
                }
                (height_gap(ta, tb) > tolerance).then_some((faces[a as usize], faces[b as usize]))
            })
        })
    })
}

fn bounds(t: &Flat) -> (DVec2, DVec2) {
    (
        t[0].0.min(t[1].0).min(t[2].0),
        t[0].0.max(t[1].0).max(t[2].0),
    )
}

fn bounds_overlap(a: &Flat, b: &Flat) -> bool {
    let ((alo, ahi), (blo, bhi)) = (bounds(a), bounds(b));
    alo.cmplt(bhi).all() && blo.cmplt(ahi).all()
}

/// The largest height difference between two projected faces over the points where their
/// projections overlap (corners strictly inside the other, proper edge crossings); 0 where they
/// do not overlap.
fn height_gap(a: &Flat, b: &Flat) -> f64 {
    let mut gap: f64 = 0.0;
    for (s, t) in [(a, b), (b, a)] {
        for &(p, h) in s {
            if let Some(ht) = height_at(t, p) {
                gap = gap.max((h - ht).abs());
            }
        }
    }
    for i in 0..3 {
        let (p0, p1) = (a[i].0, a[(i + 1) % 3].0);
        for j in 0..3 {
            let (q0, q1) = (b[j].0, b[(j + 1) % 3].0);
            let d = (p1 - p0).perp_dot(q1 - q0);
            if d.abs() < 1e-15 {
                continue;
            }
            let s = (q0 - p0).perp_dot(q1 - q0) / d;
            let t = (q0 - p0).perp_dot(p1 - p0) / d;
            if s > INSIDE && s < 1.0 - INSIDE && t > INSIDE && t < 1.0 - INSIDE {
                let ha = a[i].1 + s * (a[(i + 1) % 3].1 - a[i].1);
                let hb = b[j].1 + t * (b[(j + 1) % 3].1 - b[j].1);
                gap = gap.max((ha - hb).abs());
            }
        }
    }
    gap
}

/// The height of projected face `t` at `p` if `p` lies strictly inside it.
fn height_at(t: &Flat, p: DVec2) -> Option<f64> {
    let [(a, ha), (b, hb), (c, hc)] = *t;
    let det = (b - a).perp_dot(c - a);
    // Faces seen edge-on cover no area of the plane.
    if det.abs() < 1e-12 {
        return None;
    }
    let lb = (p - a).perp_dot(c - a) / det;
    let lc = (b - a).perp_dot(p - a) / det;
    let la = 1.0 - lb - lc;
    (la > INSIDE && lb > INSIDE && lc > INSIDE).then_some(la * ha + lb * hb + lc * hc)
}

/// `faces` in two parts: each face goes to the seed it is nearer to along the chart's surface
/// (centroid to centroid across shared edges). Faces no path reaches join the first part.
pub fn split_between(
    mesh: &Mesh,
    geo: &MeshGeometry,
    faces: &[u32],
    seeds: [u32; 2],
) -> Vec<Vec<u32>> {
    let n = faces.len();
    let mut faces_sorted = faces.to_vec();
    faces_sorted.sort_unstable();
    let index = |f: u32| faces_sorted.binary_search(&f).ok();
    let mut distance = vec![f64::INFINITY; n];
    let mut owner = vec![NONE; n];
    let mut heap = BinaryHeap::new();
    for (side, &s) in seeds.iter().enumerate() {
        if let Some(k) = index(s) {
            distance[k] = 0.0;
            owner[k] = side as u32;
            heap.push(Candidate {
                cost: 0.0,
                face: k as u32,
                chart: (),
            });
        }
    }
    // Candidates carry a face's index in `faces_sorted`; the heap pops the nearest first.
    while let Some(Candidate { cost: d, face, .. }) = heap.pop() {
        let k = face as usize;
        if d > distance[k] {
            continue;
        }
        let f = faces_sorted[k] as usize;
        for &nb in geo.face_neighbors.row(f) {
            let Some(m) = index(nb) else { continue };
            let step = (mesh.centroid(nb as usize) - mesh.centroid(f)).length();
            if d + step < distance[m] {
                distance[m] = d + step;
                owner[m] = owner[k];
                heap.push(Candidate {
                    cost: d + step,
                    face: m as u32,
                    chart: (),
                });
            }
        }
    }
    let mut parts = vec![Vec::new(), Vec::new()];
    for (k, &f) in faces_sorted.iter().enumerate() {
        parts[(owner[k] == 1) as usize].push(f);
    }
    parts.retain(|p| !p.is_empty());
    parts
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_shapes::ramp;

    #[test]
    fn a_ramp_past_one_turn_is_two_sheets() {
        let all = |m: &Mesh| (0..m.faces.len() as u32).collect::<Vec<u32>>();
        let one_turn = ramp(0.9);
        let geo = MeshGeometry::new(&one_turn);
        assert_eq!(
            overlapping_faces(&one_turn, &geo, &all(&one_turn), DVec3::Z),
            None
        );

        let mesh = ramp(1.6);
        let geo = MeshGeometry::new(&mesh);
        let (a, b) = overlapping_faces(&mesh, &geo, &all(&mesh), DVec3::Z).expect("two sheets");
        // The two faces lie a turn apart: 0.5 in height.
        let dz = (mesh.centroid(a as usize).z - mesh.centroid(b as usize).z).abs();
        assert!((dz - 0.5).abs() < 0.1, "{dz}");
    }
}
