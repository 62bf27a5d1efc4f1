//! Shadows: after a frame is drawn, one shadow ray per pixel it hit, from the hit (moved off the
//! surface) toward a light, traced through the scene's texture sets and meshes with the ray-query
//! tracer (query.rs, any hit). Texture sets, meshes and displacement shells cast and receive
//! shadows; surfels and meshes shaded through an IGT receive them only.
//!
//! Spaces: world (f64): hit points are rebuilt from each pixel's world ray and its z-depth, the
//! light is given in world space, and normals are the frame's world normals.

use std::sync::atomic::{AtomicBool, Ordering};

use glam::DVec3;

use super::frame::Shadows;
use super::{Camera, Frame, RayBackend, Renderer, Scene, SearchOptions};
use crate::cancel::Cancel;
use crate::error::{GeomtexError, Result};
use crate::profile;

/// A light that casts shadows.
#[derive(Clone, Copy, Debug)]
pub enum Light {
    /// Parallel light travelling along `direction` (world space; any length but zero).
    Directional { direction: DVec3 },
    /// Light from a point (world space).
    Point { position: DVec3 },
}

/// What shadowed pixels keep of their color.
const SHADOW_BRIGHTNESS: f64 = 0.5;

/// Attached shadows: a pixel whose surface (the side the camera sees) faces away from the light,
/// n.l below this, is shadowed without a ray, since whatever lies between, the surface itself
/// hides the light. The frame's normal is the shading normal (normal maps, interpolated normals)
/// while the surface a ray leaves is the geometric one, so near the terminator the ray must still
/// decide. Bunny on its ground at 512², three lights (bench/rays.py), pixels the rule marks that
/// embree's shadow rays (geometric normals) find lit: 317-362 at 0, 166-234 at -0.02, 47-86 at
/// -0.05, 9-24 at -0.1 (2-4 of them off a shadow edge), 4-10 at -0.2. At -0.1 the rule skips
/// 7.8k-9.3k of the ~29k rays that reach the bunny, the ones that run through its body.
const ATTACHED_BELOW: f64 = -0.1;

impl Light {
    pub fn validate(&self) -> Result<()> {
        let (what, v) = match self {
            Light::Directional { direction } => ("light direction", *direction),
            Light::Point { position } => ("light position", *position),
        };
        let zero = matches!(self, Light::Directional { .. }) && v.length_squared() == 0.0;
        if !v.is_finite() || zero {
            return Err(GeomtexError::Parameter(format!(
                "{what} must be finite{}; got {v:?}",
                if zero { " and non-zero" } else { "" }
            )));
        }
        Ok(())
    }

    /// The unit direction from `point` toward the light, and how far the light is.
    fn toward(&self, point: DVec3) -> (DVec3, f64) {
        match *self {
            Light::Directional { direction } => (-direction.normalize(), f64::MAX),
            Light::Point { position } => {
                let to = position - point;
                let distance = to.length();
                (to / distance.max(f64::MIN_POSITIVE), distance)
            }
        }
    }
}

/// How far a shadow ray starts off its surface in world units: the largest of the scene's objects'
/// offsets, each as its kind gives it (`Kind::shadow_offset`, a placement's largest scale
/// applied): a quarter of a set's texel, half a shell's voxel, `OFFSET_MESH_DIAGONAL` of a mesh.
fn start_offset(backend: &impl RayBackend, scene: &Scene) -> Result<f64> {
    let mut offset: f64 = 0.0;
    for placed in &scene.objects {
        let m = placed.world_from_object;
        let scale = [m.x_axis, m.y_axis, m.z_axis]
            .iter()
            .map(|c| c.truncate().length())
            .fold(0.0, f64::max);
        offset = offset.max(backend.shadow_offset(&placed.object, scale)?);
    }
    Ok(offset)
}

impl Renderer {
    /// Marks the frame's pixels that `light` cannot see and darkens them; `frame.shadow` is
    /// set (true where shadowed).
    pub fn cast_shadows(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        search: &SearchOptions,
        light: &Light,
        frame: &mut Frame,
        cancel: &Cancel,
    ) -> Result<()> {
        // A hybrid set's triangles are drawn as a mesh beside it (Scene::drawn).
        let scene = &scene.drawn();
        cast_shadows(self, scene, camera, search, light, frame, cancel)
    }
}

