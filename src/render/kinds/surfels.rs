//! Surfel hierarchies (src/surfels/), drawn as point splats in three compute passes before the
//! scene pass and one resolve draw inside it:
//! 1. cull (surfels_cull.wgsl): per tile and per node above the tiles, frustum test and a cut
//!    of each patch's quadtree by projected error against `max_pixel_error` (a share of it where
//!    a silhouette may show); the chosen surfels are appended to a list;
//! 2. dispatch arguments (surfels_args.wgsl): the list's length → indirect workgroup counts;
//! 3. splat: each listed surfel's disc, ray-intersected per pixel, into a visibility buffer by
//!    64-bit atomicMax of (reversed-Z depth, index) where the device has 64-bit atomics, else in
//!    two 32-bit passes (nearest depth, then the index at that depth), chosen when the renderer
//!    is made;
//! 4. resolve (surfels_resolve.wgsl), in the scene pass: the winning disc's depth (frag_depth,
//!    so the shared reversed-Z test composites surfels with meshes and texture sets), normal,
//!    color and patch id; holes inside the surface filled from a neighbour.
//!
//! Spaces: the hierarchy's object space (positions stored relative to its bounding box centre,
//! f32), view (camera-relative, composed in f64) and framebuffer pixels.

use std::sync::Arc;
use glam::{DMat3, DMat4, DVec3};
use wgpu::util::DeviceExt;

use super::{bind_buffers, ComputeStep, ComputeWork, Dispatch, DrawCall, FrameView, Kind, KindContext, Tally, UploadCache};
use crate::error::{GeomtexError, Result};
use crate::render::camera::Lens;
use crate::render::cull::{box_corners, DepthRange};
use crate::render::device::Gpu;
use crate::render::gpu_types::{
    gpu_matrix, normal_matrix, SurfelGpu, SurfelNodeGpu, SurfelObjectGpu, SurfelTileGpu,
};
use crate::render::pipelines::{
    compute_pipeline, storage_entry, uniform_entry, RasterPipeline, VERTEX_AND_FRAGMENT,
};
use crate::render::scene::SceneObject;
use crate::render::shaders::{self, SurfelPass};
use crate::surfel_data::SurfelHierarchy;

/// u32 slots of the tally buffer (TALLY_SLOTS in surfels_types.wgsl).
pub(crate) const TALLY_SLOTS: usize = 16;
/// Where the counts start in the tally: drawn, tiles in view, finest surfels of those tiles,
/// then one count per level (surfels_types.wgsl).
pub(crate) const TALLY_DRAWN: usize = 0;
/// The tally's slot of node surfels (TALLY_NODES in surfels_types.wgsl).
pub(crate) const TALLY_NODES: usize = 10;
const SPLAT_GROUP: u32 = 64;

/// One hierarchy on the GPU.
struct UploadedSurfels {
    tiles: wgpu::Buffer,
    nodes: wgpu::Buffer,
    surfels: wgpu::Buffer,
    patches: wgpu::Buffer,
    clips: wgpu::Buffer,
    patch_frames: wgpu::Buffer,
    tile_count: u32,
    node_count: u32,
    /// Finest-level surfels: the most any frame can list.
    finest: u32,
    /// Positions are stored relative to this point (object space, f64).
    centre: DVec3,
    lo: DVec3,
    hi: DVec3,
}

pub(crate) struct SurfelsKind {
    compute_layout: wgpu::BindGroupLayout,
    visibility_layout: wgpu::BindGroupLayout,
    resolve_layout: wgpu::BindGroupLayout,
    cull: wgpu::ComputePipeline,
    args: wgpu::ComputePipeline,
    /// One 64-bit pass, or the 32-bit fallback's two.
    splat: Vec<wgpu::ComputePipeline>,
    resolve: wgpu::RenderPipeline,
    /// Each hierarchy's pieces (one unless it is larger than a storage binding).
    uploads: UploadCache<SurfelHierarchy, Vec<UploadedSurfels>>,
}

fn layout(
    device: &wgpu::Device,
    label: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries,
    })
}

