use glam::{DVec2, DVec3};

use super::*;
use crate::igt_data::file;
use crate::test_shapes::uv_sphere;

fn built(primary: Primary, resolution: u32) -> (Mesh, InverseGeometricTexture) {
    let mesh = uv_sphere(24, 48);
    let opts = IgtOptions {
        primary,
        resolution,
        ..Default::default()
    };
    let igt = build(&mesh, &opts, Progress::silent()).unwrap();
    (mesh, igt)
}

/// Points spread over face `f` (corners, edge midpoints, interior), as barycentrics.
fn samples() -> Vec<[f64; 3]> {
    let n = 6;
    let mut out = vec![];
    for i in 0..=n {
        for j in 0..=n - i {
            let (a, b) = (i as f64 / n as f64, j as f64 / n as f64);
            out.push([a, b, 1.0 - a - b]);
        }
    }
    out
}

fn at(mesh: &Mesh, f: usize, l: [f64; 3]) -> DVec3 {
    let t = mesh.faces[f];
    (0..3).map(|k| mesh.positions[t[k] as usize] * l[k]).sum()
}

#[test]
fn every_sampled_cell_lists_its_triangles() {
    for primary in [Primary::Charts, Primary::Spherical, Primary::Cylindrical] {
        let (_, igt) = built(primary, 48);
        let mut missing = 0;
        for (e, entry) in igt.entries.iter().enumerate() {
            let grid = &igt.grids[entry.grid as usize];
            let t = entry.corners64();
            for l in samples() {
                let p: DVec2 = (0..3).map(|k| t[k] * l[k]).sum();
                let (i, j) = (p.x.floor() as i64, p.y.floor() as i64);
                let c = (grid.first_cell + grid.cell_index(primary, i, j)) as usize;
                missing += usize::from(!igt.list(c).contains(&(e as u32)));
            }
        }
        assert_eq!(missing, 0, "{primary:?}");
        let mean = igt.stat("list_mean").unwrap();
        assert!((1.0..20.0).contains(&mean), "{primary:?}: {mean}");
    }
}

#[test]
fn lookup_finds_the_face_under_its_own_points() {
    for primary in [Primary::Charts, Primary::Spherical] {
        let (mesh, igt) = built(primary, 64);
        let (mut wrong, mut total, mut worst) = (0, 0, 0.0f64);
        for f in 0..mesh.faces.len() {
            let g = igt.face_grid[f] as usize;
            for l in [[1.0 / 3.0; 3], [0.6, 0.3, 0.1], [0.1, 0.2, 0.7]] {
                let hit = igt.lookup(g, at(&mesh, f, l));
                total += 1;
                if hit.face != f as i64 {
                    wrong += 1;
                    continue;
                }
                let err = (0..3)
                    .map(|k| (hit.bary[k] - l[k]).abs())
                    .fold(0.0, f64::max);
                worst = worst.max(err);
                wrong += usize::from(!hit.inside);
            }
        }
        // Charts: exact; the spherical map bends triangles near the poles (this sphere's fans),
        // whose straight-edged images then overlap their neighbours (measured: 0 and 46 of 6624
        // points).
        let allowed = if primary == Primary::Charts {
            0
        } else {
            total / 100
        };
        assert!(wrong <= allowed, "{primary:?}: {wrong} of {total}");
        // Barycentrics: the charts' projection is affine, so only the f32 corners round them
        // (measured 2.1e-6); the spherical map is not, worst in the pole fans (measured 0.23).
        let bound = if primary == Primary::Charts {
            1e-5
        } else {
            0.6
        };
        eprintln!("{primary:?}: {wrong} of {total} wrong or outside, barycentric error {worst}");
        assert!(worst < bound, "{primary:?}: barycentric error {worst}");
    }
}

#[test]
fn files_round_trip_and_reject_damage() {
    let (_, igt) = built(Primary::Charts, 32);
    let bytes = file::encode(&igt);
    let back = file::decode(&bytes).unwrap();
    assert_eq!(back.grids, igt.grids);
    assert_eq!(back.cell_start, igt.cell_start);
    assert_eq!(back.cell_entries, igt.cell_entries);
    assert_eq!(back.entries, igt.entries);
    assert_eq!(back.attributes.normals, igt.attributes.normals);
    assert_eq!(back.stats, igt.stats);
    assert_eq!(file::encode(&back), bytes);
    for at in [0, 9, 13, 17, 25, 40, bytes.len() / 2, bytes.len() - 1] {
        let mut bad = bytes.clone();
        bad[at] ^= 0x40;
        assert!(file::decode(&bad).is_err(), "flip at {at}");
    }
    assert!(file::decode(&bytes[..bytes.len() - 3]).is_err());
}

#[test]
fn bad_resolution_and_cancel_are_errors() {
    let mesh = uv_sphere(8, 16);
    for r in [0, MAX_RESOLUTION + 1] {
        let opts = IgtOptions {
            resolution: r,
            ..Default::default()
        };
        let e = build(&mesh, &opts, Progress::silent());
        assert!(matches!(e, Err(GeomtexError::Parameter(_))), "{r}");
    }
    let stop = |stage: &str, _| stage != "lists";
    let progress = Progress::new(&stop, &crate::cancel::NEVER);
    let e = build(&mesh, &IgtOptions::default(), progress);
    assert!(matches!(e, Err(GeomtexError::Cancelled(s)) if s == "lists"));
}

/// The sphere shrunk by 2% around its centre, shaded through its own texture: every face's ray
/// lookup window measures the gap to the detailed surface (2% of the radius along the normal),
/// and every face walks its own grid first.
#[test]
fn windows_cover_the_gap_to_the_detailed_surface() {
    let (mesh, igt) = built(Primary::Charts, 64);
    let keep: Vec<usize> = (0..mesh.faces.len())
        .filter(|&f| igt.face_grid[f] != u32::MAX)
        .collect();
    let (lo, hi) = mesh.bounds();
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).x;
    let shrunk = Mesh {
        positions: (mesh.positions.iter())
            .map(|&p| centre + (p - centre) * 0.98)
            .collect(),
        faces: keep.iter().map(|&f| mesh.faces[f]).collect(),
        colors: None,
        appearance: Default::default(),
    };
    let grids = keep.iter().map(|&f| igt.face_grid[f] as i64).collect();
    let igt = Arc::new(igt);
    let shaded = IgtMesh::new(
        igt.clone(),
        shrunk,
        grids,
        Lookup::Ray,
        &crate::cancel::Cancel::new(),
    )
    .unwrap();
    let gap = 0.02 * radius;
    // The measured distance back out of each inside window (1.25x it plus a cell; nothing of
    // the sphere lies inside its shrunk copy near it, so that is the base); the outside window
    // reaches at least as far.
    assert!(shaded.face_window.iter().all(|w| w[0] >= w[1]));
    let parted = (shaded.face_window.iter().zip(&shaded.face_grid))
        .map(|(&w, &g)| (w[1] as f64 - igt.grids[g as usize].cell.max_element()) / 1.25);
    let worst = parted.fold(0.0f64, |m, d| m.max((d - gap).abs() / gap));
    // Measured 0.42% (the chords' sagitta and the samples' spacing).
    assert!(worst <= 0.0125, "{worst}");
    for (list, &own) in shaded.face_search_grids.iter().zip(&shaded.face_grid) {
        assert_eq!(list[0], own);
        assert!(list.len() <= window::MAX_GRIDS);
    }
}
