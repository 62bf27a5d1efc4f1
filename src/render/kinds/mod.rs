//! Object kinds. A kind uploads its objects (cached for as long as they live), widens the
//! scene's depth range by their bounds, and makes each object's draw call for a frame and its
//! dispatch for a ray query (query.rs); the camera, targets, group 0 (frame_bindings.rs) and
//! readback are shared by all kinds.
//!
//! Adding a kind: a module here (its pass, group-1 layout and upload cache) with its shader files
//! and a function in shaders.rs, a variant of `Object` (scene.rs), and one line in `registered`.
//!
//! Spaces: world (f64), each object's own (placed by `world_from_object`) and view
//! (camera-relative); every matrix a kind gives the GPU is composed in f64 as view_from_*.

mod footprint;
pub(crate) mod gdm;
pub(crate) mod gtex;
pub(crate) mod igt;
pub(crate) mod mesh;
pub(crate) mod surfels;
pub(crate) mod tiles;

use std::collections::HashMap;
use std::sync::{Arc, Weak};

use glam::{DMat4, DVec3};
use wgpu::util::DeviceExt;

use super::camera::Lens;
use super::cull::DepthRange;
use super::device::Gpu;
use super::scene::{Object, SceneObject};
use super::search::SearchOptions;
use crate::bvh::Aabb;
use crate::error::Result;

/// Every kind the renderer draws, each built once with the frame's group-0 layout and the ray
/// queries' group-2 layout.
pub(crate) fn registered(
    gpu: &Gpu,
    frame_layout: &wgpu::BindGroupLayout,
    query_layout: &wgpu::BindGroupLayout,
) -> Vec<Box<dyn Kind>> {
    let device = &gpu.device;
    vec![
        Box::new(gtex::GtexKind::new(device, frame_layout, query_layout)),
        Box::new(mesh::MeshKind::new(gpu, frame_layout, query_layout)),
        Box::new(surfels::SurfelsKind::new(
            device,
            frame_layout,
            gpu.int64_atomics,
        )),
        Box::new(gdm::GdmKind::new(device, frame_layout, query_layout)),
        Box::new(igt::IgtKind::new(device, frame_layout)),
    ]
}

/// One object kind's part in a frame.
pub(crate) trait Kind: Send {
    /// Uploads `object` unless it is cached, and widens `depth` by its bounds as
    /// `view_from_object` places them; false (doing nothing) when the object is another kind's.
    fn upload(
        &mut self,
        gpu: &Gpu,
        object: &Object,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<bool>;

    /// The draw call of an object this kind uploaded, counted in `tally`; `None` when nothing of
    /// it is in view.
    fn draw_call(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        tally: &mut Tally,
    ) -> Option<DrawCall>;

    /// Every draw call of the object: `draw_call`'s, or one per piece for a kind that draws an
    /// object in pieces (surfels larger than a storage binding, kinds/surfels.rs).
    fn draw(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        tally: &mut Tally,
    ) -> Vec<DrawCall> {
        self.draw_call(gpu, frame, placed, tally)
            .into_iter()
            .collect()
    }

    /// The draw call of an object in the surface pass (after the scene pass, depth-tested against
    /// its finished depth, into the surface target: detailed face and barycentrics per pixel),
    /// for kinds that shade through a detailed surface (kinds/igt.rs); `None` by default.
    fn draw_surface(&self, gpu: &Gpu, frame: &FrameView, placed: &SceneObject) -> Option<DrawCall> {
        let _ = (gpu, frame, placed);
        None
    }

    /// The ray-query dispatch of an object this kind uploaded, its records placed by
    /// `view_from_world` (the query's frame); `None` when it holds nothing to hit. Ids continue
    /// from those `ids` handed out so far (patch ids, mesh ids), which it advances as a frame
    /// would. An error for kinds that cannot be traced.
    fn trace(
        &self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        ids: &mut Tally,
    ) -> Result<Option<TraceCall>>;

    /// `trace` for a query whose rays all run along `direction` (unit, in the query's frame:
    /// shadow rays toward a directional light), which a kind may trace another way; by default
    /// the same dispatch.
    fn trace_parallel(
        &self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        ids: &mut Tally,
        direction: DVec3,
    ) -> Result<Option<TraceCall>> {
        let _ = direction;
        self.trace(gpu, view_from_world, placed, ids)
    }

    /// Drops the uploads of objects that no longer exist.
    fn purge(&mut self);
}

/// A storage buffer holding `contents`.
pub(crate) fn storage_buffer(device: &wgpu::Device, label: &str, contents: &[u8]) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage: wgpu::BufferUsages::STORAGE,
    })
}