impl SurfelsKind {
    pub fn new(context: &KindContext) -> SurfelsKind {
        let (device, frame_layout) = (&context.gpu.device, context.frame_layout);
        let int64_atomics = context.gpu.int64_atomics;
        let c = wgpu::ShaderStages::COMPUTE;
        let compute_layout = layout(
            device,
            "surfels compute",
            &[
                uniform_entry(0, c),
                storage_entry(1, c, true),
                storage_entry(2, c, true),
                storage_entry(3, c, false),
                storage_entry(4, c, false),
                storage_entry(5, c, true),
                storage_entry(6, c, true),
                storage_entry(7, c, true),
                storage_entry(8, c, true),
            ],
        );
        let visibility_layout = layout(device, "surfels visibility", &[storage_entry(0, c, false)]);
        let f = wgpu::ShaderStages::FRAGMENT;
        let resolve_layout = layout(
            device,
            "surfels resolve",
            &[
                uniform_entry(0, VERTEX_AND_FRAGMENT),
                storage_entry(1, f, true),
                storage_entry(2, f, true),
                storage_entry(3, f, true),
            ],
        );
        let layouts = [
            Some(frame_layout),
            Some(&compute_layout),
            Some(&visibility_layout),
        ];
        let pipeline = |pass: SurfelPass, label: &str| {
            let source = shaders::surfels_compute(pass);
            compute_pipeline(device, label, &source, &layouts, &[])
        };
        let splat = if int64_atomics {
            vec![pipeline(SurfelPass::Splat64, "surfels_splat64")]
        } else {
            vec![
                pipeline(SurfelPass::SplatDepth32, "surfels_splat_depth32"),
                pipeline(SurfelPass::SplatId32, "surfels_splat_id32"),
            ]
        };
        let resolve = RasterPipeline {
            label: "surfels_resolve",
            source: shaders::surfels_resolve(),
            layouts: &[Some(frame_layout), Some(&resolve_layout)],
            vertex_buffers: &[],
            cull: None,
            constants: &[],
        }
        .build(device);
        SurfelsKind {
            cull: pipeline(SurfelPass::Cull, "surfels_cull"),
            args: pipeline(SurfelPass::Args, "surfels_args"),
            splat,
            resolve,
            compute_layout,
            visibility_layout,
            resolve_layout,
            uploads: UploadCache::default(),
        }
    }
}

fn storage(device: &wgpu::Device, label: &str, contents: &[u8]) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage: wgpu::BufferUsages::STORAGE,
    })
}

/// The hierarchy's records, in pieces of whole patches where its surfels would take more than
/// one storage binding holds (a 4.7M-surfel set takes 150 MB against lavapipe's 128 MiB).
fn upload_pieces(gpu: &Gpu, h: &SurfelHierarchy) -> Result<Vec<UploadedSurfels>> {
    let limit = gpu.device.limits().max_storage_buffer_binding_size as usize;
    let most = limit / std::mem::size_of::<SurfelGpu>();
    if h.surfels.len() + h.nodes.len() <= most {
        return Ok(vec![upload(gpu, h)]);
    }
    Ok(h.pieces(most)?.iter().map(|p| upload(gpu, p)).collect())
}

