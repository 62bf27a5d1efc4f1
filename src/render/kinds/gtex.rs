//! Geometry-texture sets, ray cast in their patches' boxes (gtex_raycast.wgsl): one instance of
//! the unit cube per visible patch, the fragment shader searching the patch's height map.
//!
//! Spaces: the set's object space (placed by `world_from_object`), each patch's own
//! (`world_from_patch` of the set's space: the box is the unit cube, x/y are texture u/v, z is
//! height), view (camera-relative) and clip (the lens's, for culling).

use glam::{DMat3, DMat4, DVec3};
use wgpu::util::DeviceExt;

use super::{DrawCall, FrameView, Kind, Tally, UploadCache};
use crate::error::Result;
use crate::gtex::GeometryTextureSet;
use crate::render::atlas::Atlas;
use crate::render::cull::{in_frustum, lod_level, DepthRange};
use crate::render::device::Gpu;
use crate::render::gpu_types::{gpu_matrix, normal_matrix, PatchGpu};
use crate::render::pipelines::{storage_entry, texture_entry, RasterPipeline, VERTEX_AND_FRAGMENT};
use crate::render::scene::{Object, SceneObject};
use crate::render::shaders;

/// The unit cube as 12 triangles (gtex_raycast.wgsl's CUBE).
const CUBE_VERTICES: u32 = 36;

pub(crate) struct GtexKind {
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    pipeline: wgpu::RenderPipeline,
    /// The same shader with its fetch counter switched on.
    counting_pipeline: wgpu::RenderPipeline,
    atlases: UploadCache<GeometryTextureSet, Atlas>,
}

/// Group 1 of gtex_bindings.wgsl.
fn textures_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let fragment = wgpu::ShaderStages::FRAGMENT;
    let array = wgpu::TextureViewDimension::D2Array;
    let filterable = wgpu::TextureSampleType::Float { filterable: true };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("geometry textures"),
        entries: &[
            storage_entry(0, VERTEX_AND_FRAGMENT, true),
            texture_entry(1, fragment, wgpu::TextureSampleType::Uint, array),
            texture_entry(2, fragment, filterable, array),
            texture_entry(3, fragment, filterable, array),
            wgpu::BindGroupLayoutEntry {
                binding: 4,
                visibility: fragment,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
            storage_entry(5, fragment, true),
        ],
    })
}

impl GtexKind {
    pub fn new(device: &wgpu::Device, frame_layout: &wgpu::BindGroupLayout) -> GtexKind {
        let layout = textures_layout(device);
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
            atlases: UploadCache::default(),
        }
    }

    /// The records of the set's patches inside the view frustum; every patch takes an id.
    fn records(
        frame: &FrameView,
        placed: &SceneObject,
        set: &GeometryTextureSet,
        atlas: &Atlas,
        tally: &mut Tally,
    ) -> Vec<PatchGpu> {
        let lens = frame.lens;
        let view_from_object = frame.view_from_world * placed.world_from_object;
        let object_linear = DMat3::from_mat4(placed.world_from_object);
        let first_id = tally.patch_ids;
        let records: Vec<PatchGpu> = set
            .patches
            .iter()
            .zip(&atlas.places)
            .enumerate()
            .filter(|(_, (p, _))| {
                let clip_from_patch = lens.clip_from_view * view_from_object * p.world_from_patch();
                let visible = in_frustum(&clip_from_patch, !lens.orthographic);
                tally.patches_culled += usize::from(!visible);
                visible
            })
            .map(|(i, (p, &(layer, x, y)))| {
                let view_from_patch = view_from_object * p.world_from_patch();
                let axes = DMat3::from_cols(p.axes[0], p.axes[1], p.axes[2]);
                let [first_value, levels] = atlas.pyramid_at[i];
                let lod = if frame.search.lod {
                    lod_level(&view_from_patch, p, lens, levels)
                } else {
                    0
                };
                PatchGpu {
                    view_from_patch: gpu_matrix(view_from_patch),
                    patch_from_view: gpu_matrix(view_from_patch.inverse()),
                    world_normal_from_patch: normal_matrix(object_linear * axes),
                    atlas_origin: [x as f32, y as f32],
                    size: [p.width as f32, p.height as f32],
                    ids: [layer as i32, first_id + i as i32, 0, 0],
                    pyramid_at: [first_value, levels, p.code_max() as u32, lod],
                }
            })
            .collect();
        tally.patch_ids += set.patches.len() as i32;
        tally.patches_drawn += records.len();
        records
    }

    fn bind_group(
        &self,
        device: &wgpu::Device,
        atlas: &Atlas,
        records: &[PatchGpu],
    ) -> wgpu::BindGroup {
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("patch records"),
            contents: bytemuck::cast_slice(records),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let [heights, normals, colors] = &atlas.views;
        let texture = wgpu::BindingResource::TextureView;
        let resources = [
            buffer.as_entire_binding(),
            texture(heights),
            texture(normals),
            texture(colors),
            wgpu::BindingResource::Sampler(&self.sampler),
            atlas.pyramid.as_entire_binding(),
        ];
        let entries: Vec<_> = (0..)
            .zip(resources)
            .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("geometry textures"),
            layout: &self.layout,
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
        self.atlases.get_or_upload(set, |s| Atlas::upload(gpu, s))?;
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
        let atlas = self.atlases.get(set)?;
        let records = Self::records(frame, placed, set, atlas, tally);
        if records.is_empty() {
            return None;
        }
        let pipeline = if frame.search.count_fetches {
            &self.counting_pipeline
        } else {
            &self.pipeline
        };
        Some(DrawCall {
            pipeline: pipeline.clone(),
            group: self.bind_group(&gpu.device, atlas, &records),
            vertex_buffer: None,
            vertices: CUBE_VERTICES,
            instances: records.len() as u32,
        })
    }

    fn purge(&mut self) {
        self.atlases.purge();
    }
}
