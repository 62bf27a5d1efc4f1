//! Headless rendering of geometry textures (per-pixel ray casting in their patches' boxes) and
//! ordinary meshes (rasterization) into one reversed-Z depth buffer, read back as numpy-ready
//! arrays; ray queries through a hierarchy (the crate-level `bvh`) over thin pieces of the same
//! boxes (`query`), and shadows cast with them (`shadow`). Besides sets and meshes it draws the
//! other kinds' data (`igt_data`, `gdm_data`, `surfel_data`), never the stages that build them.
//!
//! One `Renderer` serves every image size: its device, pipelines and uploads are made once, and
//! targets are made per size (kept for the sizes drawn lately). A render is three steps: prepare
//! (upload what is new, choose the near plane, make each object's draw call), encode the passes
//! (the scene pass, then copies of the outputs asked for into readback buffers), read back (one
//! wait, then the `Frame`). Each object kind lives in `kinds/`; the camera, targets, group 0 and
//! readback are shared by all kinds.
//!
//! Spaces: world (f64, the scene's), object (each scene object's own, placed by
//! `world_from_object`), patch-local (unit cube) and view (camera-relative, OpenGL-style). Every
//! matrix the GPU sees is composed in f64 with the camera position subtracted, then cast to f32.

mod atlas;
pub mod camera;
mod coverage;
pub mod cpu;
mod cull;
pub mod device;
mod error_bound;
mod frame;
mod frame_bindings;
mod gpu_types;
pub(crate) mod kinds;
#[cfg(test)]
mod layouts;
mod outputs;
mod pipelines;
mod query;
mod scene;
mod search;
pub mod shaders;
mod shadow;
mod targets;

use std::time::Instant;

pub use camera::{Camera, Lens, Projection};
pub use coverage::CoverageFigures;
pub use device::Gpu;
pub use error_bound::BoundFigures;
pub use frame::{Frame, LodRule, Shadows, SurfelCounts};
pub use kinds::uploads_made;
pub use outputs::Outputs;
pub use query::RayHits;
pub use scene::{Object, Scene, SceneObject, ShadedMesh};
pub use search::{Method, Primary, Quality, SearchOptions, SearchOverrides};
pub use shadow::Light;

use crate::error::{GeomtexError, Result};
use coverage::CoverageInputs;
use cull::DepthRange;
use device::guarded;
use error_bound::{pixel_bounds, DrawnPixels, ObjectIds, PixelSources, Rounding};
use frame_bindings::FrameBindings;
use kinds::{DrawCall, FrameView, KindContext, LodPick, Registry, Tally};
use pipelines::DepthCopy;
use targets::{Readback, Targets};

pub struct Renderer {
    gpu: Gpu,
    frame_bindings: FrameBindings,
    kinds: Registry,
    depth_copy: DepthCopy,
    /// Group 2 of ray queries (query.rs).
    query_layout: wgpu::BindGroupLayout,
    /// Targets of the sizes drawn lately, the latest first.
    targets: Vec<Targets>,
    /// Target sets made so far (a new size, or one dropped and drawn again).
    targets_made: u64,
}

/// What a frame is asked for beyond its scene, camera and search.
#[derive(Clone, Copy, Debug)]
pub struct FrameRequest {
    pub width: u32,
    pub height: u32,
    /// The per-pixel outputs to read back.
    pub outputs: Outputs,
    /// The color (RGBA8) of pixels nothing is drawn on; `None` for
    /// `Renderer::DEFAULT_BACKGROUND`.
    pub background: Option<[u8; 4]>,
}

impl FrameRequest {
    /// The default outputs of a `width` x `height` frame on the default background.
    pub fn new(width: u32, height: u32) -> FrameRequest {
        FrameRequest {
            width,
            height,
            outputs: Outputs::DEFAULT,
            background: None,
        }
    }
}

/// Pixels of target sets the renderer keeps besides the one in use (a 4096² set, ~0.9 GB): a
/// notebook drawing at two or three sizes keeps them all, a sweep over many sizes does not grow.
const KEPT_TARGET_PIXELS: u64 = 1 << 24;

/// A frame ready to encode.
struct Prepared {
    lens: Lens,
    draws: Vec<DrawCall>,
    /// Draws of the surface pass (kinds/igt.rs), run after the scene pass when there are any.
    surface_draws: Vec<DrawCall>,
    tally: Tally,
    /// The ids each scene object took, in scene order.
    ids: Vec<ObjectIds>,
}

