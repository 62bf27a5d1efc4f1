//! Hybrid sets: which charts become patches and which stay the mesh's own triangles.
//!
//! A chart becomes a patch only where its height map meets the bound in fewer bytes than its
//! faces take as a mesh (`chart_triangle_bytes`); the rest stay triangles, exact. Then, since
//! a vertex on a patch/triangle border is counted both in the patch's chart and in the kept
//! triangles, the set could still cost a little more than the mesh: the patches that save the
//! least go back to triangles until it does not (all-triangles costs exactly the mesh's bytes).
//!
//! Space: world (the source mesh's coordinates).

use super::accuracy::WeightedError;
use super::draw::Drawn;
use crate::charts::overlap::Ring;
use crate::charts::repair::Chart;
use crate::gtex::triangles::mesh_bytes;
use crate::gtex::{KeptBecause, Patch, SetTriangles};
use crate::mesh::{Mesh, NormalRule};

/// The patches, their errors, the errors of everything drawn (kept triangles at zero), and the
/// triangles, if any chart stays triangles.
pub struct Split {
    pub patches: Vec<Patch>,
    pub patch_errors: Vec<f64>,
    pub errors: Vec<WeightedError>,
    pub triangles: Option<SetTriangles>,
}

/// A chart kept as a patch: the patch, its error, its triangles' bytes, and its errors.
type Kept = (Patch, f64, f64, Vec<WeightedError>);

/// Splits the charts drawn (`drawn[k]` None: no height map within the bound was cheaper) into
/// patches and triangles; `triangle_bytes` None: every chart is a patch.
pub fn split(
    mesh: &Mesh,
    rule: NormalRule,
    charts: Vec<(Chart, Ring)>,
    drawn: Vec<Option<Drawn>>,
    triangle_bytes: Option<&[f64]>,
) -> Split {
    let mut kept: Vec<Kept> = Vec::new();
    let mut clusters: Vec<(Vec<u32>, KeptBecause)> = Vec::new();
    for (k, ((chart, ring), d)) in charts.into_iter().zip(drawn).enumerate() {
        let cap = triangle_bytes.map_or(f64::INFINITY, |b| b[k]);
        match d {
            Some(Drawn {
                bx,
                maps,
                bound,
                errors,
                error,
            }) => {
                let mut patch = bx.into_patch(maps, chart.faces, ring.faces);
                patch.error_bound = bound;
                if (patch.map_bytes() as f64) < cap {
                    kept.push((patch, error, cap, errors));
                } else {
                    clusters.push((patch.faces, KeptBecause::Bound));
                }
            }
            None => clusters.push((chart.faces, KeptBecause::Bound)),
        }
    }
    if triangle_bytes.is_some() {
        within_mesh_bytes(mesh, &mut kept, &mut clusters);
    }
    let mut errors: Vec<WeightedError> = Vec::new();
    let mut patches = Vec::with_capacity(kept.len());
    let mut patch_errors = Vec::with_capacity(kept.len());
    for (patch, error, _, e) in kept {
        patches.push(patch);
        patch_errors.push(error);
        errors.extend(e);
    }
    // The kept triangles are the source's faces: no error over their area.
    errors.extend(
        clusters
            .iter()
            .flat_map(|(faces, _)| faces)
            .map(|&f| WeightedError {
                value: 0.0,
                area: face_area(mesh, f),
            }),
    );
    let triangles = (!clusters.is_empty()).then(|| SetTriangles::from_charts(mesh, rule, clusters));
    Split {
        patches,
        patch_errors,
        errors,
        triangles,
    }
}

fn face_area(mesh: &Mesh, f: u32) -> f64 {
    let [a, b, c] = mesh.faces[f as usize].map(|v| mesh.positions[v as usize]);
    0.5 * (b - a).cross(c - a).length()
}

/// Moves the patches that save the least (their triangles' bytes less their maps') back to
/// triangles until the set takes no more bytes than the mesh, counted as `SetTriangles::bytes`
/// counts them.
fn within_mesh_bytes(
    mesh: &Mesh,
    kept: &mut Vec<Kept>,
    clusters: &mut Vec<(Vec<u32>, KeptBecause)>,
) {
    let colored = mesh.colors.is_some();
    let own = mesh_bytes(mesh.positions.len(), mesh.faces.len(), colored);
    let mut used = vec![false; mesh.positions.len()];
    let mut vertices = 0usize;
    let mut faces = 0usize;
    let mut take = |chart: &[u32], used: &mut Vec<bool>| {
        for &f in chart {
            faces += 1;
            for v in mesh.faces[f as usize] {
                if !std::mem::replace(&mut used[v as usize], true) {
                    vertices += 1;
                }
            }
        }
        mesh_bytes(vertices, faces, colored)
    };
    let mut triangle_bytes = 0;
    for (chart, _) in clusters.iter() {
        triangle_bytes = take(chart, &mut used);
    }
    // Least saving last, so `pop` takes it.
    kept.sort_by(|a, b| (b.2 - b.0.map_bytes() as f64).total_cmp(&(a.2 - a.0.map_bytes() as f64)));
    let mut map_bytes: usize = kept.iter().map(|k| k.0.map_bytes()).sum();
    while map_bytes + triangle_bytes > own {
        let Some((patch, ..)) = kept.pop() else { break };
        map_bytes -= patch.map_bytes();
        triangle_bytes = take(&patch.faces, &mut used);
        clusters.push((patch.faces, KeptBecause::Budget));
    }
}