/// `cast_shadows` on either backend: the shadow rays traced by `backend`'s any-hit walk.
pub(crate) fn cast_shadows(
    backend: &mut impl RayBackend,
    scene: &Scene,
    camera: &Camera,
    search: &SearchOptions,
    light: &Light,
    frame: &mut Frame,
    cancel: &Cancel,
) -> Result<()> {
    light.validate()?;
    let start = std::time::Instant::now();
    let mut t = start;
    // Kinds the tracer does not trace (surfels, shaded simplified meshes) receive shadows
    // but do not cast them.
    let mut casters = Scene::default();
    for placed in &scene.objects {
        if backend.traces(&placed.object)? {
            casters.objects.push(placed.clone());
        }
    }
    let offset = start_offset(backend, scene)?;
    profile::mark(format_args!("casters+offset"), &mut t);
    let (Some(depth), Some(normal)) = (&frame.depth, &frame.normal) else {
        return Err(GeomtexError::Internal(
            "shadows need the frame's depth and normals read back".into(),
        ));
    };
    let n = depth.len();
    let mut shadow = vec![false; n];
    let mut figures = Shadows::default();
    if !casters.objects.is_empty() {
        let traced = std::time::Instant::now();
        let seen = SeenSurface {
            width: frame.width,
            depth,
            normal,
        };
        let rays = ShadowRays::new(camera, seen, frame.height, light, offset)?;
        // Shadow rays toward a directional light share one direction (the tracer tiles
        // texture sets along it); the query frame is the camera's, as the frame's own.
        let parallel = rays.toward_parallel.map(|(toward, _)| toward);
        let eye = camera.world_from_camera.w_axis.truncate();
        // Each pixel's surface is rebuilt once, as the tracer makes its ray: an attached
        // pixel is marked there (the tracer calls in parallel, hence atomics) and gets none.
        let marked: Vec<AtomicBool> = (0..n).map(|_| AtomicBool::new(false)).collect();
        let ray = |i: usize| match rays.pixel(i)? {
            PixelShadow::Attached => {
                marked[i].store(true, Ordering::Relaxed);
                None
            }
            PixelShadow::Ray(ray) => Some(ray),
        };
        let (occluded, traced_rays) =
            backend.occluded_rays(&casters, eye, parallel, n, &ray, search, cancel)?;
        profile::mark(format_args!("occluded"), &mut t);
        shadow = marked.into_iter().map(AtomicBool::into_inner).collect();
        let attached = shadow.iter().filter(|&&s| s).count();
        for i in occluded {
            shadow[i] = true;
        }
        figures.attached = attached as u64;
        figures.traced = traced_rays as u64;
        figures.trace_ms = traced.elapsed().as_secs_f64() * 1e3;
    }
    if let Some(color) = &mut frame.color {
        for (i, _) in shadow.iter().enumerate().filter(|(_, s)| **s) {
            for c in &mut color[4 * i..4 * i + 3] {
                *c = (f64::from(*c) * SHADOW_BRIGHTNESS).round() as u8;
            }
        }
    }
    profile::mark(
        format_args!("mark+darken ({} attached)", figures.attached),
        &mut t,
    );
    frame.shadow = Some(Shadows {
        mask: shadow,
        ms: start.elapsed().as_secs_f64() * 1e3,
        ..figures
    });
    Ok(())
}

/// What makes a frame's shadow rays: one per pixel hit, from the hit moved `offset` off the
/// surface (along the normal, to the side the camera sees) toward the light, counting hits
/// between `offset` and the light. Made per pixel, in parallel, by the tracer (`occluded`).
struct ShadowRays<'a> {
    /// The frame's pixel rays (no matrix per pixel: a frame has ~10^5 of them).
    lines: crate::render::camera::PixelLines,
    forward: DVec3,
    seen: SeenSurface<'a>,
    light: &'a Light,
    /// A directional light's `Light::toward` (the same at every point), made once rather than
    /// per pixel.
    toward_parallel: Option<(DVec3, f64)>,
    offset: f64,
}

/// A hit pixel's shadow: attached (its surface faces away from the light) or decided by a ray.
enum PixelShadow {
    Attached,
    Ray(super::query::RangedRay),
}

/// What a frame shows per pixel that its shadow rays start from: z-depth and world normals.
struct SeenSurface<'a> {
    width: u32,
    depth: &'a [f32],
    normal: &'a [f32],
}

impl<'a> ShadowRays<'a> {
    fn new(
        camera: &'a Camera,
        seen: SeenSurface<'a>,
        height: u32,
        light: &'a Light,
        offset: f64,
    ) -> Result<ShadowRays<'a>> {
        Ok(ShadowRays {
            lines: camera.pixel_lines(&camera.lens(seen.width, height, 1.0, 2.0)?),
            forward: camera.forward(),
            seen,
            light,
            toward_parallel: match *light {
                Light::Directional { .. } => Some(light.toward(DVec3::ZERO)),
                Light::Point { .. } => None,
            },
            offset,
        })
    }

    /// What pixel `i` needs: nothing where the frame hit nothing (`None`), no ray where its
    /// surface faces away from the light (`ATTACHED_BELOW`), else its ray (start, unit direction
    /// toward the light) and the stretch that counts.
    fn pixel(&self, i: usize) -> Option<PixelShadow> {
        let (point, n) = self.surface(i)?;
        let toward = |p| self.toward_parallel.unwrap_or_else(|| self.light.toward(p));
        if n.dot(toward(point).0) < ATTACHED_BELOW {
            return Some(PixelShadow::Attached);
        }
        let start = point + n * self.offset;
        let (toward, distance) = toward(start);
        Some(PixelShadow::Ray(((start, toward), (self.offset, distance))))
    }

    /// The world point pixel `i` shows and its normal on the side the camera sees, or `None`
    /// where the frame hit nothing.
    fn surface(&self, i: usize) -> Option<(DVec3, DVec3)> {
        let seen = &self.seen;
        let depth = seen.depth[i];
        if !depth.is_finite() {
            return None;
        }
        let (x, y) = (i % seen.width as usize, i / seen.width as usize);
        // d is not of unit length: the division makes the step one of z-depth all the same.
        let (o, d) = self.lines.at(x as f64 + 0.5, y as f64 + 0.5);
        let point = o + d * (f64::from(depth) / d.dot(self.forward));
        let [nx, ny, nz] = [0, 1, 2].map(|k| f64::from(seen.normal[3 * i + k]));
        let n = DVec3::new(nx, ny, nz);
        // The side of the surface the camera sees.
        Some((point, if n.dot(d) > 0.0 { -n } else { n }))
    }
}