/// What a frame's bounds are made from besides its pixels (error_bound.rs).
pub(crate) struct BoundInputs {
    pub lens: Lens,
    pub ids: Vec<ObjectIds>,
    pub lod_picks: Vec<LodPick>,
}

/// A `ParameterError` unless `width` x `height` fits an adapter whose largest image side is `max`.
pub fn check_image_size(width: u32, height: u32, max: u32) -> Result<()> {
    if width == 0 || height == 0 || width > max || height > max {
        return Err(GeomtexError::Parameter(format!(
            "image size {width}x{height} must be between 1 and {max} (this adapter's limit) on \
             each side"
        )));
    }
    Ok(())
}

impl Renderer {
    /// The color of pixels nothing was drawn on: transparent white.
    pub const DEFAULT_BACKGROUND: [u8; 4] = [255, 255, 255, 0];

    pub fn new() -> Result<Renderer> {
        let gpu = Gpu::new()?;
        let device = gpu.device.clone();
        guarded(&device, move || Ok(Self::build(gpu)))
    }

    fn build(gpu: Gpu) -> Renderer {
        let device = &gpu.device;
        let frame_bindings = FrameBindings::new(device);
        let query_layout = query::query_layout(device);
        let kinds = kinds::registered(&KindContext {
            gpu: &gpu,
            frame_layout: &frame_bindings.layout,
            query_layout: &query_layout,
        });
        let depth_copy = DepthCopy::new(device);
        Renderer {
            gpu,
            frame_bindings,
            kinds,
            depth_copy,
            query_layout,
            targets: Vec::new(),
            targets_made: 0,
        }
    }

    /// A `ParameterError` unless this adapter draws `width` x `height` images.
    pub fn check_size(&self, width: u32, height: u32) -> Result<()> {
        check_image_size(width, height, self.max_image_side())
    }

    /// The longest image side this adapter draws (its largest 2D texture).
    pub fn max_image_side(&self) -> u32 {
        self.gpu.device.limits().max_texture_dimension_2d
    }

    pub fn info(&self) -> Vec<(&'static str, String)> {
        self.gpu.info()
    }

    /// What this renderer has made so far: target sets (one per image size drawn), the image
    /// sizes it keeps targets for, the object kinds whose pipelines it made (each on its first
    /// object), and uploads of objects to the adapter (every kind's).
    pub fn counts(&self) -> Vec<(&'static str, u64)> {
        let kinds_made = self.kinds.kinds.iter().filter(|k| k.is_made()).count();
        vec![
            ("target_sets_made", self.targets_made),
            ("target_sizes_kept", self.targets.len() as u64),
            ("kinds_made", kinds_made as u64),
            ("uploads", kinds::uploads_made()),
        ]
    }

    /// The targets of a `width` x `height` frame, made unless kept, moved to the front; sizes
    /// past `KEPT_TARGET_PIXELS` drawn longest ago are dropped.
    fn targets_of(&mut self, width: u32, height: u32) -> &mut Targets {
        match self
            .targets
            .iter()
            .position(|t| (t.width, t.height) == (width, height))
        {
            Some(k) => self.targets[..=k].rotate_right(1),
            None => {
                let made = Targets::new(&self.gpu, &self.depth_copy, width, height);
                self.targets.insert(0, made);
                self.targets_made += 1;
            }
        }
        let mut kept = 0;
        self.targets.retain(|t| {
            kept += u64::from(t.width) * u64::from(t.height);
            kept <= KEPT_TARGET_PIXELS + u64::from(width) * u64::from(height)
        });
        &mut self.targets[0]
    }

    /// Renders `scene` seen by `camera` as `request` asks. GPU validation or out-of-memory
    /// errors come back as `GeomtexError::Device`, never as a panic.
    pub fn render(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        search: &SearchOptions,
        request: &FrameRequest,
    ) -> Result<Frame> {
        // A hybrid set's triangles are drawn as a mesh beside it (Scene::drawn).
        let scene = &scene.drawn();
        search.validate()?;
        self.check_size(request.width, request.height)?;
        let device = self.gpu.device.clone();
        let start = Instant::now();
        // The bounds are made from the depth and patch ids: read them whenever bounds are asked.
        let read = FrameRequest {
            outputs: request.outputs.to_read(),
            ..*request
        };
        let (frame, inputs) = guarded(&device, || {
            let prepared = self.prepare(scene, camera, search, &read)?;
            let (counters, tallies) = self.encode_passes(&prepared, &read);
            let targets = &self.targets[0];
            let readback = targets.read_back(&self.gpu, counters, read.outputs)?;
            let surfels = SurfelCounts::read(&self.gpu, &tallies)?;
            let surface = (!prepared.surface_draws.is_empty())
                .then(|| targets.read_surface(&self.gpu))
                .transpose()?;
            let inputs = BoundInputs {
                lens: prepared.lens,
                ids: prepared.ids.clone(),
                lod_picks: prepared.tally.lod_picks.clone(),
            };
            let mut frame = self.finish(prepared, readback, surfels, search, start);
            (frame.face_id, frame.barycentric) = surface.unzip();
            Ok((frame, inputs))
        })?;
        finish_outputs(
            self,
            (scene, camera, search),
            request.outputs,
            &inputs,
            frame,
            start,
        )
    }