/// The hierarchy's records, positions relative to its centre.
fn upload(gpu: &Gpu, h: &SurfelHierarchy) -> UploadedSurfels {
    let (lo, hi) = h.bounds();
    let centre = 0.5 * (lo + hi);
    let tiles: Vec<SurfelTileGpu> = h
        .tiles
        .iter()
        .map(|t| {
            let mut error = [0.0f32; 8];
            let mut start = [0u32; 8];
            let mut cone_angle = [0.0f32; 8];
            for (e, v) in error.iter_mut().zip(&t.error) {
                *e = *v as f32;
            }
            for (a, (_, v)) in cone_angle.iter_mut().zip(&t.cone) {
                *a = *v as f32;
            }
            for (s, v) in start.iter_mut().zip(&t.start) {
                *s = *v;
            }
            let c = (t.centre - centre).as_vec3();
            SurfelTileGpu {
                sphere: [c.x, c.y, c.z, t.bound as f32],
                error,
                start,
                info: [h.levels, t.patch, t.parent, 0],
                cone_axis: cone_record(t.cone[0]),
                cone_angle,
            }
        })
        .collect();
    let first_node = h.surfels.len() as u32;
    let nodes: Vec<SurfelNodeGpu> = (h.nodes.iter().enumerate())
        .map(|(k, n)| {
            let c = (n.centre - centre).as_vec3();
            SurfelNodeGpu {
                sphere: [c.x, c.y, c.z, n.bound as f32],
                cone: cone_record(n.cone),
                error: n.error as f32,
                surfel: first_node + k as u32,
                parent: n.parent,
                level: n.surfel.level as u32,
            }
        })
        .collect();
    let surfel_record = |s: &crate::surfel_data::Surfel| SurfelGpu {
        position: (s.position - centre).as_vec3().to_array(),
        radius: s.radius as f32,
        normal: s.normal.as_vec3().to_array(),
        color: u32::from_le_bytes(s.color),
    };
    let surfels: Vec<SurfelGpu> = (h.surfels.iter())
        .chain(h.nodes.iter().map(|n| &n.surfel))
        .map(surfel_record)
        .collect();
    let patches: Vec<u32> = h
        .surfel_tiles()
        .into_iter()
        .map(|t| h.tiles[t].patch)
        .chain(h.nodes.iter().map(|n| n.patch))
        .collect();
    let clips = clip_boxes(h);
    let frames: Vec<[f32; 8]> = (h.source.patches.iter())
        .flat_map(|p| {
            let u = p.axes[0] * (p.width as f64 / p.extent.x);
            let v = p.axes[1] * (p.height as f64 / p.extent.y);
            let (u0, v0) = (u.dot(centre - p.origin), v.dot(centre - p.origin));
            [[u.x, u.y, u.z, u0, v.x, v.y, v.z, v0].map(|x| x as f32)]
        })
        .collect();
    let device = &gpu.device;
    let node_count = nodes.len() as u32;
    let mut node_records = nodes;
    // A zero-length binding is invalid: one unused record where there are no nodes.
    if node_records.is_empty() {
        node_records.push(bytemuck::Zeroable::zeroed());
    }
    UploadedSurfels {
        tiles: storage(device, "surfel tiles", bytemuck::cast_slice(&tiles)),
        nodes: storage(device, "surfel nodes", bytemuck::cast_slice(&node_records)),
        surfels: storage(device, "surfels", bytemuck::cast_slice(&surfels)),
        patches: storage(device, "surfel patches", bytemuck::cast_slice(&patches)),
        clips: storage(device, "surfel clips", bytemuck::cast_slice(&clips)),
        patch_frames: storage(device, "surfel patch frames", bytemuck::cast_slice(&frames)),
        tile_count: tiles.len() as u32,
        node_count,
        finest: h.per_level()[0] as u32,
        centre,
        lo,
        hi,
    }
}

/// Per surfel (tiles' then nodes'), the box of texels it is clipped to (u0, v0, u1, v1 in its
/// patch's texel grid): its texels, wider by half a texel, so neighbouring discs tilted against
/// each other leave no crack on their shared edge. (Not by the level's error as well: on a
/// chart's rim that margin grew the outline, bunny IoU 0.9826 against 0.9858 at 1/16 of the
/// image height, and the hole fill closes what cracks remain: none measured.)
fn clip_boxes(h: &SurfelHierarchy) -> Vec<[f32; 4]> {
    let boxed = |s: &crate::surfel_data::Surfel| {
        let t = s.texels.map(|v| v as f32);
        [t[0] - 0.5, t[1] - 0.5, t[2] + 0.5, t[3] + 0.5]
    };
    let tiles = h.surfels.iter().map(boxed);
    tiles
        .chain(h.nodes.iter().map(|n| boxed(&n.surfel)))
        .collect()
}

/// A cone (unit axis, half angle) as the shaders take it, in f32.
fn cone_record((axis, angle): (DVec3, f64)) -> [f32; 4] {
    let a = axis.as_vec3();
    [a.x, a.y, a.z, angle as f32]
}

