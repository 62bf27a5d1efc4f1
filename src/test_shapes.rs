//! Meshes the unit tests of several modules share (test builds only).

use crate::mesh::{grid_faces, Mesh};

/// A UV sphere of radius 1 (poles are fans): closed, so it can never be a single height field.
pub fn uv_sphere(rings: usize, segments: usize) -> Mesh {
    let mut pos = vec![0.0, 0.0, 1.0];
    for r in 1..rings {
        let theta = std::f64::consts::PI * r as f64 / rings as f64;
        for s in 0..segments {
            let phi = std::f64::consts::TAU * s as f64 / segments as f64;
            pos.extend_from_slice(&[
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            ]);
        }
    }
    pos.extend_from_slice(&[0.0, 0.0, -1.0]);
    let ring = |r: usize, s: usize| (1 + (r - 1) * segments + s % segments) as i64;
    let south = (pos.len() / 3 - 1) as i64;
    let mut faces = Vec::new();
    for s in 0..segments {
        faces.extend_from_slice(&[0, ring(1, s), ring(1, s + 1)]);
        faces.extend_from_slice(&[south, ring(rings - 1, s + 1), ring(rings - 1, s)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            let (a, b, c, d) = (
                ring(r, s),
                ring(r, s + 1),
                ring(r + 1, s + 1),
                ring(r + 1, s),
            );
            faces.extend_from_slice(&[a, d, c, a, c, b]);
        }
    }
    Mesh::from_flat(&pos, &faces, None).unwrap()
}

/// A helicoid ramp (radius 0.5 to 1, rising 0.5 a turn) over `turns` turns: every face faces
/// up (tilted at most 9 degrees), so it never folds, yet past one turn it lies over itself.
pub fn ramp(turns: f64) -> Mesh {
    let (nr, nt) = (4usize, (48.0 * turns).ceil() as usize);
    let mut pos = Vec::new();
    for j in 0..=nt {
        let theta = turns * std::f64::consts::TAU * j as f64 / nt as f64;
        for i in 0..=nr {
            let r = 0.5 + 0.5 * i as f64 / nr as f64;
            pos.extend_from_slice(&[
                r * theta.cos(),
                r * theta.sin(),
                0.5 * theta / std::f64::consts::TAU,
            ]);
        }
    }
    Mesh::from_flat(&pos, &grid_faces(nr, nt), None).unwrap()
}
