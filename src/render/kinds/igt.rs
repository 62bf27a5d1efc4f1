//! Simplified meshes shaded through an inverse geometric texture (igt_raster.wgsl): rasterized
//! into the shared targets like meshes (two-sided), each fragment projected into its face's grid
//! of the primary space and shaded with the attributes of the detailed triangle found there
//! (igt_functions.wgsl, following src/igt_data/lookup.rs). Where the scene holds one, the surface pass
//! (igt_surface.wgsl) draws them again after the scene pass, depth-tested against the finished
//! depth buffer, writing the detailed face and barycentrics of the visible pixels
//! (`Frame::face_id`, `Frame::barycentric`). Not traced by ray queries: they receive shadows but
//! cast none.
//!
//! The texture's tables are uploaded once per texture (several simplified meshes may share it),
//! the simplified mesh once per mesh, both relative to the detailed mesh's bounding-box centre.
//!
//! Spaces: object space (the detailed and simplified meshes' own, placed by
//! `world_from_object`), stored relative to that centre ("local", f32); view (camera-relative);
//! primary space per grid in cell units (src/igt_data/primary.rs).

use std::sync::Arc;
use glam::{DMat3, DMat4, DVec3, Vec3};
use wgpu::util::DeviceExt;

use super::{bind_buffers, storage_buffer, DrawCall, FrameView, Kind, KindContext, Tally, TraceCall, UploadCache};
use crate::appearance::Image;
use crate::error::{GeomtexError, Result};
use crate::igt_data::{Entry, IgtMesh, InverseGeometricTexture, Lod, Lookup};
use crate::render::cull::DepthRange;
use crate::render::device::Gpu;
use crate::render::gpu_types::{
    gpu_matrix, normal_matrix, IgtEntryGpu, IgtGridGpu, IgtObjectGpu, IgtVertex, COLOR_FORMAT,
    DEPTH_FORMAT, NORMAL_FORMAT,
};
use crate::render::pipelines::{storage_entry, uniform_entry, RasterPipeline, VERTEX_AND_FRAGMENT};
use crate::render::scene::SceneObject;
use crate::render::shaders;

/// Format of the surface target: detailed face + 1 (0 = none) and the barycentrics' f32 bits.
pub(crate) const SURFACE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Uint;

/// Storage buffers of group 1 (bindings 1 to 7 of igt_bindings.wgsl). With the mesh's own,
/// eight: within the 8 a fragment stage may bind on any adapter (WebGPU's default limit), which
/// is why the attributes share one buffer (and the cells' heights follow their offsets in
/// one). The baked texture has its own: it grows with the cells (8 bytes each), as the cell
/// offsets and heights do (8), so the two stay the largest buffers and within lavapipe's
/// 128 MiB per binding up to about 4096² cells.
const TABLES: usize = 7;

/// A texture's tables and attributes on the GPU.
struct UploadedTables {
    /// Grids, cell offsets, cell entries, entries, the attributes (`Attributes` below), the
    /// detailed faces' corners (for the ray lookup) and the baked texture (the shader LoD's).
    buffers: [wgpu::Buffer; TABLES],
    /// Attribute bits and image size (`IgtObject.info` y, z, w).
    info: [u32; 3],
    /// Where each part starts in the attribute buffer (`IgtObject.segments`).
    segments: [u32; 4],
    /// Where the cells' heights start in the cell buffer (`IgtObject.lod.w`).
    heights_at: u32,
    /// The detailed mesh's bounding-box centre: everything is stored relative to it.
    centre: DVec3,
}

/// A simplified mesh's de-indexed vertices, three per face, each with its face's grid, and the
/// grids its faces' ray lookups walk (binding 10).
struct UploadedMesh {
    vertices: wgpu::Buffer,
    search_grids: wgpu::Buffer,
    count: u32,
    lo: DVec3,
    hi: DVec3,
}