/// The frustum's four side planes in view space (inside where n·p + d >= 0), from the pixel
/// rays at the image's edges.
fn frustum_planes(lens: &Lens, width: u32, height: u32) -> [[f32; 4]; 4] {
    let r = lens.ray;
    let xs = [r[2], width as f64 * r[0] + r[2]];
    let ys = [r[3], height as f64 * r[1] + r[3]];
    let (xl, xr) = (xs[0].min(xs[1]), xs[0].max(xs[1]));
    let (yl, yr) = (ys[0].min(ys[1]), ys[0].max(ys[1]));
    let plane = |n: DVec3, d: f64| {
        let len = n.length();
        [n.x / len, n.y / len, n.z / len, d / len].map(|v| v as f32)
    };
    if lens.orthographic {
        [
            plane(DVec3::X, -xl),
            plane(-DVec3::X, xr),
            plane(DVec3::Y, -yl),
            plane(-DVec3::Y, yr),
        ]
    } else {
        // x / -z >= xl  <=>  x + xl z >= 0, and so on.
        [
            plane(DVec3::new(1.0, 0.0, xl), 0.0),
            plane(DVec3::new(-1.0, 0.0, -xr), 0.0),
            plane(DVec3::new(0.0, 1.0, yl), 0.0),
            plane(DVec3::new(0.0, -1.0, -yr), 0.0),
        ]
    }
}

/// The hierarchy's bounding box projected to normalized device coordinates (lowest, highest
/// corner), unclipped; None when a corner lies behind the eye.
fn projected_box(
    lens: &Lens,
    view_from_object: DMat4,
    u: &UploadedSurfels,
) -> Option<(glam::DVec2, glam::DVec2)> {
    let clip_from_object = lens.clip_from_view * view_from_object;
    let mut lo = glam::DVec2::splat(f64::INFINITY);
    let mut hi = glam::DVec2::splat(f64::NEG_INFINITY);
    for corner in box_corners(u.lo, u.hi) {
        let c = clip_from_object * corner.extend(1.0);
        if c.w <= 0.0 {
            return None;
        }
        let ndc = c.truncate().truncate() / c.w;
        lo = lo.min(ndc);
        hi = hi.max(ndc);
    }
    Some((lo, hi))
}

/// The hierarchy's bounding box on screen in normalized device coordinates (x0, y0, x1, y1),
/// two pixels wider on every side (hole filling reads neighbours); the whole image when a corner
/// lies behind the eye.
fn screen_rect(box_ndc: Option<(glam::DVec2, glam::DVec2)>, size: [u32; 2]) -> [f32; 4] {
    let Some((lo, hi)) = box_ndc else {
        return [-1.0, -1.0, 1.0, 1.0];
    };
    let margin = glam::DVec2::new(4.0 / size[0] as f64, 4.0 / size[1] as f64);
    let lo = (lo - margin).clamp(glam::DVec2::splat(-1.0), glam::DVec2::splat(1.0));
    let hi = (hi + margin).clamp(glam::DVec2::splat(-1.0), glam::DVec2::splat(1.0));
    [lo.x, lo.y, hi.x, hi.y].map(|v| v as f32)
}

/// Pixels of image height per share of max_pixel_error an outline may move: a model S pixels
/// across (its box's longer projected side, at most the image's) may move its outline by
/// S / OUTLINE_PIXELS of max_pixel_error, never less than SILHOUETTE_SHARE of it. Coverage
/// lost to an outline moved by d pixels is about (outline pixels x d) / (covered pixels),
/// which for a given shape falls as d / S: holding d to a share of S keeps that loss the same
/// at every distance, where one fixed share (the one a model 1/16 of a 512² image tall needs)
/// held near models' rims at their finest levels (the Stanford bunny at 256 texels, 1/2 of a
/// 512² image tall: 56,641 surfels drawn against 26,576 with this share; at 192 texels, full
/// frame, 3.6x the 1.1 M-face bunny's count against 1.27x with it). With 1024 both bunnies
/// keep an IoU of at least 0.992, depth p99 under 0.9 px and no holes against trimesh from full
/// frame to 1/16 (bench/surfels.py); 512 let the bunny's IoU fall to 0.989 at 1/2 (on its
/// error-driven set).
const OUTLINE_PIXELS: f64 = 1024.0;
/// The least share of max_pixel_error an outline may move (SILHOUETTE_SHARE in
/// surfels_types.wgsl's words): a model 1/16 of a 512² image tall (a ~130-pixel outline) kept
/// IoU 0.990 with 1/16 and 0.977 with 1/8.
const MIN_OUTLINE_SHARE: f64 = 0.0625;

