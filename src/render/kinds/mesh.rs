//! Ordinary triangle meshes, rasterized (mesh_raster.wgsl) into the same targets as the ray-cast
//! kinds, so the nearer surface wins at every pixel. Two-sided, as a ray caster sees them, and
//! shaded by the same normal rule as `convert` (crease-split by default, `mesh::NormalRule`).
//! Vertices go up unwelded, three per face, each with its corner's normal, color and texture
//! coordinates; a textured mesh's image goes up once with its mip chain and is sampled per pixel.
//!
//! Meshes are traced too (ray queries and shadow rays): their triangles and a hierarchy over
//! them (bvh.rs) go up once per mesh in its local space and stay; each query only moves its rays
//! into that space (mesh_trace_rays.wgsl), so a frame's shadow rays do not re-place, refit and
//! re-upload the mesh (about 8 MB for the 69k-triangle bunny) every frame.
//!
//! Spaces: the mesh's object space (placed by `world_from_object`); its vertices are stored
//! relative to their bounding box centre ("local", f32) so f32 keeps their detail, for drawing
//! and tracing alike; view (camera-relative); a query's frame (world translated near its rays).

use std::sync::{Arc, Mutex, OnceLock};

use glam::{DMat3, DMat4, DVec3};
use wgpu::util::DeviceExt;

use super::footprint::Footprint;
use super::tiles::{self, TileLists};
use super::{bind_buffers, storage_buffer, DrawCall, FrameView, Kind, KindContext, RayTest, Tally, TraceCall, UploadCache};
use crate::appearance::{Image, Texture, TextureCoords};
use crate::bvh::{Aabb, Bvh};
use crate::error::Result;
use crate::mesh::{Mesh, MeshGeometry, NormalRule};
use crate::render::cull::DepthRange;
use crate::render::device::Gpu;
use crate::render::gpu_types::{
    gpu_matrix, normal_matrix, MeshObjectGpu, MeshTraceGpu, MeshVertex, TraceTriangleGpu,
};
use crate::render::pipelines::{
    compute_pipeline, storage_entry, texture_entry, uniform_entry, RasterPipeline,
    VERTEX_AND_FRAGMENT,
};
use crate::render::scene::{SceneObject, ShadedMesh};
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

/// A mesh's triangles and the hierarchy over them on the device, in its local space (object
/// space relative to its bounding box centre, f32), as every query traces them.
struct TracedMesh {
    nodes: wgpu::Buffer,
    triangles: wgpu::Buffer,
    /// Object-space bounding box; local space is object space less its centre.
    lo: DVec3,
    hi: DVec3,
}

/// Everything kept of one mesh: its uploads under each normal rule it was drawn with, its
/// texture image (uploaded with the first of them), and its triangles for tracing, uploaded the
/// first time it is traced, and what parallel rays along the last direction they were traced
/// along used (the next frame's shadow rays toward the same light reuse it).
#[derive(Default)]
struct MeshUploads {
    drawn: Vec<(NormalRule, UploadedMesh)>,
    image: Option<wgpu::TextureView>,
    traced: OnceLock<TracedMesh>,
    along: Mutex<Option<Arc<MeshAlong>>>,
}

/// A mesh as parallel rays along one direction see it, in its local space: its footprint (the
/// CPU's test of each ray) and, from the second query along the direction on, its triangles
/// tiled along it, nearest first per tile, with the lists on the device (the GPU's walk; `None`
/// where no triangle covers the grid). A one-off query walks the hierarchy instead: on a
/// 1.1M-triangle mesh (2 cores, 1000 rays) the query that builds the lists takes 0.25-0.27 s,
/// twice a one-off query's whole 0.12 s.
struct MeshAlong {
    /// Local-space unit direction.
    direction: DVec3,
    footprint: Footprint,
    tiles: OnceLock<Option<(TileLists, wgpu::Buffer, wgpu::Buffer)>>,
}

impl MeshAlong {
    fn new(mesh: &Mesh, direction: DVec3) -> MeshAlong {
        MeshAlong {
            direction,
            footprint: Footprint::new(local_triangles(mesh), direction),
            tiles: OnceLock::new(),
        }
    }

    fn tiles(&self, gpu: &Gpu, mesh: &Mesh) -> Option<&(TileLists, wgpu::Buffer, wgpu::Buffer)> {
        let build = || {
            let lists = tiles::parallel((0..).zip(local_triangles(mesh)), self.direction)?;
            let device = &gpu.device;
            let ranges = bytemuck::cast_slice(&lists.ranges);
            let ranges = storage_buffer(device, "mesh tile ranges", ranges);
            let entries = bytemuck::cast_slice(&lists.entries);
            let entries = storage_buffer(device, "mesh tile entries", entries);
            Some((lists, ranges, entries))
        };
        self.tiles.get_or_init(build).as_ref()
    }
}

