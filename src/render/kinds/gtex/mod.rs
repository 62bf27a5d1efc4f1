//! Geometry-texture sets. Frames ray cast them per pixel in their patches' boxes: by default one
//! rectangle over the set whose fragments walk their screen tile's pieces nearest first,
//! searching each patch they enter once (tiles.rs, gtex_tiles.wgsl; the pieces: boxes.rs'
//! tile_pieces over the texels each patch owns, owners.rs), or one instance of the unit cube per visible patch, each fragment
//! searching its box (gtex_raycast.wgsl, `primary="boxes"`). Ray queries trace them (gtex_trace_rays.wgsl): a hierarchy
//! (bvh.rs) over thin pieces of the patches' boxes (boxes.rs), both made on the first query of a
//! set, is walked front to back, and a piece a ray enters before its nearest hit so far gets a
//! search of its patch's height map over the stretch inside it.
//!
//! Spaces: the set's object space (placed by `world_from_object`; the hierarchy's shape is built
//! there), each patch's own (`world_from_patch` of the set's space: the box is the unit cube, x/y
//! are texture u/v, z is height), view (camera-relative: the patch records and the refitted
//! bounds; for queries, world space translated near the rays) and clip (the lens's, for culling).

pub(crate) mod boxes;
mod lod;
pub(crate) mod owners;

use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use bytemuck::Zeroable;
use glam::{DMat3, DMat4, DVec3};
use rayon::prelude::*;

use super::{
    storage_buffer, DrawCall, FrameView, Kind, KindContext, LodPick, Tally, TraceCall, UploadCache,
};
use crate::bvh::{Aabb, Bvh};
use crate::error::Result;
use crate::gtex::{GeometryTextureSet, Patch};
use crate::heightfield::min_max_pyramid;
use crate::render::atlas::Atlas;
use crate::render::cull::{bound_lod_level, in_frustum, lod_level, DepthRange};
use crate::render::device::Gpu;
use crate::render::error_bound::largest_singular_value;
use crate::render::gpu_types::{gpu_matrix, normal_matrix, PatchGpu};
use crate::render::pipelines::{
    compute_pipeline, storage_entry, texture_entry, RasterPipeline, VERTEX_AND_FRAGMENT,
};
use crate::render::scene::SceneObject;
use crate::render::search::Primary;
use crate::render::shaders;

use super::tiles::{self, TileLists};
use boxes::{patch_boxes, placed as placed_box, tile_piece_corners, tile_pieces, PatchBoxGpu};

/// The unit cube as 12 triangles (gtex_raycast.wgsl's CUBE), one instance per drawn patch.
const CUBE_VERTICES: u32 = 36;

/// A rectangle as two triangles (camera_functions.wgsl's RECT_CORNERS).
const RECT_VERTICES: u32 = 6;

/// A set on the GPU: its maps and pyramids, and the pieces of its boxes that ray queries walk
/// and tiled frames list (each made on first use, so a set never pays for what it is not used
/// for).
pub(crate) struct GtexUpload {
    atlas: Atlas,
    /// Each patch's heights less the texels another patch owns (owners.rs): what both the
    /// tracer's and the tiles' pieces cover, so a ray walked through either meets one surface.
    owned: OnceLock<Vec<Vec<u16>>>,
    tracing: OnceLock<Tracing>,
    tile_pieces: OnceLock<Pieces>,
    /// Per patch, per pyramid level, the bound on a drawn point's distance to the source mesh
    /// (lod.rs), in the set's units; made on the first frame with `lod`.
    level_bounds: OnceLock<Vec<Vec<f64>>>,
    /// Parallel queries' tiles, one per placement of the set (a scene may hold it several
    /// times), all along the last direction asked for.
    parallel: Mutex<Vec<Arc<ParallelTiles>>>,
    /// Seconds spent making the above and not yet reported in a frame's `setup_ms`.
    unreported_seconds: Mutex<f64>,
}

/// Placements of one set whose parallel tiles are kept (each a few MB at most: the bunny's take
/// 1.2 MB).
const PLACEMENTS_KEPT: usize = 8;

