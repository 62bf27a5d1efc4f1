//! Headless rendering of geometry textures (per-pixel ray casting) and ordinary meshes
//! (rasterization) into one reversed-Z depth buffer, read back as numpy-ready arrays.
//!
//! Spaces: world (f64, the scene's), object (each scene object's own, placed by
//! `world_from_object`), patch-local (unit cube) and view (camera-relative, OpenGL-style). Every
//! matrix the GPU sees is composed in f64 with the camera position subtracted, then cast to f32.

pub mod camera;
pub mod device;
pub mod shaders;

use std::collections::HashMap;
use std::sync::{Arc, Weak};
use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::{DMat3, DMat4, DVec3};
use wgpu::util::DeviceExt;

pub use camera::{Camera, Lens, Projection};
pub use device::Gpu;

use crate::error::{GeomtexError, Result};
use crate::gtex::GeometryTextureSet;
use crate::mesh::Mesh;

/// What a scene holds.
#[derive(Clone)]
pub enum Object {
    Textures(Arc<GeometryTextureSet>),
    Mesh(Arc<Mesh>),
}

#[derive(Clone)]
pub struct SceneObject {
    pub object: Object,
    pub world_from_object: DMat4,
}

#[derive(Clone, Default)]
pub struct Scene {
    pub objects: Vec<SceneObject>,
}

/// How a ray finds its first hit in a height map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The paper's search: a linear march balanced by slant, then bisection.
    LinearBinary,
    /// Exact: descend a max pyramid, skip what the ray passes above, solve each cell in closed form.
    MaxMip,
}

/// Search settings of a render.
#[derive(Clone, Copy, Debug)]
pub struct SearchOptions {
    pub method: Method,
    /// Linear samples per texel the ray crosses in the patch (the balance by slant).
    pub steps_per_texel: f32,
    pub min_linear_steps: u32,
    pub max_linear_steps: u32,
    pub binary_steps: u32,
    /// Most node visits of the max-pyramid traversal per fragment.
    pub max_traversal_steps: u32,
    /// Count height-map fetches per fragment (a slower counting build of the pipeline).
    pub count_fetches: bool,
    /// Level of detail (max-pyramid search only): each patch's traversal stops at the pyramid
    /// level whose nodes are about one pixel at the patch's nearest point, and hits the node's
    /// mid height there instead of descending to the exact bilinear cell.
    pub lod: bool,
}

impl Default for SearchOptions {
    fn default() -> Self {
        SearchOptions {
            method: Method::LinearBinary,
            steps_per_texel: 0.5,
            min_linear_steps: 2,
            max_linear_steps: 1024,
            binary_steps: 8,
            max_traversal_steps: 4096,
            count_fetches: false,
            lod: false,
        }
    }
}

impl SearchOptions {
    pub fn validate(&self) -> Result<()> {
        let ok = self.steps_per_texel.is_finite()
            && self.steps_per_texel > 0.0
            && self.min_linear_steps >= 1
            && self.max_linear_steps >= self.min_linear_steps
            && self.max_linear_steps <= 65536
            && self.binary_steps <= 64
            && (1..=1 << 20).contains(&self.max_traversal_steps);
        if self.lod && self.method != Method::MaxMip {
            return Err(GeomtexError::Parameter(
                "lod needs the max-pyramid search (method='maxmip' or quality='exact')".into(),
            ));
        }
        if ok {
            Ok(())
        } else {
            Err(GeomtexError::Parameter(format!(
                "search options out of range: {self:?} (need steps_per_texel > 0, \
                 1 <= min_linear_steps <= max_linear_steps <= 65536, binary_steps <= 64, \
                 1 <= max_traversal_steps <= 2^20)"
            )))
        }
    }
}

/// One rendered image, row-major with row 0 at the top.
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// RGBA8, shaded with a headlight; the background where nothing was hit.
    pub color: Vec<u8>,
    /// z-depth: distance along the camera's forward axis in world units; +inf on a miss.
    pub depth: Vec<f32>,
    /// World-space unit normals (xyz), 0 on a miss.
    pub normal: Vec<f32>,
    /// Patch index (0.. across the scene's texture sets in order), -1 on a miss, -2 - k for the
    /// k-th mesh of the scene.
    pub patch_id: Vec<i32>,
    pub gpu_ms: Option<f64>,
    pub cpu_ms: f64,
    pub patches_drawn: usize,
    /// Patches whose box lies wholly outside the view frustum, skipped before drawing.
    pub patches_culled: usize,
    pub meshes_drawn: usize,
    pub near: f64,
    /// With `count_fetches`: height-map and pyramid reads, and the fragments that ray cast.
    pub fetches: Option<(u64, u64)>,
}

