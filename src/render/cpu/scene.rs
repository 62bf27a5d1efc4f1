//! A scene as the CPU backend traces it: each texture set and mesh with its own hierarchy (kept
//! between frames by `CpuRenderer`), placed by its `world_from_object`, with the ids the GPU
//! backend gives (patches 0.. across the sets in scene order, -2 - k for the k-th mesh).
//!
//! A frame's rays come in bundles (8 x 8 pixel tiles): `bundle` finds once what a tile's rays
//! may meet — the objects, and a set's pieces inside the tile's frustum, nearest first — and
//! `nearest_in` tests only that for each of its rays.
//!
//! Spaces: rays arrive in world space (f64) and are taken into each object's space by its
//! inverse placement, keeping their parameter t; normals return to world space by the inverse
//! transpose; a bundle's planes and depth go into each object's space by the transpose of its
//! placement's linear part.

use std::cell::Cell;
use std::sync::Arc;

use glam::{DMat3, DMat4, DVec3};

use super::mesh::{FaceHit, MeshTracer};
use super::set::SetSearch;
use crate::bvh::Aabb;
use crate::heightfield::{BundlePieces, Plane};
use crate::render::error_bound::ObjectIds;

/// An object's hierarchy.
#[derive(Clone)]
pub(crate) enum Traced {
    Set(Arc<SetSearch>),
    Mesh(Arc<MeshTracer>),
}

impl Traced {
    /// The object's bounding box in its own space (made with its hierarchy, kept).
    fn bounds(&self) -> Aabb {
        match self {
            Traced::Set(s) => s.bounds,
            Traced::Mesh(m) => m.bounds,
        }
    }
}

struct Placed {
    traced: Traced,
    object_from_world: DMat4,
    /// A plane or affine function of world points as one of object points: the transpose of
    /// the placement's linear part, and its translation (n . p + c = (L^T n) . q + n . m + c).
    plane_to_object: (DMat3, DVec3),
    /// World normals from object normals: the inverse transpose of the placement's linear part.
    world_normal_from_object: DMat3,
    /// The object's box in world space (a ray that misses it skips the object).
    world_box: Aabb,
    /// Its first patch id (sets) or its mesh id -2 - k (meshes).
    first_id: i32,
}

impl Placed {
    /// Object `k` (this one) with the world ray o + t d in its space, t kept.
    fn ray_in(&self, k: usize, o: DVec3, d: DVec3) -> (usize, &Placed, DVec3, DVec3) {
        let m = &self.object_from_world;
        (k, self, m.transform_point3(o), m.transform_vector3(d))
    }
}

/// Where a ray met the scene: its t, the object, and the patch or face.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Hit {
    pub t: f64,
    pub object: usize,
    pub part: Part,
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum Part {
    Patch(u32),
    Face(FaceHit),
}

/// What a bundle of rays may meet (`SceneTrace::bundle`): objects by index, and for a set the
/// pieces its rays may meet, nearest first.
pub(crate) struct Bundle {
    objects: Vec<BundleObject>,
}

/// An object a bundle's rays may meet: its index, and for a set the pieces they may meet.
struct BundleObject {
    object: usize,
    pieces: Option<BundlePieces>,
}

impl Bundle {
    /// Whether the bundle's rays can meet nothing.
    #[cfg(test)]
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }
}

pub(crate) struct SceneTrace {
    placed: Vec<Placed>,
    /// The ids each object took, in scene order (error_bound.rs reads them).
    pub ids: Vec<ObjectIds>,
}

impl SceneTrace {
    /// The scene's objects (their hierarchies and placements), ids given in scene order.
    pub fn new(objects: Vec<(Traced, DMat4)>) -> SceneTrace {
        let (mut patches, mut meshes) = (0i32, 0usize);
        let mut ids = Vec::with_capacity(objects.len());
        let placed = (objects.into_iter())
            .map(|(traced, world_from_object)| {
                let first_id = match &traced {
                    Traced::Set(s) => {
                        let n = s.set.patches.len() as i32;
                        ids.push(ObjectIds {
                            patches: patches..patches + n,
                            meshes: meshes..meshes,
                        });
                        patches += n;
                        patches - n
                    }
                    Traced::Mesh(_) => {
                        ids.push(ObjectIds {
                            patches: patches..patches,
                            meshes: meshes..meshes + 1,
                        });
                        meshes += 1;
                        -2 - (meshes as i32 - 1)
                    }
                };
                let linear = DMat3::from_mat4(world_from_object);
                let world_box = Aabb::of_points(
                    (traced.bounds().corners()).map(|c| world_from_object.transform_point3(c)),
                );
                Placed {
                    traced,
                    object_from_world: world_from_object.inverse(),
                    plane_to_object: (linear.transpose(), world_from_object.w_axis.truncate()),
                    world_normal_from_object: linear.inverse().transpose(),
                    world_box,
                    first_id,
                }
            })
            .collect();
        SceneTrace { placed, ids }
    }

