//! A triangle mesh made ready for the CPU backend: an 8-wide BVH over its faces (`wide_bvh`:
//! obvhs builds the tree, the walk is ours). The BVH picks the face in f32; the hit is then
//! recomputed in f64 from the face's own vertices, so distances and barycentrics are as exact as
//! the mesh.
//!
//! Spaces: the mesh's object space, re-centred on its bounding box's centre for the f32 hierarchy
//! (`centre`); rays arrive in object space (f64) with t meaning world distance (the placement is
//! affine, so the parameter carries over).

use std::sync::Arc;

use glam::{DVec3, Vec3A};
use obvhs::triangle::Triangle;

use crate::wide_bvh::{WideBvh, WideRay};

use crate::mesh::{CornerNormals, Mesh, MeshGeometry, NormalRule};

/// One hit on a mesh: distance, face and barycentric coordinates (of its corners 0, 1, 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FaceHit {
    pub t: f64,
    pub face: u32,
    pub barycentric: [f64; 3],
}

pub(crate) struct MeshTracer {
    mesh: Arc<Mesh>,
    /// Over the faces, f32 relative to `centre`; its primitives are face indices.
    bvh: WideBvh,
    centre: DVec3,
    normals: CornerNormals,
    /// The mesh's bounding box.
    pub bounds: crate::bvh::Aabb,
}

impl MeshTracer {
    /// The hierarchy over the mesh's faces (every core), and its corner normals under `rule`.
    pub fn new(mesh: Arc<Mesh>, rule: NormalRule) -> MeshTracer {
        let (lo, hi) = mesh.bounds();
        let centre = 0.5 * (lo + hi);
        let at = |v: u32| Vec3A::from((mesh.positions[v as usize] - centre).as_vec3());
        let all: Vec<Triangle> = (mesh.faces.iter())
            .map(|&[a, b, c]| Triangle {
                v0: at(a),
                v1: at(b),
                v2: at(c),
            })
            .collect();
        let bvh = WideBvh::build(&all);
        let normals = MeshGeometry::new(&mesh).corner_normals(&mesh, rule);
        MeshTracer {
            mesh,
            bvh,
            centre,
            normals,
            bounds: crate::bvh::Aabb { lo, hi },
        }
    }

    /// The f32 ray of an object-space ray, for stretch [t0, t1], and its far end.
    fn ray(&self, o: DVec3, d: DVec3, (t0, t1): (f64, f64)) -> (WideRay, f32) {
        let far = if t1.is_finite() {
            t1 as f32
        } else {
            f32::INFINITY
        };
        let ray = WideRay::new(
            Vec3A::from((o - self.centre).as_vec3()),
            Vec3A::from(d.as_vec3()),
            t0 as f32,
        );
        (ray, far)
    }

    /// The nearest hit of the object-space ray o + t d for t in `span`, or None.
    pub fn nearest(&self, o: DVec3, d: DVec3, span: (f64, f64)) -> Option<FaceHit> {
        let (ray, far) = self.ray(o, d, span);
        let (t, face) = self.bvh.nearest(&ray, far)?;
        // The f32 pick, recomputed in f64; kept as picked where f64 finds the ray parallel.
        self.exact(face, o, d)
            .filter(|h| h.t >= span.0 && h.t <= span.1)
            .or(Some(FaceHit {
                t: f64::from(t),
                face,
                barycentric: [1.0 / 3.0; 3],
            }))
    }

    /// Whether the object-space ray meets any face for t in `span` (stops at the first found).
    pub fn any(&self, o: DVec3, d: DVec3, span: (f64, f64)) -> bool {
        let (ray, far) = self.ray(o, d, span);
        self.bvh.any(&ray, far)
    }

    /// Every face the object-space ray crosses for t in `span`, nearest first.
    pub fn all(&self, o: DVec3, d: DVec3, span: (f64, f64)) -> Vec<FaceHit> {
        let (ray, far) = self.ray(o, d, span);
        let mut hits: Vec<FaceHit> = (self.bvh.all(&ray, far).into_iter())
            .filter_map(|f| self.exact(f, o, d))
            .filter(|h| h.t >= span.0 && h.t <= span.1)
            .collect();
        hits.sort_by(|a, b| a.t.total_cmp(&b.t));
        hits
    }

