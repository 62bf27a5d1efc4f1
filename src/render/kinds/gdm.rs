//! Displacement shells (gdm): each prism's back faces are rasterized (gdm_raster.wgsl) and each
//! fragment traces its pixel's ray through that prism's piece of mesostructure, writing the hit's
//! true depth into the shared reversed-Z buffer. Ray queries and shadow rays walk a hierarchy over
//! the prisms (trace_functions.wgsl), each leaf traced by the same prism march
//! (gdm_trace_functions.wgsl), so shells cast shadows onto themselves and everything else.
//!
//! Spaces: the shell's object space, stored relative to its bounding box's centre ("local", f32);
//! view (camera-relative); texture space in voxels of the tile (gdm_data/volume.rs).

use std::sync::Arc;
use std::sync::OnceLock;

use glam::{DMat3, DMat4, DVec3};
use wgpu::util::DeviceExt;

use super::{bind_buffers, storage_buffer, DrawCall, FrameView, Kind, KindContext, Tally, TraceCall, UploadCache};
use crate::bvh::{Aabb, Bvh};
use crate::error::Result;
use crate::gdm_data::GdmShell;
use crate::render::cull::DepthRange;
use crate::render::device::Gpu;
use crate::render::gpu_types::{gpu_matrix, normal_matrix, GdmObjectGpu, GdmVertex, PrismGpu};
use crate::render::pipelines::{
    compute_pipeline, storage_entry, uniform_entry, RasterPipeline, VERTEX_AND_FRAGMENT,
};
use crate::render::scene::SceneObject;
use crate::render::shaders;

struct UploadedShell {
    vertices: wgpu::Buffer,
    count: u32,
    prisms: wgpu::Buffer,
    radii: wgpu::Buffer,
    weights: wgpu::Buffer,
    eigen: wgpu::Buffer,
    /// Each prism's six corners (local space), which bound it: the prism's map blends them.
    corners: Vec<[DVec3; 6]>,
    /// The hierarchy over the prisms for ray queries, built on the first one.
    tree: OnceLock<Bvh>,
    centre: DVec3,
    lo: DVec3,
    hi: DVec3,
}

pub(crate) struct GdmKind {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    trace_layout: wgpu::BindGroupLayout,
    trace_pipeline: wgpu::ComputePipeline,
    uploads: UploadCache<GdmShell, UploadedShell>,
}

impl GdmKind {
    pub fn new(context: &KindContext) -> GdmKind {
        let device = &context.gpu.device;
        let (frame_layout, query_layout) = (context.frame_layout, context.query_layout);
        let compute = wgpu::ShaderStages::COMPUTE;
        // Group 1 of gdm_trace_bindings.wgsl.
        let trace_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("gdm shell (tracer)"),
            entries: &(0..6)
                .map(|binding| storage_entry(binding, compute, true))
                .collect::<Vec<_>>(),
        });
        let trace_pipeline = compute_pipeline(
            device,
            "gdm_trace_rays",
            &shaders::gdm_trace_rays(),
            &[Some(frame_layout), Some(&trace_layout), Some(query_layout)],
            &[],
        );
        let fragment = wgpu::ShaderStages::FRAGMENT;
        // Group 1 of gdm_bindings.wgsl.
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("gdm shell"),
            entries: &[
                uniform_entry(0, VERTEX_AND_FRAGMENT),
                storage_entry(1, fragment, true),
                storage_entry(2, fragment, true),
                storage_entry(3, fragment, true),
                storage_entry(4, fragment, true),
            ],
        });
        let vertex_layout = wgpu::VertexBufferLayout {
            array_stride: size_of::<GdmVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Uint32],
        };
        let pipeline = RasterPipeline {
            label: "gdm_raster",
            source: shaders::gdm_raster(),
            layouts: &[Some(frame_layout), Some(&layout)],
            vertex_buffers: &[Some(vertex_layout)],
            // Back faces: one fragment per prism and pixel, and a camera inside still sees it.
            cull: Some(wgpu::Face::Front),
            constants: &[],
        }
        .build(device);
        GdmKind {
            layout,
            pipeline,
            trace_layout,
            trace_pipeline,
            uploads: UploadCache::default(),
        }
    }
}

