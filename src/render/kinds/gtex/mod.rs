//! Geometry-texture sets. Frames ray cast them per pixel in their patches' boxes
//! (gtex_raycast.wgsl: one instance of the unit cube per visible patch, the fragment shader
//! searching the patch's height map). Ray queries trace them (gtex_trace_rays.wgsl): a hierarchy
//! (bvh.rs) over thin pieces of the patches' boxes (boxes.rs), both made on the first query of a
//! set, is walked front to back, and a piece a ray enters before its nearest hit so far gets a
//! search of its patch's height map over the stretch inside it.
//!
//! Spaces: the set's object space (placed by `world_from_object`; the hierarchy's shape is built
//! there), each patch's own (`world_from_patch` of the set's space: the box is the unit cube, x/y
//! are texture u/v, z is height), view (camera-relative: the patch records and the refitted
//! bounds; for queries, world space translated near the rays) and clip (the lens's, for culling).

mod boxes;

use std::sync::OnceLock;

use bytemuck::Zeroable;
use glam::{DMat3, DMat4, DVec3};

use super::{storage_buffer, DrawCall, FrameView, Kind, Tally, TraceCall, UploadCache};
use crate::error::Result;
use crate::gtex::GeometryTextureSet;
use crate::heightfield::min_max_pyramid;
use crate::render::atlas::Atlas;
use crate::render::bvh::{Aabb, Bvh};
use crate::render::cull::{in_frustum, lod_level, DepthRange};
use crate::render::device::Gpu;
use crate::render::gpu_types::{gpu_matrix, normal_matrix, PatchGpu};
use crate::render::pipelines::{
    compute_pipeline, storage_entry, texture_entry, RasterPipeline, VERTEX_AND_FRAGMENT,
};
use crate::render::scene::{Object, SceneObject};
use crate::render::shaders;

use boxes::{patch_boxes, placed as placed_box, PatchBoxGpu};

/// The unit cube as 12 triangles (gtex_raycast.wgsl's CUBE), one instance per drawn patch.
const CUBE_VERTICES: u32 = 36;

/// A set on the GPU: its maps and pyramids, and what ray queries walk (made on the first
/// query, so sets that are only drawn never pay for it).
pub(crate) struct GtexUpload {
    atlas: Atlas,
    tracing: OnceLock<Tracing>,
}

/// The pieces of a set's boxes (here and on the GPU) and the shape of the hierarchy over them.
struct Tracing {
    pieces: Vec<PatchBoxGpu>,
    pieces_buffer: wgpu::Buffer,
    bvh: Bvh,
}

impl GtexUpload {
    fn new(gpu: &Gpu, set: &GeometryTextureSet) -> Result<GtexUpload> {
        Ok(GtexUpload {
            atlas: Atlas::upload(gpu, set)?,
            tracing: OnceLock::new(),
        })
    }

    fn tracing(&self, gpu: &Gpu, set: &GeometryTextureSet) -> &Tracing {
        self.tracing.get_or_init(|| Tracing::new(gpu, set))
    }
}

impl Tracing {
    fn new(gpu: &Gpu, set: &GeometryTextureSet) -> Tracing {
        let pieces: Vec<PatchBoxGpu> = (0..)
            .zip(&set.patches)
            .flat_map(|(i, p)| patch_boxes(i, p, &min_max_pyramid(p)))
            .collect();
        let bounds: Vec<Aabb> = pieces
            .iter()
            .map(|b| placed_box(b, &set.patches[b.patch_index as usize].world_from_patch()))
            .collect();
        // A set with no surface at all still binds one (empty) piece; it is never traced.
        let contents: &[PatchBoxGpu] = if pieces.is_empty() {
            &[PatchBoxGpu::zeroed()]
        } else {
            &pieces
        };
        let pieces_buffer = storage_buffer(
            &gpu.device,
            "patch box pieces",
            bytemuck::cast_slice(contents),
        );
        Tracing {
            bvh: Bvh::build(&bounds),
            pieces,
            pieces_buffer,
        }
    }
}

pub(crate) struct GtexKind {
    /// Group 1 of the raster pass (gtex_bindings.wgsl).
    layout: wgpu::BindGroupLayout,
    /// Group 1 of ray queries (gtex_bindings.wgsl + gtex_trace_bindings.wgsl).
    trace_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    pipeline: wgpu::RenderPipeline,
    /// The same shader with its fetch counter switched on.
    counting_pipeline: wgpu::RenderPipeline,
    trace_pipeline: wgpu::ComputePipeline,
    uploads: UploadCache<GeometryTextureSet, GtexUpload>,
}

