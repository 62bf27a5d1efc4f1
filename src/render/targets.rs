//! Render targets shared by every object kind (color, normal, id, albedo and reversed-Z depth), and
//! reading back the outputs a frame asks for: one image size each, kept by the renderer while
//! frames of that size are drawn (mod.rs).
//!
//! Spaces: framebuffer pixels, row-major with row 0 at the top; depth values are reversed Z
//! (0 = nothing) until `Camera::distance_from_depth` turns them into view distances.

use crate::error::{GeomtexError, Result};

use super::device::{texture_2d, Gpu};
use super::gpu_types::{COLOR_FORMAT, DEPTH_FORMAT, ID_FORMAT, NORMAL_FORMAT};
use super::outputs::Outputs;
use super::pipelines::DepthCopy;

/// Bytes per row of a texture copy, padded as wgpu requires.
fn padded_row(bytes_per_pixel: u32, width: u32) -> u32 {
    let a = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    (bytes_per_pixel * width).div_ceil(a) * a
}

/// GPU timestamps around the scene pass: the query set, its resolve buffer and a readback copy.
type Timestamps = (wgpu::QuerySet, wgpu::Buffer, wgpu::Buffer);

pub(crate) struct Targets {
    pub width: u32,
    pub height: u32,
    color: wgpu::Texture,
    normal: wgpu::Texture,
    id: wgpu::Texture,
    /// The unshaded base color (RGBA8), beside the shaded `color`.
    albedo: wgpu::Texture,
    depth: wgpu::Texture,
    /// The depth texture copied to a buffer by the depth copy pass (see depth_copy.wgsl).
    depth_values: wgpu::Buffer,
    depth_copy_group: wgpu::BindGroup,
    /// Color, normal, id, albedo (rows padded) and depth.
    readback: [wgpu::Buffer; 5],
    timestamps: Option<Timestamps>,
    /// The surface target (kinds/igt.rs) and its readback buffer, made the first time a frame
    /// needs them.
    surface: Option<(wgpu::Texture, wgpu::Buffer)>,
}

/// What one frame's readback holds: the outputs asked for.
pub(crate) struct Readback {
    pub color: Option<Vec<u8>>,
    /// Unit normals, xyz per pixel.
    pub normal: Option<Vec<f32>>,
    pub patch_id: Option<Vec<i32>>,
    pub albedo: Option<Vec<u8>>,
    /// Reversed-Z depth values.
    pub depth: Option<Vec<f32>>,
    pub gpu_ms: Option<f64>,
    /// The frame's counters: height fetches (counting build only), piece searches and tiled
    /// walks' piece tests (counting build only).
    pub counters: [u32; 3],
}

fn render_texture(
    device: &wgpu::Device,
    label: &str,
    size: wgpu::Extent3d,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    texture_2d(
        device,
        label,
        size,
        format,
        wgpu::TextureUsages::RENDER_ATTACHMENT | usage,
    )
}

fn map_buffer(device: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

fn make_timestamps(device: &wgpu::Device) -> Timestamps {
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
    (set, resolve, map_buffer(device, "timestamp readback", 16))
}

/// A mappable copy of `source` (a COPY_SRC buffer), filled at this point of `encoder`.
pub(crate) fn copy_for_readback(
    device: &wgpu::Device,
    encoder: &mut wgpu::CommandEncoder,
    source: &wgpu::Buffer,
) -> wgpu::Buffer {
    let readback = map_buffer(device, "readback", source.size());
    encoder.copy_buffer_to_buffer(source, 0, &readback, 0, source.size());
    readback
}

/// Maps every buffer, waits once, and returns their bytes (buffers unmapped again).
pub(crate) fn read_buffers(
    device: &wgpu::Device,
    buffers: &[&wgpu::Buffer],
) -> Result<Vec<Vec<u8>>> {
    for b in buffers {
        b.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    }
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| GeomtexError::Device(format!("waiting for the GPU failed: {e}")))?;
    let bytes = buffers
        .iter()
        .map(|b| {
            Ok(b.slice(..)
                .get_mapped_range()
                .map_err(|e| GeomtexError::Device(format!("readback failed: {e:?}")))?
                .to_vec())
        })
        .collect();
    for b in buffers {
        b.unmap();
    }
    bytes
}

