//! Object kinds. A kind uploads its objects (cached for as long as they live), widens the
//! scene's depth range by their bounds, makes each object's draw call for a frame and its
//! dispatch for a ray query (query.rs), and says how its objects take part in shadows; the
//! camera, targets, group 0 (frame_bindings.rs) and readback are shared by all kinds.
//!
//! Adding a kind (the recipe docs/contributing.md gives in full): a module here whose type
//! implements `Kind` for its payload type (what a scene object of that kind holds), with its
//! shader files and a function in shaders.rs, and one line in `kinds!` below. A scene object
//! holds any payload (`Object::new`); the renderer routes it to the kind registered for its
//! payload type, and an object no kind draws is a `ParameterError`, never a silent blank.
//!
//! Spaces: world (f64), each object's own (placed by `world_from_object`) and view
//! (camera-relative); every matrix a kind gives the GPU is composed in f64 as view_from_*.

mod footprint;
pub(crate) mod tiles;

use std::any::{Any, TypeId};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Weak};

use glam::{DMat4, DVec3};
use wgpu::util::DeviceExt;

use super::camera::Lens;
use super::cull::DepthRange;
use super::device::Gpu;
use super::scene::{Object, SceneObject};
use super::search::SearchOptions;
use crate::bvh::Aabb;
use crate::error::{GeomtexError, Result};

/// What every kind is built with: the device, the frame's group-0 layout and the ray queries'
/// group-2 layout.
pub(crate) struct KindContext<'a> {
    pub gpu: &'a Gpu,
    pub frame_layout: &'a wgpu::BindGroupLayout,
    pub query_layout: &'a wgpu::BindGroupLayout,
}