// GPU records: layouts mirror the WGSL structs (mat4 = 64 bytes, vec4 = 16).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct CameraGpu {
    clip_from_view: [[f32; 4]; 4],
    view_from_world: [[f32; 4]; 4],
    ray: [f32; 4],
    params: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SearchGpu {
    steps: [f32; 4],
    method: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct PatchGpu {
    view_from_patch: [[f32; 4]; 4],
    patch_from_view: [[f32; 4]; 4],
    world_normal_from_patch: [[f32; 4]; 4],
    atlas_origin: [f32; 2],
    size: [f32; 2],
    ids: [i32; 4],
    pyramid_at: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct MeshObjectGpu {
    view_from_object: [[f32; 4]; 4],
    world_normal_from_object: [[f32; 4]; 4],
    ids: [i32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct MeshVertex {
    position: [f32; 3],
    normal: [f32; 3],
    color: [u8; 4],
}

fn mat(m: DMat4) -> [[f32; 4]; 4] {
    m.as_mat4().to_cols_array_2d()
}

/// Inverse transpose of a linear map, as a 4x4 acting on directions (w = 0).
fn normal_matrix(linear: DMat3) -> [[f32; 4]; 4] {
    let n = linear.inverse().transpose();
    mat(DMat4::from_mat3(n))
}

const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const ID_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Sint;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A texture set's maps packed into three texture arrays (height, normal, color).
struct UploadedTextures {
    set: Weak<GeometryTextureSet>,
    /// Per patch: (layer, x, y) of its first texel in the atlas.
    places: Vec<(u32, u32, u32)>,
    bind_textures: [wgpu::TextureView; 3],
    /// Every patch's min-max pyramid (src/heightfield.rs); per patch its first value and level
    /// count.
    pyramid: wgpu::Buffer,
    pyramid_at: Vec<[u32; 2]>,
}

struct UploadedMesh {
    mesh: Weak<Mesh>,
    vertices: wgpu::Buffer,
    count: u32,
    /// Vertices are stored relative to this point (f64) so f32 keeps their detail.
    centre: DVec3,
    lo: DVec3,
    hi: DVec3,
}

/// Render targets and readback buffers for one image size, reused by every frame.
struct Targets {
    width: u32,
    height: u32,
    color: wgpu::Texture,
    normal: wgpu::Texture,
    id: wgpu::Texture,
    depth: wgpu::Texture,
    depth_values: wgpu::Buffer,
    depth_copy_group: wgpu::BindGroup,
    readback: [wgpu::Buffer; 4],
    timestamps: Option<(wgpu::QuerySet, wgpu::Buffer, wgpu::Buffer)>,
}

fn padded_row(bytes_per_pixel: u32, width: u32) -> u32 {
    let a = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    (bytes_per_pixel * width).div_ceil(a) * a
}

pub struct Renderer {
    gpu: Gpu,
    textures_layout: wgpu::BindGroupLayout,
    mesh_layout: wgpu::BindGroupLayout,
    gtex_pipeline: wgpu::RenderPipeline,
    gtex_counting_pipeline: wgpu::RenderPipeline,
    mesh_pipeline: wgpu::RenderPipeline,
    depth_copy_pipeline: wgpu::ComputePipeline,
    sampler: wgpu::Sampler,
    camera_buffer: wgpu::Buffer,
    counters: wgpu::Buffer,
    counters_readback: wgpu::Buffer,
    search_buffer: wgpu::Buffer,
    frame_group: wgpu::BindGroup,
    targets: Targets,
    textures: HashMap<usize, UploadedTextures>,
    meshes: HashMap<usize, UploadedMesh>,
    pub background: [f64; 4],
}

impl Renderer {
    pub fn new(width: u32, height: u32) -> Result<Renderer> {
        let gpu = Gpu::new()?;
        let device = gpu.device.clone();
        guarded(&device, move || Self::build(gpu, width, height))
    }

    fn build(gpu: Gpu, width: u32, height: u32) -> Result<Renderer> {
        let max = gpu.device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(GeomtexError::Parameter(format!(
                "image size {width}x{height} must be between 1 and {max} (this adapter's limit) on each side"
            )));
        }
        let device = &gpu.device;
        let uniform = |binding, visibility| wgpu::BindGroupLayoutEntry {
            binding,
            visibility,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let vf = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame"),
            entries: &[
                uniform(0, vf),
                uniform(1, wgpu::ShaderStages::FRAGMENT),
                storage(2, false),
            ],
        });
        let texture_entry = |binding, filterable| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable },
                view_dimension: wgpu::TextureViewDimension::D2Array,
                multisampled: false,
            },
            count: None,
        };
        let textures_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("geometry textures"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: vf,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Uint,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                texture_entry(2, true),
                texture_entry(3, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 4,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
                storage(5, true),
            ],
        });
        let mesh_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mesh object"),
            entries: &[uniform(0, vf)],
        });
        let targets_state = [
            Some(wgpu::ColorTargetState {
                format: COLOR_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            }),
            Some(wgpu::ColorTargetState {
                format: NORMAL_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            }),
            Some(wgpu::ColorTargetState {
                format: ID_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            }),
        ];
        let depth_state = wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Greater), // reversed Z
            stencil: Default::default(),
            bias: Default::default(),
        };
        let make_pipeline = |label: &str,
                             source: String,
                             layouts: &[Option<&wgpu::BindGroupLayout>],
                             buffers: &[Option<wgpu::VertexBufferLayout>],
                             cull: Option<wgpu::Face>,
                             constants: &[(&str, f64)]| {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: layouts,
                immediate_size: 0,
            });
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    front_face: wgpu::FrontFace::Ccw,
                    cull_mode: cull,
                    ..Default::default()
                },
                depth_stencil: Some(depth_state.clone()),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants,
                        zero_initialize_workgroup_memory: true,
                    },
                    targets: &targets_state,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        // Back faces of each box: a camera inside a box still gets its fragments.
        let gtex_pipeline = make_pipeline(
            "gtex_raycast",
            shaders::gtex_raycast(),
            &[Some(&frame_layout), Some(&textures_layout)],
            &[],
            Some(wgpu::Face::Front),
            &[],
        );
        // The same shader with its fetch counter switched on.
        let gtex_counting_pipeline = make_pipeline(
            "gtex_raycast (counting fetches)",
            shaders::gtex_raycast(),
            &[Some(&frame_layout), Some(&textures_layout)],
            &[],
            Some(wgpu::Face::Front),
            &[("COUNT_FETCHES", 1.0)],
        );
        let mesh_vertex_layout = wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<MeshVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Unorm8x4],
        };
        // Meshes are two-sided, as a ray caster sees them.
        let mesh_pipeline = make_pipeline(
            "mesh_raster",
            shaders::mesh_raster(),
            &[Some(&frame_layout), Some(&mesh_layout)],
            &[Some(mesh_vertex_layout)],
            None,
            &[],
        );
        let depth_copy_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("depth copy"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: false },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let depth_copy_pipeline = {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("depth_copy"),
                source: wgpu::ShaderSource::Wgsl(shaders::depth_copy().into()),
            });
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("depth_copy"),
                bind_group_layouts: &[Some(&depth_copy_layout)],
                immediate_size: 0,
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("depth_copy"),
                layout: Some(&layout),
                module: &module,
                entry_point: Some("cs_main"),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("linear clamp"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            address_mode_w: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Nearest,
            ..Default::default()
        });
        let buffer = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let camera_buffer = buffer("camera", std::mem::size_of::<CameraGpu>() as u64);
        let search_buffer = buffer("search", std::mem::size_of::<SearchGpu>() as u64);
        let counters = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fetch counters"),
            size: 8,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let counters_readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fetch counters readback"),
            size: 8,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let frame_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &frame_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: camera_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: search_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: counters.as_entire_binding(),
                },
            ],
        });
        let targets = Self::make_targets(&gpu, &depth_copy_layout, width, height);
        Ok(Renderer {
            gpu,
            textures_layout,
            mesh_layout,
            gtex_pipeline,
            gtex_counting_pipeline,
            mesh_pipeline,
            depth_copy_pipeline,
            sampler,
            camera_buffer,
            search_buffer,
            counters,
            counters_readback,
            frame_group,
            targets,
            textures: HashMap::new(),
            meshes: HashMap::new(),
            background: [1.0, 1.0, 1.0, 0.0],
        })
    }

    pub fn size(&self) -> (u32, u32) {
        (self.targets.width, self.targets.height)
    }

    pub fn info(&self) -> Vec<(&'static str, String)> {
        self.gpu.info()
    }

    fn make_targets(
        gpu: &Gpu,
        depth_copy_layout: &wgpu::BindGroupLayout,
        width: u32,
        height: u32,
    ) -> Targets {
        let device = &gpu.device;
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let texture = |label, format, extra| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | extra,
                view_formats: &[],
            })
        };
        let color = texture("color", COLOR_FORMAT, wgpu::TextureUsages::COPY_SRC);
        let normal = texture("normal", NORMAL_FORMAT, wgpu::TextureUsages::COPY_SRC);
        let id = texture("id", ID_FORMAT, wgpu::TextureUsages::COPY_SRC);
        let depth = texture("depth", DEPTH_FORMAT, wgpu::TextureUsages::TEXTURE_BINDING);
        let depth_bytes = (width as u64) * (height as u64) * 4;
        let depth_values = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("depth values"),
            size: depth_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let depth_view = depth.create_view(&wgpu::TextureViewDescriptor {
            aspect: wgpu::TextureAspect::DepthOnly,
            ..Default::default()
        });
        let depth_copy_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("depth copy"),
            layout: depth_copy_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&depth_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: depth_values.as_entire_binding(),
                },
            ],
        });
        let map_buffer = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let h = height as u64;
        let readback = [
            map_buffer("color readback", padded_row(4, width) as u64 * h),
            map_buffer("normal readback", padded_row(8, width) as u64 * h),
            map_buffer("id readback", padded_row(4, width) as u64 * h),
            map_buffer("depth readback", depth_bytes),
        ];
        let timestamps = gpu.timestamps.then(|| {
            let set = device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("frame timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            });
            let resolve = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            (set, resolve, map_buffer("timestamp readback", 16))
        });
        Targets {
            width,
            height,
            color,
            normal,
            id,
            depth,
            depth_values,
            depth_copy_group,
            readback,
            timestamps,
        }
    }

    /// Packs a set's patches into texture-array layers (shelf packing, 1-texel gaps) and uploads
    /// them; cached for as long as the set is alive.
    fn upload_textures(&mut self, set: &Arc<GeometryTextureSet>) -> Result<usize> {
        let key = Arc::as_ptr(set) as usize;
        if let Some(u) = self.textures.get(&key) {
            if u.set.upgrade().is_some_and(|s| Arc::ptr_eq(&s, set)) {
                return Ok(key);
            }
        }
        let limits = self.gpu.device.limits();
        let side = limits.max_texture_dimension_2d.min(4096);
        let mut order: Vec<usize> = (0..set.patches.len()).collect();
        order.sort_by_key(|&i| std::cmp::Reverse(set.patches[i].height));
        let mut places = vec![(0u32, 0u32, 0u32); set.patches.len()];
        let (mut layer, mut x, mut y, mut shelf) = (0u32, 0u32, 0u32, 0u32);
        for &i in &order {
            let p = &set.patches[i];
            if p.width > side || p.height > side {
                return Err(GeomtexError::Device(format!(
                    "patch {i} is {}x{} texels; this adapter's texture layers hold at most {side}x{side} \
                     (convert with a smaller max_resolution)",
                    p.width, p.height
                )));
            }
            if x + p.width > side {
                x = 0;
                y += shelf + 1;
                shelf = 0;
            }
            if y + p.height > side {
                layer += 1;
                x = 0;
                y = 0;
                shelf = 0;
            }
            places[i] = (layer, x, y);
            x += p.width + 1;
            shelf = shelf.max(p.height);
        }
        let layers = layer + 1;
        if layers > limits.max_texture_array_layers {
            return Err(GeomtexError::Device(format!(
                "the set needs {layers} atlas layers of {side}x{side}; this adapter allows {} \
                 (convert with a smaller max_resolution)",
                limits.max_texture_array_layers
            )));
        }
        let device = &self.gpu.device;
        let size = wgpu::Extent3d {
            width: side,
            height: side,
            depth_or_array_layers: layers,
        };
        let make = |label, format| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            })
        };
        // One byte per height texel when every patch has 8-bit codes; the shader reads either
        // format as u32 and decodes with each patch's own largest code.
        let narrow = set.patches.iter().all(|p| p.height_bits == 8);
        let (height_format, height_bytes) = if narrow {
            (wgpu::TextureFormat::R8Uint, 1)
        } else {
            (wgpu::TextureFormat::R16Uint, 2)
        };
        let textures = [
            make("heights", height_format),
            make("normals", wgpu::TextureFormat::Rgba8Snorm),
            make("colors", wgpu::TextureFormat::Rgba8Unorm),
        ];
        for (p, &(layer, x, y)) in set.patches.iter().zip(&places) {
            let extent = wgpu::Extent3d {
                width: p.width,
                height: p.height,
                depth_or_array_layers: 1,
            };
            let narrow_codes: Vec<u8>;
            let height_plane: &[u8] = if narrow {
                narrow_codes = p.heights.iter().map(|&q| q as u8).collect();
                &narrow_codes
            } else {
                bytemuck::cast_slice(&p.heights)
            };
            let planes: [(&[u8], u32); 3] = [
                (height_plane, height_bytes),
                (bytemuck::cast_slice(&p.normals), 4),
                (bytemuck::cast_slice(&p.colors), 4),
            ];
            for (texture, (bytes, texel)) in textures.iter().zip(planes) {
                self.gpu.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture,
                        mip_level: 0,
                        origin: wgpu::Origin3d { x, y, z: layer },
                        aspect: wgpu::TextureAspect::All,
                    },
                    bytes,
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(p.width * texel),
                        rows_per_image: None,
                    },
                    extent,
                );
            }
        }
        let view = |t: &wgpu::Texture| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            })
        };
        let bind_textures = [view(&textures[0]), view(&textures[1]), view(&textures[2])];
        let mut values: Vec<u32> = Vec::new();
        let mut pyramid_at = Vec::with_capacity(set.patches.len());
        for p in &set.patches {
            let levels = crate::heightfield::min_max_pyramid(p);
            pyramid_at.push([values.len() as u32, levels.len() as u32]);
            for (_, _, v) in &levels {
                values.extend_from_slice(v);
            }
        }
        let pyramid_bytes = values.len() as u64 * 4;
        let binding_limit = u64::from(limits.max_storage_buffer_binding_size);
        if pyramid_bytes > binding_limit {
            return Err(GeomtexError::Device(format!(
                "the set's {} texels need {:.0} MiB of max pyramids; this adapter binds at most \
                 {:.0} MiB (convert with a smaller max_resolution or fewer charts)",
                set.texels(),
                pyramid_bytes as f64 / 1048576.0,
                binding_limit as f64 / 1048576.0
            )));
        }
        let pyramid = self
            .gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("max pyramids"),
                contents: bytemuck::cast_slice(&values),
                usage: wgpu::BufferUsages::STORAGE,
            });
        self.textures.insert(
            key,
            UploadedTextures {
                set: Arc::downgrade(set),
                places,
                bind_textures,
                pyramid,
                pyramid_at,
            },
        );
        Ok(key)
    }

    /// De-indexed vertices with face normals (flat, like a ray caster's hits) and colors.
    fn upload_mesh(&mut self, mesh: &Arc<Mesh>) -> usize {
        let key = Arc::as_ptr(mesh) as usize;
        if let Some(u) = self.meshes.get(&key) {
            if u.mesh.upgrade().is_some_and(|m| Arc::ptr_eq(&m, mesh)) {
                return key;
            }
        }
        let (lo, hi) = mesh.bounds();
        let centre = 0.5 * (lo + hi);
        let mut vertices = Vec::with_capacity(mesh.faces.len() * 3);
        for t in &mesh.faces {
            let p = t.map(|v| mesh.positions[v as usize]);
            let n = (p[1] - p[0])
                .cross(p[2] - p[0])
                .normalize_or_zero()
                .as_vec3()
                .to_array();
            for k in 0..3 {
                vertices.push(MeshVertex {
                    position: (p[k] - centre).as_vec3().to_array(),
                    normal: n,
                    color: mesh
                        .colors
                        .as_ref()
                        .map_or(crate::gtex::NEUTRAL_COLOR, |c| c[t[k] as usize]),
                });
            }
        }
        let buffer = self
            .gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("mesh vertices"),
                contents: bytemuck::cast_slice(&vertices),
                usage: wgpu::BufferUsages::VERTEX,
            });
        self.meshes.insert(
            key,
            UploadedMesh {
                mesh: Arc::downgrade(mesh),
                vertices: buffer,
                count: vertices.len() as u32,
                centre,
                lo,
                hi,
            },
        );
        key
    }

    /// Drops GPU copies of sets and meshes that no longer exist.
    fn purge(&mut self) {
        self.textures.retain(|_, u| u.set.strong_count() > 0);
        self.meshes.retain(|_, u| u.mesh.strong_count() > 0);
    }

    /// Renders `scene` seen by `camera`. GPU validation or out-of-memory errors come back as
    /// `GeomtexError::Device`, never as a panic.
    pub fn render(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        search: &SearchOptions,
    ) -> Result<Frame> {
        search.validate()?;
        let device = self.gpu.device.clone();
        guarded(&device, || self.render_unguarded(scene, camera, search))
    }

    fn render_unguarded(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        search: &SearchOptions,
    ) -> Result<Frame> {
        let start = Instant::now();
        self.purge();
        let (width, height) = self.size();
        let view_from_world = camera.view_from_world();

        // Upload what is new, and find the scene's depth range for the near plane.
        let mut keys = Vec::with_capacity(scene.objects.len());
        let (mut z_min, mut z_max) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut include = |corner: DVec3, view_from_object: &DMat4| {
            let z = -view_from_object.transform_point3(corner).z;
            z_min = z_min.min(z);
            z_max = z_max.max(z);
        };
        for (k, o) in scene.objects.iter().enumerate() {
            if !o.world_from_object.is_finite() || o.world_from_object.determinant().abs() < 1e-300
            {
                return Err(GeomtexError::Parameter(format!(
                    "scene object {k}: world_from_object must be finite and invertible"
                )));
            }
            let view_from_object = view_from_world * o.world_from_object;
            match &o.object {
                Object::Textures(set) => {
                    keys.push(self.upload_textures(set)?);
                    for p in &set.patches {
                        let m = view_from_object * p.world_from_patch();
                        for c in 0..8 {
                            let unit = DVec3::new(
                                (c & 1) as f64,
                                ((c >> 1) & 1) as f64,
                                ((c >> 2) & 1) as f64,
                            );
                            include(unit, &m);
                        }
                    }
                }
                Object::Mesh(mesh) => {
                    let key = self.upload_mesh(mesh);
                    let u = &self.meshes[&key];
                    for c in 0..8 {
                        let corner = DVec3::new(
                            if c & 1 == 0 { u.lo.x } else { u.hi.x },
                            if c & 2 == 0 { u.lo.y } else { u.hi.y },
                            if c & 4 == 0 { u.lo.z } else { u.hi.z },
                        );
                        include(corner, &view_from_object);
                    }
                    keys.push(key);
                }
            }
        }
        if !z_min.is_finite() {
            (z_min, z_max) = (1.0, 2.0); // empty scene
        }
        let lens = camera.lens(width, height, z_min, z_max)?;

        let queue = &self.gpu.queue;
        let device = &self.gpu.device;
        let rotation_only = DMat4::from_mat3(DMat3::from_mat4(view_from_world));
        queue.write_buffer(
            &self.camera_buffer,
            0,
            bytemuck::bytes_of(&CameraGpu {
                clip_from_view: mat(lens.clip_from_view),
                view_from_world: mat(rotation_only),
                ray: lens.ray.map(|v| v as f32),
                params: [
                    lens.orthographic as u8 as f32,
                    lens.near as f32,
                    lens.far.min(f64::MAX) as f32,
                    0.0,
                ],
            }),
        );
        queue.write_buffer(
            &self.search_buffer,
            0,
            bytemuck::bytes_of(&SearchGpu {
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
            }),
        );
        if search.count_fetches {
            queue.write_buffer(&self.counters, 0, &[0u8; 8]);
        }

        // Per-object GPU records for this view.
        enum Draw {
            Textures {
                group: wgpu::BindGroup,
                instances: u32,
            },
            Mesh {
                group: wgpu::BindGroup,
                key: usize,
            },
        }
        let mut draws = Vec::with_capacity(scene.objects.len());
        let (mut next_patch_id, mut mesh_index) = (0i32, 0i32);
        let (mut patches_drawn, mut meshes_drawn, mut patches_culled) = (0usize, 0usize, 0usize);
        for (o, &key) in scene.objects.iter().zip(&keys) {
            let view_from_object = view_from_world * o.world_from_object;
            let object_linear = DMat3::from_mat4(o.world_from_object);
            match &o.object {
                Object::Textures(set) => {
                    let up = &self.textures[&key];
                    let records: Vec<PatchGpu> = set
                        .patches
                        .iter()
                        .zip(&up.places)
                        .enumerate()
                        .filter(|(_, (p, _))| {
                            let clip_from_patch =
                                lens.clip_from_view * view_from_object * p.world_from_patch();
                            let visible = in_frustum(&clip_from_patch, !lens.orthographic);
                            patches_culled += usize::from(!visible);
                            visible
                        })
                        .map(|(i, (p, &(layer, x, y)))| {
                            let view_from_patch = view_from_object * p.world_from_patch();
                            let axes = DMat3::from_cols(p.axes[0], p.axes[1], p.axes[2]);
                            PatchGpu {
                                view_from_patch: mat(view_from_patch),
                                patch_from_view: mat(view_from_patch.inverse()),
                                world_normal_from_patch: normal_matrix(object_linear * axes),
                                atlas_origin: [x as f32, y as f32],
                                size: [p.width as f32, p.height as f32],
                                ids: [layer as i32, next_patch_id + i as i32, 0, 0],
                                pyramid_at: [
                                    up.pyramid_at[i][0],
                                    up.pyramid_at[i][1],
                                    p.code_max() as u32,
                                    if search.lod {
                                        lod_level(&view_from_patch, p, &lens, up.pyramid_at[i][1])
                                    } else {
                                        0
                                    },
                                ],
                            }
                        })
                        .collect();
                    next_patch_id += set.patches.len() as i32;
                    patches_drawn += records.len();
                    if records.is_empty() {
                        continue;
                    }
                    let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("patch records"),
                        contents: bytemuck::cast_slice(&records),
                        usage: wgpu::BufferUsages::STORAGE,
                    });
                    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("geometry textures"),
                        layout: &self.textures_layout,
                        entries: &[
                            wgpu::BindGroupEntry {
                                binding: 0,
                                resource: buffer.as_entire_binding(),
                            },
                            wgpu::BindGroupEntry {
                                binding: 1,
                                resource: wgpu::BindingResource::TextureView(&up.bind_textures[0]),
                            },
                            wgpu::BindGroupEntry {
                                binding: 2,
                                resource: wgpu::BindingResource::TextureView(&up.bind_textures[1]),
                            },
                            wgpu::BindGroupEntry {
                                binding: 3,
                                resource: wgpu::BindingResource::TextureView(&up.bind_textures[2]),
                            },
                            wgpu::BindGroupEntry {
                                binding: 4,
                                resource: wgpu::BindingResource::Sampler(&self.sampler),
                            },
                            wgpu::BindGroupEntry {
                                binding: 5,
                                resource: up.pyramid.as_entire_binding(),
                            },
                        ],
                    });
                    draws.push(Draw::Textures {
                        group,
                        instances: records.len() as u32,
                    });
                }
                Object::Mesh(_) => {
                    let u = &self.meshes[&key];
                    let view_from_local = view_from_object * DMat4::from_translation(u.centre);
                    let record = MeshObjectGpu {
                        view_from_object: mat(view_from_local),
                        world_normal_from_object: normal_matrix(object_linear),
                        ids: [-2 - mesh_index, 0, 0, 0],
                    };
                    mesh_index += 1;
                    meshes_drawn += 1;
                    let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("mesh object"),
                        contents: bytemuck::bytes_of(&record),
                        usage: wgpu::BufferUsages::UNIFORM,
                    });
                    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("mesh object"),
                        layout: &self.mesh_layout,
                        entries: &[wgpu::BindGroupEntry {
                            binding: 0,
                            resource: buffer.as_entire_binding(),
                        }],
                    });
                    draws.push(Draw::Mesh { group, key });
                }
            }
        }

        let t = &self.targets;
        let views = [&t.color, &t.normal, &t.id].map(|x| x.create_view(&Default::default()));
        let depth_view = t.depth.create_view(&Default::default());
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame"),
        });
        {
            let clear = |c: wgpu::Color| wgpu::Operations {
                load: wgpu::LoadOp::Clear(c),
                store: wgpu::StoreOp::Store,
            };
            let bg = self.background;
            let attachments = [
                Some(wgpu::RenderPassColorAttachment {
                    view: &views[0],
                    depth_slice: None,
                    resolve_target: None,
                    ops: clear(wgpu::Color {
                        r: bg[0],
                        g: bg[1],
                        b: bg[2],
                        a: bg[3],
                    }),
                }),
                Some(wgpu::RenderPassColorAttachment {
                    view: &views[1],
                    depth_slice: None,
                    resolve_target: None,
                    ops: clear(wgpu::Color::TRANSPARENT),
                }),
                Some(wgpu::RenderPassColorAttachment {
                    view: &views[2],
                    depth_slice: None,
                    resolve_target: None,
                    ops: clear(wgpu::Color {
                        r: -1.0,
                        g: 0.0,
                        b: 0.0,
                        a: 0.0,
                    }),
                }),
            ];
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("scene"),
                color_attachments: &attachments,
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(0.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: t.timestamps.as_ref().map(|(set, _, _)| {
                    wgpu::RenderPassTimestampWrites {
                        query_set: set,
                        beginning_of_pass_write_index: Some(0),
                        end_of_pass_write_index: Some(1),
                    }
                }),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.frame_group, &[]);
            for d in &draws {
                match d {
                    Draw::Mesh { group, key } => {
                        let u = &self.meshes[key];
                        pass.set_pipeline(&self.mesh_pipeline);
                        pass.set_bind_group(1, group, &[]);
                        pass.set_vertex_buffer(0, u.vertices.slice(..));
                        pass.draw(0..u.count, 0..1);
                    }
                    Draw::Textures { group, instances } => {
                        pass.set_pipeline(if search.count_fetches {
                            &self.gtex_counting_pipeline
                        } else {
                            &self.gtex_pipeline
                        });
                        pass.set_bind_group(1, group, &[]);
                        pass.draw(0..36, 0..*instances);
                    }
                }
            }
        }
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("depth copy"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.depth_copy_pipeline);
            pass.set_bind_group(0, &t.depth_copy_group, &[]);
            pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
        }
        for (texture, buffer, bpp) in [
            (&t.color, &t.readback[0], 4),
            (&t.normal, &t.readback[1], 8),
            (&t.id, &t.readback[2], 4),
        ] {
            encoder.copy_texture_to_buffer(
                wgpu::TexelCopyTextureInfo {
                    texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::TexelCopyBufferInfo {
                    buffer,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(padded_row(bpp, width)),
                        rows_per_image: None,
                    },
                },
                wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
            );
        }
        encoder.copy_buffer_to_buffer(&t.depth_values, 0, &t.readback[3], 0, t.depth_values.size());
        if search.count_fetches {
            encoder.copy_buffer_to_buffer(&self.counters, 0, &self.counters_readback, 0, 8);
        }
        if let Some((set, resolve, readback)) = &t.timestamps {
            encoder.resolve_query_set(set, 0..2, resolve, 0);
            encoder.copy_buffer_to_buffer(resolve, 0, readback, 0, 16);
        }
        queue.submit(Some(encoder.finish()));

        // Read everything back in one wait.
        let mut buffers: Vec<&wgpu::Buffer> = t.readback.iter().collect();
        if search.count_fetches {
            buffers.push(&self.counters_readback);
        }
        if let Some((_, _, r)) = &t.timestamps {
            buffers.push(r);
        }
        for b in &buffers {
            b.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        }
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GeomtexError::Device(format!("waiting for the GPU failed: {e}")))?;
        let read = |b: &wgpu::Buffer| -> Result<Vec<u8>> {
            let v = b
                .slice(..)
                .get_mapped_range()
                .map_err(|e| GeomtexError::Device(format!("readback failed: {e:?}")))?
                .to_vec();
            Ok(v)
        };
        let unpad = |bytes: Vec<u8>, bpp: u32| -> Vec<u8> {
            let row = (bpp * width) as usize;
            let pitch = padded_row(bpp, width) as usize;
            if row == pitch {
                return bytes;
            }
            bytes
                .chunks(pitch)
                .take(height as usize)
                .flat_map(|r| &r[..row])
                .copied()
                .collect()
        };
        let color = unpad(read(&t.readback[0])?, 4);
        let normal_half = unpad(read(&t.readback[1])?, 8);
        let ids = unpad(read(&t.readback[2])?, 4);
        let depth_raw = read(&t.readback[3])?;
        let fetches = if search.count_fetches {
            let c: Vec<u32> = bytemuck::cast_slice(&read(&self.counters_readback)?).to_vec();
            Some((c[0] as u64, c[1] as u64))
        } else {
            None
        };
        let gpu_ms = match &t.timestamps {
            Some((_, _, r)) => {
                let ticks: Vec<u64> = bytemuck::cast_slice(&read(r)?).to_vec();
                let period = queue.get_timestamp_period() as f64;
                Some(ticks[1].saturating_sub(ticks[0]) as f64 * period / 1e6)
            }
            None => None,
        };
        for b in &buffers {
            b.unmap();
        }

        let depth: Vec<f32> = bytemuck::cast_slice::<u8, f32>(&depth_raw)
            .iter()
            .map(|&d| Camera::distance_from_depth(&lens, d))
            .collect();
        let normal: Vec<f32> = bytemuck::cast_slice::<u8, [u16; 4]>(&normal_half)
            .iter()
            .flat_map(|n| [n[0], n[1], n[2]].map(|h| half::f16::from_bits(h).to_f32()))
            .collect();
        let patch_id: Vec<i32> = bytemuck::cast_slice(&ids).to_vec();
        Ok(Frame {
            width,
            height,
            color,
            depth,
            normal,
            patch_id,
            gpu_ms,
            cpu_ms: start.elapsed().as_secs_f64() * 1e3,
            patches_drawn,
            patches_culled,
            meshes_drawn,
            near: lens.near,
            fetches,
        })
    }
}

