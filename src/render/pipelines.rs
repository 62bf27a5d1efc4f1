//! Pipeline and layout building shared by every pass: bind group layout entries, the raster
//! pipeline every kind draws with (same targets, reversed-Z depth) and compute pipelines (ray
//! queries and the depth copy). Each kind builds its own group-1 layout and pipelines from these
//! (see `kinds/`).
//!
//! Spaces: none of their own; see the shaders each pipeline runs.

use super::gpu_types::{COLOR_FORMAT, DEPTH_FORMAT, ID_FORMAT, NORMAL_FORMAT};
use super::shaders;

/// The stages that see the per-frame and per-object records of a raster pass.
pub(crate) const VERTEX_AND_FRAGMENT: wgpu::ShaderStages =
    wgpu::ShaderStages::VERTEX.union(wgpu::ShaderStages::FRAGMENT);

/// Every stage that reads the frame's group 0: the raster passes and the ray queries (which use
/// its search settings).
pub(crate) const FRAME_STAGES: wgpu::ShaderStages =
    VERTEX_AND_FRAGMENT.union(wgpu::ShaderStages::COMPUTE);

pub(crate) fn uniform_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(binding, visibility, wgpu::BufferBindingType::Uniform)
}

pub(crate) fn storage_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    read_only: bool,
) -> wgpu::BindGroupLayoutEntry {
    let ty = wgpu::BufferBindingType::Storage { read_only };
    buffer_entry(binding, visibility, ty)
}

fn buffer_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    ty: wgpu::BufferBindingType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A texture (array) read by one stage.
pub(crate) fn texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    sample_type: wgpu::TextureSampleType,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension,
            multisampled: false,
        },
        count: None,
    }
}

/// What differs between the raster pipelines of the object kinds.
pub(crate) struct RasterPipeline<'a> {
    pub label: &'a str,
    pub source: String,
    /// Group 0 is the frame's (frame_bindings.rs), group 1 the kind's own.
    pub layouts: &'a [Option<&'a wgpu::BindGroupLayout>],
    pub vertex_buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
    pub cull: Option<wgpu::Face>,
    /// Pipeline-overridable constants of the fragment stage.
    pub constants: &'a [(&'a str, f64)],
}

impl RasterPipeline<'_> {
    /// A pipeline drawing into the shared targets (targets.rs), with reversed-Z depth testing.
    pub fn build(&self, device: &wgpu::Device) -> wgpu::RenderPipeline {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(self.label),
            source: wgpu::ShaderSource::Wgsl(self.source.as_str().into()),
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(self.label),
            bind_group_layouts: self.layouts,
            immediate_size: 0,
        });
        let target = |format| {
            Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })
        };
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(self.label),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: self.vertex_buffers,
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: self.cull,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater), // reversed Z
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: self.constants,
                    zero_initialize_workgroup_memory: true,
                },
                targets: &[
                    target(COLOR_FORMAT),
                    target(NORMAL_FORMAT),
                    target(ID_FORMAT),
                    target(COLOR_FORMAT), // albedo
                ],
            }),
            multiview_mask: None,
            cache: None,
        })
    }
}

/// A compute pipeline running `cs_main` of `source`.
pub(crate) fn compute_pipeline(
    device: &wgpu::Device,
    label: &str,
    source: &str,
    layouts: &[Option<&wgpu::BindGroupLayout>],
    constants: &[(&str, f64)],
) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: layouts,
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&layout),
        module: &module,
        entry_point: Some("cs_main"),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants,
            zero_initialize_workgroup_memory: true,
        },
        cache: None,
    })
}

/// The compute pass that copies the depth target into a buffer (see depth_copy.wgsl).
pub(crate) struct DepthCopy {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl DepthCopy {
    pub fn new(device: &wgpu::Device) -> DepthCopy {
        let compute = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("depth copy"),
            entries: &[
                texture_entry(
                    0,
                    compute,
                    wgpu::TextureSampleType::Float { filterable: false },
                    wgpu::TextureViewDimension::D2,
                ),
                storage_entry(1, compute, false),
            ],
        });
        let source = shaders::depth_copy();
        let pipeline = compute_pipeline(device, "depth_copy", &source, &[Some(&layout)], &[]);
        DepthCopy { layout, pipeline }
    }

    /// Binds a depth target (its depth aspect) and the buffer its values go to.
    pub fn bind_group(
        &self,
        device: &wgpu::Device,
        depth: &wgpu::Texture,
        values: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let depth_view = depth.create_view(&wgpu::TextureViewDescriptor {
            aspect: wgpu::TextureAspect::DepthOnly,
            ..Default::default()
        });
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("depth copy"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&depth_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: values.as_entire_binding(),
                },
            ],
        })
    }

    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        group: &wgpu::BindGroup,
        width: u32,
        height: u32,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("depth copy"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, group, &[]);
        // 8 x 8 workgroups, as depth_copy.wgsl declares.
        pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
    }
}
