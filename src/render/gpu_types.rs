//! GPU records: Rust mirrors of the WGSL structs, byte for byte (mat4 = 64 bytes, vec4 = 16,
//! vec3 = 12 aligned to 16, so a scalar or a padding field follows it). layouts.rs's test checks
//! each against naga's layout of its struct (one line there per record).
//!
//! Spaces: every matrix here is camera-relative (view space, OpenGL-style): composed in f64 with
//! the camera position subtracted, then cast to f32, so far-off models keep their detail.

use std::mem::offset_of;

use bytemuck::{Pod, Zeroable};
use glam::{DMat3, DMat4};

use super::camera::Lens;
use super::search::{Method, SearchOptions};

// Formats of the shared render targets (targets.rs), which every pipeline writes; here so that
// pipelines.rs and targets.rs need not import each other.
pub(crate) const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
pub(crate) const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const ID_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Sint;
pub(crate) const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// `Camera` in camera_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct CameraGpu {
    pub clip_from_view: [[f32; 4]; 4],
    pub view_from_world: [[f32; 4]; 4],
    pub ray: [f32; 4],
    pub params: [f32; 4],
}

/// `Search` in search_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct SearchGpu {
    pub steps: [f32; 4],
    pub method: [u32; 4],
}

/// `Patch` in gtex_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct PatchGpu {
    pub view_from_patch: [[f32; 4]; 4],
    pub patch_from_view: [[f32; 4]; 4],
    pub world_normal_from_patch: [[f32; 4]; 4],
    pub atlas_origin: [f32; 2],
    pub size: [f32; 2],
    pub ids: [i32; 4],
    pub pyramid_at: [u32; 4],
}

/// `MeshObject` in mesh_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct MeshObjectGpu {
    pub view_from_object: [[f32; 4]; 4],
    pub world_normal_from_object: [[f32; 4]; 4],
    pub ids: [i32; 4],
}

/// `VsIn` in mesh_raster.wgsl (vertex buffer 0: Float32x3, Float32x3, Unorm8x4, Float32x2).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct MeshVertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub color: [u8; 4],
    /// Texture coordinates (appearance.rs's convention); 0 without a texture.
    pub uv: [f32; 2],
}

/// `GdmObject` in gdm_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct GdmObjectGpu {
    pub view_from_object: [[f32; 4]; 4],
    pub object_from_view: [[f32; 4]; 4],
    pub world_normal_from_object: [[f32; 4]; 4],
    pub size: [u32; 4],
    pub color: [f32; 4],
    pub ids: [i32; 4],
    pub lookup: [u32; 4],
    pub params: [f32; 4],
}

/// `Prism` in gdm_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct PrismGpu {
    pub corners: [[f32; 4]; 6],
    pub uv01: [f32; 4],
    pub uv2: [f32; 4],
}

/// `VsIn` in gdm_raster.wgsl (vertex buffer 0: Float32x3, Uint32).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct GdmVertex {
    pub position: [f32; 3],
    pub prism: u32,
}

/// A matrix as the GPU takes it (f32, column-major).
pub(crate) fn gpu_matrix(m: DMat4) -> [[f32; 4]; 4] {
    m.as_mat4().to_cols_array_2d()
}

/// Inverse transpose of a linear map, as a 4x4 acting on directions (w = 0).
pub(crate) fn normal_matrix(linear: DMat3) -> [[f32; 4]; 4] {
    let n = linear.inverse().transpose();
    gpu_matrix(DMat4::from_mat3(n))
}

impl CameraGpu {
    pub fn new(lens: &Lens, view_from_world: DMat4) -> CameraGpu {
        // Normals are shaded by direction only; the translation would cost f32 precision.
        let rotation_only = DMat4::from_mat3(DMat3::from_mat4(view_from_world));
        CameraGpu {
            clip_from_view: gpu_matrix(lens.clip_from_view),
            view_from_world: gpu_matrix(rotation_only),
            ray: lens.ray.map(|v| v as f32),
            params: [
                lens.orthographic as u8 as f32,
                lens.near as f32,
                lens.far.min(f64::MAX) as f32,
                0.0,
            ],
        }
    }
}

impl SearchGpu {
    pub fn new(search: &SearchOptions) -> SearchGpu {
        SearchGpu {
            steps: [
                search.steps_per_texel,
                search.min_linear_steps as f32,
                search.max_linear_steps as f32,
                search.binary_steps as f32,
            ],
            method: [
                (search.method == Method::MaxMip) as u32,
                search.max_traversal_steps,
                0,
                0,
            ],
        }
    }
}