/// Runs `work` inside validation and out-of-memory error scopes and turns what they catch into
/// `GeomtexError::Device`.
fn guarded<T>(device: &wgpu::Device, work: impl FnOnce() -> Result<T>) -> Result<T> {
    let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let result = work();
    let oom = pollster::block_on(memory.pop());
    let invalid = pollster::block_on(validation.pop());
    match (oom, invalid) {
        (Some(e), _) => Err(GeomtexError::Device(format!(
            "the GPU ran out of memory: {e}"
        ))),
        (None, Some(e)) => Err(GeomtexError::Device(format!(
            "the GPU rejected a command: {e}"
        ))),
        (None, None) => result,
    }
}

// The GPU records must match the WGSL struct layouts byte for byte.
const _: () = assert!(std::mem::size_of::<PatchGpu>() == 240);
const _: () = assert!(std::mem::size_of::<SearchGpu>() == 32);
const _: () = assert!(std::mem::size_of::<CameraGpu>() == 160);
const _: () = assert!(std::mem::size_of::<MeshObjectGpu>() == 144);

/// The corners of the unit cube (a patch's box in patch-local space).
fn unit_cube_corners() -> [DVec3; 8] {
    std::array::from_fn(|k| {
        DVec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64)
    })
}

/// Whether a box (the unit cube under `clip_from_box`) may reach the view: false only when all
/// eight corners lie outside one side of the frustum (left, right, bottom, top, or, for a
/// perspective camera, behind the eye). Conservative: a box across a corner of the frustum is
/// kept; the ray caster then draws nothing for it.
fn in_frustum(clip_from_box: &DMat4, perspective: bool) -> bool {
    let corners = unit_cube_corners().map(|c| *clip_from_box * c.extend(1.0));
    let outside = |test: &dyn Fn(&glam::DVec4) -> bool| corners.iter().all(test);
    // A relative slack so rounding never culls a box that touches the frustum.
    let slack = |c: &glam::DVec4| c.w.abs() * 1e-9;
    !(outside(&|c| c.x > c.w + slack(c))
        || outside(&|c| c.x < -c.w - slack(c))
        || outside(&|c| c.y > c.w + slack(c))
        || outside(&|c| c.y < -c.w - slack(c))
        || (perspective && outside(&|c| c.w <= 0.0)))
}

/// The pyramid level at which a patch's nodes are about one pixel: from its texel size and the
/// pixel footprint at the nearest corner of its box (so no part of the patch gets coarser than
/// a pixel; far parts of a long patch get finer than they need).
fn lod_level(view_from_patch: &DMat4, p: &crate::gtex::Patch, lens: &Lens, levels: u32) -> u32 {
    let nearest = unit_cube_corners()
        .iter()
        .map(|&c| -view_from_patch.transform_point3(c).z)
        .fold(f64::INFINITY, f64::min)
        .max(lens.near);
    let pixel = if lens.orthographic {
        lens.ray[1].abs()
    } else {
        nearest * lens.ray[1].abs()
    };
    let texel = (p.extent.x / p.width as f64).min(p.extent.y / p.height as f64);
    let texels_per_pixel = pixel / texel;
    if !(texels_per_pixel >= 2.0) {
        return 0;
    }
    (texels_per_pixel.log2().floor() as u32).min(levels.saturating_sub(1))
}