pub(crate) struct IgtKind {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    surface_pipeline: wgpu::RenderPipeline,
    tables: UploadCache<InverseGeometricTexture, UploadedTables>,
    meshes: UploadCache<IgtMesh, UploadedMesh>,
}

/// A unit normal's octahedral encoding as two snorm16 (x in the low half, as WGSL's
/// unpack2x16snorm reads it).
fn octahedral(n: Vec3) -> u32 {
    let n = n / (n.x.abs() + n.y.abs() + n.z.abs()).max(f32::MIN_POSITIVE);
    let (x, y) = if n.z >= 0.0 {
        (n.x, n.y)
    } else {
        let sign = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
        ((1.0 - n.y.abs()) * sign(n.x), (1.0 - n.x.abs()) * sign(n.y))
    };
    let snorm = |v: f32| ((v.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16 as u32;
    snorm(x) | (snorm(y) << 16)
}

fn pack_rgba(c: [u8; 4]) -> u32 {
    u32::from_le_bytes(c)
}

/// A baked cell with nothing listed near it: a normal code the encoder never writes (it
/// rounds to ±32767 at most), so the shader can tell it from every normal.
const EMPTY_CELL: u32 = 0x8000_8000;

/// The attribute buffer: corner normals (always first), corner colors, texture coordinates
/// (f32 bits), image pixels and corner occlusion (three unorm8 per face), each part where
/// `segments` says: colors, uvs, image, occlusion (an absent part is empty).
struct Attributes {
    words: Vec<u32>,
    segments: [u32; 4],
}

/// The baked texture (igt_data/bake.rs) as the shader reads it: per cell its normal's code and color.
fn pack_baked(igt: &InverseGeometricTexture) -> Vec<[u32; 2]> {
    (igt.bake().into_iter())
        .map(|b| match b {
            Some(b) => [octahedral(b.normal), pack_rgba(b.color)],
            None => [EMPTY_CELL, 0],
        })
        .collect()
}

fn pack_attributes(igt: &InverseGeometricTexture, image: Option<&Image>) -> Attributes {
    let a = &igt.attributes;
    let mut words: Vec<u32> = (a.normals.iter().flatten())
        .map(|n| octahedral(Vec3::from_array(*n)))
        .collect();
    let mut segments = [0u32; 4];
    let mut part = |k: usize, words: &mut Vec<u32>, part: &mut dyn Iterator<Item = u32>| {
        segments[k] = words.len() as u32;
        words.extend(part);
    };
    part(
        0,
        &mut words,
        &mut a.colors.iter().flatten().flatten().map(|c| pack_rgba(*c)),
    );
    let uvs = a.uv.iter().flatten().flatten().flatten();
    part(1, &mut words, &mut uvs.map(|x| x.to_bits()));
    let pixels = image.map(|i| i.pixels().iter().map(|p| pack_rgba(*p)));
    part(2, &mut words, &mut pixels.into_iter().flatten());
    let ao =
        a.ao.iter()
            .flatten()
            .map(|c| pack_rgba([c[0], c[1], c[2], 0]));
    part(3, &mut words, &mut ao.into_iter());
    Attributes { words, segments }
}

/// Per grid, the heights (along its z, from its origin) its listed faces span, widened by a
/// little slack and rounded outward to f32: the ray lookup's slab (`IgtGrid.z.w`, `size.w`).
pub(crate) fn grid_slabs(igt: &InverseGeometricTexture) -> Vec<(f32, f32)> {
    let mut heights = vec![(f64::INFINITY, f64::NEG_INFINITY); igt.grids.len()];
    for e in &igt.entries {
        let h = &mut heights[e.grid as usize];
        let (lo, hi) = face_heights(igt, e);
        *h = (h.0.min(lo), h.1.max(hi));
    }
    (igt.grids.iter().zip(heights))
        .map(|(g, (lo, hi))| {
            let slack = 1e-4 * (hi - lo).abs().max(g.cell.max_element());
            ((lo - slack) as f32, (hi + slack) as f32)
        })
        .collect()
}

/// The heights (along its grid's z, from the grid's origin) entry `e`'s face spans.
pub(crate) fn face_heights(igt: &InverseGeometricTexture, e: &Entry) -> (f64, f64) {
    let g = &igt.grids[e.grid as usize];
    (igt.faces[e.face as usize].iter()).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
        let z = (igt.positions[v as usize] - g.origin).dot(g.axes[2]);
        (lo.min(z), hi.max(z))
    })
}