/// A mesh's triangles in its local space (object space less its bounding box centre), where its
/// traced triangles are kept (`upload_traced`).
fn local_triangles(mesh: &Mesh) -> impl Iterator<Item = [DVec3; 3]> + Clone + '_ {
    let (lo, hi) = mesh.bounds();
    let centre = 0.5 * (lo + hi);
    (mesh.faces.iter()).map(move |t| t.map(|k| mesh.positions[k as usize] - centre))
}

/// What both tracers of one mesh in one query share.
struct MeshQuery<'a> {
    mesh: &'a Mesh,
    uploads: &'a MeshUploads,
    traced: &'a TracedMesh,
    /// mesh_types.wgsl's `MeshTrace`.
    settings: wgpu::Buffer,
    /// The placed bounding box (query frame): no tighter than the placed triangles' boxes, so
    /// its test may keep a few more rays, never drop one that reaches a triangle.
    bounds: Aabb,
    local_from_query: DMat4,
}

pub(crate) struct MeshKind {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    /// Repeating, trilinear: how a rasterizer samples a mesh's texture.
    sampler: wgpu::Sampler,
    /// The image of meshes without a texture: one white pixel, so vertex colors pass unchanged.
    white: wgpu::TextureView,
    trace_layout: wgpu::BindGroupLayout,
    trace_pipeline: wgpu::ComputePipeline,
    /// Group 1 of parallel ray queries (mesh_trace_bindings.wgsl's settings and triangles,
    /// tiles_bindings.wgsl) and their pipeline.
    tiles_trace_layout: wgpu::BindGroupLayout,
    tiles_trace_pipeline: wgpu::ComputePipeline,
    uploads: UploadCache<Mesh, MeshUploads>,
}