/// Group 1 of gtex_bindings.wgsl, seen by `stages` (the patch records also by the vertex stage
/// when it is among them), followed by `extra` entries.
fn textures_layout(
    device: &wgpu::Device,
    label: &str,
    stages: wgpu::ShaderStages,
    extra: &[wgpu::BindGroupLayoutEntry],
) -> wgpu::BindGroupLayout {
    let array = wgpu::TextureViewDimension::D2Array;
    let filterable = wgpu::TextureSampleType::Float { filterable: true };
    let reads = stages.difference(wgpu::ShaderStages::VERTEX);
    let mut entries = vec![
        storage_entry(0, stages, true),
        texture_entry(1, reads, wgpu::TextureSampleType::Uint, array),
        texture_entry(2, reads, wgpu::TextureSampleType::Sint, array),
        texture_entry(3, reads, filterable, array),
        wgpu::BindGroupLayoutEntry {
            binding: 4,
            visibility: reads,
            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
            count: None,
        },
        texture_entry(
            5,
            reads,
            wgpu::TextureSampleType::Uint,
            wgpu::TextureViewDimension::D2,
        ),
        texture_entry(8, reads, filterable, array),
    ];
    entries.extend_from_slice(extra);
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    })
}

/// Where a set's patches are drawn or traced: its placement and, for a frame, the lens (for
/// culling and level of detail).
struct Placing<'a> {
    view_from_object: DMat4,
    world_from_object: DMat4,
    lens: Option<&'a crate::render::camera::Lens>,
    lod: bool,
    first_id: i32,
}

impl GtexKind {
    pub fn new(
        device: &wgpu::Device,
        frame_layout: &wgpu::BindGroupLayout,
        query_layout: &wgpu::BindGroupLayout,
    ) -> GtexKind {
        let layout = textures_layout(device, "geometry textures", VERTEX_AND_FRAGMENT, &[]);
        let compute = wgpu::ShaderStages::COMPUTE;
        let trace_layout = textures_layout(
            device,
            "geometry textures (tracer)",
            compute,
            &[
                storage_entry(6, compute, true),
                storage_entry(7, compute, true),
            ],
        );
        let trace_pipeline = compute_pipeline(
            device,
            "gtex_trace_rays",
            &shaders::gtex_trace_rays(),
            &[Some(frame_layout), Some(&trace_layout), Some(query_layout)],
            &[],
        );
        let pipeline = |label, constants| {
            RasterPipeline {
                label,
                source: shaders::gtex_raycast(),
                layouts: &[Some(frame_layout), Some(&layout)],
                vertex_buffers: &[],
                // Back faces of each box: a camera inside a box still gets its fragments.
                cull: Some(wgpu::Face::Front),
                constants,
            }
            .build(device)
        };
        let counting = [("COUNT_FETCHES", 1.0)];
        GtexKind {
            pipeline: pipeline("gtex_raycast", &[]),
            counting_pipeline: pipeline("gtex_raycast (counting fetches)", &counting),
            sampler: device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("linear clamp"),
                address_mode_u: wgpu::AddressMode::ClampToEdge,
                address_mode_v: wgpu::AddressMode::ClampToEdge,
                address_mode_w: wgpu::AddressMode::ClampToEdge,
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                mipmap_filter: wgpu::MipmapFilterMode::Nearest,
                ..Default::default()
            }),
            layout,
            trace_layout,
            trace_pipeline,
            uploads: UploadCache::default(),
        }
    }

    /// The records of every patch of the set (each takes an id), and each one's view_from_patch
    /// unless a lens is given and its box lies wholly outside the view frustum (culled).
    fn records(
        placing: &Placing,
        set: &GeometryTextureSet,
        atlas: &Atlas,
    ) -> (Vec<PatchGpu>, Vec<Option<DMat4>>) {
        let object_linear = DMat3::from_mat4(placing.world_from_object);
        set.patches
            .iter()
            .zip(&atlas.places)
            .enumerate()
            .map(|(i, (p, &(layer, x, y)))| {
                let view_from_patch = placing.view_from_object * p.world_from_patch();
                let visible = placing.lens.is_none_or(|lens| {
                    in_frustum(&(lens.clip_from_view * view_from_patch), !lens.orthographic)
                });
                let axes = DMat3::from_cols(p.axes[0], p.axes[1], p.axes[2]);
                let [first_value, levels] = atlas.pyramid_at[i];
                let lod = match placing.lens {
                    Some(lens) if placing.lod => lod_level(&view_from_patch, p, lens, levels),
                    _ => 0,
                };
                let record = PatchGpu {
                    view_from_patch: gpu_matrix(view_from_patch),
                    patch_from_view: gpu_matrix(view_from_patch.inverse()),
                    world_normal_from_patch: normal_matrix(object_linear * axes),
                    atlas_origin: [x as f32, y as f32],
                    size: [p.width as f32, p.height as f32],
                    ids: [
                        layer as i32,
                        placing.first_id + i as i32,
                        p.has_colors() as i32,
                        0,
                    ],
                    pyramid_at: [first_value, levels, p.code_max() as u32, lod],
                };
                (record, visible.then_some(view_from_patch))
            })
            .unzip()
    }

    /// Group 1 under `layout`: the set's records and maps, then `extra` (binding, resource).
    fn bind_group(
        &self,
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        upload: &GtexUpload,
        records: &[PatchGpu],
        extra: Vec<(u32, wgpu::BindingResource)>,
    ) -> wgpu::BindGroup {
        let atlas = &upload.atlas;
        let records = storage_buffer(device, "patch records", bytemuck::cast_slice(records));
        let [heights, normals, colors, outlines] = &atlas.views;
        let texture = wgpu::BindingResource::TextureView;
        let resources = [
            (0, records.as_entire_binding()),
            (1, texture(heights)),
            (2, texture(normals)),
            (3, texture(colors)),
            (4, wgpu::BindingResource::Sampler(&self.sampler)),
            (5, texture(&atlas.pyramid)),
            (8, texture(outlines)),
        ];
        let entries: Vec<_> = resources
            .into_iter()
            .chain(extra)
            .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("geometry textures"),
            layout,
            entries: &entries,
        })
    }
}