/// Per cell, the heights its listed faces span as two unorm16 of its grid's slab (`slabs`;
/// low half the lowest, rounded down, high half the highest, rounded up; an empty cell
/// 0x0000ffff): the ray lookup skips the triangle tests of a cell whose heights the ray's
/// stretch over it misses (igt_ray_walk). At 512² on the 1.1 M-face bunny a cell lists 14
/// triangles on average, and most cells a slanted view ray crosses lie well above or below
/// the surface there.
pub(crate) fn cell_heights(igt: &InverseGeometricTexture, slabs: &[(f32, f32)]) -> Vec<u32> {
    let mut words = vec![0x0000_ffffu32; igt.cell_start.len().saturating_sub(1)];
    for (grid, &(lo, hi)) in igt.grids.iter().zip(slabs) {
        let span = f64::from(hi - lo).max(f64::MIN_POSITIVE);
        let unit = |h: f64| ((h - f64::from(lo)) / span * 65535.0).clamp(0.0, 65535.0);
        for c in grid.first_cell..grid.first_cell + grid.cells() {
            let listed = igt.cell_start[c as usize]..igt.cell_start[c as usize + 1];
            let (a, b) = (igt.cell_entries[listed.start as usize..listed.end as usize].iter())
                .map(|&k| face_heights(igt, &igt.entries[k as usize]))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (l, h)| {
                    (a.min(l), b.max(h))
                });
            if a <= b {
                words[c as usize] = unit(a).floor() as u32 | ((unit(b).ceil() as u32) << 16);
            }
        }
    }
    words
}

/// The grids as the shader takes them, relative to `centre`, with their slabs (`grid_slabs`).
fn grid_records(
    igt: &InverseGeometricTexture,
    centre: DVec3,
    slabs: &[(f32, f32)],
) -> Vec<IgtGridGpu> {
    let per = |cell: f64| if cell > 0.0 { (1.0 / cell) as f32 } else { 0.0 };
    (igt.grids.iter().zip(slabs))
        .map(|(g, &(lo, hi))| {
            let o = (g.origin - centre).as_vec3();
            let [x, _, z] = g.axes.map(|a| a.as_vec3());
            IgtGridGpu {
                origin: [o.x, o.y, o.z, per(g.cell.x)],
                x: [x.x, x.y, x.z, per(g.cell.y)],
                z: [z.x, z.y, z.z, lo],
                size: [g.width, g.height, g.first_cell, hi.to_bits()],
            }
        })
        .collect()
}