/// A set's tile pieces tiled as seen along one direction (tiles.rs, `parallel`), here and on
/// the GPU, for the rays along it. Each frame's shadow rays toward a directional light are such
/// a query: rebuilding the lists every frame took 4-17 ms of a 512² frame's 150-300 ms shadow
/// pass on the bunny (loaded machine), for the same lists while the light and the set stay put.
struct ParallelTiles {
    /// What the lists depend on: the direction and the set's placement, both in world space.
    direction: DVec3,
    world_from_object: DMat4,
    /// The query frame the lists were built in (the next query's frame may be translated).
    view_from_world: DMat4,
    tiles: TileLists,
    ranges: wgpu::Buffer,
    entries: wgpu::Buffer,
}

/// Pieces of a set's boxes at one pyramid level (boxes.rs), here and on the GPU.
struct Pieces {
    list: Vec<PatchBoxGpu>,
    /// Tile pieces: whether each one's surface spans its whole column (boxes.rs,
    /// `spans_column`); empty for the tracer's pieces.
    spans_column: Vec<bool>,
    buffer: wgpu::Buffer,
}

/// What ray queries walk: pieces and the shape of the hierarchy over them.
struct Tracing {
    pieces: Pieces,
    bvh: Bvh,
}

impl GtexUpload {
    fn new(gpu: &Gpu, set: &GeometryTextureSet) -> Result<GtexUpload> {
        let start = Instant::now();
        let atlas = Atlas::upload(gpu, set)?;
        Ok(GtexUpload {
            atlas,
            owned: OnceLock::new(),
            tracing: OnceLock::new(),
            tile_pieces: OnceLock::new(),
            level_bounds: OnceLock::new(),
            parallel: Mutex::new(Vec::new()),
            unreported_seconds: Mutex::new(start.elapsed().as_secs_f64()),
        })
    }

    /// `make`'s result, its time counted for the next frame's `setup_ms`.
    fn timed<T>(&self, make: impl FnOnce() -> T) -> T {
        let start = Instant::now();
        let made = make();
        *self.unreported() += start.elapsed().as_secs_f64();
        made
    }

    fn unreported(&self) -> std::sync::MutexGuard<'_, f64> {
        (self.unreported_seconds.lock()).unwrap_or_else(|e| e.into_inner())
    }

    /// The one-off setup seconds not yet reported, and none left to report.
    fn take_setup_seconds(&self) -> f64 {
        std::mem::take(&mut *self.unreported())
    }

    fn tracing(&self, gpu: &Gpu, set: &GeometryTextureSet) -> &Tracing {
        self.tracing.get_or_init(|| {
            let pieces = Pieces::new(gpu, set, self.owned(set));
            let bounds: Vec<Aabb> = (pieces.list.iter())
                .map(|b| placed_box(b, &set.patches[b.patch_index as usize].world_from_patch()))
                .collect();
            Tracing {
                bvh: Bvh::build(&bounds),
                pieces,
            }
        })
    }

    fn tile_pieces(&self, gpu: &Gpu, set: &GeometryTextureSet) -> &Pieces {
        self.tile_pieces
            .get_or_init(|| {
                let owned = self.owned(set); // timed on its own, not twice
                self.timed(|| Pieces::for_tiles(gpu, set, owned))
            })
    }

    fn level_bounds(&self, set: &GeometryTextureSet) -> &[Vec<f64>] {
        self.level_bounds.get_or_init(|| {
            self.timed(|| set.patches.par_iter().map(lod::level_bounds).collect())
        })
    }

    fn owned(&self, set: &GeometryTextureSet) -> &[Vec<u16>] {
        self.owned
            .get_or_init(|| self.timed(|| owners::owned_heights(set)))
    }

    /// The tiles for rays along `direction` (unit, in the query frame `view_from_world`) through
    /// the set placed by `world_from_object` (its patches at `view_from_patch`): kept ones made
    /// for the same direction and placement, else new ones (then kept). `None` when no piece
    /// covers the grid.
    fn parallel_tiles(
        &self,
        gpu: &Gpu,
        set: &GeometryTextureSet,
        placing: (DMat4, DMat4, &[DMat4]),
        direction: DVec3,
    ) -> Option<Arc<ParallelTiles>> {
        let (view_from_world, world_from_object, view_from_patch) = placing;
        let world_direction = view_from_world.inverse().transform_vector3(direction);
        let mut kept = self.parallel.lock().unwrap_or_else(|e| e.into_inner());
        let same = |t: &ParallelTiles| {
            t.direction == world_direction && t.world_from_object == world_from_object
        };
        if let Some(found) = kept.iter().find(|t| same(t)) {
            return Some(found.clone());
        }
        // Another direction's tiles serve no query until that light comes back; a scene that
        // places the set more often than PLACEMENTS_KEPT rebuilds some of them per query.
        kept.retain(|t| t.direction == world_direction);
        if kept.len() >= PLACEMENTS_KEPT {
            kept.remove(0);
        }
        let pieces = self.tile_pieces(gpu, set);
        let placements: Vec<Option<DMat4>> = view_from_patch.iter().copied().map(Some).collect();
        let tiles = tiles::parallel(piece_corners(pieces, &placements), direction)?;
        let [_, ranges, entries] = tile_buffers(&gpu.device, &tiles);
        let made = Arc::new(ParallelTiles {
            direction: world_direction,
            world_from_object,
            view_from_world,
            tiles,
            ranges,
            entries,
        });
        kept.push(made.clone());
        Some(made)
    }
}