/// Declares every kind's module and registers its type, one line each.
macro_rules! kinds {
    ($($(#[$attr:meta])* $module:ident :: $kind:ident),* $(,)?) => {
        $($(#[$attr])* pub(crate) mod $module;)*

        /// Every kind the renderer draws, each built once, with the payload types they draw.
        // Pushed one by one: a kind's attributes (`#[cfg(test)]`) apply to its statement.
        #[allow(clippy::vec_init_then_push)]
        pub(crate) fn registered(context: &KindContext) -> Registry {
            let mut kinds: Vec<Box<dyn AnyKind>> = Vec::new();
            $($(#[$attr])* kinds.push(Box::new(Lazy::new(context, $module::$kind::new)));)*
            Registry::new(kinds)
        }
    };
}

kinds! {
    gtex::GtexKind,
    mesh::MeshKind,
    surfels::SurfelsKind,
    gdm::GdmKind,
    igt::IgtKind,
    #[cfg(test)] spheres::SpheresKind,
}

/// The kinds, and which one draws each payload type: an object is mapped to its kind here, once.
pub(crate) struct Registry {
    pub kinds: Vec<Box<dyn AnyKind>>,
    by_payload: HashMap<TypeId, usize>,
}

impl Registry {
    fn new(kinds: Vec<Box<dyn AnyKind>>) -> Registry {
        let by_payload: HashMap<_, _> = (kinds.iter().enumerate())
            .map(|(k, kind)| (kind.payload_type(), k))
            .collect();
        assert_eq!(
            by_payload.len(),
            kinds.len(),
            "two kinds draw one payload type"
        );
        Registry { kinds, by_payload }
    }

    /// The index of the kind that draws `object`; a `ParameterError` when none does.
    pub fn kind_of(&self, object: &Object) -> Result<usize> {
        self.by_payload
            .get(&object.payload_type())
            .copied()
            .ok_or_else(|| {
                GeomtexError::Parameter(format!(
                    "no kind of the renderer draws a {}",
                    object.payload_name()
                ))
            })
    }
}

/// One object kind's part in frames, ray queries and shadows, for objects holding a `Payload`.
pub(crate) trait Kind: Send + 'static {
    /// What a scene object of this kind holds (`Object::new`).
    type Payload: Any + Send + Sync;

    /// Uploads `payload` unless it is cached, and widens `depth` by its bounds as
    /// `view_from_object` places them.
    fn upload(
        &mut self,
        gpu: &Gpu,
        payload: &Arc<Self::Payload>,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<()>;

    /// The draw call of an object this kind uploaded (`placed` holds `payload`), counted in
    /// `tally`; `None` when nothing of it is in view.
    fn draw_call(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        payload: &Arc<Self::Payload>,
        tally: &mut Tally,
    ) -> Option<DrawCall>;

    /// Every draw call of the object: `draw_call`'s, or one per piece for a kind that draws an
    /// object in pieces (surfels larger than a storage binding, kinds/surfels.rs).
    fn draw(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        payload: &Arc<Self::Payload>,
        tally: &mut Tally,
    ) -> Vec<DrawCall> {
        (self
            .draw_call(gpu, frame, placed, payload, tally)
            .into_iter())
        .collect()
    }

    /// The draw call of an object in the surface pass (after the scene pass, depth-tested against
    /// its finished depth, into the surface target: detailed face and barycentrics per pixel),
    /// for kinds that shade through a detailed surface (kinds/igt.rs); `None` by default.
    fn draw_surface(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        payload: &Arc<Self::Payload>,
    ) -> Option<DrawCall> {
        let _ = (gpu, frame, placed, payload);
        None
    }

    /// The ray-query dispatch of an object this kind uploaded, its records placed by
    /// `view_from_world` (the query's frame); `None` when it holds nothing to hit. Ids continue
    /// from those `ids` handed out so far (patch ids, mesh ids), which it advances as a frame
    /// would. An error for kinds that cannot be traced (`casts_shadows` false).
    fn trace(
        &self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        payload: &Arc<Self::Payload>,
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
        payload: &Arc<Self::Payload>,
        ids: &mut Tally,
        direction: DVec3,
    ) -> Result<Option<TraceCall>> {
        let _ = direction;
        self.trace(gpu, view_from_world, placed, payload, ids)
    }

    /// Whether its objects cast shadows (are traced by shadow rays); every kind receives them.
    fn casts_shadows(&self) -> bool {
        true
    }

    /// How far off a surface of `payload` a shadow ray starts (world units under a placement
    /// scaling by at most `scale`): past the stored surface's own rounding, so that a surface
    /// does not shadow itself.
    fn shadow_offset(&self, payload: &Self::Payload, scale: f64) -> f64;

    /// Drops the uploads of objects that no longer exist.
    fn purge(&mut self);
}

/// A `Kind` as the renderer holds it, its payload type erased: each call finds the payload in
/// the scene object (the registry routed the object here by that type).
pub(crate) trait AnyKind: Send {
    fn payload_type(&self) -> TypeId;
    fn upload(
        &mut self,
        gpu: &Gpu,
        object: &Object,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<()>;
    fn draw(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        tally: &mut Tally,
    ) -> Vec<DrawCall>;
    fn draw_surface(&self, gpu: &Gpu, frame: &FrameView, placed: &SceneObject) -> Option<DrawCall>;
    fn trace(
        &self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        ids: &mut Tally,
        direction: Option<DVec3>,
    ) -> Result<Option<TraceCall>>;
    fn casts_shadows(&self) -> bool;
    fn shadow_offset(&self, object: &Object, scale: f64) -> f64;
    fn purge(&mut self);
    /// Whether the kind has been made (`Lazy`); a plain kind always is.
    fn is_made(&self) -> bool {
        true
    }
}

/// The payload of `object`, which the registry routed to kind `K`.
fn payload<K: Kind>(object: &Object) -> Arc<K::Payload> {
    object
        .payload::<K::Payload>()
        .expect("the registry routes each object to the kind of its payload type")
}

impl<K: Kind> AnyKind for K {
    fn payload_type(&self) -> TypeId {
        TypeId::of::<K::Payload>()
    }

    fn upload(
        &mut self,
        gpu: &Gpu,
        object: &Object,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<()> {
        Kind::upload(self, gpu, &payload::<K>(object), view_from_object, depth)
    }

    fn draw(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        tally: &mut Tally,
    ) -> Vec<DrawCall> {
        let p = payload::<K>(&placed.object);
        Kind::draw(self, gpu, frame, placed, &p, tally)
    }

    fn draw_surface(&self, gpu: &Gpu, frame: &FrameView, placed: &SceneObject) -> Option<DrawCall> {
        let p = payload::<K>(&placed.object);
        Kind::draw_surface(self, gpu, frame, placed, &p)
    }

    fn trace(
        &self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        ids: &mut Tally,
        direction: Option<DVec3>,
    ) -> Result<Option<TraceCall>> {
        let p = payload::<K>(&placed.object);
        match direction {
            Some(d) => Kind::trace_parallel(self, gpu, view_from_world, placed, &p, ids, d),
            None => Kind::trace(self, gpu, view_from_world, placed, &p, ids),
        }
    }

    fn casts_shadows(&self) -> bool {
        Kind::casts_shadows(self)
    }

    fn shadow_offset(&self, object: &Object, scale: f64) -> f64 {
        Kind::shadow_offset(self, &payload::<K>(object), scale)
    }

    fn purge(&mut self) {
        Kind::purge(self)
    }
}

/// A kind made when its first object is uploaded: its pipelines cost nothing until a scene
/// holds one. Making every kind's pipelines took most of a new renderer's second on lavapipe,
/// for kinds most scenes never draw. Every other call comes after the object's upload
/// (`Renderer::upload_scene`), so finds the kind made.
pub(crate) struct Lazy<K: Kind> {
    make: fn(&KindContext) -> K,
    frame_layout: wgpu::BindGroupLayout,
    query_layout: wgpu::BindGroupLayout,
    kind: Option<K>,
}

impl<K: Kind> Lazy<K> {
    fn new(context: &KindContext, make: fn(&KindContext) -> K) -> Lazy<K> {
        Lazy {
            make,
            frame_layout: context.frame_layout.clone(),
            query_layout: context.query_layout.clone(),
            kind: None,
        }
    }

    fn made(&self) -> &K {
        (self.kind.as_ref()).expect("a kind is made when its first object is uploaded")
    }
}

impl<K: Kind> AnyKind for Lazy<K> {
    fn payload_type(&self) -> TypeId {
        TypeId::of::<K::Payload>()
    }

    fn upload(
        &mut self,
        gpu: &Gpu,
        object: &Object,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<()> {
        let (make, frame_layout, query_layout) =
            (self.make, &self.frame_layout, &self.query_layout);
        let kind = self.kind.get_or_insert_with(|| {
            make(&KindContext {
                gpu,
                frame_layout,
                query_layout,
            })
        });
        AnyKind::upload(kind, gpu, object, view_from_object, depth)
    }

    fn draw(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        tally: &mut Tally,
    ) -> Vec<DrawCall> {
        AnyKind::draw(self.made(), gpu, frame, placed, tally)
    }

    fn draw_surface(&self, gpu: &Gpu, frame: &FrameView, placed: &SceneObject) -> Option<DrawCall> {
        AnyKind::draw_surface(self.made(), gpu, frame, placed)
    }

    fn trace(
        &self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        ids: &mut Tally,
        direction: Option<DVec3>,
    ) -> Result<Option<TraceCall>> {
        AnyKind::trace(self.made(), gpu, view_from_world, placed, ids, direction)
    }

    fn casts_shadows(&self) -> bool {
        AnyKind::casts_shadows(self.made())
    }

    fn shadow_offset(&self, object: &Object, scale: f64) -> f64 {
        AnyKind::shadow_offset(self.made(), object, scale)
    }

    fn purge(&mut self) {
        if let Some(kind) = &mut self.kind {
            AnyKind::purge(kind);
        }
    }

    fn is_made(&self) -> bool {
        self.kind.is_some()
    }
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
    /// Milliseconds spent making what the drawn sets' first frame needs (maps and pyramids
    /// uploaded, ownership, tile pieces), 0 once made.
    pub setup_ms: f64,
    /// With `lod`: the stop level each drawn patch got (kinds/gtex).
    pub lod_picks: Vec<LodPick>,
}

/// The level-of-detail stop level a drawn patch got, and the bound (world units) on how far its
/// points drawn there lie from the source mesh (kinds/gtex/lod.rs); level 0 is the exact search.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LodPick {
    pub patch_id: i32,
    pub level: u32,
    pub bound: f64,
}

impl Tally {
    /// The id of the next mesh-like object (meshes, GDM shells, IGT meshes), counted: the k-th
    /// writes -2 - k (-1 is a miss, 0.. are patches), in frames and ray queries alike.
    pub fn next_mesh_id(&mut self) -> i32 {
        let id = -2 - self.meshes_drawn as i32;
        self.meshes_drawn += 1;
        id
    }
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

/// Objects uploaded in this process so far, by every kind (a cache entry made): what tells a
/// user that a set drawn at two sizes and queried was uploaded once.
static UPLOADS_MADE: AtomicU64 = AtomicU64::new(0);

pub fn uploads_made() -> u64 {
    UPLOADS_MADE.load(Ordering::Relaxed)
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
            UPLOADS_MADE.fetch_add(1, Ordering::Relaxed);
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
            UPLOADS_MADE.fetch_add(1, Ordering::Relaxed);
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
