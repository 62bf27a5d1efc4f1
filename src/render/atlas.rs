//! A texture set on the GPU: its patches' maps packed into four texture arrays (height, normal,
//! color, outline) by shelf packing, each array only as large as its content, and every patch's
//! min-max pyramid in one 2D texture (a texture, not a storage buffer: a buffer binding is
//! capped, 128 MiB on lavapipe, and large sets passed it).
//!
//! Spaces: atlas texels (layer, x, y); a patch's texel (i, j) sits at its place + (i, j), for i
//! in -1..=width and j in -1..=height: heights and outlines are stored with a one-texel border
//! continuing them past the map's edge (heightfield::padded_heights), which the cells at the
//! map's sides reach into; the other maps leave that border unread.
//! Pyramid node k sits at texel (k mod width, k div width) of the pyramid texture.

use super::device::{texture_2d, Gpu};
use crate::error::{GeomtexError, Result};
use crate::gtex::{GeometryTextureSet, NEUTRAL_COLOR};
use crate::heightfield::{min_max_pyramid, padded_heights, padded_outline};
use rayon::prelude::*;

/// A patch's min-max pyramid: per level its width, height and packed values.
pub(crate) type Pyramid = Vec<(u32, u32, Vec<u32>)>;

/// Where a patch's first texel sits in the atlas: (layer, x, y).
pub(crate) type Place = (u32, u32, u32);

/// Share of texels the shelf packing is expected to leave unused, allowed for when sizing.
const PACKING_SLACK: f64 = 0.08;

/// A texture set's maps and pyramids, uploaded.
pub(crate) struct Atlas {
    pub places: Vec<Place>,
    /// Height, normal, color and outline arrays, as gtex_bindings.wgsl binds them. Without any
    /// color map the color array is one neutral texel.
    pub views: [wgpu::TextureView; 4],
    /// Every patch's min-max pyramid (src/heightfield.rs), one node per R16Uint texel
    /// (`pack_node`).
    pub pyramid: wgpu::TextureView,
    /// Bytes of every texture above on the adapter (maps, packing gaps and pyramid).
    pub bytes: u64,
    /// Per patch: its first value in `pyramid` and its level count.
    pub pyramid_at: Vec<[u32; 2]>,
}

impl Atlas {
    /// Packs and uploads a set with its patches' min-max pyramids
    /// (heightfield::min_max_pyramid); errors when it does not fit this adapter's limits.
    pub fn upload(gpu: &Gpu, set: &GeometryTextureSet) -> Result<Atlas> {
        let limits = gpu.device.limits();
        let side = limits.max_texture_dimension_2d.min(4096);
        let (places, size) = fitted(set, side)?;
        if size.depth_or_array_layers > limits.max_texture_array_layers {
            return Err(GeomtexError::Device(format!(
                "the set needs {} atlas layers of {side}x{side}; this adapter allows {} \
                 (convert with a smaller max_resolution)",
                size.depth_or_array_layers, limits.max_texture_array_layers
            )));
        }
        // One byte per height texel when every patch has 8-bit codes; the shader reads either
        // format as u32 and decodes with each patch's own largest code.
        let narrow = set.patches.iter().all(|p| p.height_bits == 8);
        let colored = set.patches.iter().any(|p| p.has_colors());
        let textures = map_textures(&gpu.device, size, narrow, colored);
        write_maps(&gpu.queue, &textures, set, &places, narrow);
        let view = |t: &wgpu::Texture| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            })
        };
        let (pyramid, pyramid_at, pyramid_bytes) = upload_pyramids(gpu, set)?;
        let texture_bytes = |t: &wgpu::Texture| {
            let s = t.size();
            let texel = t.format().block_copy_size(None).unwrap_or(4) as u64;
            s.width as u64 * s.height as u64 * s.depth_or_array_layers as u64 * texel
        };
        Ok(Atlas {
            bytes: textures.iter().map(texture_bytes).sum::<u64>() + pyramid_bytes,
            places,
            views: textures.each_ref().map(view),
            pyramid,
            pyramid_at,
        })
    }
}

/// The patches' places and the atlas size: layers as narrow and short as the patches allow
/// (at most `side` square), so a set costs about its maps' bytes, not whole `side`² layers.
fn fitted(set: &GeometryTextureSet, side: u32) -> Result<(Vec<Place>, wgpu::Extent3d)> {
    let gapped = |p: &crate::gtex::Patch| (p.width as u64 + 3) * (p.height as u64 + 3);
    let area = set.patches.iter().map(gapped).sum::<u64>() as f64 * (1.0 + PACKING_SLACK);
    let widest = set.patches.iter().map(|p| p.width + 2).max().unwrap_or(1);
    let tallest = set.patches.iter().map(|p| p.height + 2).max().unwrap_or(1);
    let side_f = side as f64;
    let width = if area < side_f * side_f {
        (area.sqrt().ceil() as u32).max(widest).min(side)
    } else {
        side
    };
    let layers_wanted = (area / (width as f64 * side_f)).ceil().max(1.0) as u32;
    let mut height = ((area / (width as f64 * layers_wanted as f64)).ceil() as u32)
        .max(tallest)
        .min(side);
    loop {
        let (places, layers, used) = pack(set, width, height)?;
        // Taller layers until the patches fit in the layers the area asks for (or full size).
        if layers <= layers_wanted || height == side {
            let size = wgpu::Extent3d {
                width,
                height: if layers == 1 { used.max(1) } else { height },
                depth_or_array_layers: layers,
            };
            return Ok((places, size));
        }
        height = (height + height.div_ceil(16)).min(side);
    }
}