/// A bind group of whole buffers at bindings 0, 1, ... in order.
pub(crate) fn bind_buffers(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<_> = (buffers.iter().enumerate())
        .map(|(binding, buffer)| wgpu::BindGroupEntry {
            binding: binding as u32,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// Whether a ray (origin and unit direction in the query's frame, the stretch of t that counts)
/// may hit an object: tested on the CPU before its dispatch, which then runs only for the rays
/// that may. On lavapipe an invocation of a texture set's tracer that returns at once still
/// costs ~0.5 µs (its bindings and size, not its work; a mesh's costs ~0.1 µs), and most shadow
/// rays of a scene pass beside any one object.
/// Shared across threads: the test runs over a batch's rays in parallel.
pub(crate) type RayTest = Box<dyn Fn(&TestRay) -> bool + Send + Sync>;

/// A ray as the CPU-side tests (`RayTest`) take it, in the query's frame: origin, the inverse of
/// its unit direction (made once for rays that share a direction, as a directional light's shadow
/// rays do) and the stretch of t that counts.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TestRay {
    pub origin: DVec3,
    pub inverse: DVec3,
    pub range: (f64, f64),
}

impl TestRay {
    pub fn new(origin: DVec3, direction: DVec3, range: (f64, f64)) -> TestRay {
        TestRay {
            origin,
            inverse: direction.recip(),
            range,
        }
    }
}

/// One object's ray-query dispatch, after groups 0 and 2 are bound.
pub(crate) struct TraceCall {
    pub pipeline: wgpu::ComputePipeline,
    /// Group 1: the kind's records, resources and hierarchy for this object.
    pub group: wgpu::BindGroup,
    pub reaches: RayTest,
}

impl TraceCall {
    /// A dispatch for rays that meet the union of `bounds` (the leaves of its hierarchy, in
    /// the query's frame).
    pub fn within(
        pipeline: wgpu::ComputePipeline,
        group: wgpu::BindGroup,
        bounds: &[Aabb],
    ) -> TraceCall {
        let all = bounds.iter().fold(Aabb::EMPTY, |a, &b| a.union(b));
        TraceCall {
            pipeline,
            group,
            reaches: Box::new(move |ray| all.meets_inverse(ray.origin, ray.inverse, ray.range)),
        }
    }
}

/// What every kind needs to know about the frame being drawn.
pub(crate) struct FrameView<'a> {
    pub lens: &'a Lens,
    /// Image width and height in pixels.
    pub size: [u32; 2],
    pub view_from_world: DMat4,
    pub search: &'a SearchOptions,
}

/// A frame's counts, and the ids handed out so far (drawn in scene order).
#[derive(Default)]
pub(crate) struct Tally {
    /// Patches numbered so far, across the scene's texture sets, culled ones included.
    pub patch_ids: i32,
    pub patches_drawn: usize,
    pub patches_culled: usize,
    /// Meshes drawn so far; the k-th mesh writes id -2 - k.
    pub meshes_drawn: usize,
    /// Bytes the drawn texture sets' maps and pyramids take on the adapter.
    pub texture_bytes: u64,
}

/// One object's draw in the scene pass, after group 0 is bound.
pub(crate) struct DrawCall {
    pub pipeline: wgpu::RenderPipeline,
    /// Group 1: the kind's records and resources for this object.
    pub group: wgpu::BindGroup,
    pub vertex_buffer: Option<wgpu::Buffer>,
    pub vertices: u32,
    pub instances: u32,
    /// Compute passes to run before the scene pass (surfel culling and splatting).
    pub compute: Option<ComputeWork>,
}

/// How a compute step is sized: workgroup counts, or read from a buffer a step before wrote.
pub(crate) enum Dispatch {
    Groups([u32; 3]),
    Indirect(wgpu::Buffer),
}

/// One compute dispatch, after group 0 (the frame's) is bound; `groups` go to 1, 2, ...
pub(crate) struct ComputeStep {
    pub pipeline: wgpu::ComputePipeline,
    pub groups: Vec<wgpu::BindGroup>,
    pub dispatch: Dispatch,
}

/// An object's compute passes, in order, and the buffer of counts it leaves for the frame's
/// figures (u32s, read back after the frame).
pub(crate) struct ComputeWork {
    pub steps: Vec<ComputeStep>,
    pub tally: wgpu::Buffer,
}

impl ComputeWork {
    pub fn encode(&self, pass: &mut wgpu::ComputePass<'_>) {
        for step in &self.steps {
            pass.set_pipeline(&step.pipeline);
            for (k, group) in step.groups.iter().enumerate() {
                pass.set_bind_group(k as u32 + 1, group, &[]);
            }
            match &step.dispatch {
                Dispatch::Groups([x, y, z]) => pass.dispatch_workgroups(*x, *y, *z),
                Dispatch::Indirect(buffer) => pass.dispatch_workgroups_indirect(buffer, 0),
            }
        }
    }
}

impl DrawCall {
    pub fn encode(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(1, &self.group, &[]);
        if let Some(buffer) = &self.vertex_buffer {
            pass.set_vertex_buffer(0, buffer.slice(..));
        }
        pass.draw(0..self.vertices, 0..self.instances);
    }
}

/// GPU copies of objects, keyed by the object's identity and kept while it lives (a new object
/// at a freed address is uploaded again).
pub(crate) struct UploadCache<T, U> {
    entries: HashMap<usize, (Weak<T>, U)>,
}

impl<T, U> Default for UploadCache<T, U> {
    fn default() -> Self {
        UploadCache {
            entries: HashMap::new(),
        }
    }
}

impl<T, U> UploadCache<T, U> {
    fn key(object: &Arc<T>) -> usize {
        Arc::as_ptr(object) as usize
    }

    /// The upload of this very object, if cached.
    pub fn get(&self, object: &Arc<T>) -> Option<&U> {
        let (weak, upload) = self.entries.get(&Self::key(object))?;
        let same = weak.upgrade().is_some_and(|o| Arc::ptr_eq(&o, object));
        same.then_some(upload)
    }

    /// The cached upload of `object`, made by `upload` when there is none.
    pub fn get_or_upload(
        &mut self,
        object: &Arc<T>,
        upload: impl FnOnce(&T) -> Result<U>,
    ) -> Result<&U> {
        let key = Self::key(object);
        if self.get(object).is_none() {
            let made = upload(object)?;
            self.entries.insert(key, (Arc::downgrade(object), made));
        }
        Ok(&self.entries[&key].1)
    }

    /// The cached upload of `object`, made empty (`U::default()`) when there is none: for kinds
    /// that keep several uploads of one object (a mesh under different normal rules).
    pub fn entry(&mut self, object: &Arc<T>) -> &mut U
    where
        U: Default,
    {
        let key = Self::key(object);
        if self.get(object).is_none() {
            self.entries
                .insert(key, (Arc::downgrade(object), U::default()));
        }
        &mut self.entries.get_mut(&key).expect("just inserted").1
    }

    pub fn purge(&mut self) {
        self.entries.retain(|_, (weak, _)| weak.strong_count() > 0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uploads_are_kept_while_their_object_lives() {
        let mut cache: UploadCache<u32, u32> = UploadCache::default();
        let object = Arc::new(7);
        let mut uploads = 0;
        for _ in 0..2 {
            let got = cache.get_or_upload(&object, |v| {
                uploads += 1;
                Ok(*v * 2)
            });
            assert_eq!(*got.unwrap(), 14);
        }
        assert_eq!(uploads, 1);
        let twin = Arc::new(7);
        assert!(
            cache.get(&twin).is_none(),
            "an equal but distinct object is not cached"
        );
        drop(object);
        cache.purge();
        assert!(cache.entries.is_empty());
    }
}