/// Copies `source` (a COPY_SRC buffer) out at the end of `encoder`, submits it and returns the
/// bytes after one wait.
pub(crate) fn read_buffer(
    gpu: &Gpu,
    mut encoder: wgpu::CommandEncoder,
    source: &wgpu::Buffer,
) -> Result<Vec<u8>> {
    let readback = map_buffer(&gpu.device, "readback", source.size());
    encoder.copy_buffer_to_buffer(source, 0, &readback, 0, source.size());
    gpu.queue.submit(Some(encoder.finish()));
    Ok(read_buffers(&gpu.device, &[&readback])?.remove(0))
}

impl Targets {
    pub fn new(gpu: &Gpu, depth_copy: &DepthCopy, width: u32, height: u32) -> Targets {
        let device = &gpu.device;
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let copied = wgpu::TextureUsages::COPY_SRC;
        let color = render_texture(device, "color", size, COLOR_FORMAT, copied);
        let normal = render_texture(device, "normal", size, NORMAL_FORMAT, copied);
        let id = render_texture(device, "id", size, ID_FORMAT, copied);
        let albedo = render_texture(device, "albedo", size, COLOR_FORMAT, copied);
        let bound = wgpu::TextureUsages::TEXTURE_BINDING;
        let depth = render_texture(device, "depth", size, DEPTH_FORMAT, bound);
        let depth_bytes = (width as u64) * (height as u64) * 4;
        let depth_values = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("depth values"),
            size: depth_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let depth_copy_group = depth_copy.bind_group(device, &depth, &depth_values);
        let rows = |bytes_per_pixel| padded_row(bytes_per_pixel, width) as u64 * height as u64;
        let readback = [
            map_buffer(device, "color readback", rows(4)),
            map_buffer(device, "normal readback", rows(8)),
            map_buffer(device, "id readback", rows(4)),
            map_buffer(device, "albedo readback", rows(4)),
            map_buffer(device, "depth readback", depth_bytes),
        ];
        Targets {
            width,
            height,
            color,
            normal,
            id,
            albedo,
            depth,
            depth_values,
            depth_copy_group,
            readback,
            timestamps: gpu.timestamps.then(|| make_timestamps(device)),
            surface: None,
        }
    }

    /// Makes the surface target if there is none yet.
    pub fn ensure_surface(&mut self, device: &wgpu::Device) {
        if self.surface.is_some() {
            return;
        }
        let size = wgpu::Extent3d {
            width: self.width,
            height: self.height,
            depth_or_array_layers: 1,
        };
        let format = super::kinds::igt::SURFACE_FORMAT;
        let texture = render_texture(
            device,
            "surface",
            size,
            format,
            wgpu::TextureUsages::COPY_SRC,
        );
        let bytes = padded_row(16, self.width) as u64 * self.height as u64;
        self.surface = Some((texture, map_buffer(device, "surface readback", bytes)));
    }