    /// Uploads what is new, chooses the near plane from the scene's depth range, writes the
    /// frame's records and makes every object's draw call, in scene order.
    fn prepare(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        search: &SearchOptions,
        request: &FrameRequest,
    ) -> Result<Prepared> {
        let view_from_world = camera.view_from_world();
        let (owners, depth) = self.upload_scene(scene, view_from_world)?;
        let (width, height) = (request.width, request.height);
        let (z_min, z_max) = depth.or_default();
        let lens = camera.lens(width, height, z_min, z_max)?;
        self.frame_bindings
            .write(&self.gpu.queue, &lens, view_from_world, search);

        let frame = FrameView {
            lens: &lens,
            size: [width, height],
            view_from_world,
            search,
        };
        let mut tally = Tally::default();
        let mut draws = Vec::with_capacity(scene.objects.len());
        let mut ids = Vec::with_capacity(scene.objects.len());
        for (placed, &owner) in scene.objects.iter().zip(&owners) {
            let (patches, meshes) = (tally.patch_ids, tally.meshes_drawn);
            draws.extend(self.kinds.kinds[owner].draw(&self.gpu, &frame, placed, &mut tally));
            ids.push(ObjectIds {
                patches: patches..tally.patch_ids,
                meshes: meshes..tally.meshes_drawn,
            });
        }
        let surface_draws: Vec<DrawCall> = (scene.objects.iter().zip(&owners))
            .filter_map(|(placed, &owner)| {
                self.kinds.kinds[owner].draw_surface(&self.gpu, &frame, placed)
            })
            .collect();
        let device = self.gpu.device.clone();
        let targets = self.targets_of(width, height);
        if !surface_draws.is_empty() {
            targets.ensure_surface(&device);
        }
        Ok(Prepared {
            lens,
            draws,
            surface_draws,
            tally,
            ids,
        })
    }

    /// Drops the uploads of objects gone, uploads what is new; each object's kind (its index) and
    /// the depth range the scene occupies under `view_from_world`.
    fn upload_scene(
        &mut self,
        scene: &Scene,
        view_from_world: glam::DMat4,
    ) -> Result<(Vec<usize>, DepthRange)> {
        for kind in &mut self.kinds.kinds {
            kind.purge();
        }
        let mut depth = DepthRange::empty();
        let mut owners = Vec::with_capacity(scene.objects.len());
        for (index, placed) in scene.objects.iter().enumerate() {
            placed.check_placement(index)?;
            let view_from_object = view_from_world * placed.world_from_object;
            owners.push(self.upload(&placed.object, &view_from_object, &mut depth)?);
        }
        Ok((owners, depth))
    }

    /// Uploads an object through the kind registered for its payload; that kind's index.
    fn upload(
        &mut self,
        object: &Object,
        view_from_object: &glam::DMat4,
        depth: &mut DepthRange,
    ) -> Result<usize> {
        let k = self.kinds.kind_of(object)?;
        self.kinds.kinds[k].upload(&self.gpu, object, view_from_object, depth)?;
        Ok(k)
    }