/// The eight triangles of a prism (corners 0-2 base, 3-5 top), counter-clockwise from outside;
/// fin e is split by the diagonal `bits` bit e names, so neighbours rasterize the same
/// triangles (the fragment then intersects the exact bilinear fin, gdm_prism_interval).
fn prism_triangles(bits: u32) -> [[usize; 3]; 8] {
    let mut t = [
        [3, 4, 5],
        [0, 2, 1],
        [0; 3],
        [0; 3],
        [0; 3],
        [0; 3],
        [0; 3],
        [0; 3],
    ];
    for e in 0..3 {
        let (a, b) = (e, (e + 1) % 3);
        let pair = if bits >> e & 1 == 1 {
            [[a, b, b + 3], [a, b + 3, a + 3]]
        } else {
            [[a, b, a + 3], [b, b + 3, a + 3]]
        };
        t[2 + 2 * e] = pair[0];
        t[3 + 2 * e] = pair[1];
    }
    t
}

fn upload(gpu: &Gpu, object: &GdmShell) -> UploadedShell {
    let s = &object.shell;
    let lift = |k: u32, h: f64| s.positions[k as usize] + s.normals[k as usize] * (h * s.thickness);
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for k in 0..s.positions.len() as u32 {
        for h in [0.0, 1.0] {
            lo = lo.min(lift(k, h));
            hi = hi.max(lift(k, h));
        }
    }
    let centre = 0.5 * (lo + hi);
    let scale = [s.size[0] as f64, s.size[1] as f64];
    let mut prisms = Vec::with_capacity(s.faces.len());
    let mut prism_corners = Vec::with_capacity(s.faces.len());
    let mut vertices = Vec::with_capacity(s.faces.len() * 24);
    for (f, tri) in s.faces.iter().enumerate() {
        // Fin e's diagonal runs from the lower vertex id's base corner to the other's top.
        let bits = (0..3).fold(0u32, |acc, e| {
            acc | (u32::from(tri[e] < tri[(e + 1) % 3]) << e)
        });
        let corners: [DVec3; 6] =
            std::array::from_fn(|c| lift(tri[c % 3], (c / 3) as f64) - centre);
        let mut record = PrismGpu {
            corners: corners.map(|c| {
                let v = c.as_vec3();
                [v.x, v.y, v.z, 0.0]
            }),
            uv01: [0.0; 4],
            uv2: [0.0; 4],
        };
        record.corners[0][3] = bits as f32;
        let uv = s.uv[f].map(|t| [(t.x * scale[0]) as f32, (t.y * scale[1]) as f32]);
        record.uv01 = [uv[0][0], uv[0][1], uv[1][0], uv[1][1]];
        record.uv2 = [uv[2][0], uv[2][1], 0.0, 0.0];
        prisms.push(record);
        prism_corners.push(corners);
        for t in prism_triangles(bits) {
            for c in t {
                vertices.push(GdmVertex {
                    position: corners[c].as_vec3().to_array(),
                    prism: f as u32,
                });
            }
        }
    }
    let radii: Vec<u32> = object
        .volume
        .empty_radius()
        .into_iter()
        .map(u32::from)
        .collect();
    let device = &gpu.device;
    let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("gdm prism faces"),
        contents: bytemuck::cast_slice(&vertices),
        usage: wgpu::BufferUsages::VERTEX,
    });
    // One float stands in for the terms of a shell without a lookup (bindings need a buffer).
    let (weights, eigen) = match &object.lookup {
        Some(t) => (t.weights.as_slice(), t.eigen.as_slice()),
        None => (&[0.0f32][..], &[0.0f32][..]),
    };
    UploadedShell {
        weights: storage_buffer(device, "gdm weights", bytemuck::cast_slice(weights)),
        eigen: storage_buffer(device, "gdm eigen-maps", bytemuck::cast_slice(eigen)),
        vertices: buffer,
        count: vertices.len() as u32,
        prisms: storage_buffer(device, "gdm prisms", bytemuck::cast_slice(&prisms)),
        radii: storage_buffer(device, "gdm radii", bytemuck::cast_slice(&radii)),
        corners: prism_corners,
        tree: OnceLock::new(),
        centre,
        lo,
        hi,
    }
}