    /// The ray's crossing of face `f`'s plane in f64 (Möller–Trumbore without the inside test:
    /// the f32 pick decided that), or None where the ray runs along the plane.
    fn exact(&self, f: u32, o: DVec3, d: DVec3) -> Option<FaceHit> {
        let [a, b, c] = self.mesh.faces[f as usize].map(|v| self.mesh.positions[v as usize]);
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-300 || !det.is_finite() {
            return None;
        }
        let s = o - a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let t = e2.dot(q) / det;
        t.is_finite().then_some(FaceHit {
            t,
            face: f,
            barycentric: [1.0 - u - v, u, v],
        })
    }

    /// The object-space unit normal a hit shows (its corners' normals blended).
    pub fn normal(&self, hit: &FaceHit) -> DVec3 {
        let l = hit.barycentric.map(|w| w.clamp(0.0, 1.0));
        let corners = self.normals.face(hit.face as usize);
        (corners[0] * l[0] + corners[1] * l[1] + corners[2] * l[2]).normalize_or_zero()
    }

    /// The object-space unit normal of the face hit (what ray queries report, as the GPU's).
    pub fn face_normal(&self, hit: &FaceHit) -> DVec3 {
        let [a, b, c] = self.mesh.faces[hit.face as usize].map(|v| self.mesh.positions[v as usize]);
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// The base color (RGBA8) a hit shows.
    pub fn color(&self, hit: &FaceHit) -> [u8; 4] {
        let l = hit.barycentric.map(|w| w.clamp(0.0, 1.0));
        self.mesh.base_color(hit.face, l)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::NormalSource;

    /// A unit cube's 12 faces (two triangles per side), as `Mesh::from_flat` takes them.
    fn cube() -> Mesh {
        let mut positions = Vec::new();
        for k in 0..8 {
            positions.extend([k & 1, (k >> 1) & 1, (k >> 2) & 1].map(f64::from));
        }
        let faces: [i64; 36] = [
            0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4,
            6, 1, 3, 5, 3, 7, 5,
        ];
        Mesh::from_flat(&positions, &faces, None).unwrap()
    }

    /// Rays through a cube from outside: the nearest hit is where the ray enters, exactly;
    /// every ray through it crosses two faces (or more along an edge's diagonal); any-hit
    /// agrees with the nearest.
    #[test]
    fn a_cube_is_entered_where_its_sides_are() {
        let rule = NormalRule::from_keywords(Some(NormalSource::Flat), None).unwrap();
        let tracer = MeshTracer::new(Arc::new(cube()), rule);
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut unit = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut hits, mut misses) = (0, 0);
        for _ in 0..2000 {
            let o = DVec3::new(unit() * 4.0 - 1.5, unit() * 4.0 - 1.5, -2.0);
            let target = DVec3::new(unit() * 1.2 - 0.1, unit() * 1.2 - 0.1, 0.5);
            let d = (target - o).normalize();
            let inside = (0.0..=1.0).contains(&target.x) && (0.0..=1.0).contains(&target.y);
            let nearest = tracer.nearest(o, d, (0.0, f64::INFINITY));
            assert_eq!(tracer.any(o, d, (0.0, f64::INFINITY)), nearest.is_some());
            let all = tracer.all(o, d, (0.0, f64::INFINITY));
            let Some(hit) = nearest else {
                // Only rays within f32 rounding of an edge may go either way.
                let edge = [target.x, target.y].iter().any(|v| v.abs() < 1e-5);
                assert!(!inside || edge, "{o} {d} missed");
                assert!(all.is_empty());
                misses += 1;
                continue;
            };
            hits += 1;
            // A box entered at the slab test's entry point.
            let inv = d.recip();
            let (a, b) = ((DVec3::ZERO - o) * inv, (DVec3::ONE - o) * inv);
            let entry = a.min(b).max_element();
            assert!(
                (hit.t - entry).abs() < 1e-12 * (1.0 + entry),
                "{} vs {entry}",
                hit.t
            );
            assert!(all.len() >= 2, "{all:?}");
            assert_eq!(all[0].t, hit.t);
        }
        // Measured 1,871 hits and 129 misses.
        assert!(hits > 1000 && misses > 50, "{hits} {misses}");
    }
}