/// The share of max_pixel_error a tile or node that may show a silhouette is held to.
fn outline_share(box_ndc: Option<(glam::DVec2, glam::DVec2)>, size: [u32; 2]) -> f64 {
    let image = size[0].max(size[1]) as f64;
    let across = box_ndc.map_or(image, |(lo, hi)| {
        let px = (hi - lo) * glam::DVec2::new(size[0] as f64, size[1] as f64) * 0.5;
        px.x.max(px.y).min(image)
    });
    (across / OUTLINE_PIXELS).clamp(MIN_OUTLINE_SHARE, 1.0)
}

/// This frame's buffers of one object: the chosen list, the tally, the splat passes' indirect
/// arguments and the visibility buffer.
struct FrameBuffers {
    chosen: wgpu::Buffer,
    tally: wgpu::Buffer,
    dispatch: wgpu::Buffer,
    visibility: wgpu::Buffer,
}

fn frame_buffers(device: &wgpu::Device, u: &UploadedSurfels, pixels: u64) -> FrameBuffers {
    let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::STORAGE | usage,
            mapped_at_creation: false,
        })
    };
    let none = wgpu::BufferUsages::empty();
    // New buffers are zeroed: an empty list, a zero tally, no pixel covered.
    FrameBuffers {
        // A cut lists at most one surfel per finest one; nodes on top for rounding's sake.
        chosen: buffer(
            "surfels chosen",
            4 * (u.finest + u.node_count).max(1) as u64,
            none,
        ),
        tally: buffer(
            "surfels tally",
            4 * TALLY_SLOTS as u64,
            wgpu::BufferUsages::COPY_SRC,
        ),
        dispatch: buffer("surfels dispatch", 12, wgpu::BufferUsages::INDIRECT),
        visibility: buffer("surfels visibility", 8 * pixels, none),
    }
}

impl SurfelsKind {
    /// The object's record for this frame.
    fn record(
        &self,
        frame: &FrameView,
        placed: &SceneObject,
        u: &UploadedSurfels,
        first_id: i32,
    ) -> SurfelObjectGpu {
        let view_from_object = frame.view_from_world * placed.world_from_object;
        let view_from_local = view_from_object * DMat4::from_translation(u.centre);
        let linear = DMat3::from_mat4(view_from_object);
        let scale = [linear.x_axis, linear.y_axis, linear.z_axis]
            .iter()
            .map(|a| a.length())
            .fold(0.0, f64::max);
        let [width, height] = frame.size;
        let box_ndc = projected_box(frame.lens, view_from_object, u);
        SurfelObjectGpu {
            view_from_object: gpu_matrix(view_from_local),
            world_normal_from_object: normal_matrix(DMat3::from_mat4(placed.world_from_object)),
            planes: frustum_planes(frame.lens, width, height),
            params: [
                frame.search.max_pixel_error,
                frame.lens.ray[1].abs() as f32,
                scale as f32,
                outline_share(box_ndc, frame.size) as f32,
            ],
            sizes: [width, height, first_id.max(0) as u32, u.tile_count],
            rect: screen_rect(box_ndc, frame.size),
            counts: [u.node_count, 0, 0, 0],
        }
    }