fn upload_tables(gpu: &Gpu, igt: &InverseGeometricTexture) -> Result<UploadedTables> {
    // The shader derives y as z × x.
    if let Some(g) =
        (igt.grids.iter()).find(|g| (g.axes[2].cross(g.axes[0]) - g.axes[1]).length() > 1e-6)
    {
        return Err(GeomtexError::Parameter(format!(
            "grid at {:?}: its axes are not right-handed",
            g.origin
        )));
    }
    let (lo, hi) = bounds(&igt.positions);
    let centre = 0.5 * (lo + hi);
    let entries: Vec<IgtEntryGpu> = (igt.entries.iter())
        .map(|e| IgtEntryGpu {
            corners: e.corners,
            face: e.face,
            grid: e.grid,
        })
        .collect();
    let a = &igt.attributes;
    let image = a.uv.as_ref().and(a.image.as_deref());
    let packed = pack_attributes(igt, image);
    let corners: Vec<[f32; 3]> = (igt.faces.iter().flatten())
        .map(|&v| (igt.positions[v as usize] - centre).as_vec3().to_array())
        .collect();
    let bits = u32::from(a.colors.is_some())
        | (u32::from(image.is_some()) << 1)
        | (u32::from(a.ao.is_some()) << 2);
    let (w, h) = image.map_or((0, 0), |i| (i.width() as u32, i.height() as u32));
    let slabs = grid_slabs(igt);
    // The cell offsets, then the cells' heights (from `IgtObject.lod.w` on).
    let cells = [igt.cell_start.as_slice(), &cell_heights(igt, &slabs)].concat();
    let device = &gpu.device;
    // Bindings need a buffer: absent parts take one zero.
    let buffer = |label: &str, bytes: &[u8]| {
        let zero = [0u8; 8];
        storage_buffer(device, label, if bytes.is_empty() { &zero } else { bytes })
    };
    Ok(UploadedTables {
        buffers: [
            buffer(
                "igt grids",
                bytemuck::cast_slice(&grid_records(igt, centre, &slabs)),
            ),
            buffer("igt cells", bytemuck::cast_slice(&cells)),
            buffer("igt cell entries", bytemuck::cast_slice(&igt.cell_entries)),
            buffer("igt entries", bytemuck::cast_slice(&entries)),
            buffer("igt attributes", bytemuck::cast_slice(&packed.words)),
            buffer("igt face corners", bytemuck::cast_slice(&corners)),
            buffer("igt baked", bytemuck::cast_slice(&pack_baked(igt))),
        ],
        info: [bits, w, h],
        segments: packed.segments,
        heights_at: igt.cell_start.len() as u32,
        centre,
    })
}

fn bounds(points: &[DVec3]) -> (DVec3, DVec3) {
    points
        .iter()
        .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        })
}