    /// Encodes and submits the kinds' compute passes, the scene pass and the copies into
    /// readback buffers; the counters and the compute passes' tallies to read back.
    fn encode_passes(
        &self,
        prepared: &Prepared,
        request: &FrameRequest,
    ) -> (&wgpu::Buffer, Vec<wgpu::Buffer>) {
        let targets = &self.targets[0];
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame"),
            });
        let work: Vec<_> = prepared
            .draws
            .iter()
            .filter_map(|d| d.compute.as_ref())
            .collect();
        if !work.is_empty() {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("kinds' compute"),
                timestamp_writes: targets.compute_timestamps(),
            });
            pass.set_bind_group(0, &self.frame_bindings.group, &[]);
            for w in &work {
                w.encode(&mut pass);
            }
        }
        let surface = !prepared.surface_draws.is_empty();
        {
            let background = request.background.unwrap_or(Self::DEFAULT_BACKGROUND);
            let mut pass = targets.begin_scene_pass(
                &mut encoder,
                background.map(|v| f64::from(v) / 255.0),
                !work.is_empty(),
                surface,
            );
            pass.set_bind_group(0, &self.frame_bindings.group, &[]);
            for draw in &prepared.draws {
                draw.encode(&mut pass);
            }
        }
        if surface {
            let mut pass = targets.begin_surface_pass(&mut encoder, true);
            pass.set_bind_group(0, &self.frame_bindings.group, &[]);
            for draw in &prepared.surface_draws {
                draw.encode(&mut pass);
            }
        }
        targets.encode_readback(&mut encoder, &self.depth_copy, request.outputs);
        if surface {
            targets.encode_surface_readback(&mut encoder);
        }
        let counters = self.frame_bindings.encode_counters_readback(&mut encoder);
        let tallies = work
            .iter()
            .map(|w| targets::copy_for_readback(&self.gpu.device, &mut encoder, &w.tally))
            .collect();
        self.gpu.queue.submit(Some(encoder.finish()));
        (counters, tallies)
    }

    fn finish(
        &self,
        prepared: Prepared,
        readback: Readback,
        surfels: Option<SurfelCounts>,
        search: &SearchOptions,
        start: Instant,
    ) -> Frame {
        let (width, height) = (self.targets[0].width, self.targets[0].height);
        let lens = prepared.lens;
        let depth = readback.depth.map(|values| {
            (values.iter())
                .map(|&d| Camera::distance_from_depth(&lens, d))
                .collect()
        });
        let tally = prepared.tally;
        let [fetches, searches, piece_tests] = readback.counters;
        Frame {
            width,
            height,
            color: readback.color,
            albedo: readback.albedo,
            depth,
            normal: readback.normal,
            patch_id: readback.patch_id,
            gpu_ms: readback.gpu_ms,
            cpu_ms: start.elapsed().as_secs_f64() * 1e3,
            patches_drawn: tally.patches_drawn,
            patches_culled: tally.patches_culled,
            meshes_drawn: tally.meshes_drawn,
            texture_bytes: tally.texture_bytes,
            setup_ms: tally.setup_ms,
            near: lens.near,
            method: search.method,
            primary: search.primary,
            searches: searches as u64,
            fetches: search.count_fetches.then_some(fetches as u64),
            piece_tests: search.count_fetches.then_some(piece_tests as u64),
            shadow: None,
            surfels,
            face_id: None,
            barycentric: None,
            error_bound: None,
            depth_rounding: None,
            bound_figures: None,
            coverage_uncertain: None,
            coverage: None,
            lod_levels: search.lod.then(|| {
                let rule = match search.lod_bound_pixels {
                    Some(_) => LodRule::Bound,
                    None => LodRule::Pixel,
                };
                (lod_histogram(&tally.lod_picks), rule)
            }),
            device: "gpu",
        }
    }
}

/// Drawn patches per level-of-detail stop level, from level 0 to the coarsest picked.
fn lod_histogram(picks: &[LodPick]) -> Vec<u64> {
    let levels = picks
        .iter()
        .map(|p| p.level as usize + 1)
        .max()
        .unwrap_or(1);
    let mut counts = vec![0u64; levels];
    for p in picks {
        counts[p.level as usize] += 1;
    }
    counts
}

/// The last step of a render on either backend: the bounds where asked (`add_bounds`, counted
/// in `cpu_ms` from `start`), then only the outputs asked for.
pub(crate) fn finish_outputs(
    backend: &mut impl RayBackend,
    (scene, camera, search): (&Scene, &Camera, &SearchOptions),
    outputs: Outputs,
    inputs: &BoundInputs,
    mut frame: Frame,
    start: Instant,
) -> Result<Frame> {
    if outputs.needs_bounds() {
        add_bounds(backend, scene, camera, search, outputs, inputs, &mut frame)?;
        frame.cpu_ms = start.elapsed().as_secs_f64() * 1e3;
    }
    frame.keep_only(outputs);
    Ok(frame)
}