    /// The cull, arguments and splat passes of one object.
    fn compute_work(
        &self,
        device: &wgpu::Device,
        u: &UploadedSurfels,
        uniform: &wgpu::Buffer,
        buffers: &FrameBuffers,
    ) -> ComputeWork {
        let group = bind_buffers(
            device,
            "surfels",
            &self.compute_layout,
            &[
                uniform,
                &u.tiles,
                &u.surfels,
                &buffers.chosen,
                &buffers.tally,
                &u.nodes,
                &u.clips,
                &u.patches,
                &u.patch_frames,
            ],
        );
        // Group 2 is one writable buffer in every pass: the arguments, then the visibility.
        let arguments = bind_buffers(
            device,
            "surfels",
            &self.visibility_layout,
            &[&buffers.dispatch],
        );
        let visibility = bind_buffers(
            device,
            "surfels",
            &self.visibility_layout,
            &[&buffers.visibility],
        );
        let mut steps = vec![
            ComputeStep {
                pipeline: self.cull.clone(),
                groups: vec![group.clone(), arguments.clone()],
                dispatch: Dispatch::Groups([
                    (u.tile_count + u.node_count).div_ceil(SPLAT_GROUP).max(1),
                    1,
                    1,
                ]),
            },
            ComputeStep {
                pipeline: self.args.clone(),
                groups: vec![group.clone(), arguments],
                dispatch: Dispatch::Groups([1, 1, 1]),
            },
        ];
        steps.extend(self.splat.iter().map(|pipeline| ComputeStep {
            pipeline: pipeline.clone(),
            groups: vec![group.clone(), visibility.clone()],
            dispatch: Dispatch::Indirect(buffers.dispatch.clone()),
        }));
        ComputeWork {
            steps,
            tally: buffers.tally.clone(),
        }
    }

    /// One piece's draw: its cull, arguments and splat passes, and its resolve draw.
    fn piece_draw(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        u: &UploadedSurfels,
        first_id: i32,
    ) -> DrawCall {
        let device = &gpu.device;
        let record = self.record(frame, placed, u, first_id);
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("surfel object"),
            contents: bytemuck::bytes_of(&record),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let [width, height] = frame.size;
        let buffers = frame_buffers(device, u, width as u64 * height as u64);
        let compute = self.compute_work(device, u, &uniform, &buffers);
        let group = bind_buffers(
            device,
            "surfels",
            &self.resolve_layout,
            &[&uniform, &u.surfels, &u.patches, &buffers.visibility],
        );
        DrawCall {
            pipeline: self.resolve.clone(),
            group,
            vertex_buffer: None,
            vertices: 6,
            instances: 1,
            compute: Some(compute),
        }
    }
}

impl Kind for SurfelsKind {
    type Payload = SurfelHierarchy;

    fn upload(
        &mut self,
        gpu: &Gpu,
        h: &Arc<SurfelHierarchy>,
        view_from_object: &DMat4,
        depth: &mut DepthRange,
    ) -> Result<()> {
        let pieces = self.uploads.get_or_upload(h, |h| upload_pieces(gpu, h))?;
        for u in pieces.iter().filter(|u| u.tile_count > 0) {
            depth.include_box(view_from_object, u.lo, u.hi);
        }
        Ok(())
    }

    /// Not asked: surfels override `draw`, which makes one call per piece.
    fn draw_call(
        &self,
        _gpu: &Gpu,
        _frame: &FrameView,
        _placed: &SceneObject,
        _h: &Arc<SurfelHierarchy>,
        _tally: &mut Tally,
    ) -> Option<DrawCall> {
        None
    }

    fn draw(
        &self,
        gpu: &Gpu,
        frame: &FrameView,
        placed: &SceneObject,
        h: &Arc<SurfelHierarchy>,
        tally: &mut Tally,
    ) -> Vec<DrawCall> {
        let Some(pieces) = self.uploads.get(h) else {
            return Vec::new();
        };
        // Every piece numbers its patches as the whole set does.
        let first_id = tally.patch_ids;
        tally.patch_ids += h.source.patches.len() as i32;
        (pieces.iter().filter(|u| u.tile_count > 0))
            .map(|u| self.piece_draw(gpu, frame, placed, u, first_id))
            .collect()
    }