    /// The objects the world ray o + t d may meet within `span`, each with the ray in its space.
    fn candidates(
        &self,
        o: DVec3,
        d: DVec3,
        span: (f64, f64),
    ) -> impl Iterator<Item = (usize, &Placed, DVec3, DVec3)> + '_ {
        let inverse = d.recip();
        (self.placed.iter().enumerate())
            .filter(move |(_, p)| p.world_box.meets_inverse(o, inverse, span))
            .map(move |(k, p)| p.ray_in(k, o, d))
    }

    /// The nearest hit of the world ray o + t d for t in `span` (d of any length: t is its
    /// parameter), or None.
    pub fn nearest(&self, o: DVec3, d: DVec3, span: (f64, f64)) -> Option<Hit> {
        self.nearest_of(self.candidates(o, d, span).map(|c| (c, None)), span)
    }

    /// What the rays of a bundle (a frame's tile) may meet, found once for all of them: the
    /// objects whose boxes meet the bundle, and for sets the pieces that may (nearest first).
    /// The bundle lies inside `planes` (world space), and `depth` (a . p + b) is the rays' t.
    pub fn bundle(&self, planes: &[Plane], (a, b): (DVec3, f64)) -> Bundle {
        let objects = (self.placed.iter().enumerate())
            .filter_map(|(k, placed)| {
                // Planes and depth in the object's space.
                let (linear_t, shift) = placed.plane_to_object;
                let to_object = |(n, c): Plane| (linear_t * n, n.dot(shift) + c);
                let local: Vec<Plane> = planes.iter().map(|&p| to_object(p)).collect();
                let pieces = match &placed.traced {
                    Traced::Set(s) => {
                        let found = s.tracer.pieces_within(&local, to_object((a, b)));
                        if found.is_empty() {
                            return None;
                        }
                        Some(found)
                    }
                    Traced::Mesh(_) => None,
                };
                Some(BundleObject { object: k, pieces })
            })
            .collect();
        Bundle { objects }
    }

    /// `nearest` for a ray of `bundle`: only what the bundle may meet is tested.
    pub fn nearest_in(&self, bundle: &Bundle, o: DVec3, d: DVec3, span: (f64, f64)) -> Option<Hit> {
        let inverse = d.recip();
        let objects = (bundle.objects.iter())
            .filter(|b| {
                self.placed[b.object]
                    .world_box
                    .meets_inverse(o, inverse, span)
            })
            .map(|b| {
                (
                    self.placed[b.object].ray_in(b.object, o, d),
                    b.pieces.as_deref(),
                )
            });
        self.nearest_of(objects, span)
    }

    /// The nearest hit among `objects` (each with the ray in its space, and for a set in a
    /// bundle the pieces to test), for t in `span`.
    fn nearest_of<'a>(
        &self,
        objects: impl Iterator<Item = ((usize, &'a Placed, DVec3, DVec3), Option<&'a [(f64, u32)]>)>,
        span: (f64, f64),
    ) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        for ((object, placed, lo, ld), pieces) in objects {
            let within = (span.0, best.map_or(span.1, |b| b.t));
            let hit = match (&placed.traced, pieces) {
                (Traced::Set(s), Some(pieces)) => {
                    (s.nearest_among(pieces, lo, ld, within)).map(|(t, k)| (t, Part::Patch(k)))
                }
                (Traced::Set(s), None) => {
                    s.nearest(lo, ld, within).map(|(t, k)| (t, Part::Patch(k)))
                }
                (Traced::Mesh(m), _) => m.nearest(lo, ld, within).map(|h| (h.t, Part::Face(h))),
            };
            if let Some((t, part)) = hit.filter(|h| h.0 <= within.1) {
                best = Some(Hit { t, object, part });
            }
        }
        best
    }

    /// The nearest hit of the first object the world ray meets within `span` (objects in
    /// scene order): an any-hit query's answer, with a distance and normal to report.
    pub fn first_found(&self, o: DVec3, d: DVec3, span: (f64, f64)) -> Option<Hit> {
        self.candidates(o, d, span)
            .find_map(|(object, placed, lo, ld)| {
                let (t, part) = match &placed.traced {
                    Traced::Set(s) => s.nearest(lo, ld, span).map(|(t, k)| (t, Part::Patch(k)))?,
                    Traced::Mesh(m) => m.nearest(lo, ld, span).map(|h| (h.t, Part::Face(h)))?,
                };
                Some(Hit { t, object, part })
            })
    }

    /// Whether the world ray meets anything for t in `span` (stops at the first found). `last`
    /// holds the set piece (object, piece) that stopped a neighbouring ray, tested first here,
    /// and is left at this ray's, if a set's.
    pub fn any_after(
        &self,
        o: DVec3,
        d: DVec3,
        span: (f64, f64),
        last: &Cell<Option<(usize, u32)>>,
    ) -> bool {
        self.candidates(o, d, span)
            .any(|(k, placed, lo, ld)| match &placed.traced {
                Traced::Set(s) => {
                    let piece = Cell::new(last.get().filter(|h| h.0 == k).map(|h| h.1));
                    let found = s.any(lo, ld, span, &piece);
                    if let Some(p) = piece.get().filter(|_| found) {
                        last.set(Some((k, p)));
                    }
                    found
                }
                Traced::Mesh(m) => m.any(lo, ld, span),
            })
    }

    /// Every crossing of the world ray with the scene for t in `span`, nearest first: (t, id).
    pub fn all(&self, o: DVec3, d: DVec3, span: (f64, f64)) -> Vec<(f64, i32)> {
        let mut hits = Vec::new();
        for (_, placed, lo, ld) in self.candidates(o, d, span) {
            match &placed.traced {
                Traced::Set(s) => hits.extend(
                    (s.all(lo, ld, span).into_iter()).map(|(t, k)| (t, placed.first_id + k)),
                ),
                Traced::Mesh(m) => hits.extend(
                    m.all(lo, ld, span)
                        .into_iter()
                        .map(|h| (h.t, placed.first_id)),
                ),
            }
        }
        hits.sort_by(|a, b| a.0.total_cmp(&b.0));
        hits
    }

    /// The id a hit draws (as `Frame::patch_id`).
    pub fn id(&self, hit: &Hit) -> i32 {
        let placed = &self.placed[hit.object];
        match hit.part {
            Part::Patch(k) => placed.first_id + k as i32,
            Part::Face(_) => placed.first_id,
        }
    }

    /// The world unit normal a ray query reports for a hit of the world ray o + t d: a set's
    /// shading normal, a mesh's face normal (as the GPU's queries).
    pub fn query_normal(&self, hit: &Hit, o: DVec3, d: DVec3) -> DVec3 {
        let placed = &self.placed[hit.object];
        let n = match (&placed.traced, hit.part) {
            (Traced::Set(s), Part::Patch(k)) => {
                let m = &placed.object_from_world;
                s.normal(k, m.transform_point3(o), m.transform_vector3(d), hit.t)
            }
            (Traced::Mesh(m), Part::Face(face)) => m.face_normal(&face),
            _ => unreachable!("a set's hit is a patch, a mesh's a face"),
        };
        (placed.world_normal_from_object * n).normalize_or_zero()
    }

    /// What a frame's pixel shows of a hit of the world ray o + t d: the world unit shading
    /// normal (a set's as `query_normal`, a mesh's corner normals blended) and the base color (RGBA8), found together (a set's hit is placed
    /// in its maps once for both).
    pub fn shade(&self, hit: &Hit, o: DVec3, d: DVec3) -> (DVec3, [u8; 4]) {
        let placed = &self.placed[hit.object];
        let (n, color) = match (&placed.traced, hit.part) {
            (Traced::Set(s), Part::Patch(k)) => {
                let m = &placed.object_from_world;
                s.shade(k, m.transform_point3(o), m.transform_vector3(d), hit.t)
            }
            (Traced::Mesh(m), Part::Face(face)) => (m.normal(&face), m.color(&face)),
            _ => unreachable!("a set's hit is a patch, a mesh's a face"),
        };
        (
            (placed.world_normal_from_object * n).normalize_or_zero(),
            color,
        )
    }

    /// The world bounds of every object (the frame's depth range is made from them).
    pub fn world_boxes(&self) -> impl Iterator<Item = &Aabb> {
        self.placed.iter().map(|p| &p.world_box)
    }
}
