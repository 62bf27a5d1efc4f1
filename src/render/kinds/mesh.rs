//! Ordinary triangle meshes, rasterized (mesh_raster.wgsl) into the same targets as the ray-cast
//! kinds, so the nearer surface wins at every pixel. Two-sided, as a ray caster sees them, and
//! shaded by the same normal rule as `convert` (crease-split by default, `mesh::NormalRule`).
//! Vertices go up unwelded, three per face, each with its corner's normal and color.
//!
//! Spaces: the mesh's object space (placed by `world_from_object`); its vertices are stored
//! relative to their bounding box centre ("local", f32) so f32 keeps their detail; view
//! (camera-relative).

use glam::{DMat3, DMat4, DVec3};
use wgpu::util::DeviceExt;

use super::{DrawCall, FrameView, Kind, Tally, UploadCache};
use crate::error::{GeomtexError, Result};
use crate::mesh::{Mesh, MeshGeometry, NormalRule};
use crate::render::cull::DepthRange;
use crate::render::device::Gpu;
use crate::render::gpu_types::{gpu_matrix, normal_matrix, MeshObjectGpu, MeshVertex};
use crate::render::pipelines::{uniform_entry, RasterPipeline, VERTEX_AND_FRAGMENT};
use crate::render::scene::{Object, SceneObject};
use crate::render::shaders;

/// A mesh's de-indexed vertices on the GPU.
struct UploadedMesh {
    vertices: wgpu::Buffer,
    count: u32,
    /// Vertices are stored relative to this point (f64) so f32 keeps their detail.
    centre: DVec3,
    /// Bounding box in object space.
    lo: DVec3,
    hi: DVec3,
}

pub(crate) struct MeshKind {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    /// Per mesh, its uploads under each normal rule it was drawn with.
    uploads: UploadCache<Mesh, Vec<(NormalRule, UploadedMesh)>>,
}

impl MeshKind {
    pub fn new(device: &wgpu::Device, frame_layout: &wgpu::BindGroupLayout) -> MeshKind {
        // Group 1 of mesh_bindings.wgsl.
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mesh object"),
            entries: &[uniform_entry(0, VERTEX_AND_FRAGMENT)],
        });
        let vertex_layout = wgpu::VertexBufferLayout {
            array_stride: size_of::<MeshVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Unorm8x4],
        };
        let pipeline = RasterPipeline {
            label: "mesh_raster",
            source: shaders::mesh_raster(),
            layouts: &[Some(frame_layout), Some(&layout)],
            vertex_buffers: &[Some(vertex_layout)],
            // Two-sided, as a ray caster sees a mesh.
            cull: None,
            constants: &[],
        }
        .build(device);
        MeshKind {
            layout,
            pipeline,
            uploads: UploadCache::default(),
        }
    }
}

/// De-indexed vertices, three per face, with their corners' normals under `rule` and base
/// colors (vertex or face colors; a texture's color at each corner).
fn upload(gpu: &Gpu, mesh: &Mesh, rule: NormalRule) -> UploadedMesh {
    let (lo, hi) = mesh.bounds();
    let centre = 0.5 * (lo + hi);
    let normals = MeshGeometry::new(mesh).corner_normals(mesh, rule);
    let mut vertices = Vec::with_capacity(mesh.faces.len() * 3);
    for (f, (t, n)) in mesh.faces.iter().zip(&normals).enumerate() {
        let colors = mesh.face_color(f as u32, None);
        for k in 0..3 {
            vertices.push(MeshVertex {
                position: (mesh.positions[t[k] as usize] - centre)
                    .as_vec3()
                    .to_array(),
                normal: n[k].as_vec3().to_array(),
                // A texture is only sampled at the corners (the Python layer warns).
                color: colors.at(std::array::from_fn(|c| f64::from(u8::from(c == k)))),
            });
        }
    }
    let buffer = gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("mesh vertices"),
            contents: bytemuck::cast_slice(&vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
    UploadedMesh {
        vertices: buffer,
        count: vertices.len() as u32,
        centre,
        lo,
        hi,
    }
}

impl Kind for MeshKind {
    fn upload(
        &mut self,
        gpu: &Gpu,
        object: &Object,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<bool> {
        let Object::Mesh(mesh, rule) = object else {
            return Ok(false);
        };
        let uploads = self.uploads.entry(mesh);
        if !uploads.iter().any(|(r, _)| r == rule) {
            uploads.push((*rule, upload(gpu, mesh, *rule)));
        }
        let (_, u) = uploads.iter().find(|(r, _)| r == rule).expect("uploaded");
        depth.include_box(view_from_object, u.lo, u.hi);
        Ok(true)
    }

    fn draw(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        tally: &mut Tally,
    ) -> Option<DrawCall> {
        let Object::Mesh(mesh, rule) = &placed.object else {
            return None;
        };
        let (_, u) = self.uploads.get(mesh)?.iter().find(|(r, _)| r == rule)?;
        let view_from_object = frame.view_from_world * placed.world_from_object;
        let view_from_local = view_from_object * DMat4::from_translation(u.centre);
        let record = MeshObjectGpu {
            view_from_object: gpu_matrix(view_from_local),
            world_normal_from_object: normal_matrix(DMat3::from_mat4(placed.world_from_object)),
            ids: [-2 - tally.meshes_drawn as i32, 0, 0, 0],
        };
        tally.meshes_drawn += 1;
        let device = &gpu.device;
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("mesh object"),
            contents: bytemuck::bytes_of(&record),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("mesh object"),
            layout: &self.layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: buffer.as_entire_binding(),
            }],
        });
        Some(DrawCall {
            pipeline: self.pipeline.clone(),
            group,
            vertex_buffer: Some(u.vertices.clone()),
            vertices: u.count,
            instances: 1,
            compute: None,
        })
    }

    fn trace(
        &self,
        _gpu: &Gpu,
        _view_from_world: DMat4,
        placed: &SceneObject,
        _first_id: &mut i32,
    ) -> Result<Option<super::TraceCall>> {
        match &placed.object {
            Object::Mesh(..) => Err(GeomtexError::Parameter(
                "ray queries through meshes are not supported yet; query the texture sets, or \
                 use trimesh's ray queries for the meshes"
                    .into(),
            )),
            _ => Ok(None),
        }
    }

    fn purge(&mut self) {
        self.uploads.purge();
    }
}
