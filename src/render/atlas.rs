//! A texture set on the GPU: its patches' maps packed into four texture arrays (height, normal,
//! color, outline) by shelf packing, and every patch's min-max pyramid in one storage buffer.
//!
//! Spaces: atlas texels (layer, x, y); a patch's texel (i, j) sits at its place + (i, j).

use wgpu::util::DeviceExt;

use super::device::{texture_2d, Gpu};
use crate::error::{GeomtexError, Result};
use crate::gtex::GeometryTextureSet;

/// A patch's min-max pyramid: per level its width, height and packed values.
pub(crate) type Pyramid = Vec<(u32, u32, Vec<u32>)>;

/// Where a patch's first texel sits in the atlas: (layer, x, y).
pub(crate) type Place = (u32, u32, u32);

/// A texture set's maps and pyramids, uploaded.
pub(crate) struct Atlas {
    pub places: Vec<Place>,
    /// Height, normal, color and outline arrays, as gtex_bindings.wgsl binds them.
    pub views: [wgpu::TextureView; 4],
    /// Every patch's min-max pyramid (src/heightfield.rs).
    pub pyramid: wgpu::Buffer,
    /// Per patch: its first value in `pyramid` and its level count.
    pub pyramid_at: Vec<[u32; 2]>,
}

impl Atlas {
    /// Packs and uploads a set with its patches' min-max pyramids
    /// (heightfield::min_max_pyramid); errors when it does not fit this adapter's limits.
    pub fn upload(gpu: &Gpu, set: &GeometryTextureSet, pyramids: &[Pyramid]) -> Result<Atlas> {
        let limits = gpu.device.limits();
        let side = limits.max_texture_dimension_2d.min(4096);
        let (places, layers) = pack(set, side)?;
        if layers > limits.max_texture_array_layers {
            return Err(GeomtexError::Device(format!(
                "the set needs {layers} atlas layers of {side}x{side}; this adapter allows {} \
                 (convert with a smaller max_resolution)",
                limits.max_texture_array_layers
            )));
        }
        // One byte per height texel when every patch has 8-bit codes; the shader reads either
        // format as u32 and decodes with each patch's own largest code.
        let narrow = set.patches.iter().all(|p| p.height_bits == 8);
        let textures = map_textures(&gpu.device, side, layers, narrow);
        write_maps(&gpu.queue, &textures, set, &places, narrow);
        let view = |t: &wgpu::Texture| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            })
        };
        let (pyramid, pyramid_at) = upload_pyramids(gpu, set, pyramids)?;
        Ok(Atlas {
            places,
            views: textures.each_ref().map(view),
            pyramid,
            pyramid_at,
        })
    }
}

/// Shelf packing of the patches, tallest first, with 1-texel gaps: each patch's (layer, x, y)
/// and the number of layers.
fn pack(set: &GeometryTextureSet, side: u32) -> Result<(Vec<Place>, u32)> {
    let mut order: Vec<usize> = (0..set.patches.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(set.patches[i].height));
    let mut places: Vec<Place> = vec![(0, 0, 0); set.patches.len()];
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
    Ok((places, layer + 1))
}

/// The height, normal, color and outline arrays, `layers` of `side` x `side` texels each.
fn map_textures(device: &wgpu::Device, side: u32, layers: u32, narrow: bool) -> [wgpu::Texture; 4] {
    let size = wgpu::Extent3d {
        width: side,
        height: side,
        depth_or_array_layers: layers,
    };
    let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
    let make = |label, format| texture_2d(device, label, size, format, usage);
    let height_format = if narrow {
        wgpu::TextureFormat::R8Uint
    } else {
        wgpu::TextureFormat::R16Uint
    };
    [
        make("heights", height_format),
        make("normals", wgpu::TextureFormat::Rgba8Snorm),
        make("colors", wgpu::TextureFormat::Rgba8Unorm),
        make("outlines", wgpu::TextureFormat::R8Snorm),
    ]
}

/// Writes every patch's four maps at its place.
fn write_maps(
    queue: &wgpu::Queue,
    textures: &[wgpu::Texture; 4],
    set: &GeometryTextureSet,
    places: &[Place],
    narrow: bool,
) {
    let height_bytes = if narrow { 1 } else { 2 };
    for (p, &(layer, x, y)) in set.patches.iter().zip(places) {
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
        let planes: [(&[u8], u32); 4] = [
            (height_plane, height_bytes),
            (bytemuck::cast_slice(&p.normals), 4),
            (bytemuck::cast_slice(&p.colors), 4),
            (bytemuck::cast_slice(&p.outline), 1),
        ];
        for (texture, (bytes, texel)) in textures.iter().zip(planes) {
            queue.write_texture(
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
}

/// Every patch's min-max pyramid in one buffer, and where each patch's starts.
fn upload_pyramids(
    gpu: &Gpu,
    set: &GeometryTextureSet,
    pyramids: &[Pyramid],
) -> Result<(wgpu::Buffer, Vec<[u32; 2]>)> {
    let mut values: Vec<u32> = Vec::new();
    let mut pyramid_at = Vec::with_capacity(set.patches.len());
    for levels in pyramids {
        pyramid_at.push([values.len() as u32, levels.len() as u32]);
        for (_, _, v) in levels {
            values.extend_from_slice(v);
        }
    }
    let pyramid_bytes = values.len() as u64 * 4;
    let binding_limit = gpu.device.limits().max_storage_buffer_binding_size;
    if pyramid_bytes > binding_limit {
        return Err(GeomtexError::Device(format!(
            "the set's {} texels need {:.0} MiB of max pyramids; this adapter binds at most \
             {:.0} MiB (convert with a smaller max_resolution or fewer charts)",
            set.texels(),
            pyramid_bytes as f64 / 1048576.0,
            binding_limit as f64 / 1048576.0
        )));
    }
    let pyramid = gpu
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("max pyramids"),
            contents: bytemuck::cast_slice(&values),
            usage: wgpu::BufferUsages::STORAGE,
        });
    Ok((pyramid, pyramid_at))
}