impl Pieces {
    /// The tracer's pieces (boxes.rs) over the texels each patch owns (owners.rs), cut as the
    /// tiles' are: over every texel, a ray grazing a chart's rim met the overlap ring's copy of
    /// the surface where the tiles met the owner's (pymeshlab's bunny: one parallel ray in
    /// 20,000 landed 0.10 of the diagonal nearer through the hierarchy; trimesh agreed with the
    /// tiles).
    fn new(gpu: &Gpu, set: &GeometryTextureSet, owned: &[Vec<u16>]) -> Pieces {
        let list = per_patch(set, owned, |i, p, heights| {
            patch_boxes(i, p, heights, &owned_pyramid(p, heights))
        });
        Self::upload(gpu, list, Vec::new())
    }

    /// The tiles' pieces (boxes.rs, `tile_pieces`): TILE_LEVEL nodes of each patch's pyramid
    /// over the texels it owns (owners.rs). On the bunny's five headline views (256² maps, 512²,
    /// loaded machine) level 4 (16 texels) started 1.15-1.18 searches per covered pixel, level 5
    /// 1.24-1.31 in about 0.8x the frame time (shorter lists), level 6 1.8-2.0.
    fn for_tiles(gpu: &Gpu, set: &GeometryTextureSet, owned: &[Vec<u16>]) -> Pieces {
        let (list, spans_column): (Vec<PatchBoxGpu>, Vec<bool>) =
            per_patch(set, owned, |i, p, heights| {
                let pyramid = owned_pyramid(p, heights);
                tile_pieces(i, p, heights, &pyramid, TILE_LEVEL, TILE_MIN_THICKNESS)
            })
            .into_iter()
            .unzip();
        Self::upload(gpu, list, spans_column)
    }

    fn upload(gpu: &Gpu, list: Vec<PatchBoxGpu>, spans_column: Vec<bool>) -> Pieces {
        // A set with no surface at all still binds one (empty) piece; it is never searched.
        let contents: &[PatchBoxGpu] = if list.is_empty() {
            &[PatchBoxGpu::zeroed()]
        } else {
            &list
        };
        let buffer = storage_buffer(
            &gpu.device,
            "patch box pieces",
            bytemuck::cast_slice(contents),
        );
        Pieces {
            list,
            spans_column,
            buffer,
        }
    }
}

