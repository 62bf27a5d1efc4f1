//! A test-only toy kind: analytic spheres, drawn and traced as tessellated meshes through a mesh
//! kind of its own. It shows what a new kind takes: this file and one line in `kinds!` (mod.rs);
//! the renderer routes a scene object holding `Spheres` here by its type, and frames, ray queries
//! and shadows take it with no other edit.
//!
//! Spaces: the spheres' centres and radii are in the object's own space, placed by
//! `world_from_object` like any scene object.

use std::sync::Arc;

use glam::{DMat4, DVec3};

use super::mesh::{extent_offset, MeshKind};
use super::{DrawCall, FrameView, Kind, KindContext, Tally, TraceCall, UploadCache};
use crate::error::Result;
use crate::mesh::Mesh;
use crate::render::cull::DepthRange;
use crate::render::device::Gpu;
use crate::render::scene::{SceneObject, ShadedMesh};

/// Spheres by centre and radius (object space).
pub(crate) struct Spheres {
    pub spheres: Vec<(DVec3, f64)>,
}

/// Rings of each sphere's tessellation (twice as many segments): its chords stay within
/// 1 - cos(pi / 2 RINGS) ~ 3e-4 of a radius of the sphere.
const RINGS: usize = 64;

pub(crate) struct SpheresKind {
    meshes: MeshKind,
    tessellated: UploadCache<Spheres, Arc<ShadedMesh>>,
}

impl SpheresKind {
    pub fn new(context: &KindContext) -> SpheresKind {
        SpheresKind {
            meshes: MeshKind::new(context),
            tessellated: UploadCache::default(),
        }
    }

    /// The tessellation of `spheres` made in `upload`.
    fn shaded(&self, spheres: &Arc<Spheres>) -> Option<Arc<ShadedMesh>> {
        self.tessellated.get(spheres).cloned()
    }
}

/// Every sphere as a UV sphere, in one mesh.
fn tessellate(spheres: &Spheres) -> Result<Mesh> {
    let unit = crate::test_shapes::uv_sphere(RINGS, 2 * RINGS);
    let (mut positions, mut faces) = (Vec::new(), Vec::new());
    for (k, (centre, radius)) in spheres.spheres.iter().enumerate() {
        let first = (k * unit.positions.len()) as i64;
        positions.extend(unit.positions.iter().flat_map(|p| (*centre + *p * *radius).to_array()));
        faces.extend(unit.faces.iter().flatten().map(|&v| first + v as i64));
    }
    Mesh::from_flat(&positions, &faces, None)
}

impl Kind for SpheresKind {
    type Payload = Spheres;