/// A hybrid conversion's figures: what went where and why, and the bytes of each side against
/// the mesh's own (`SetTriangles::bytes` of all its faces).
pub fn figures(mesh: &Mesh, set: &crate::gtex::GeometryTextureSet) -> Vec<(&'static str, f64)> {
    let own = mesh_bytes(
        mesh.positions.len(),
        mesh.faces.len(),
        mesh.colors.is_some(),
    );
    let t = set.triangles.as_ref();
    let count = |why: KeptBecause| t.map_or(0, |t| t.because.iter().filter(|&&b| b == why).count());
    vec![
        ("hybrid", 1.0),
        ("mesh_bytes", own as f64),
        ("patch_bytes", set.map_bytes() as f64),
        ("triangle_bytes", t.map_or(0, SetTriangles::bytes) as f64),
        (
            "triangle_clusters",
            t.map_or(0, SetTriangles::clusters) as f64,
        ),
        (
            "triangle_faces",
            t.map_or(0, |t| t.mesh().faces.len()) as f64,
        ),
        ("triangle_clusters_bound", count(KeptBecause::Bound) as f64),
        (
            "triangle_clusters_budget",
            count(KeptBecause::Budget) as f64,
        ),
    ]
}

#[cfg(test)]
mod tests {
    use crate::convert::{convert, ConvertOptions};
    use crate::gtex::{file, GeometryTextureSet, KEPT_AS_TRIANGLES};
    use crate::mesh::Mesh;
    use crate::progress::Progress;
    use crate::test_shapes::uv_sphere;

    fn hybrid(mesh: &Mesh) -> GeometryTextureSet {
        let opts = ConvertOptions::default();
        convert(mesh, &opts, Progress::silent()).unwrap()
    }

    /// Every source face is in exactly one patch or kept as a triangle, and the set holds no
    /// more bytes than the mesh.
    fn check_whole(mesh: &Mesh, set: &GeometryTextureSet) {
        let stat = |n: &str| set.stats.get(n).unwrap();
        let own = 12 * (mesh.positions.len() + mesh.faces.len());
        assert_eq!(stat("mesh_bytes"), own as f64);
        assert!(
            set.bytes() <= own,
            "{} bytes for a mesh of {own}",
            set.bytes()
        );
        assert_eq!(stat("bytes"), set.bytes() as f64);
        let face_patch = set.face_patch();
        assert!(face_patch.iter().all(|&k| k >= 0 || k == KEPT_AS_TRIANGLES));
        let listed: usize = set.patches.iter().map(|p| p.faces.len()).sum::<usize>()
            + set.triangles.as_ref().map_or(0, |t| t.source_faces.len());
        assert_eq!(listed, mesh.faces.len());
        // Kept triangles are the source's faces, vertex for vertex (to f32 offsets).
        if let Some(t) = &set.triangles {
            for (corners, &f) in t.face_corners().zip(&t.source_faces) {
                let source = mesh.faces[f as usize].map(|v| mesh.positions[v as usize]);
                for (a, b) in corners.iter().zip(source) {
                    assert!(a.distance(b) < 1e-6, "{a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn a_small_mesh_stays_triangles_within_its_bytes() {
        // 224 faces: no height map within the bound is cheaper than its faces (measured: every
        // chart kept, 0 patches).
        let mesh = uv_sphere(8, 16);
        let set = hybrid(&mesh);
        check_whole(&mesh, &set);
        assert!(set.patches.is_empty(), "{} patches", set.patches.len());
        assert_eq!(set.bytes(), 12 * (mesh.positions.len() + mesh.faces.len()));
        // The file holds it exactly (version 7) and reads back equal.
        let bytes = file::encode(&set);
        assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 7);
        let back = file::decode(&bytes).unwrap();
        assert_eq!(back.triangles, set.triangles);
        assert_eq!(back.patches, set.patches);
    }

    #[test]
    fn a_dense_smooth_mesh_becomes_mostly_patches() {
        // 32k faces of a smooth sphere: height maps win nearly everywhere (measured: 65 patches,
        // 885 faces (2.7%) kept, 0.45x the mesh's bytes).
        let mesh = uv_sphere(128, 128);
        let set = hybrid(&mesh);
        check_whole(&mesh, &set);
        let kept = set.triangles.as_ref().map_or(0, |t| t.mesh().faces.len());
        assert!(kept * 20 < mesh.faces.len(), "{kept} faces kept");
        let own = 12 * (mesh.positions.len() + mesh.faces.len());
        assert!(
            (set.bytes() as f64) < 0.6 * own as f64,
            "{} of {own}",
            set.bytes()
        );
    }

    #[test]
    fn a_crafted_triangle_section_is_an_error() {
        let mesh = uv_sphere(8, 16);
        let set = hybrid(&mesh);
        let good = file::encode(&set);
        // Every truncation is an error, never a panic; so is a face index past the vertices.
        for cut in [1, 5, 40, 200] {
            let mut bad = good[..good.len() - cut].to_vec();
            let len = (bad.len() - 32) as u64;
            bad[16..24].copy_from_slice(&len.to_le_bytes());
            let crc = crc32fast::hash(&bad[32..]);
            bad[24..28].copy_from_slice(&crc.to_le_bytes());
            assert!(file::decode(&bad).is_err(), "cut {cut}");
        }
        let mut t = set.clone();
        if let Some(tri) = &mut t.triangles {
            let mut m = (*tri.shaded.mesh).clone();
            m.faces[3][1] = m.positions.len() as u32;
            *tri = crate::gtex::SetTriangles::new(
                m,
                tri.shaded.rule,
                tri.starts.clone(),
                tri.because.clone(),
                tri.source_faces.clone(),
            );
        }
        let e = t.validate().unwrap_err();
        assert!(e.contains("face 3 indexes past"), "{e}");
    }
}
