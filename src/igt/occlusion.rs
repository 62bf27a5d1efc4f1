//! Ambient occlusion per vertex of the detailed mesh, by ray casting on the CPU: from each
//! vertex, cosine-weighted rays over the hemisphere around its normal; the attribute is the
//! fraction that leave the mesh (1 = open sky, 0 = enclosed), within `distance` when one is
//! given. Rays are cast through a bounding-volume hierarchy over the faces (bvh.rs, the
//! tracer's own tree) with an any-hit walk, since occlusion needs no nearest hit.
//!
//! The directions are one fixed cosine-weighted set (Hammersley points through Malley's
//! method), turned about the normal by an angle hashed from the vertex index: neighbours see
//! different directions, so the sampling error is noise rather than bands, and the result is
//! the same on every run.
//!
//! Spaces: the mesh's own (f64).

use glam::DVec3;

use crate::bvh::{Aabb, Bvh, ItemWalk};
use crate::error::Result;
use crate::mesh::{Mesh, MeshGeometry};
use crate::progress::Progress;

/// Rays per vertex by default: the sampling error's standard deviation is at most
/// 0.5 / sqrt(64) = 0.06 of the full range.
pub const DEFAULT_RAYS: u32 = 64;
/// Most rays per vertex.
pub const MAX_RAYS: u32 = 4096;
/// Vertices per parallel job (also how often the stage polls for cancellation).
const CHUNK: usize = 1024;

/// How to compute ambient occlusion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OcclusionOptions {
    pub rays: u32,
    /// Hits farther than this (mesh units) do not occlude; None: any hit does.
    pub distance: Option<f64>,
}

impl Default for OcclusionOptions {
    fn default() -> Self {
        OcclusionOptions {
            rays: DEFAULT_RAYS,
            distance: None,
        }
    }
}

/// The ray p + t d meets triangle (a, b, c) for t in (t0, t1) (Möller–Trumbore, two-sided).
fn meets_triangle(a: DVec3, b: DVec3, c: DVec3, p: DVec3, d: DVec3, span: (f64, f64)) -> bool {
    let (e1, e2) = (b - a, c - a);
    let q = d.cross(e2);
    let det = e1.dot(q);
    if det.abs() < 1e-300 {
        return false;
    }
    let inv = 1.0 / det;
    let s = p - a;
    let u = s.dot(q) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let r = s.cross(e1);
    let v = d.dot(r) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    let t = e2.dot(r) * inv;
    t > span.0 && t < span.1
}

/// `n` cosine-weighted unit directions about +z: Hammersley points (i + 0.5) / n and the
/// radical inverse of i, lifted from the unit disc to the hemisphere (Malley's method).
fn cosine_directions(n: u32) -> Vec<DVec3> {
    (0..n)
        .map(|i| {
            let u = (i as f64 + 0.5) / n as f64;
            let v = i.reverse_bits() as f64 / 2f64.powi(32);
            let r = u.sqrt();
            let phi = std::f64::consts::TAU * v;
            DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u).max(0.0).sqrt())
        })
        .collect()
}

/// A turn in [0, 2π) hashed from `k` (splitmix64's finalizer).
fn turn(k: u64) -> f64 {
    let mut z = k.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    std::f64::consts::TAU * (z >> 11) as f64 / 2f64.powi(53)
}