    /// The surface pass (after the scene pass): the surface target cleared to 0 (no face), the
    /// scene's depth kept; it ends the frame's timing when `timed`.
    pub fn begin_surface_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        timed: bool,
    ) -> wgpu::RenderPass<'e> {
        let (texture, _) = self.surface.as_ref().expect("ensure_surface ran");
        let views = [texture, &self.color, &self.normal, &self.albedo]
            .map(|t| t.create_view(&Default::default()));
        let depth_view = self.depth.create_view(&Default::default());
        // The surface target cleared; the scene's color, normal and albedo kept, to be shaded
        // over where the pass draws.
        let attachments = views.iter().enumerate().map(|(k, view)| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: if k == 0 {
                        wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT)
                    } else {
                        wgpu::LoadOp::Load
                    },
                    store: wgpu::StoreOp::Store,
                },
            })
        });
        let attachments: Vec<_> = attachments.collect();
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("surface"),
            color_attachments: &attachments,
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: self
                .timestamps
                .as_ref()
                .filter(|_| timed)
                .map(|(set, _, _)| wgpu::RenderPassTimestampWrites {
                    query_set: set,
                    beginning_of_pass_write_index: None,
                    end_of_pass_write_index: Some(1),
                }),
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }

    /// Copies the surface target into its readback buffer.
    pub fn encode_surface_readback(&self, encoder: &mut wgpu::CommandEncoder) {
        let (texture, buffer) = self.surface.as_ref().expect("ensure_surface ran");
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded_row(16, self.width)),
                    rows_per_image: None,
                },
            },
            texture.size(),
        );
    }

    /// The surface target of the submitted frame: per pixel the detailed face (-1 for none) and
    /// its barycentrics (0 for none).
    pub fn read_surface(&self, gpu: &Gpu) -> Result<(Vec<i32>, Vec<f32>)> {
        let (_, buffer) = self.surface.as_ref().expect("ensure_surface ran");
        let bytes = read_buffers(&gpu.device, &[buffer])?.remove(0);
        let texels: Vec<[u32; 4]> = bytemuck::cast_slice(&self.unpad(bytes, 16)).to_vec();
        let face = texels.iter().map(|t| t[0] as i32 - 1).collect();
        let bary = (texels.iter())
            .flat_map(|t| [t[1], t[2], t[3]].map(f32::from_bits))
            .collect();
        Ok((face, bary))
    }

    /// Timestamps for a compute pass run before the scene pass: the frame's time then starts
    /// there (`begin_scene_pass` with `timed_before`).
    pub fn compute_timestamps(&self) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.timestamps
            .as_ref()
            .map(|(set, _, _)| wgpu::ComputePassTimestampWrites {
                query_set: set,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: None,
            })
    }

    /// The pass every object kind draws in: all targets cleared (color to `background`, ids to
    /// -1, albedo to transparent black, depth to 0 = nothing in reversed Z), timed when the
    /// adapter can (from this pass's start, or from a compute pass's if `timed_before`; to its
    /// end, or to the surface pass's if `timed_after`).
    pub fn begin_scene_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        background: [f64; 4],
        timed_before: bool,
        timed_after: bool,
    ) -> wgpu::RenderPass<'e> {
        let clear = |c: wgpu::Color| wgpu::Operations {
            load: wgpu::LoadOp::Clear(c),
            store: wgpu::StoreOp::Store,
        };
        let [r, g, b, a] = background;
        let no_id = wgpu::Color {
            r: -1.0,
            g: 0.0,
            b: 0.0,
            a: 0.0,
        };
        let clears = [
            wgpu::Color { r, g, b, a },
            wgpu::Color::TRANSPARENT,
            no_id,
            wgpu::Color::TRANSPARENT,
        ];
        let views = [&self.color, &self.normal, &self.id, &self.albedo]
            .map(|t| t.create_view(&Default::default()));
        let attachments: Vec<_> = views
            .iter()
            .zip(clears)
            .map(|(view, color)| {
                Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: clear(color),
                })
            })
            .collect();
        let depth_view = self.depth.create_view(&Default::default());
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
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
            // Timed before and after: this pass writes neither timestamp.
            timestamp_writes: (self.timestamps.as_ref())
                .filter(|_| !(timed_before && timed_after))
                .map(|(set, _, _)| wgpu::RenderPassTimestampWrites {
                    query_set: set,
                    beginning_of_pass_write_index: (!timed_before).then_some(0),
                    end_of_pass_write_index: (!timed_after).then_some(1),
                }),
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }

    /// The color targets in readback order (color, normal, id, albedo), each with its bytes per
    /// pixel and whether `outputs` asks for it.
    fn color_targets(&self, outputs: Outputs) -> [(&wgpu::Texture, u32, bool); 4] {
        [
            (&self.color, 4, outputs.color),
            (&self.normal, 8, outputs.normal),
            (&self.id, 4, outputs.patch_id),
            (&self.albedo, 4, outputs.albedo),
        ]
    }

    /// Copies the targets `outputs` asks for into their readback buffers (depth through the
    /// depth copy pass, the others as texture copies); then the timestamps.
    pub fn encode_readback(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        depth_copy: &DepthCopy,
        outputs: Outputs,
    ) {
        for ((texture, bytes_per_pixel, wanted), buffer) in
            self.color_targets(outputs).into_iter().zip(&self.readback)
        {
            if !wanted {
                continue;
            }
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
                        bytes_per_row: Some(padded_row(bytes_per_pixel, self.width)),
                        rows_per_image: None,
                    },
                },
                texture.size(),
            );
        }
        if outputs.depth {
            depth_copy.encode(encoder, &self.depth_copy_group, self.width, self.height);
            let depth_size = self.depth_values.size();
            encoder.copy_buffer_to_buffer(&self.depth_values, 0, &self.readback[4], 0, depth_size);
        }
        if let Some((set, resolve, readback)) = &self.timestamps {
            encoder.resolve_query_set(set, 0..2, resolve, 0);
            encoder.copy_buffer_to_buffer(resolve, 0, readback, 0, 16);
        }
    }

    /// Reads the submitted frame's `outputs` back in one wait, with the frame's counters.
    pub fn read_back(
        &self,
        gpu: &Gpu,
        counters: &wgpu::Buffer,
        outputs: Outputs,
    ) -> Result<Readback> {
        let wanted = [
            outputs.color,
            outputs.normal,
            outputs.patch_id,
            outputs.albedo,
            outputs.depth,
        ];
        let mut buffers: Vec<&wgpu::Buffer> = (self.readback.iter().zip(wanted))
            .filter_map(|(b, w)| w.then_some(b))
            .collect();
        buffers.push(counters);
        buffers.extend(self.timestamps.as_ref().map(|(_, _, r)| r));
        let mut bytes = read_buffers(&gpu.device, &buffers)?.into_iter();
        let mut next = || bytes.next().unwrap_or_default();
        let mut read = |k: usize| wanted[k].then(&mut next);
        let color = read(0).map(|b| self.unpad(b, 4));
        let normal = read(1).map(|b| unit_normals(&self.unpad(b, 8)));
        let patch_id = read(2).map(|b| bytemuck::cast_slice(&self.unpad(b, 4)).to_vec());
        let albedo = read(3).map(|b| self.unpad(b, 4));
        let depth = read(4).map(|b| bytemuck::cast_slice(&b).to_vec());
        let counts: Vec<u32> = bytemuck::cast_slice(&next()).to_vec();
        let counters = [counts[0], counts[1], counts[2]];
        let gpu_ms = self.timestamps.as_ref().map(|_| {
            let ticks: Vec<u64> = bytemuck::cast_slice(&next()).to_vec();
            let period = gpu.queue.get_timestamp_period() as f64;
            ticks[1].saturating_sub(ticks[0]) as f64 * period / 1e6
        });
        Ok(Readback {
            color,
            normal,
            patch_id,
            albedo,
            depth,
            gpu_ms,
            counters,
        })
    }

    /// Drops the row padding of a texture copy.
    fn unpad(&self, bytes: Vec<u8>, bytes_per_pixel: u32) -> Vec<u8> {
        let row = (bytes_per_pixel * self.width) as usize;
        let pitch = padded_row(bytes_per_pixel, self.width) as usize;
        if row == pitch {
            return bytes;
        }
        bytes
            .chunks(pitch)
            .take(self.height as usize)
            .flat_map(|r| &r[..row])
            .copied()
            .collect()
    }
}