/// The shell's record (gdm_types.wgsl), with `view_from_world` the frame's (or a query's) view;
/// its hits get `id`.
fn shell_record(
    shell: &GdmShell,
    u: &UploadedShell,
    view_from_world: DMat4,
    world_from_object: DMat4,
    id: i32,
) -> GdmObjectGpu {
    let view_from_local = view_from_world * world_from_object * DMat4::from_translation(u.centre);
    let [nx, ny, nz] = shell.volume.size.map(|n| n as u32);
    GdmObjectGpu {
        view_from_object: gpu_matrix(view_from_local),
        object_from_view: gpu_matrix(view_from_local.inverse()),
        world_normal_from_object: normal_matrix(DMat3::from_mat4(world_from_object)),
        size: [nx, ny, nz, shell.pieces.max(1)],
        color: shell.color.map(|c| f32::from(c) / 255.0),
        ids: [id, 0, 0, 0],
        lookup: shell.lookup.as_ref().map_or([1, 1, 0, 0], |t| {
            let [nt, np] = t.directions.map(|n| n as u32);
            [nt, np, t.k as u32, if t.bound { 2 } else { 1 }]
        }),
        params: [
            shell.lookup.as_ref().map_or(0.0, |t| t.refine),
            0.0,
            0.0,
            f32::from(u8::from(shell.count_steps)),
        ],
    }
}

/// The same offset for displacement shells, in voxels of their tile. Against embree's shadow
/// rays on `Shell.to_mesh()` (a torus under chain links and a weave, 256², three lights): half a
/// voxel lost 3-5% of the shadowed pixels, where thin wires curve away from their tangent plane
/// within the offset; 0.05 voxel agrees on 98.3-99.4% of the pixels; 0.03 starts to shadow
/// surfaces by themselves away from shadow edges.
const OFFSET_VOXELS: f64 = 0.05;

impl Kind for GdmKind {
    type Payload = GdmShell;

    fn upload(
        &mut self,
        gpu: &Gpu,
        shell: &Arc<GdmShell>,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<()> {
        if shell.shell.faces.is_empty() {
            return Ok(());
        }
        let u = self.uploads.get_or_upload(shell, |s| Ok(upload(gpu, s)))?;
        depth.include_box(view_from_object, u.lo, u.hi);
        Ok(())
    }

    fn draw_call(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        shell: &Arc<GdmShell>,
        tally: &mut Tally,
    ) -> Option<DrawCall> {
        let u = self.uploads.get(shell)?;
        let id = tally.next_mesh_id();
        let record = shell_record(
            shell,
            u,
            frame.view_from_world,
            placed.world_from_object,
            id,
        );
        let device = &gpu.device;
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("gdm shell"),
            contents: bytemuck::bytes_of(&record),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let buffers = [&buffer, &u.prisms, &u.radii, &u.weights, &u.eigen];
        Some(DrawCall {
            pipeline: self.pipeline.clone(),
            group: bind_buffers(device, "gdm shell", &self.layout, &buffers),
            vertex_buffer: Some(u.vertices.clone()),
            vertices: u.count,
            instances: 1,
            compute: None,
        })
    }

    fn trace(
        &self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        shell: &Arc<GdmShell>,
        ids: &mut Tally,
    ) -> Result<Option<TraceCall>> {
        // Hits get the id the shell's pixels get in a frame.
        let id = ids.next_mesh_id();
        let Some(u) = self.uploads.get(shell) else {
            return Ok(None);
        };
        let boxes = |from_local: DMat4| -> Vec<Aabb> {
            (u.corners.iter())
                .map(|c| Aabb::of_points(c.iter().map(|&p| from_local.transform_point3(p))))
                .collect()
        };
        let tree = u.tree.get_or_init(|| Bvh::build(&boxes(DMat4::IDENTITY)));
        let query_from_local =
            view_from_world * placed.world_from_object * DMat4::from_translation(u.centre);
        let bounds = boxes(query_from_local);
        let nodes = tree.refit(&bounds);
        let record = shell_record(shell, u, view_from_world, placed.world_from_object, id);
        let device = &gpu.device;
        let record = storage_buffer(device, "gdm shell", bytemuck::bytes_of(&record));
        let nodes = storage_buffer(device, "prism hierarchy", bytemuck::cast_slice(&nodes));
        let buffers = [&record, &u.prisms, &u.radii, &u.weights, &u.eigen, &nodes];
        let group = bind_buffers(device, "gdm shell (tracer)", &self.trace_layout, &buffers);
        Ok(Some(TraceCall::within(
            self.trace_pipeline.clone(),
            group,
            &bounds,
        )))
    }

    /// A twentieth of a voxel: see `OFFSET_VOXELS`.
    fn shadow_offset(&self, shell: &GdmShell, scale: f64) -> f64 {
        OFFSET_VOXELS * shell.voxel_size() * scale
    }

    fn purge(&mut self) {
        self.uploads.purge();
    }
}