fn upload_mesh(gpu: &Gpu, shaded: &IgtMesh, centre: DVec3) -> UploadedMesh {
    let mesh = &shaded.mesh;
    let mut first = 0u32;
    let search: Vec<[u32; 2]> = (shaded.face_search_grids.iter())
        .map(|list| {
            first += list.len() as u32;
            [first - list.len() as u32, list.len() as u32]
        })
        .collect();
    let faces = mesh.faces.iter().zip(&shaded.face_grid);
    let vertices: Vec<IgtVertex> = (faces.zip(shaded.face_window.iter().zip(search)))
        .flat_map(|((t, &grid), (&window, search))| {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
            let normal = (b - a)
                .cross(c - a)
                .normalize_or_zero()
                .as_vec3()
                .to_array();
            t.map(|v| IgtVertex {
                position: (mesh.positions[v as usize] - centre).as_vec3().to_array(),
                grid,
                window,
                search,
                normal,
            })
        })
        .collect();
    let grids: Vec<u32> = shaded.face_search_grids.concat();
    let search_grids = storage_buffer(
        &gpu.device,
        "igt search grids",
        bytemuck::cast_slice(if grids.is_empty() { &[0u32] } else { &grids }),
    );
    let (lo, hi) = mesh.bounds();
    let buffer = gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("igt mesh vertices"),
            contents: bytemuck::cast_slice(&vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
    UploadedMesh {
        vertices: buffer,
        search_grids,
        count: vertices.len() as u32,
        lo,
        hi,
    }
}

impl IgtKind {
    pub fn new(context: &KindContext) -> IgtKind {
        let (device, frame_layout) = (&context.gpu.device, context.frame_layout);
        let fragment = wgpu::ShaderStages::FRAGMENT;
        // Group 1 of igt_bindings.wgsl.
        let mut entries = vec![uniform_entry(0, VERTEX_AND_FRAGMENT)];
        // Bindings 1 to TABLES: the texture's; the last: the mesh's search grids.
        entries.extend((1..=TABLES as u32 + 1).map(|b| storage_entry(b, fragment, true)));
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("igt object"),
            entries: &entries,
        });
        let pipeline = RasterPipeline {
            label: "igt_raster",
            source: shaders::igt_raster(false),
            layouts: &[Some(frame_layout), Some(&layout)],
            vertex_buffers: &[Some(vertex_layout())],
            // Two-sided, as a ray caster sees a mesh.
            cull: None,
            constants: &[],
        }
        .build(device);
        let surface_pipeline = surface_pipeline(device, &[Some(frame_layout), Some(&layout)]);
        IgtKind {
            layout,
            pipeline,
            surface_pipeline,
            tables: UploadCache::default(),
            meshes: UploadCache::default(),
        }
    }

    /// Group 1 for `placed` (an uploaded IgtMesh), its mesh upload, or None.
    fn bind(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        shaded: &Arc<IgtMesh>,
        id: i32,
    ) -> Option<(wgpu::BindGroup, &UploadedMesh)> {
        let tables = self.tables.get(&shaded.igt)?;
        let mesh = self.meshes.get(shaded)?;
        let view_from_local = frame.view_from_world
            * placed.world_from_object
            * DMat4::from_translation(tables.centre);
        // The ray lookup's code (ids.y): 1 along the view ray, 0 projecting; ids.z: samples.
        let ray = u32::from(shaded.lookup == Lookup::Ray) as i32;
        let [bits, w, h] = tables.info;
        let [colors, uvs, image, ao] = tables.segments;
        // lod.y: 0 off, 1 where a cell covers less than a pixel, 2 beyond distance lod.z.
        let (mode, distance) = match shaded.lod {
            Lod::Off => (0, 0.0),
            Lod::Auto => (1, 0.0),
            Lod::Distance(d) => (2, d),
        };
        let record = IgtObjectGpu {
            view_from_object: gpu_matrix(view_from_local),
            world_normal_from_object: normal_matrix(DMat3::from_mat4(placed.world_from_object)),
            ids: [id, ray, shaded.samples as i32, 0],
            info: [shaded.igt.primary.code(), bits, w, h],
            object_from_view: gpu_matrix(view_from_local.inverse()),
            segments: [colors, uvs, image, ao],
            lod: [0, mode, distance.to_bits(), tables.heights_at],
        };
        let device = &gpu.device;
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("igt object"),
            contents: bytemuck::bytes_of(&record),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let buffers: Vec<_> = (std::iter::once(&uniform).chain(&tables.buffers))
            .chain(std::iter::once(&mesh.search_grids))
            .collect();
        let group = bind_buffers(device, "igt object", &self.layout, &buffers);
        Some((group, mesh))
    }
}

fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    const ATTRIBUTES: [wgpu::VertexAttribute; 5] = wgpu::vertex_attr_array![
        0 => Float32x3, 1 => Uint32, 2 => Float32x2, 3 => Uint32x2, 4 => Float32x3
    ];
    wgpu::VertexBufferLayout {
        array_stride: size_of::<IgtVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &ATTRIBUTES,
    }
}

/// The surface pass's pipeline: the scene pass's vertex stage, depth tested (not written)
/// against the finished depth buffer, one target (`SURFACE_FORMAT`).
fn surface_pipeline(
    device: &wgpu::Device,
    layouts: &[Option<&wgpu::BindGroupLayout>],
) -> wgpu::RenderPipeline {
    let source = shaders::igt_raster(true);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("igt_surface"),
        source: wgpu::ShaderSource::Wgsl(source.as_str().into()),
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("igt_surface"),
        bind_group_layouts: layouts,
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("igt_surface"),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[Some(vertex_layout())],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            front_face: wgpu::FrontFace::Ccw,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(false),
            // The finished buffer holds the nearest depth: the visible fragment meets it
            // (reversed Z; >= keeps it should the two draws round differently upward).
            depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_surface"),
            compilation_options: Default::default(),
            targets: &[SURFACE_FORMAT, COLOR_FORMAT, NORMAL_FORMAT, COLOR_FORMAT].map(|format| {
                Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })
            }),
        }),
        multiview_mask: None,
        cache: None,
    })
}