/// Shelf packing of the patches (each with its one-texel border) into layers of `width` x
/// `height`, tallest first, with 1-texel gaps: each patch's (layer, x, y) (of its texel (0, 0)),
/// the number of layers and the height the last one uses.
fn pack(set: &GeometryTextureSet, width: u32, height: u32) -> Result<(Vec<Place>, u32, u32)> {
    let mut order: Vec<usize> = (0..set.patches.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(set.patches[i].height));
    let mut places: Vec<Place> = vec![(0, 0, 0); set.patches.len()];
    let (mut layer, mut x, mut y, mut shelf) = (0u32, 0u32, 0u32, 0u32);
    for &i in &order {
        let p = &set.patches[i];
        let (pw, ph) = (p.width + 2, p.height + 2);
        if pw > width || ph > height {
            return Err(GeomtexError::Device(format!(
                "patch {i} is {}x{} texels (and a 1-texel border); this adapter's texture \
                 layers hold at most {width}x{height} (convert with a smaller max_resolution)",
                p.width, p.height
            )));
        }
        if x + pw > width {
            x = 0;
            y += shelf + 1;
            shelf = 0;
        }
        if y + ph > height {
            layer += 1;
            x = 0;
            y = 0;
            shelf = 0;
        }
        places[i] = (layer, x + 1, y + 1);
        x += pw + 1;
        shelf = shelf.max(ph);
    }
    Ok((places, layer + 1, y + shelf))
}