    fn trace(
        &self,
        _gpu: &Gpu,
        _view_from_world: DMat4,
        _placed: &SceneObject,
        _h: &Arc<SurfelHierarchy>,
        _ids: &mut super::Tally,
    ) -> Result<Option<super::TraceCall>> {
        Err(GeomtexError::Parameter(
            "ray queries through surfels are not supported; query the texture set they were \
             built from"
                .into(),
        ))
    }

    /// Surfels receive shadows but do not cast them (the tracer does not trace them).
    fn casts_shadows(&self) -> bool {
        false
    }

    fn shadow_offset(&self, _h: &SurfelHierarchy, _scale: f64) -> f64 {
        0.0
    }

    fn purge(&mut self) {
        self.uploads.purge();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::camera::Camera;

    /// The view ray through pixel position (px, py) (edges at integers), as camera_ray builds it.
    fn ray_point(lens: &Lens, px: f64, py: f64, depth: f64) -> DVec3 {
        let a = [
            px * lens.ray[0] + lens.ray[2],
            py * lens.ray[1] + lens.ray[3],
        ];
        if lens.orthographic {
            DVec3::new(a[0], a[1], -depth)
        } else {
            DVec3::new(a[0], a[1], -1.0) * depth
        }
    }

    fn side(plane: [f32; 4], p: DVec3) -> f64 {
        let [x, y, z, d] = plane.map(f64::from);
        x * p.x + y * p.y + z * p.z + d
    }

    /// The frustum planes pass through the image's edge rays and hold its centre ray inside,
    /// for both projections.
    #[test]
    fn frustum_planes_bound_the_image() {
        let (w, h) = (320u32, 200u32);
        let perspective = Camera::look_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 50.0);
        let ortho = Camera::orthographic(DMat4::IDENTITY, 3.0);
        for camera in [perspective.unwrap(), ortho.unwrap()] {
            let lens = camera.lens(w, h, 1.0, 10.0).unwrap();
            let planes = frustum_planes(&lens, w, h);
            let (w, h) = (w as f64, h as f64);
            for depth in [1.0, 7.0] {
                let centre = ray_point(&lens, w / 2.0, h / 2.0, depth);
                assert!(planes.iter().all(|&p| side(p, centre) > 0.0));
                let edges = [(0.0, h / 2.0), (w, h / 2.0), (w / 2.0, 0.0), (w / 2.0, h)];
                for (px, py) in edges {
                    let on_edge = ray_point(&lens, px, py, depth);
                    let nearest = planes
                        .iter()
                        .map(|&p| side(p, on_edge).abs())
                        .fold(f64::MAX, f64::min);
                    assert!(nearest < 1e-5 * depth, "{nearest}");
                    assert!(planes.iter().all(|&p| side(p, on_edge) > -1e-5 * depth));
                }
                let outside = ray_point(&lens, -0.1 * w, h / 2.0, depth);
                assert!(planes.iter().any(|&p| side(p, outside) < 0.0));
            }
        }
    }

    /// The outline share follows the box's longer side on screen: the floor for a small model,
    /// proportional in between, capped where the box passes the image or the eye.
    #[test]
    fn outline_share_follows_the_size_on_screen() {
        let size = [512, 256];
        let box_of = |w: f64, h: f64| Some((glam::DVec2::ZERO, glam::DVec2::new(w, h)));
        // 2/512 of the width (half the NDC span of 2 per image side): 2 pixels across.
        let share = outline_share(box_of(2.0 / 256.0, 0.0), size);
        assert_eq!(share, MIN_OUTLINE_SHARE);
        // Half the image's height (128 px) and a quarter of its width (128 px): 128 px.
        let share = outline_share(box_of(0.5, 1.0), size);
        assert!((share - 128.0 / OUTLINE_PIXELS).abs() < 1e-12, "{share}");
        // Larger than the image, or behind the eye: the image's longer side.
        let whole = 512.0 / OUTLINE_PIXELS;
        assert!((outline_share(box_of(40.0, 40.0), size) - whole).abs() < 1e-12);
        assert!((outline_share(None, size) - whole).abs() < 1e-12);
    }
}