/// Computes the frame's error bounds and, where asked, which pixels' coverage is uncertain
/// (error_bound.rs, coverage.rs), from its depth and patch ids; `backend` traces the probes.
fn add_bounds(
    backend: &mut impl RayBackend,
    scene: &Scene,
    camera: &Camera,
    search: &SearchOptions,
    outputs: Outputs,
    inputs: &BoundInputs,
    frame: &mut Frame,
) -> Result<()> {
    let (Some(depth), Some(patch_id)) = (&frame.depth, &frame.patch_id) else {
        return Err(GeomtexError::Internal(
            "error bounds need the frame's depth and patch ids read back".into(),
        ));
    };
    let eye = (camera.eye(), backend.rounding());
    let mut sources = PixelSources::new(scene, &inputs.ids, &inputs.lod_picks, eye);
    sources.exact_search = search.method == crate::render::search::Method::MaxMip;
    let pixels = DrawnPixels {
        width: frame.width,
        lines: camera.pixel_lines(&inputs.lens),
        forward: camera.forward(),
        depth,
        patch_id,
        depth_rounding: frame.depth_rounding.as_deref(),
    };
    let (bounds, figures) = pixel_bounds(&sources, &pixels);
    let coverage = if outputs.coverage_uncertain {
        let coverage_inputs = CoverageInputs {
            pixels: &pixels,
            height: frame.height,
            bounds: &bounds,
            sources: &sources,
            lens: &inputs.lens,
        };
        Some(coverage::coverage_uncertain(
            backend,
            scene,
            camera,
            search,
            &coverage_inputs,
        )?)
    } else {
        None
    };
    (frame.coverage_uncertain, frame.coverage) = coverage.unzip();
    frame.error_bound = Some(bounds);
    frame.bound_figures = Some(figures);
    Ok(())
}

/// What shadows (shadow.rs) and coverage probes (coverage.rs) ask of a backend: the GPU's
/// `Renderer` or the CPU's `cpu::CpuRenderer`.
pub(crate) trait RayBackend {
    /// Whether the backend traces `object` (it then casts shadows and answers probes).
    fn traces(&self, object: &Object) -> Result<bool>;

    /// How far a shadow ray starts off `object`'s surface under a placement scaling by `scale`.
    fn shadow_offset(&self, object: &Object, scale: f64) -> Result<f64>;

    /// Of `count` rays (`ray(i)`, None for none), the ones that hit something within their
    /// stretch, and how many were traced; `origin` is a point near the rays, `parallel` their
    /// shared direction, if any.
    #[allow(clippy::too_many_arguments)] // the query's own settings, passed through
    fn occluded_rays(
        &mut self,
        scene: &Scene,
        origin: glam::DVec3,
        parallel: Option<glam::DVec3>,
        count: usize,
        ray: &(dyn Fn(usize) -> Option<query::RangedRay> + Sync),
        search: &SearchOptions,
        cancel: &crate::cancel::Cancel,
    ) -> Result<(Vec<usize>, usize)>;

    /// How the points this backend draws are rounded (error_bound.rs).
    fn rounding(&self) -> Rounding;

    /// Per ray (unit direction) within its stretch, the nearest hit's distance along it and id,
    /// or with `any_hit` the first hit found's; (infinity, -1) for none.
    fn hits(
        &mut self,
        scene: &Scene,
        rays: &[(glam::DVec3, glam::DVec3)],
        ranges: &[(f64, f64)],
        search: &SearchOptions,
        any_hit: bool,
    ) -> Result<(Vec<f64>, Vec<i32>)>;
}

impl RayBackend for Renderer {
    fn rounding(&self) -> Rounding {
        Rounding::F32Tracer
    }

    fn traces(&self, object: &Object) -> Result<bool> {
        Ok(self.kinds.kinds[self.kinds.kind_of(object)?].casts_shadows())
    }

    fn shadow_offset(&self, object: &Object, scale: f64) -> Result<f64> {
        Ok(self.kinds.kinds[self.kinds.kind_of(object)?].shadow_offset(object, scale))
    }

    fn occluded_rays(
        &mut self,
        scene: &Scene,
        origin: glam::DVec3,
        parallel: Option<glam::DVec3>,
        count: usize,
        ray: &(dyn Fn(usize) -> Option<query::RangedRay> + Sync),
        search: &SearchOptions,
        cancel: &crate::cancel::Cancel,
    ) -> Result<(Vec<usize>, usize)> {
        self.occluded(scene, origin, parallel, count, ray, search, cancel)
    }

    fn hits(
        &mut self,
        scene: &Scene,
        rays: &[(glam::DVec3, glam::DVec3)],
        ranges: &[(f64, f64)],
        search: &SearchOptions,
        any_hit: bool,
    ) -> Result<(Vec<f64>, Vec<i32>)> {
        let batch = self.largest_batch();
        let never = &crate::cancel::NEVER;
        let hits = self.trace_rays(scene, rays, Some(ranges), batch, search, any_hit, never)?;
        Ok((hits.distance, hits.patch_id))
    }
}