/// `make`'s pieces of every patch (index, patch, owned heights), made on all cores and listed
/// in patch order, as a serial walk lists them.
fn per_patch<T: Send>(
    set: &GeometryTextureSet,
    owned: &[Vec<u16>],
    make: impl Fn(u32, &Patch, &[u16]) -> Vec<T> + Sync,
) -> Vec<T> {
    let lists: Vec<Vec<T>> = (0..set.patches.len())
        .into_par_iter()
        .map(|i| make(i as u32, &set.patches[i], &owned[i]))
        .collect();
    lists.into_iter().flatten().collect()
}

/// The min-max pyramid of a patch's owned heights (a copy of the patch's geometry with them:
/// its normal, color and face lists are not needed, so not copied).
fn owned_pyramid(p: &Patch, heights: &[u16]) -> Vec<(u32, u32, Vec<u32>)> {
    min_max_pyramid(&Patch {
        heights: heights.to_vec(),
        outline: p.outline.clone(),
        normals: Vec::new(),
        colors: Vec::new(),
        faces: Vec::new(),
        ring_faces: Vec::new(),
        error_bound: None,
        ..*p
    })
}

/// The pyramid level tiles list pieces at (for_tiles).
const TILE_LEVEL: u32 = 4;

/// A tile piece's least thickness, in units of its node's width (a quarter texel at level 4).
const TILE_MIN_THICKNESS: f64 = 1.0 / 64.0;

/// A primary pass and the same shader with its fetch counter switched on.
struct PrimaryPipelines {
    plain: wgpu::RenderPipeline,
    counting: wgpu::RenderPipeline,
}

impl PrimaryPipelines {
    fn pick(&self, count_fetches: bool) -> wgpu::RenderPipeline {
        if count_fetches {
            self.counting.clone()
        } else {
            self.plain.clone()
        }
    }
}

pub(crate) struct GtexKind {
    /// Group 1 of the box pass (gtex_bindings.wgsl).
    layout: wgpu::BindGroupLayout,
    /// Group 1 of the tiled pass (gtex_bindings.wgsl + tiles_bindings.wgsl).
    tiles_layout: wgpu::BindGroupLayout,
    /// Group 1 of ray queries (gtex_bindings.wgsl + gtex_pieces_bindings.wgsl +
    /// gtex_trace_bindings.wgsl).
    trace_layout: wgpu::BindGroupLayout,
    /// Group 1 of parallel ray queries (gtex_bindings.wgsl + gtex_pieces_bindings.wgsl +
    /// tiles_bindings.wgsl).
    tiles_trace_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    boxes: PrimaryPipelines,
    tiles: PrimaryPipelines,
    trace_pipeline: wgpu::ComputePipeline,
    tiles_trace_pipeline: wgpu::ComputePipeline,
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
    lod: LodRule<'a>,
    first_id: i32,
}

/// How a frame picks each patch's level-of-detail stop level.
#[derive(Clone, Copy)]
enum LodRule<'a> {
    /// Exact search (level 0).
    Off,
    /// The level whose nodes are about a pixel wide (cull::lod_level).
    Pixel,
    /// The coarsest level whose bound (per patch, per level, in the set's units, scaled to the
    /// world by `scale`) projects to at most `max_pixels` (cull::bound_lod_level).
    Bound {
        max_pixels: f64,
        level_bounds: &'a [Vec<f64>],
        scale: f64,
    },
}

