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

/// How far past its edges (barycentric units) the f32 walk of `nearest` takes a face: f32
/// Möller–Trumbore is not watertight, and a ray along an edge shared by two faces slipped
/// between them (11% of rays aimed at the edges of a fine grid, in the test below). A face taken
/// past its edge is rejected by the f64 check, which then decides among the faces the walk
/// meets: a second walk for 195 of the bunny's 1 M random rays, 1,007 of 9 M frame rays.
const PICK_EDGE_SLACK: f32 = 1e-4;

/// How far (in barycentric units) an f64 hit may fall outside its face and still count: the
/// f64 test's own rounding, so that a ray through a shared edge meets one of its faces. Off the
/// face by at most this times its size, far inside the f64 term of its error bound.
const ON_FACE_SLACK: f64 = 64.0 * f64::EPSILON;

/// Whether an f64 hit lies on its face (within `ON_FACE_SLACK`).
fn on_face(hit: &FaceHit) -> bool {
    hit.barycentric.iter().all(|&w| w >= -ON_FACE_SLACK)
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
        let ray = ray.with_edge_slack(PICK_EDGE_SLACK);
        let (t, face) = self.bvh.nearest(&ray, far)?;
        // The f32 pick, recomputed in f64. Within f32 rounding of an edge the pick may lie off
        // its face (by ~1e-7 of the mesh's size, as much as the depth's own rounding): then the
        // faces the walk meets decide in f64, so a drawn point lies on a face, as its error
        // bound says, and a ray f64 finds passing beside the last face misses.
        match self.exact(face, o, d) {
            Some(hit) if on_face(&hit) && hit.t >= span.0 && hit.t <= span.1 => Some(hit),
            Some(_) => self.exact_nearest(&ray, far, (o, d), span),
            // Parallel to the face in f64: kept as picked.
            None => self
                .exact_nearest(&ray, far, (o, d), span)
                .or(Some(FaceHit {
                    t: f64::from(t),
                    face,
                    barycentric: [1.0 / 3.0; 3],
                })),
        }
    }

    /// The nearest face the ray meets in f64 (inside test included) among those of the leaves
    /// the f32 walk enters, for t in `span`.
    fn exact_nearest(
        &self,
        ray: &WideRay,
        far: f32,
        (o, d): (DVec3, DVec3),
        span: (f64, f64),
    ) -> Option<FaceHit> {
        let mut best: Option<FaceHit> = None;
        self.bvh.visit_primitives(ray, far, |f, tmax| {
            let Some(hit) = self.exact(f, o, d).filter(on_face) else {
                return;
            };
            if hit.t >= span.0 && hit.t <= span.1 && best.is_none_or(|b| hit.t < b.t) {
                best = Some(hit);
                // The walk's boxes are f32: stop only past a step beyond the hit.
                *tmax = tmax.min((hit.t as f32).next_up().next_up());
            }
        });
        best
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
    use crate::wide_bvh::tests::uniform;

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
        let mut unit = uniform(0x2545_f491_4f6c_dd1d);
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

    /// Rays aimed at the shared edges of a fine tilted grid far from the origin, where the f32
    /// pick may fall on either face and off it by f32 rounding: every hit lies on a face in
    /// f64, where the ray was aimed, and none slips between two faces. Keeping the f32 pick as
    /// found turns this red (a pick off its face by 8e-12 of it), as does a walk without
    /// `PICK_EDGE_SLACK` (432 of 4,000 rays slipped through).
    #[test]
    fn a_ray_along_a_shared_edge_lands_on_a_face() {
        let n = 48;
        let corner = |i: usize, j: usize| {
            let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
            DVec3::new(1000.0 + x, 2000.0 + y, 0.3 * x - 0.2 * y)
        };
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                positions.extend(corner(i, j).to_array());
            }
        }
        let mut faces = Vec::new();
        for j in 0..n as i64 {
            for i in 0..n as i64 {
                let v = |di: i64, dj: i64| (j + dj) * (n as i64 + 1) + i + di;
                faces.extend([v(0, 0), v(1, 0), v(1, 1), v(0, 0), v(1, 1), v(0, 1)]);
            }
        }
        let mesh = Mesh::from_flat(&positions, &faces, None).unwrap();
        let tracer = MeshTracer::new(Arc::new(mesh), NormalRule::default());
        let mut unit = uniform(0x9e37_79b9_7f4a_7c15);
        let (mut worst, mut slipped) = (0.0f64, 0);
        for k in 0..4000 {
            // A point on a grid line, a column line or a diagonal, inside the grid.
            let (i, j, s) = (
                1 + (unit() * (n - 2) as f64) as usize,
                1 + (unit() * (n - 2) as f64) as usize,
                unit(),
            );
            let (a, b) = match k % 3 {
                0 => (corner(i, j), corner(i + 1, j)),
                1 => (corner(i, j), corner(i, j + 1)),
                _ => (corner(i, j), corner(i + 1, j + 1)),
            };
            let target = a + (b - a) * s;
            let o = target + DVec3::new(unit() - 0.5, unit() - 0.5, 1.0 + unit()) * 3.0;
            let d = (target - o).normalize();
            let hit = tracer.nearest(o, d, (0.0, f64::INFINITY));
            // Only where f32 rounding passes the widened test too (PICK_EDGE_SLACK).
            let Some(hit) = hit else {
                slipped += 1;
                continue;
            };
            let least = hit
                .barycentric
                .iter()
                .copied()
                .fold(f64::INFINITY, f64::min);
            worst = worst.min(least);
            let p = o + d * hit.t;
            assert!((p - target).length() < 1e-9, "ray {k}: {p} vs {target}");
        }
        assert!(worst >= -ON_FACE_SLACK, "a hit off its face by {worst}");
        assert_eq!(slipped, 0, "rays slipped through");
    }
}