// Vertex buffers, not WGSL structs: tightly packed as the attribute formats say.
const _: () = assert!(size_of::<GdmVertex>() == 16);
const _: () = assert!(size_of::<MeshVertex>() == 36);
const _: () = assert!(offset_of!(MeshVertex, normal) == 12);
const _: () = assert!(offset_of!(MeshVertex, color) == 24);

/// `TraceTriangle` in mesh_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct TraceTriangleGpu {
    pub a: [f32; 3],
    pub _pad0: u32,
    pub b: [f32; 3],
    pub _pad1: u32,
    pub c: [f32; 3],
    pub _pad2: u32,
}

/// `MeshTrace` in mesh_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct MeshTraceGpu {
    pub local_from_query: [[f32; 4]; 4],
    pub world_normal_from_local: [[f32; 4]; 4],
    pub ids: [i32; 4],
}

/// `QueryRay` in query_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct QueryRayGpu {
    pub origin: [f32; 3],
    pub t_min: f32,
    pub dir: [f32; 3],
    pub _pad: u32,
}

/// `QueryHit` in query_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct QueryHitGpu {
    pub normal: [f32; 3],
    pub t: f32,
    pub id: i32,
    pub _pad: [u32; 3],
}

/// `Query` in query_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct QueryGpu {
    pub counts: [u32; 4],
}

/// `SurfelTile` in surfels_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct SurfelTileGpu {
    pub sphere: [f32; 4],
    pub error: [f32; 8],
    pub start: [u32; 8],
    pub info: [u32; 4],
    pub cone_axis: [f32; 4],
    pub cone_angle: [f32; 8],
}

/// `SurfelNode` in surfels_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct SurfelNodeGpu {
    pub sphere: [f32; 4],
    pub cone: [f32; 4],
    pub error: f32,
    pub surfel: u32,
    pub parent: u32,
    pub level: u32,
}

/// `Surfel` in surfels_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct SurfelGpu {
    pub position: [f32; 3],
    pub radius: f32,
    pub normal: [f32; 3],
    pub color: u32,
}

/// `SurfelObject` in surfels_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct SurfelObjectGpu {
    pub view_from_object: [[f32; 4]; 4],
    pub world_normal_from_object: [[f32; 4]; 4],
    pub planes: [[f32; 4]; 4],
    pub params: [f32; 4],
    pub sizes: [u32; 4],
    pub rect: [f32; 4],
    pub counts: [u32; 4],
}

/// `IgtObject` in igt_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct IgtObjectGpu {
    pub view_from_object: [[f32; 4]; 4],
    pub world_normal_from_object: [[f32; 4]; 4],
    pub ids: [i32; 4],
    pub info: [u32; 4],
    pub object_from_view: [[f32; 4]; 4],
    pub segments: [u32; 4],
    pub lod: [u32; 4],
}

/// `IgtGrid` in igt_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct IgtGridGpu {
    pub origin: [f32; 4],
    pub x: [f32; 4],
    pub z: [f32; 4],
    pub size: [u32; 4],
}

/// `IgtEntry` in igt_types.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct IgtEntryGpu {
    pub corners: [[f32; 2]; 3],
    pub face: u32,
    pub grid: u32,
}

/// `VsIn` in igt_raster.wgsl (vertex buffer 0: Float32x3, Uint32, Float32x2, Uint32x2,
/// Float32x3).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub(crate) struct IgtVertex {
    pub position: [f32; 3],
    pub grid: u32,
    /// The face's ray-lookup windows, outside and inside (IgtMesh::face_window).
    pub window: [f32; 2],
    /// The grids it walks (IgtMesh::face_search_grids): first and count in the mesh's list.
    pub search: [u32; 2],
    /// The face's unit normal by its winding (object space): which side the camera is on.
    pub normal: [f32; 3],
}

// The sizes the texture's figures count (igt::GRID_BYTES, igt::ENTRY_BYTES).
const _: () = assert!(size_of::<IgtGridGpu>() == crate::igt_data::GRID_BYTES);
const _: () = assert!(size_of::<IgtEntryGpu>() == crate::igt_data::ENTRY_BYTES);
const _: () = assert!(size_of::<IgtVertex>() == 44);