impl GtexKind {
    pub fn new(context: &KindContext) -> GtexKind {
        let device = &context.gpu.device;
        let (frame_layout, query_layout) = (context.frame_layout, context.query_layout);
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
        let tile_layout_entries = |stages: wgpu::ShaderStages| {
            let reads = stages.difference(wgpu::ShaderStages::VERTEX);
            [7, 9, 10, 11].map(|b| storage_entry(b, if b == 9 { stages } else { reads }, true))
        };
        let tiles_layout = textures_layout(
            device,
            "geometry textures (tiles)",
            VERTEX_AND_FRAGMENT,
            &tile_layout_entries(VERTEX_AND_FRAGMENT),
        );
        let tiles_trace_layout = textures_layout(
            device,
            "geometry textures (parallel rays)",
            compute,
            &tile_layout_entries(compute),
        );
        let tiles_trace_pipeline = compute_pipeline(
            device,
            "gtex_tiles_rays",
            &shaders::gtex_tiles_rays(),
            &[
                Some(frame_layout),
                Some(&tiles_trace_layout),
                Some(query_layout),
            ],
            &[],
        );
        let pipelines = |label: &str, source: String, group: &wgpu::BindGroupLayout, cull| {
            let build = |label: &str, constants: &[(&str, f64)]| {
                RasterPipeline {
                    label,
                    source: source.clone(),
                    layouts: &[Some(frame_layout), Some(group)],
                    vertex_buffers: &[],
                    cull,
                    constants,
                }
                .build(device)
            };
            PrimaryPipelines {
                plain: build(label, &[]),
                counting: build(
                    &format!("{label} (counting fetches)"),
                    &[("COUNT_FETCHES", 1.0)],
                ),
            }
        };
        GtexKind {
            // Back faces of each box: a camera inside a box still gets its fragments.
            boxes: pipelines(
                "gtex_raycast",
                shaders::gtex_raycast(),
                &layout,
                Some(wgpu::Face::Front),
            ),
            tiles: pipelines("gtex_tiles", shaders::gtex_tiles(), &tiles_layout, None),
            tiles_layout,
            tiles_trace_layout,
            tiles_trace_pipeline,
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
                let lod = match (placing.lens, placing.lod) {
                    (Some(lens), LodRule::Pixel) => lod_level(&view_from_patch, p, lens, levels),
                    (Some(lens), LodRule::Bound { max_pixels, level_bounds, scale }) => {
                        let world: Vec<f64> = level_bounds[i].iter().map(|b| b * scale).collect();
                        bound_lod_level(&view_from_patch, lens, &world, max_pixels)
                            .min(levels.saturating_sub(1))
                    }
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

    /// For a ray query in the frame `view_from_world`: the set, its upload, the records of all
    /// its patches (ids continuing from `ids`, which it advances) and each one's
    /// view_from_patch; `None` when the object is not a set or was not uploaded.
    #[allow(clippy::type_complexity)] // the four things every query dispatch of a set starts from
    fn query_records<'a>(
        &'a self,
        view_from_world: DMat4,
        placed: &SceneObject,
        set: &Arc<GeometryTextureSet>,
        ids: &mut Tally,
    ) -> Option<(&'a GtexUpload, Vec<PatchGpu>, Vec<DMat4>)> {
        let upload = self.uploads.get(set)?;
        let placing = Placing {
            view_from_object: view_from_world * placed.world_from_object,
            world_from_object: placed.world_from_object,
            lens: None,
            lod: LodRule::Off,
            first_id: ids.patch_ids,
        };
        ids.patch_ids += set.patches.len() as i32;
        // No lens: every patch is placed (none culled).
        let (records, placements) = Self::records(&placing, set, &upload.atlas);
        Some((upload, records, placements.into_iter().flatten().collect()))
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

/// The stop level of each drawn patch (`records` of a set, in patch order) and its bound, scaled
/// to the world by `scale`.
fn lod_picks<'a>(
    records: &'a [PatchGpu],
    placements: &'a [Option<DMat4>],
    level_bounds: &'a [Vec<f64>],
    scale: f64,
) -> impl Iterator<Item = LodPick> + 'a {
    (records.iter().zip(placements).zip(level_bounds))
        .filter(|((_, placement), _)| placement.is_some())
        .map(move |((record, _), bounds)| {
            let level = record.pyramid_at[3];
            LodPick {
                patch_id: record.ids[1],
                level,
                bound: bounds.get(level as usize).copied().unwrap_or(0.0) * scale,
            }
        })
}

/// The corners of each piece whose patch is placed (by its view_from_patch), with the piece's
/// index.
fn piece_corners<'a>(
    pieces: &'a Pieces,
    placements: &'a [Option<DMat4>],
) -> impl Iterator<Item = (u32, [DVec3; 8])> + 'a {
    (0..).zip(&pieces.list).filter_map(|(k, b)| {
        let view_from_patch = placements[b.patch_index as usize]?;
        let spans = pieces.spans_column.get(k as usize) == Some(&true);
        Some((
            k | if spans { tiles::SPANS_COLUMN } else { 0 },
            tile_piece_corners(b).map(|c| view_from_patch.transform_point3(c)),
        ))
    })
}