    fn upload(
        &mut self,
        gpu: &Gpu,
        spheres: &Arc<Spheres>,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<()> {
        let shaded = self.tessellated.get_or_upload(spheres, |s| {
            Ok(Arc::new(ShadedMesh::new(
                Arc::new(tessellate(s)?),
                Default::default(),
            )))
        })?;
        let shaded = shaded.clone();
        self.meshes.upload(gpu, &shaded, view_from_object, depth)
    }

    fn draw_call(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        spheres: &Arc<Spheres>,
        tally: &mut Tally,
    ) -> Option<DrawCall> {
        let shaded = self.shaded(spheres)?;
        self.meshes.draw_call(gpu, frame, placed, &shaded, tally)
    }

    fn trace(
        &self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        spheres: &Arc<Spheres>,
        ids: &mut Tally,
    ) -> Result<Option<TraceCall>> {
        let Some(shaded) = self.shaded(spheres) else {
            return Ok(None);
        };
        self.meshes.trace(gpu, view_from_world, placed, &shaded, ids)
    }

    /// As a mesh's of the spheres' extent.
    fn shadow_offset(&self, spheres: &Spheres, scale: f64) -> f64 {
        let (lo, hi) = (spheres.spheres.iter()).fold(
            (DVec3::INFINITY, DVec3::NEG_INFINITY),
            |(lo, hi), &(c, r)| (lo.min(c - r), hi.max(c + r)),
        );
        extent_offset(lo, hi, scale)
    }

    fn purge(&mut self) {
        self.tessellated.purge();
        self.meshes.purge();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::{Camera, FrameRequest, Light, Object, Renderer, Scene, SearchOptions};

    /// The renderer, or `None` where this machine has no adapter (CI installs lavapipe).
    fn renderer() -> Option<Renderer> {
        match Renderer::new() {
            Ok(r) => Some(r),
            Err(e) => {
                eprintln!("skipped: no adapter ({e})");
                None
            }
        }
    }

    fn two_spheres() -> Scene {
        let spheres = Spheres {
            spheres: vec![(DVec3::new(-0.6, 0.0, 0.0), 0.5), (DVec3::new(0.7, 0.2, -0.3), 0.35)],
        };
        Scene {
            objects: vec![SceneObject {
                object: Object::new(Arc::new(spheres)),
                world_from_object: DMat4::from_translation(DVec3::new(0.0, 0.0, 0.1)),
            }],
        }
    }

    /// The exact distance along each ray to the nearest sphere of `two_spheres` (+inf: none) and
    /// the cosine of its incidence there.
    fn exact(rays: &[[f64; 3]], origins: &[[f64; 3]]) -> Vec<(f64, f64)> {
        let Some(spheres) = two_spheres().objects[0].object.payload::<Spheres>() else {
            unreachable!("the scene holds spheres")
        };
        let lift = DVec3::new(0.0, 0.0, 0.1);
        (origins.iter().zip(rays))
            .map(|(o, d)| {
                let (o, d) = (DVec3::from(*o), DVec3::from(*d));
                (spheres.spheres.iter())
                    .filter_map(|&(c, r)| {
                        let oc = o - (c + lift);
                        let b = oc.dot(d);
                        let disc = b * b - (oc.length_squared() - r * r);
                        (disc >= 0.0).then(|| (-b - disc.sqrt(), disc.sqrt() / r))
                    })
                    .fold((f64::INFINITY, 0.0), |a, b| if b.0 < a.0 { b } else { a })
            })
            .collect()
    }

    #[test]
    fn a_toy_kind_draws_traces_and_casts_shadows_through_the_trait_alone() {
        let Some(mut renderer) = renderer() else {
            return;
        };
        let camera = Camera::look_at(DVec3::new(0.3, 0.4, 3.0), DVec3::ZERO, DVec3::Y, 45.0).unwrap();
        let (size, search) = (96, SearchOptions::default());
        let scene = two_spheres();
        let mut frame = renderer
            .render(&scene, &camera, &search, &FrameRequest::new(size, size))
            .unwrap();
        let (origins, directions) = camera.pixel_rays(size, size).unwrap();
        let truth = exact(&directions, &origins);
        let depth = frame.depth.clone().unwrap();
        let (mut both, mut either) = (0, 0);
        for (d, (t, _)) in depth.iter().zip(&truth) {
            both += (d.is_finite() && t.is_finite()) as usize;
            either += (d.is_finite() || t.is_finite()) as usize;
        }
        // Measured: IoU 0.99944 (the tessellation's chords lose an edge pixel here and there).
        let iou = both as f64 / either as f64;
        assert!(iou > 0.998, "IoU {iou}");
        // Ray queries reach the kind through the same trait: rays through the pixel centres hit
        // where the exact spheres are, at their distance (chords: within 3e-4 of a radius; a
        // ray grazing a sphere meets its chords far along it, so those are left out).
        let rays: Vec<_> = (origins.iter().zip(&directions))
            .map(|(o, d)| (DVec3::from(*o), DVec3::from(*d)))
            .collect();
        let hits = renderer
            .intersect(&scene, &rays, &search, false, &crate::cancel::NEVER)
            .unwrap();
        let mut worst: f64 = 0.0;
        let (mut hit, mut missed) = (0, 0);
        for (h, &(t, cosine)) in hits.distance.iter().zip(&truth) {
            if t.is_finite() && cosine > 0.3 {
                hit += h.is_finite() as usize;
                missed += h.is_infinite() as usize;
                worst = worst.max((h - t).abs());
            }
        }
        // Measured: 1,605 such rays, every one hit, worst error 8.6e-4 (radii 0.5 and 0.35).
        assert!(hit > 1000 && missed == 0, "{hit} hit, {missed} missed");
        assert!(worst < 1e-3, "worst distance error {worst}");
        assert!(hits.patch_id.iter().all(|&id| id == -1 || id == -2), "mesh ids");
        // And shadows: the small sphere, lit from behind the large one, is partly shadowed.
        let light = Light::Directional {
            direction: DVec3::new(1.0, 0.1, -0.4),
        };
        renderer
            .cast_shadows(&scene, &camera, &search, &light, &mut frame, &crate::cancel::NEVER)
            .unwrap();
        let shadowed = frame.shadow.unwrap().mask.iter().filter(|&&s| s).count();
        // Measured: 907 of the 96² pixels.
        assert!(shadowed > 300, "{shadowed} shadowed pixels");
    }

    #[test]
    fn an_object_no_kind_draws_is_refused_by_name() {
        let Some(mut renderer) = renderer() else {
            return;
        };
        let camera = Camera::look_at(DVec3::new(0.0, 0.0, 3.0), DVec3::ZERO, DVec3::Y, 45.0).unwrap();
        let scene = Scene {
            objects: vec![SceneObject {
                object: Object::new(Arc::new(42_u32)),
                world_from_object: DMat4::IDENTITY,
            }],
        };
        let request = FrameRequest::new(8, 8);
        let err = renderer
            .render(&scene, &camera, &SearchOptions::default(), &request)
            .err()
            .expect("refused");
        assert!(err.to_string().contains("no kind of the renderer draws a u32"), "{err}");
    }
}
