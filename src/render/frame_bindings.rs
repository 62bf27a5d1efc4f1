//! Group 0 of every raster pass and tracer (frame_bindings.wgsl): the camera (a uniform), the
//! search settings (a read-only storage buffer: see frame_bindings.wgsl) and the counters (box
//! searches, and height fetches in the counting build), written once per frame and shared by all
//! objects of every kind.
//!
//! Spaces: the camera record is camera-relative view space (see gpu_types.rs).

use glam::DMat4;

use super::camera::Lens;
use super::gpu_types::{CameraGpu, SearchGpu};
use super::pipelines::{storage_entry, uniform_entry, FRAME_STAGES};
use super::search::SearchOptions;

/// Bytes of the counters: height fetches (counting build only), box searches and piece tests
/// (counting build only), u32 each.
const COUNTERS_BYTES: u64 = 12;

pub(crate) struct FrameBindings {
    pub layout: wgpu::BindGroupLayout,
    pub group: wgpu::BindGroup,
    camera: wgpu::Buffer,
    search: wgpu::Buffer,
    counters: wgpu::Buffer,
    counters_readback: wgpu::Buffer,
}

impl FrameBindings {
    pub fn new(device: &wgpu::Device) -> FrameBindings {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame"),
            entries: &[
                uniform_entry(0, FRAME_STAGES),
                storage_entry(1, FRAME_STAGES, true),
                // Writable storage is not allowed in vertex shaders (without a feature).
                storage_entry(
                    2,
                    FRAME_STAGES.difference(wgpu::ShaderStages::VERTEX),
                    false,
                ),
            ],
        });
        let written = |label, size, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let camera = written(
            "camera",
            size_of::<CameraGpu>() as u64,
            wgpu::BufferUsages::UNIFORM,
        );
        let search = written(
            "search",
            size_of::<SearchGpu>() as u64,
            wgpu::BufferUsages::STORAGE,
        );
        let counters = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("counters"),
            size: COUNTERS_BYTES,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let counters_readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("counters readback"),
            size: COUNTERS_BYTES,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: camera.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: search.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: counters.as_entire_binding(),
                },
            ],
        });
        FrameBindings {
            layout,
            group,
            camera,
            search,
            counters,
            counters_readback,
        }
    }

    /// This frame's camera and search records; the counters start from zero.
    pub fn write(
        &self,
        queue: &wgpu::Queue,
        lens: &Lens,
        view_from_world: DMat4,
        search: &SearchOptions,
    ) {
        let camera = CameraGpu::new(lens, view_from_world);
        queue.write_buffer(&self.camera, 0, bytemuck::bytes_of(&camera));
        queue.write_buffer(&self.search, 0, bytemuck::bytes_of(&SearchGpu::new(search)));
        queue.write_buffer(&self.counters, 0, &[0u8; COUNTERS_BYTES as usize]);
    }

    /// The search record alone, for ray queries (which use no camera).
    pub fn write_search(&self, queue: &wgpu::Queue, search: &SearchOptions) {
        queue.write_buffer(&self.search, 0, bytemuck::bytes_of(&SearchGpu::new(search)));
    }

    /// Copies the counters for reading back; the buffer to read.
    pub fn encode_counters_readback(&self, encoder: &mut wgpu::CommandEncoder) -> &wgpu::Buffer {
        let readback = &self.counters_readback;
        encoder.copy_buffer_to_buffer(&self.counters, 0, readback, 0, COUNTERS_BYTES);
        readback
    }
}