/// Per vertex of `mesh`, the unoccluded fraction of its cosine-weighted hemisphere; vertices
/// with no normal (only degenerate faces around them) get 1.
pub fn vertex_occlusion(
    mesh: &Mesh,
    geo: &MeshGeometry,
    opts: &OcclusionOptions,
    progress: Progress,
) -> Result<Vec<f32>> {
    let corners = |f: usize| mesh.faces[f].map(|v| mesh.positions[v as usize]);
    let boxes: Vec<Aabb> = (0..mesh.faces.len())
        .map(|f| {
            if geo.degenerate[f] {
                Aabb::EMPTY
            } else {
                Aabb::of_points(corners(f))
            }
        })
        .collect();
    let (lo, hi) = mesh.bounds();
    if boxes.is_empty() {
        return Ok(vec![1.0; mesh.positions.len()]);
    }
    let bvh = Bvh::build(&boxes);
    let bounds = bvh.node_bounds(&boxes);
    // Rays start this far off the surface, so that the vertex's own faces, met at t = 0 in
    // f64 rounding, never count; far below any feature the rays should see.
    let lift = 1e-6 * (hi - lo).length().max(f64::MIN_POSITIVE);
    let reach = opts.distance.unwrap_or(f64::INFINITY);
    let directions = cosine_directions(opts.rays);
    let occluded = |p: DVec3, d: DVec3| {
        bvh.with(&bounds).any(p, d, (lift, reach), |f| {
            let [a, b, c] = corners(f as usize);
            meets_triangle(a, b, c, p, d, (lift, reach))
        })
    };
    let at_vertex = |v: usize| -> f32 {
        let n = geo.vertex_normals[v];
        if !n.is_finite() || n.length_squared() < 0.5 {
            return 1.0;
        }
        let (x, y) = n.any_orthonormal_pair();
        let (s, c) = turn(v as u64).sin_cos();
        let (x, y) = (x * c + y * s, y * c - x * s);
        let p = mesh.positions[v] + n * lift;
        let open = (directions.iter())
            .filter(|w| !occluded(p, x * w.x + y * w.y + n * w.z))
            .count();
        open as f32 / directions.len() as f32
    };
    let chunks: Vec<std::ops::Range<usize>> = (0..mesh.positions.len())
        .step_by(CHUNK)
        .map(|s| s..(s + CHUNK).min(mesh.positions.len()))
        .collect();
    let parts = crate::progress::each_chart(&chunks, progress, "occlusion", |r| {
        r.clone().map(at_vertex).collect::<Vec<f32>>()
    })?;
    Ok(parts.concat())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The set's mean cosine is 2/3, as the cosine-weighted hemisphere's is.
    #[test]
    fn directions_are_cosine_weighted() {
        let d = cosine_directions(256);
        let mean = d.iter().map(|w| w.z).sum::<f64>() / 256.0;
        assert!((mean - 2.0 / 3.0).abs() < 0.01, "{mean}");
        assert!(d
            .iter()
            .all(|w| (w.length() - 1.0).abs() < 1e-12 && w.z >= 0.0));
    }

    /// From the centre of a box's floor, a ray escapes when it leaves through the open top:
    /// the cosine-weighted share of the hemisphere the opening covers is the view factor of a
    /// parallel unit square at height 1 seen from below its centre, 0.2394 (four quarter
    /// squares of the corner-point formula); a closed box lets none escape.
    #[test]
    fn a_box_occludes_its_inside() {
        #[rustfmt::skip]
        let positions = [
            0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.,
            0., 0., 1., 1., 0., 1., 1., 1., 1., 0., 1., 1., 0.5, 0.5, 0.,
        ];
        // Floor (fanned around its centre, vertex 8) and four walls, normals inward.
        let mut faces: Vec<i64> = vec![0, 1, 8, 1, 2, 8, 2, 3, 8, 3, 0, 8];
        for k in 0..4 {
            let (a, b) = (k, (k + 1) % 4);
            faces.extend([a, a + 4, b + 4, a, b + 4, b]);
        }
        let opts = OcclusionOptions {
            rays: 1024,
            distance: None,
        };
        let ao = |faces: &[i64]| {
            let mesh = Mesh::from_flat(&positions, faces, None).unwrap();
            let geo = MeshGeometry::new(&mesh);
            vertex_occlusion(&mesh, &geo, &opts, Progress::silent()).unwrap()[8]
        };
        let open = ao(&faces);
        // Measured 0.243 (as the texture keeps it, 62/255; 1024 rays, whose standard error
        // would be 0.013).
        assert!((open - 0.2394).abs() < 0.01, "open box: {open}");
        faces.extend([4, 6, 5, 4, 7, 6]);
        let closed = ao(&faces);
        assert!(closed == 0.0, "closed box: {closed}");
        let near = OcclusionOptions {
            distance: Some(0.5),
            ..opts
        };
        let mesh = Mesh::from_flat(&positions, &faces, None).unwrap();
        let geo = MeshGeometry::new(&mesh);
        // Within half the box's height from the floor's centre only the walls' lower halves
        // occlude: most rays go free.
        let short = vertex_occlusion(&mesh, &geo, &near, Progress::silent()).unwrap()[8];
        assert!(short > 0.5, "distance 0.5: {short}");
    }
}