/// The normal target's half-float texels (xyzw) as unit normals, xyz per pixel.
fn unit_normals(texels: &[u8]) -> Vec<f32> {
    (bytemuck::cast_slice::<u8, [u16; 4]>(texels).iter())
        .flat_map(|n| unit_normal([n[0], n[1], n[2]]))
        .collect()
}

/// A stored half-float normal made unit length again (in f64, so the f32 result is within
/// float32 rounding of 1): the target holds 11-bit mantissas, whose lengths run 0.9994-1.0000,
/// and a user taking `arccos` of a dot product with a true normal would read that as degrees of
/// error. Values whose length is not within NORMAL_LENGTH_SLACK of 1 are not normals (a miss's
/// zeros; the counts GDM shells write there with `count_steps`) and are kept as stored.
fn unit_normal(bits: [u16; 3]) -> [f32; 3] {
    let n = bits.map(|h| half::f16::from_bits(h).to_f64());
    let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if (length - 1.0).abs() <= NORMAL_LENGTH_SLACK {
        n.map(|v| (v / length) as f32)
    } else {
        n.map(|v| v as f32)
    }
}

/// How far from 1 a stored normal's length may be (half-float rounding gives at most ~1e-3).
const NORMAL_LENGTH_SLACK: f64 = 0.01;

#[cfg(test)]
mod tests {
    use super::unit_normal;

    #[test]
    fn read_back_normals_are_unit_length() {
        let half = |v: f32| half::f16::from_f32(v).to_bits();
        for n in [[0.3f32, -0.5, 0.81], [1.0, 0.0, 0.0], [0.577, 0.577, 0.577]] {
            let u = unit_normal(n.map(half));
            let length = u.iter().map(|v| (*v as f64).powi(2)).sum::<f64>().sqrt();
            assert!(
                (length - 1.0).abs() < 1e-6,
                "{n:?} -> {u:?} has length {length}"
            );
        }
        assert_eq!(unit_normal([0; 3]), [0.0; 3]);
        // Not a normal (GDM's count_steps counts): kept as stored.
        assert_eq!(unit_normal([3.0f32, 1.0, 0.0].map(half)), [3.0, 1.0, 0.0]);
    }
}