/// The buffers of `tiles` (tiles_bindings.wgsl).
fn tile_buffers(device: &wgpu::Device, tiles: &TileLists) -> [wgpu::Buffer; 3] {
    [
        storage_buffer(device, "tiles", bytemuck::bytes_of(&tiles.header)),
        storage_buffer(device, "tile ranges", bytemuck::cast_slice(&tiles.ranges)),
        // Never empty: at least one tile is covered, so it lists a piece.
        storage_buffer(device, "tile entries", bytemuck::cast_slice(&tiles.entries)),
    ]
}

/// Group-1 entries binding `pieces` and the tiles' `buffers` (gtex_pieces_bindings.wgsl,
/// tiles_bindings.wgsl).
fn tile_entries<'a>(
    pieces: &'a Pieces,
    buffers: &'a [wgpu::Buffer; 3],
) -> Vec<(u32, wgpu::BindingResource<'a>)> {
    let [header, ranges, entries] = buffers;
    vec![
        (7, pieces.buffer.as_entire_binding()),
        (9, header.as_entire_binding()),
        (10, ranges.as_entire_binding()),
        (11, entries.as_entire_binding()),
    ]
}

/// Texels a shadow ray starts off its surface (along the normal, and again along the ray), so
/// that it does not hit the surface it starts on (stored twice near chart borders, by the
/// overlap rings). Against embree's shadow rays on the bunny: 2 texels lose 8% of the shadowed
/// pixels (near the terminator), a quarter texel agrees on 99.87–99.89% of the pixels.
const OFFSET_TEXELS: f64 = 0.25;

impl Kind for GtexKind {
    type Payload = GeometryTextureSet;