impl MeshKind {
    pub fn new(context: &KindContext) -> MeshKind {
        let gpu = context.gpu;
        let (frame_layout, query_layout) = (context.frame_layout, context.query_layout);
        let (device, queue) = (&gpu.device, &gpu.queue);
        let compute = wgpu::ShaderStages::COMPUTE;
        // Group 1 of mesh_trace_bindings.wgsl.
        let trace_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mesh (tracer)"),
            entries: &[
                storage_entry(0, compute, true),
                storage_entry(1, compute, true),
                storage_entry(2, compute, true),
            ],
        });
        let trace_pipeline = compute_pipeline(
            device,
            "mesh_trace_rays",
            &shaders::mesh_trace_rays(),
            &[Some(frame_layout), Some(&trace_layout), Some(query_layout)],
            &[],
        );
        let tiles_trace_layout =
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("mesh (tiled tracer)"),
                entries: &[0, 2, 9, 10, 11].map(|binding| storage_entry(binding, compute, true)),
            });
        let tiles_trace_pipeline = compute_pipeline(
            device,
            "mesh_tiles_rays",
            &shaders::mesh_tiles_rays(),
            &[
                Some(frame_layout),
                Some(&tiles_trace_layout),
                Some(query_layout),
            ],
            &[],
        );
        // Group 1 of mesh_bindings.wgsl.
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mesh object"),
            entries: &[
                uniform_entry(0, VERTEX_AND_FRAGMENT),
                texture_entry(
                    1,
                    fragment,
                    wgpu::TextureSampleType::Float { filterable: true },
                    wgpu::TextureViewDimension::D2,
                ),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: fragment,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let vertex_layout = wgpu::VertexBufferLayout {
            array_stride: size_of::<MeshVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![
                0 => Float32x3, 1 => Float32x3, 2 => Unorm8x4, 3 => Float32x2
            ],
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
        let repeat = wgpu::AddressMode::Repeat;
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("mesh texture"),
            address_mode_u: repeat,
            address_mode_v: repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        MeshKind {
            layout,
            pipeline,
            sampler,
            white: image_texture(device, queue, &[(1, 1, &[[255u8; 4]])]),
            trace_layout,
            trace_pipeline,
            tiles_trace_layout,
            tiles_trace_pipeline,
            uploads: UploadCache::default(),
        }
    }

    /// What a query of `placed` (a mesh, uploaded) in the query frame `view_from_world` needs of
    /// it, its triangles uploaded the first time; its hits get the id its pixels get in a frame.
    fn query<'a>(
        &'a self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        mesh: &'a Arc<Mesh>,
        ids: &mut Tally,
    ) -> Option<MeshQuery<'a>> {
        let id = ids.next_mesh_id();
        let uploads = self.uploads.get(mesh)?;
        let traced = uploads.traced.get_or_init(|| upload_traced(gpu, mesh));
        let centre = 0.5 * (traced.lo + traced.hi);
        let view_from_object = view_from_world * placed.world_from_object;
        let view_from_local = view_from_object * DMat4::from_translation(centre);
        // Rays move into local space by the inverse placement, their directions unnormalized,
        // so t stays the distance along the query's unit direction (in world units) under any
        // scale. Normals come back by the cofactor matrix (det M times M^-T): it turns the
        // local face normal into that of the placed triangle, mirrored placements included.
        let linear = DMat3::from_mat4(placed.world_from_object);
        let cofactor = linear.inverse().transpose() * linear.determinant();
        let local_from_query = view_from_local.inverse();
        let settings = MeshTraceGpu {
            local_from_query: gpu_matrix(local_from_query),
            world_normal_from_local: gpu_matrix(DMat4::from_mat3(cofactor)),
            ids: [id, 0, 0, 0],
        };
        let (lo, hi) = (traced.lo, traced.hi);
        let corners = (0..8).map(|k| {
            let pick = |bit: usize, a: f64, b: f64| if k >> bit & 1 == 1 { b } else { a };
            let corner = DVec3::new(
                pick(0, lo.x, hi.x),
                pick(1, lo.y, hi.y),
                pick(2, lo.z, hi.z),
            );
            view_from_object.transform_point3(corner)
        });
        Some(MeshQuery {
            mesh,
            uploads,
            traced,
            settings: storage_buffer(&gpu.device, "mesh trace", bytemuck::bytes_of(&settings)),
            bounds: Aabb::of_points(corners),
            local_from_query,
        })
    }

    /// Group 1 of a query's walk of the mesh's hierarchy (mesh_trace_bindings.wgsl).
    fn hierarchy_group(&self, gpu: &Gpu, query: &MeshQuery) -> wgpu::BindGroup {
        let buffers = [
            &query.settings,
            &query.traced.nodes,
            &query.traced.triangles,
        ];
        bind_buffers(&gpu.device, "mesh (tracer)", &self.trace_layout, &buffers)
    }
}

/// The mesh's triangles as `view_from_object` places them (in f64, then f32), and their boxes.
fn placed_triangles(mesh: &Mesh, view_from_object: &DMat4) -> (Vec<TraceTriangleGpu>, Vec<Aabb>) {
    let points: Vec<DVec3> = (mesh.positions.iter())
        .map(|&p| view_from_object.transform_point3(p))
        .collect();
    mesh.faces
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|k| points[k as usize]);
            let corner = |p: DVec3| p.as_vec3().to_array();
            let triangle = TraceTriangleGpu {
                a: corner(a),
                _pad0: 0,
                b: corner(b),
                _pad1: 0,
                c: corner(c),
                _pad2: 0,
            };
            (triangle, Aabb::of_points([a, b, c]))
        })
        .unzip()
}

/// The mesh's triangles and their hierarchy in local space, uploaded.
fn upload_traced(gpu: &Gpu, mesh: &Mesh) -> TracedMesh {
    let (lo, hi) = mesh.bounds();
    let (triangles, boxes) = placed_triangles(mesh, &DMat4::from_translation(-0.5 * (lo + hi)));
    let nodes = Bvh::build(&boxes).refit(&boxes);
    let device = &gpu.device;
    TracedMesh {
        nodes: storage_buffer(device, "triangle hierarchy", bytemuck::cast_slice(&nodes)),
        triangles: storage_buffer(device, "triangles", bytemuck::cast_slice(&triangles)),
        lo,
        hi,
    }
}