impl Kind for GtexKind {
    fn upload(
        &mut self,
        gpu: &Gpu,
        object: &Object,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<bool> {
        let Object::Textures(set) = object else {
            return Ok(false);
        };
        self.uploads
            .get_or_upload(set, |s| GtexUpload::new(gpu, s))?;
        for p in &set.patches {
            let view_from_patch = *view_from_object * p.world_from_patch();
            depth.include_box(&view_from_patch, DVec3::ZERO, DVec3::ONE);
        }
        Ok(true)
    }

    fn draw(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        tally: &mut Tally,
    ) -> Option<DrawCall> {
        let Object::Textures(set) = &placed.object else {
            return None;
        };
        let upload = self.uploads.get(set)?;
        let placing = Placing {
            view_from_object: frame.view_from_world * placed.world_from_object,
            world_from_object: placed.world_from_object,
            lens: Some(frame.lens),
            lod: frame.search.lod,
            first_id: tally.patch_ids,
        };
        let (records, placements) = Self::records(&placing, set, &upload.atlas);
        tally.patch_ids += set.patches.len() as i32;
        tally.texture_bytes += upload.atlas.bytes;
        let drawn: Vec<PatchGpu> = records
            .into_iter()
            .zip(&placements)
            .filter_map(|(record, placement)| placement.map(|_| record))
            .collect();
        tally.patches_drawn += drawn.len();
        tally.patches_culled += set.patches.len() - drawn.len();
        if drawn.is_empty() {
            return None;
        }
        let pipeline = if frame.search.count_fetches {
            &self.counting_pipeline
        } else {
            &self.pipeline
        };
        Some(DrawCall {
            pipeline: pipeline.clone(),
            group: self.bind_group(&gpu.device, &self.layout, upload, &drawn, vec![]),
            vertex_buffer: None,
            vertices: CUBE_VERTICES,
            instances: drawn.len() as u32,
            compute: None,
        })
    }

    fn trace(
        &self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        ids: &mut Tally,
    ) -> Result<Option<TraceCall>> {
        let Object::Textures(set) = &placed.object else {
            return Ok(None);
        };
        let Some(upload) = self.uploads.get(set) else {
            return Ok(None);
        };
        let placing = Placing {
            view_from_object: view_from_world * placed.world_from_object,
            world_from_object: placed.world_from_object,
            lens: None,
            lod: false,
            first_id: ids.patch_ids,
        };
        ids.patch_ids += set.patches.len() as i32;
        let tracing = upload.tracing(gpu, set);
        if tracing.pieces.is_empty() {
            return Ok(None);
        }
        // No lens: every patch is placed (none culled).
        let (records, placements) = Self::records(&placing, set, &upload.atlas);
        let view_from_patch: Vec<DMat4> = placements.into_iter().flatten().collect();
        let bounds: Vec<Aabb> = (tracing.pieces.iter())
            .map(|b| placed_box(b, &view_from_patch[b.patch_index as usize]))
            .collect();
        let nodes = tracing.bvh.refit(&bounds);
        let device = &gpu.device;
        let nodes = storage_buffer(device, "piece hierarchy", bytemuck::cast_slice(&nodes));
        let extra = vec![
            (6, nodes.as_entire_binding()),
            (7, tracing.pieces_buffer.as_entire_binding()),
        ];
        Ok(Some(TraceCall {
            pipeline: self.trace_pipeline.clone(),
            group: self.bind_group(device, &self.trace_layout, upload, &records, extra),
        }))
    }

    fn purge(&mut self) {
        self.uploads.purge();
    }
}