impl Kind for IgtKind {
    type Payload = IgtMesh;

    fn upload(
        &mut self,
        gpu: &Gpu,
        shaded: &Arc<IgtMesh>,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<()> {
        if shaded.mesh.faces.is_empty() {
            return Ok(());
        }
        let centre = (self.tables)
            .get_or_upload(&shaded.igt, |igt| upload_tables(gpu, igt))?
            .centre;
        let m = self
            .meshes
            .get_or_upload(shaded, |s| Ok(upload_mesh(gpu, s, centre)))?;
        depth.include_box(view_from_object, m.lo, m.hi);
        Ok(())
    }

    fn draw_call(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        shaded: &Arc<IgtMesh>,
        tally: &mut Tally,
    ) -> Option<DrawCall> {
        // Numbered as meshes are, whether drawn or not (the surface pass does not count).
        let id = tally.next_mesh_id();
        let (group, mesh) = self.bind(gpu, frame, placed, shaded, id)?;
        Some(DrawCall {
            pipeline: self.pipeline.clone(),
            group,
            vertex_buffer: Some(mesh.vertices.clone()),
            vertices: mesh.count,
            instances: 1,
            compute: None,
        })
    }

    fn draw_surface(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        shaded: &Arc<IgtMesh>,
    ) -> Option<DrawCall> {
        let (group, mesh) = self.bind(gpu, frame, placed, shaded, 0)?;
        Some(DrawCall {
            pipeline: self.surface_pipeline.clone(),
            group,
            vertex_buffer: Some(mesh.vertices.clone()),
            vertices: mesh.count,
            instances: 1,
            compute: None,
        })
    }

    fn trace(
        &self,
        _gpu: &Gpu,
        _view_from_world: DMat4,
        _placed: &SceneObject,
        _shaded: &Arc<IgtMesh>,
        _ids: &mut Tally,
    ) -> Result<Option<TraceCall>> {
        Err(GeomtexError::Parameter(
            "ray queries through an IgtMesh are not supported; query its detailed mesh".into(),
        ))
    }

    /// Shaded simplified meshes receive shadows as meshes do but do not cast them (the tracer
    /// does not trace them).
    fn casts_shadows(&self) -> bool {
        false
    }

    fn shadow_offset(&self, shaded: &IgtMesh, scale: f64) -> f64 {
        super::mesh::mesh_offset(&shaded.mesh, scale)
    }

    fn purge(&mut self) {
        self.meshes.purge();
        self.tables.purge();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The encoding decoded as igt_octahedral does (WGSL) comes back within snorm16 rounding.
    #[test]
    fn octahedral_normals_round_trip() {
        let decode = |bits: u32| {
            let v = |h: u32| ((h & 0xffff) as u16 as i16) as f32 / 32767.0;
            let (x, y) = (v(bits).max(-1.0), v(bits >> 16).max(-1.0));
            let mut n = Vec3::new(x, y, 1.0 - x.abs() - y.abs());
            let t = (-n.z).max(0.0);
            n.x += if n.x >= 0.0 { -t } else { t };
            n.y += if n.y >= 0.0 { -t } else { t };
            n.normalize()
        };
        let mut worst: f32 = 0.0;
        for k in 0..2000 {
            let (a, b) = (k as f32 * 0.61803, k as f32 * 0.0137);
            let n = Vec3::new(a.cos() * b.sin(), a.sin() * b.sin(), b.cos()).normalize();
            // |n x m| is the sine of the angle: f32 acos near 1 cannot resolve 1e-4 rad.
            worst = worst.max(n.cross(decode(octahedral(n))).length());
        }
        // Measured 5.8e-5 rad (snorm16 steps are 3e-5 of the octahedron's unit square).
        assert!(worst < 2e-4, "{worst}");
    }
}
