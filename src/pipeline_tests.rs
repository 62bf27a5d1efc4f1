//! Tests that run one stage's output through another: an inverse geometric texture built by
//! `igt`, encoded for the GPU by the renderer. Stages never import each other (tests/structure.rs),
//! so these live above them all, as the binding layer does.

use crate::progress::Progress;
use crate::render::kinds::igt::{cell_heights, face_heights, grid_slabs};
use crate::test_shapes::uv_sphere;

/// Every listed face's heights lie within its cell's decoded bounds (the ray lookup skips
/// the cell otherwise), and the bounds are the listed faces' own, to a quantum each side.
#[test]
fn igt_cell_heights_hold_their_listed_faces_tightly() {
    let mesh = uv_sphere(24, 48);
    let igt = crate::igt::build(&mesh, &Default::default(), Progress::silent()).unwrap();
    let slabs = grid_slabs(&igt);
    let words = cell_heights(&igt, &slabs);
    let (mut outside, mut loose, mut tested) = (0, 0, 0);
    for (grid, &(lo, hi)) in igt.grids.iter().zip(&slabs) {
        let quantum = f64::from(hi - lo) / 65535.0;
        for c in grid.first_cell..grid.first_cell + grid.cells() {
            let w = words[c as usize];
            let decode = |q: u32| f64::from(lo) + f64::from(q & 0xffff) * quantum;
            let (a, b) = (decode(w), decode(w >> 16));
            let listed = igt.list(c as usize);
            let spans = listed
                .iter()
                .map(|&k| face_heights(&igt, &igt.entries[k as usize]));
            let (l, h) = spans.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), (x, y)| {
                (l.min(x), h.max(y))
            });
            if listed.is_empty() {
                assert_eq!(w, 0x0000_ffff);
                continue;
            }
            tested += 1;
            outside += usize::from(l < a - 1e-12 || h > b + 1e-12);
            loose += usize::from(a < l - quantum || b > h + quantum);
        }
    }
    assert!(tested > 1000, "{tested}");
    assert_eq!((outside, loose), (0, 0), "of {tested} cells");
}

/// A hybrid set handed straight to the core renderer (no binding layer) draws its triangles:
/// every ray aimed at the sphere's centre hits it, the kept faces as the next mesh (-2), at the
/// faceted sphere's distance.
#[test]
fn the_core_renderer_traces_a_hybrid_sets_triangles() {
    use crate::render::cpu::CpuRenderer;
    use crate::render::{Object, Scene, SceneObject};
    use glam::{DMat4, DVec3};
    use std::sync::Arc;

    let mesh = uv_sphere(8, 16);
    let set = crate::convert::convert(&mesh, &Default::default(), Progress::silent()).unwrap();
    let kept = set.triangles.as_ref().map_or(0, |t| t.mesh().faces.len());
    assert_eq!(kept, mesh.faces.len(), "224 faces: all kept");
    let scene = Scene {
        objects: vec![SceneObject {
            object: Object::new(Arc::new(set)),
            world_from_object: DMat4::IDENTITY,
        }],
    };
    let rays: Vec<(DVec3, DVec3)> = (0..64)
        .map(|k| {
            let a = k as f64 * 0.7;
            let o = DVec3::new(a.cos() * 3.0, a.sin() * 3.0, (k as f64 * 0.31).sin());
            (o, -o)
        })
        .collect();
    let hits = CpuRenderer::new()
        .intersect(&scene, &rays, false, &crate::cancel::NEVER)
        .unwrap();
    // The faceted sphere lies between the chords' sag (1 - cos(pi/8) for 8 rings) and 1.
    for ((o, _), (&t, &id)) in rays.iter().zip(hits.distance.iter().zip(&hits.patch_id)) {
        let r = o.length() - t;
        assert_eq!(id, -2);
        assert!(
            r <= 1.0 + 1e-9 && r >= (std::f64::consts::PI / 8.0).cos() - 1e-9,
            "{r}"
        );
    }
}