/// A sampled RGBA8 texture from `levels` (full size first, each row-major with row 0 at the top,
/// each `width >> k` by `height >> k` pixels, at least 1, as wgpu sizes mip levels).
fn image_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    levels: &[(usize, usize, &[[u8; 4]])],
) -> wgpu::TextureView {
    let (width, height) = (levels[0].0 as u32, levels[0].1 as u32);
    let texels: Vec<[u8; 4]> = levels.iter().flat_map(|l| l.2.iter().copied()).collect();
    device
        .create_texture_with_data(
            queue,
            &wgpu::TextureDescriptor {
                label: Some("mesh texture"),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: levels.len() as u32,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                // Unorm, not sRGB: texel values are averaged as stored, as conversion does.
                format: wgpu::TextureFormat::Rgba8Unorm,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            bytemuck::cast_slice(&texels),
        )
        .create_view(&Default::default())
}

/// The mesh's image as a sampled texture: from the first level of its mip chain the adapter can
/// hold, through the levels sized as wgpu sizes them. `Image` rounds odd sizes up where wgpu
/// rounds down, so an image whose sides are not powers of two keeps only its leading levels
/// (minified further, it is sampled from the smallest of them).
fn upload_image(gpu: &Gpu, image: &Image) -> wgpu::TextureView {
    let limit = gpu.device.limits().max_texture_dimension_2d as usize;
    let mut levels = image
        .levels()
        .skip_while(|(w, h, _)| *w > limit || *h > limit);
    let first = levels.next().expect("an image has a 1 x 1 level");
    let wgpu_size = |k: usize| ((first.0 >> k).max(1), (first.1 >> k).max(1));
    let following = (levels.enumerate()).take_while(|(k, (w, h, _))| wgpu_size(k + 1) == (*w, *h));
    let levels: Vec<_> = std::iter::once(first)
        .chain(following.map(|(_, l)| l))
        .collect();
    image_texture(&gpu.device, &gpu.queue, &levels)
}

/// De-indexed vertices, three per face, with their corners' normals under `rule`, base colors
/// (vertex or face colors; white where a texture gives the color) and texture coordinates.
fn upload(gpu: &Gpu, mesh: &Mesh, rule: NormalRule) -> UploadedMesh {
    let (lo, hi) = mesh.bounds();
    let centre = 0.5 * (lo + hi);
    let normals = MeshGeometry::new(mesh).corner_normals(mesh, rule);
    let texture = mesh.appearance.texture.as_ref();
    let mut vertices = Vec::with_capacity(mesh.faces.len() * 3);
    for (f, (t, n)) in mesh.faces.iter().zip(normals.faces()).enumerate() {
        let colors = mesh.face_color(f as u32, None);
        let uv = texture.map(|Texture { coords, .. }| match coords {
            TextureCoords::PerVertex(uv) => t.map(|v| uv[v as usize]),
            TextureCoords::PerCorner(uv) => uv[f],
        });
        for k in 0..3 {
            let corner = std::array::from_fn(|c| f64::from(u8::from(c == k)));
            vertices.push(MeshVertex {
                position: (mesh.positions[t[k] as usize] - centre)
                    .as_vec3()
                    .to_array(),
                normal: n[k].as_vec3().to_array(),
                color: if uv.is_some() {
                    [255; 4]
                } else {
                    colors.at(corner)
                },
                uv: uv.map_or([0.0; 2], |uv| uv[k].as_vec2().to_array()),
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

/// The same offset for meshes, as a fraction of the largest mesh's bounding-box diagonal: above
/// f32's rounding of the triangles in the query's frame (~1e-7 of their extent), far below any
/// detail a mesh shows.
const OFFSET_MESH_DIAGONAL: f64 = 1e-5;

impl Kind for MeshKind {
    type Payload = ShadedMesh;

    fn upload(
        &mut self,
        gpu: &Gpu,
        shaded: &Arc<ShadedMesh>,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<()> {
        let (mesh, rule) = (&shaded.mesh, &shaded.rule);
        let uploads = self.uploads.entry(mesh);
        if let (None, Some(texture)) = (&uploads.image, &mesh.appearance.texture) {
            uploads.image = Some(upload_image(gpu, &texture.image));
        }
        let uploads = &mut uploads.drawn;
        if !uploads.iter().any(|(r, _)| r == rule) {
            uploads.push((*rule, upload(gpu, mesh, *rule)));
        }
        let (_, u) = uploads.iter().find(|(r, _)| r == rule).expect("uploaded");
        depth.include_box(view_from_object, u.lo, u.hi);
        Ok(())
    }

    fn draw_call(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        shaded: &Arc<ShadedMesh>,
        tally: &mut Tally,
    ) -> Option<DrawCall> {
        let (mesh, rule) = (&shaded.mesh, &shaded.rule);
        let uploads = self.uploads.get(mesh)?;
        let (_, u) = uploads.drawn.iter().find(|(r, _)| r == rule)?;
        let image = uploads.image.as_ref().unwrap_or(&self.white);
        let view_from_object = frame.view_from_world * placed.world_from_object;
        let view_from_local = view_from_object * DMat4::from_translation(u.centre);
        let record = MeshObjectGpu {
            view_from_object: gpu_matrix(view_from_local),
            world_normal_from_object: normal_matrix(DMat3::from_mat4(placed.world_from_object)),
            ids: [tally.next_mesh_id(), 0, 0, 0],
        };
        let device = &gpu.device;
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("mesh object"),
            contents: bytemuck::bytes_of(&record),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("mesh object"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(image),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Sampler(&self.sampler),
                },
            ],
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
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        shaded: &Arc<ShadedMesh>,
        ids: &mut Tally,
    ) -> Result<Option<TraceCall>> {
        let Some(query) = self.query(gpu, view_from_world, placed, &shaded.mesh, ids) else {
            return Ok(None);
        };
        Ok(Some(TraceCall::within(
            self.trace_pipeline.clone(),
            self.hierarchy_group(gpu, &query),
            &[query.bounds],
        )))
    }

    /// Parallel rays pass the mesh's footprint along their direction first (footprint.rs): one
    /// whose line misses every triangle's projection is not traced. From the second query
    /// along a direction on, they walk the mesh's triangles tiled along it (kinds/tiles.rs,
    /// mesh_tiles_rays.wgsl); before, its hierarchy (`MeshAlong`).
    fn trace_parallel(
        &self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        shaded: &Arc<ShadedMesh>,
        ids: &mut Tally,
        direction: DVec3,
    ) -> Result<Option<TraceCall>> {
        let Some(query) = self.query(gpu, view_from_world, placed, &shaded.mesh, ids) else {
            return Ok(None);
        };
        // Lines along `direction` map to lines along its local image under the placement
        // (affine), so the footprint and tiles are built and looked up in local space.
        let local_from_query = query.local_from_query;
        let along = local_from_query.transform_vector3(direction).normalize();
        let (kept, seen) = {
            let mut kept = (query.uploads.along.lock()).unwrap_or_else(|e| e.into_inner());
            match &*kept {
                Some(a) if a.direction == along => (a.clone(), true),
                _ => (
                    kept.insert(Arc::new(MeshAlong::new(query.mesh, along)))
                        .clone(),
                    false,
                ),
            }
        };
        let tiled = if seen {
            kept.tiles(gpu, query.mesh)
        } else {
            None
        };
        let (pipeline, group) = match tiled {
            Some((tiles, ranges, entries)) => {
                let header = tiles.header_for(local_from_query);
                let device = &gpu.device;
                let header = storage_buffer(device, "mesh tiles", bytemuck::bytes_of(&header));
                let bound = [
                    (0, &query.settings),
                    (2, &query.traced.triangles),
                    (9, &header),
                    (10, ranges),
                    (11, entries),
                ];
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("mesh (tiled tracer)"),
                    layout: &self.tiles_trace_layout,
                    entries: &bound.map(|(binding, buffer)| wgpu::BindGroupEntry {
                        binding,
                        resource: buffer.as_entire_binding(),
                    }),
                });
                (self.tiles_trace_pipeline.clone(), group)
            }
            None => (
                self.trace_pipeline.clone(),
                self.hierarchy_group(gpu, &query),
            ),
        };
        let box_test = query.bounds;
        let reaches: RayTest = Box::new(move |ray| {
            box_test.meets_inverse(ray.origin, ray.inverse, ray.range)
                && (kept.footprint).covers(local_from_query.transform_point3(ray.origin))
        });
        Ok(Some(TraceCall {
            pipeline,
            group,
            reaches,
        }))
    }

    fn shadow_offset(&self, shaded: &ShadedMesh, scale: f64) -> f64 {
        mesh_offset(&shaded.mesh, scale)
    }

    fn purge(&mut self) {
        self.uploads.purge();
    }
}

/// A shadow ray's start offset off a mesh under a placement scaling by at most `scale`: see
/// `OFFSET_MESH_DIAGONAL`. Meshes shaded through an inverse geometric texture (kinds/igt.rs)
/// use it too.
pub(crate) fn mesh_offset(mesh: &Mesh, scale: f64) -> f64 {
    let (lo, hi) = mesh.bounds();
    extent_offset(lo, hi, scale)
}

/// `mesh_offset` of whatever spans the box `lo`..`hi`.
pub(crate) fn extent_offset(lo: DVec3, hi: DVec3, scale: f64) -> f64 {
    OFFSET_MESH_DIAGONAL * (hi - lo).length() * scale
}
