//! Folding repair: a chart folds if any of its faces has normal·z <= 0 in its frame, so no
//! height field can hold it. A folding chart is split in two (VSA seeded at its worst and best
//! fitting faces) until every chart has a z that all its faces face. A chart that does not fold
//! but lies in two sheets over one point of its projection (`sheets`) is split between them.
//!
//! Space: world (face normals and height directions, unit vectors).

use glam::DVec3;
use rayon::prelude::*;

use super::frame::{self, FOLD_COS};
use super::sheets;
use super::vsa::{self, FaceSet, NONE};
use crate::mesh::{Mesh, MeshGeometry};

/// A chart after repair: its faces and height direction.
pub struct Chart {
    pub faces: Vec<u32>,
    pub z: DVec3,
}

/// How many charts fold, and how many faces face away from their chart's z.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Folding {
    pub charts: usize,
    pub inverted_faces: usize,
}

impl Folding {
    /// Of charts given as (faces, height direction).
    pub fn count<'a>(
        geo: &MeshGeometry,
        charts: impl IntoIterator<Item = (&'a [u32], DVec3)>,
    ) -> Folding {
        let mut folding = Folding::default();
        for (faces, z) in charts {
            let inverted = faces
                .iter()
                .filter(|&&f| geo.face_normals[f as usize].dot(z) <= 0.0)
                .count();
            folding.charts += usize::from(inverted > 0);
            folding.inverted_faces += inverted;
        }
        folding
    }

    /// Of VSA's charts in the paper's frame (the median normal): the yardstick for the
    /// "before repair" figures.
    pub fn before_repair(geo: &MeshGeometry, groups: &[Vec<u32>]) -> Folding {
        let z = |g: &[u32]| {
            frame::median_normal(geo, g)
                .try_normalize()
                .unwrap_or(DVec3::Z)
        };
        Folding::count(geo, groups.iter().map(|g| (g.as_slice(), z(g))))
    }
}

/// The charts after repair, largest first, and how many splits it took.
pub struct Repaired {
    pub charts: Vec<Chart>,
    pub splits: usize,
    /// Of those, splits of charts that did not fold but lay in two sheets.
    pub sheet_splits: usize,
}

/// What repair makes of one chart.
enum Verdict {
    /// One sheet facing this z.
    Fine(DVec3),
    /// Some face does not face the best z there is.
    Folds(DVec3),
    /// Two sheets, with a face of each.
    Sheets(u32, u32),
}

fn judge(mesh: &Mesh, geo: &MeshGeometry, faces: &[u32]) -> Verdict {
    let (z, worst) = frame::choose_z(geo, faces);
    if worst <= FOLD_COS && faces.len() > 1 {
        return Verdict::Folds(z);
    }
    match sheets::overlapping_faces(mesh, geo, faces, z) {
        Some((a, b)) => Verdict::Sheets(a, b),
        None => Verdict::Fine(z),
    }
}

/// Splits folding charts, and charts in two sheets, until none is left. Charts are judged in
/// parallel, a round at a time (the parts of a split are judged in the next round).
pub fn repair(mesh: &Mesh, geo: &MeshGeometry, groups: Vec<Vec<u32>>) -> Repaired {
    let mut scratch = vec![NONE; geo.degenerate.len()];
    let mut queue = groups;
    let mut charts: Vec<Chart> = Vec::with_capacity(queue.len());
    let (mut splits, mut sheet_splits) = (0usize, 0usize);
    while !queue.is_empty() {
        let verdicts: Vec<Verdict> = queue.par_iter().map(|f| judge(mesh, geo, f)).collect();
        let mut next = Vec::new();
        for (faces, verdict) in queue.into_iter().zip(verdicts) {
            match verdict {
                Verdict::Fine(z) => charts.push(Chart { faces, z }),
                Verdict::Folds(z) => {
                    next.extend(split(mesh, geo, &faces, z, &mut scratch));
                    splits += 1;
                }
                Verdict::Sheets(a, b) => {
                    next.extend(sheets::split_between(mesh, geo, &faces, [a, b]));
                    splits += 1;
                    sheet_splits += 1;
                }
            }
        }
        queue = next;
    }
    // Largest charts first: a stable, meaningful order for users and for atlas packing.
    charts.sort_by(|a, b| {
        b.faces
            .len()
            .cmp(&a.faces.len())
            .then(a.faces[0].cmp(&b.faces[0]))
    });
    Repaired {
        charts,
        splits,
        sheet_splits,
    }
}

/// A folding chart's two (rarely more) parts.
fn split(
    mesh: &Mesh,
    geo: &MeshGeometry,
    faces: &[u32],
    z: DVec3,
    scratch: &mut [u32],
) -> Vec<Vec<u32>> {
    let sub = FaceSet::new(mesh, geo, faces, scratch);
    let parts = vsa::split_in_two(&sub, z).groups(&sub);
    if parts.len() >= 2 {
        return parts;
    }
    // VSA could not separate them (identical normals cannot fold): split by facing.
    let (up, down): (Vec<u32>, Vec<u32>) = faces
        .iter()
        .partition(|&&f| geo.face_normals[f as usize].dot(z) > FOLD_COS);
    let mut parts = vec![up, down];
    parts.retain(|p| !p.is_empty());
    parts
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_shapes::ramp;

    #[test]
    fn repair_separates_the_sheets_of_a_ramp_past_one_turn() {
        let mesh = ramp(1.6);
        let geo = MeshGeometry::new(&mesh);
        let all: Vec<u32> = (0..mesh.faces.len() as u32).collect();
        let repaired = repair(&mesh, &geo, vec![all.clone()]);
        assert!(repaired.sheet_splits >= 1);
        let mut placed: Vec<u32> = repaired
            .charts
            .iter()
            .flat_map(|c| c.faces.clone())
            .collect();
        placed.sort_unstable();
        assert_eq!(placed, all);
        for chart in &repaired.charts {
            assert_eq!(
                sheets::overlapping_faces(&mesh, &geo, &chart.faces, chart.z),
                None
            );
        }
    }
}