    fn upload(
        &mut self,
        gpu: &Gpu,
        set: &Arc<GeometryTextureSet>,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<()> {
        self.uploads
            .get_or_upload(set, |s| GtexUpload::new(gpu, s))?;
        for p in &set.patches {
            let view_from_patch = *view_from_object * p.world_from_patch();
            depth.include_box(&view_from_patch, DVec3::ZERO, DVec3::ONE);
        }
        Ok(())
    }

    fn draw_call(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        set: &Arc<GeometryTextureSet>,
        tally: &mut Tally,
    ) -> Option<DrawCall> {
        let upload = self.uploads.get(set)?;
        let scale = largest_singular_value(&placed.world_from_object);
        let level_bounds = frame.search.lod.then(|| upload.level_bounds(set));
        let lod = match (level_bounds, frame.search.lod_bound_pixels) {
            (None, _) => LodRule::Off,
            (Some(_), None) => LodRule::Pixel,
            (Some(level_bounds), Some(p)) => LodRule::Bound {
                max_pixels: f64::from(p),
                level_bounds,
                scale,
            },
        };
        let placing = Placing {
            view_from_object: frame.view_from_world * placed.world_from_object,
            world_from_object: placed.world_from_object,
            lens: Some(frame.lens),
            lod,
            first_id: tally.patch_ids,
        };
        let (records, placements) = Self::records(&placing, set, &upload.atlas);
        if let Some(level_bounds) = level_bounds {
            tally.lod_picks.extend(lod_picks(&records, &placements, level_bounds, scale));
        }
        tally.patch_ids += set.patches.len() as i32;
        tally.texture_bytes += upload.atlas.bytes;
        tally.setup_ms += upload.take_setup_seconds() * 1e3;
        let visible = placements.iter().flatten().count();
        tally.patches_drawn += visible;
        tally.patches_culled += set.patches.len() - visible;
        if visible == 0 {
            return None;
        }
        let device = &gpu.device;
        let count = frame.search.count_fetches;
        if frame.search.primary == Primary::Boxes {
            let drawn: Vec<PatchGpu> = (records.into_iter().zip(&placements))
                .filter_map(|(record, placement)| placement.map(|_| record))
                .collect();
            return Some(DrawCall {
                pipeline: self.boxes.pick(count),
                group: self.bind_group(device, &self.layout, upload, &drawn, vec![]),
                vertex_buffer: None,
                vertices: CUBE_VERTICES,
                instances: drawn.len() as u32,
                compute: None,
            });
        }
        let pieces = upload.tile_pieces(gpu, set);
        tally.setup_ms += upload.take_setup_seconds() * 1e3;
        let tiles = TileLists::build(piece_corners(pieces, &placements), frame.lens, frame.size)?;
        let buffers = tile_buffers(device, &tiles);
        let extra = tile_entries(pieces, &buffers);
        Some(DrawCall {
            pipeline: self.tiles.pick(count),
            group: self.bind_group(device, &self.tiles_layout, upload, &records, extra),
            vertex_buffer: None,
            vertices: RECT_VERTICES,
            instances: 1,
            compute: None,
        })
    }

    fn trace(
        &self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        set: &Arc<GeometryTextureSet>,
        ids: &mut Tally,
    ) -> Result<Option<TraceCall>> {
        let Some((upload, records, view_from_patch)) =
            self.query_records(view_from_world, placed, set, ids)
        else {
            return Ok(None);
        };
        let tracing = upload.tracing(gpu, set);
        if tracing.pieces.list.is_empty() {
            return Ok(None);
        }
        let bounds: Vec<Aabb> = (tracing.pieces.list.iter())
            .map(|b| placed_box(b, &view_from_patch[b.patch_index as usize]))
            .collect();
        let nodes = tracing.bvh.refit(&bounds);
        let device = &gpu.device;
        let nodes = storage_buffer(device, "piece hierarchy", bytemuck::cast_slice(&nodes));
        let extra = vec![
            (6, nodes.as_entire_binding()),
            (7, tracing.pieces.buffer.as_entire_binding()),
        ];
        let group = self.bind_group(device, &self.trace_layout, upload, &records, extra);
        let pipeline = self.trace_pipeline.clone();
        Ok(Some(TraceCall::within(pipeline, group, &bounds)))
    }

    /// Parallel rays walk tiles seen along their direction (tiles.rs, `parallel`) instead of
    /// the hierarchy: each ray stays in one tile. The tiles are kept for the next query along
    /// the same direction through the set in the same place (the next frame's shadow rays).
    fn trace_parallel(
        &self,
        gpu: &Gpu,
        view_from_world: DMat4,
        placed: &SceneObject,
        set: &Arc<GeometryTextureSet>,
        ids: &mut Tally,
        direction: DVec3,
    ) -> Result<Option<TraceCall>> {
        let Some((upload, records, view_from_patch)) =
            self.query_records(view_from_world, placed, set, ids)
        else {
            return Ok(None);
        };
        let placing = (
            view_from_world,
            placed.world_from_object,
            &view_from_patch[..],
        );
        let Some(kept) = upload.parallel_tiles(gpu, set, placing, direction) else {
            return Ok(None);
        };
        let header = (kept.tiles).header_for(kept.view_from_world * view_from_world.inverse());
        let buffers = [
            storage_buffer(&gpu.device, "tiles", bytemuck::bytes_of(&header)),
            kept.ranges.clone(),
            kept.entries.clone(),
        ];
        let extra = tile_entries(upload.tile_pieces(gpu, set), &buffers);
        let group = self.bind_group(
            &gpu.device,
            &self.tiles_trace_layout,
            upload,
            &records,
            extra,
        );
        Ok(Some(TraceCall {
            pipeline: self.tiles_trace_pipeline.clone(),
            group,
            reaches: kept.tiles.reaches(&header),
        }))
    }

    /// A quarter texel: see `OFFSET_TEXELS`.
    fn shadow_offset(&self, set: &GeometryTextureSet, scale: f64) -> f64 {
        OFFSET_TEXELS * set.texel_size * scale
    }

    fn purge(&mut self) {
        self.uploads.purge();
    }
}