/// The height, normal, color and outline arrays of `size` (the color array one texel when no
/// patch has a color map). Normals are octahedral codes, read as exact integers.
fn map_textures(
    device: &wgpu::Device,
    size: wgpu::Extent3d,
    narrow: bool,
    colored: bool,
) -> [wgpu::Texture; 4] {
    let one = wgpu::Extent3d {
        width: 1,
        height: 1,
        depth_or_array_layers: 1,
    };
    let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
    let make = |label, format| texture_2d(device, label, size, format, usage);
    let color_size = if colored { size } else { one };
    let height_format = if narrow {
        wgpu::TextureFormat::R8Uint
    } else {
        wgpu::TextureFormat::R16Uint
    };
    [
        make("heights", height_format),
        make("normals", wgpu::TextureFormat::Rg8Sint),
        texture_2d(
            device,
            "colors",
            color_size,
            wgpu::TextureFormat::Rgba8Unorm,
            usage,
        ),
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
    let colored = set.patches.iter().any(|p| p.has_colors());
    if !colored {
        write_texels(queue, &textures[2], (0, 0, 0), (1, 1), &NEUTRAL_COLOR, 4);
    }
    for (p, &(layer, x, y)) in set.patches.iter().zip(places) {
        // Heights and outlines with their continued border, from texel (-1, -1).
        let padded_codes = padded_heights(p);
        let narrow_codes: Vec<u8>;
        let height_plane: &[u8] = if narrow {
            narrow_codes = padded_codes.iter().map(|&q| q as u8).collect();
            &narrow_codes
        } else {
            bytemuck::cast_slice(&padded_codes)
        };
        let padded_outlines = padded_outline(p);
        let bordered = ((layer, x - 1, y - 1), (p.width + 2, p.height + 2));
        write_texels(
            queue,
            &textures[0],
            bordered.0,
            bordered.1,
            height_plane,
            height_bytes,
        );
        write_texels(
            queue,
            &textures[3],
            bordered.0,
            bordered.1,
            bytemuck::cast_slice(&padded_outlines),
            1,
        );
        // A patch without a color map beside patches with one (a merged set) gets neutral texels.
        let neutral: Vec<[u8; 4]>;
        let color_plane: &[u8] = if p.has_colors() || !colored {
            bytemuck::cast_slice(&p.colors)
        } else {
            neutral = vec![NEUTRAL_COLOR; p.texels()];
            bytemuck::cast_slice(&neutral)
        };
        let planes: [(&wgpu::Texture, &[u8], u32); 2] = [
            (&textures[1], bytemuck::cast_slice(&p.normals), 2),
            (&textures[2], color_plane, 4),
        ];
        for (texture, bytes, texel) in planes {
            if bytes.is_empty() {
                continue; // no color map anywhere: the one neutral texel is written above
            }
            write_texels(
                queue,
                texture,
                (layer, x, y),
                (p.width, p.height),
                bytes,
                texel,
            );
        }
    }
}

/// Writes a `size` block of `texel`-byte texels at `place` (layer, x, y) of `texture`.
fn write_texels(
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    (layer, x, y): Place,
    (width, height): (u32, u32),
    bytes: &[u8],
    texel: u32,
) {
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
            bytes_per_row: Some(width * texel),
            rows_per_image: None,
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
}

/// A pyramid node (heightfield::min_max_pyramid: largest code << 16 | smallest, 0 = empty) in
/// 16 bits: the largest and smallest code of a patch of `height_bits` rounded outwards to 8 bits
/// (largest << 8 | smallest; exact for 8-bit codes), `EMPTY_NODE` for no surface. A looser bound
/// only sends a search one level further down, to the exact cells: hits do not change.
pub(crate) fn pack_node(v: u32, height_bits: u8) -> u16 {
    if v == 0 {
        return EMPTY_NODE;
    }
    let shift = height_bits as u32 - 8;
    let (hi, lo) = ((v >> 16) >> shift, (v & 0xffff) >> shift);
    ((hi << 8) | lo) as u16
}

/// A node with no surface: smallest (low byte) above largest, which no real node has.
pub(crate) const EMPTY_NODE: u16 = 0x00ff;

/// Every patch's min-max pyramid in one R16Uint texture (`pack_node`), row by row, and where
/// each patch's starts. Made on all cores a few patches at a time and packed in patch order,
/// so the full-width pyramids of a large set never sit in memory together.
/// Texels whose patches' full-width pyramids are made together: 16 M texels hold about 90 MB
/// of u32 nodes (a patch larger than that is made alone).
const PYRAMID_TEXELS_AT_ONCE: usize = 1 << 24;

/// Consecutive runs of `patches` holding at most `texels` texels each (at least one patch).
fn texel_chunks(patches: &[crate::gtex::Patch], texels: usize) -> Vec<&[crate::gtex::Patch]> {
    let mut chunks = Vec::new();
    let (mut start, mut held) = (0, 0);
    for (i, p) in patches.iter().enumerate() {
        if held + p.texels() > texels && i > start {
            chunks.push(&patches[start..i]);
            (start, held) = (i, 0);
        }
        held += p.texels();
    }
    if start < patches.len() {
        chunks.push(&patches[start..]);
    }
    chunks
}

fn upload_pyramids(
    gpu: &Gpu,
    set: &GeometryTextureSet,
) -> Result<(wgpu::TextureView, Vec<[u32; 2]>, u64)> {
    let mut values: Vec<u16> = Vec::new();
    let mut pyramid_at = Vec::with_capacity(set.patches.len());
    for chunk in texel_chunks(&set.patches, PYRAMID_TEXELS_AT_ONCE) {
        let made: Vec<Pyramid> = chunk.par_iter().map(min_max_pyramid).collect();
        for (p, levels) in chunk.iter().zip(made) {
            pyramid_at.push([values.len() as u32, levels.len() as u32]);
            for (_, _, v) in levels {
                values.extend(v.iter().map(|&v| pack_node(v, p.height_bits)));
            }
        }
    }
    let side = gpu.device.limits().max_texture_dimension_2d;
    let width = (values.len() as u32).clamp(1, side);
    let rows = (values.len() as u64).div_ceil(width as u64).max(1);
    if rows > side as u64 {
        return Err(GeomtexError::Device(format!(
            "the set's {} texels need {} min-max pyramid nodes; this adapter's largest texture \
             holds {} (convert with max_bytes= or a smaller max_resolution)",
            set.texels(),
            values.len(),
            side as u64 * side as u64
        )));
    }
    values.resize(width as usize * rows as usize, EMPTY_NODE);
    let size = wgpu::Extent3d {
        width,
        height: rows as u32,
        depth_or_array_layers: 1,
    };
    let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
    let texture = texture_2d(
        &gpu.device,
        "min-max pyramids",
        size,
        wgpu::TextureFormat::R16Uint,
        usage,
    );
    let bytes: &[u8] = bytemuck::cast_slice(&values);
    write_texels(
        &gpu.queue,
        &texture,
        (0, 0, 0),
        (width, rows as u32),
        bytes,
        2,
    );
    let bytes = values.len() as u64 * 2;
    Ok((texture.create_view(&Default::default()), pyramid_at, bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_nodes_bound_their_codes_outwards() {
        for (hi, lo) in [
            (65535u32, 1u32),
            (300, 299),
            (255, 1),
            (1, 1),
            (40000, 39999),
        ] {
            let q = pack_node((hi << 16) | lo, 16);
            let (h8, l8) = ((q >> 8) as u32, (q & 0xff) as u32);
            assert!(
                l8 <= h8 && (l8 << 8) <= lo && ((h8 << 8) | 0xff) >= hi,
                "{hi} {lo}"
            );
        }
        // 8-bit codes are kept exactly; no real node packs as empty.
        assert_eq!(pack_node((200 << 16) | 7, 8), (200 << 8) | 7);
        assert_eq!(pack_node(0, 16), EMPTY_NODE);
        assert_ne!(pack_node((1 << 16) | 1, 8), EMPTY_NODE);
    }
}
