//! Ray queries: the nearest hit (or any hit) of many rays against a scene's texture sets and
//! meshes, traced on the GPU through each object's hierarchy (over the pieces of a set's patch
//! boxes, kinds/gtex; over a mesh's triangles, kinds/mesh.rs) by the shared walk
//! (trace_functions.wgsl), object after object, in batches under the adapter's binding and
//! dispatch limits.
//!
//! Spaces: rays come in world space (f64). The query's frame is world space translated by the
//! rays' mean origin, so f32 coordinates stay small near the rays; t is the distance along each
//! ray's unit direction, in world units.

use glam::{DMat4, DVec3};
use rayon::prelude::*;
use wgpu::util::DeviceExt;

use super::camera::check_view_distance;
use super::device::guarded;
use super::gpu_types::{QueryGpu, QueryHitGpu, QueryRayGpu};
use super::kinds::{bind_buffers, storage_buffer, Tally, TestRay, TraceCall};
use super::pipelines::storage_entry;
use super::{Renderer, Scene, SearchOptions};
use crate::cancel::Cancel;
use crate::error::{GeomtexError, Result};
use crate::profile;

/// Rays per batch of a query: 2 MiB of rays and of hits, far under every adapter's binding
/// limit, and short enough on a software adapter (about half a second) that the cancel token,
/// checked between batches, answers Ctrl-C within a second.
const BATCH: usize = 1 << 16;

/// Invocations per workgroup (gtex_trace_rays.wgsl).
const WORKGROUP: u32 = 64;

/// The record of a ray no object hit (id -1; its t is then unused).
const MISS: QueryHitGpu = QueryHitGpu {
    normal: [0.0; 3],
    t: 0.0,
    id: -1,
    _pad: [0; 3],
};

/// The rays of a batch that some object's test keeps (`kept`, in order, as indices into the
/// batch), and where each ray of the batch sits among them (`slot`; `u32::MAX` for a ray no test
/// keeps).
struct Compact {
    kept: Vec<u32>,
    slot: Vec<u32>,
}

impl Compact {
    /// From the rays (indices into a batch of `rays`) each object's test keeps.
    fn new(rays: usize, reached: &[Vec<u32>]) -> Compact {
        let mut slot = vec![u32::MAX; rays];
        // 0 marks a kept ray until the pass below numbers the kept rays in order.
        for &i in reached.iter().flatten() {
            slot[i as usize] = 0;
        }
        let mut kept = Vec::with_capacity(reached.iter().map(Vec::len).max().unwrap_or(0));
        for (i, s) in slot.iter_mut().enumerate() {
            if *s == 0 {
                *s = kept.len() as u32;
                kept.push(i as u32);
            }
        }
        Compact { kept, slot }
    }

    /// The hits of the whole batch of `rays` from those of the kept rays: a miss for the rest.
    fn expand(&self, found: &[QueryHitGpu], rays: usize) -> Vec<QueryHitGpu> {
        let mut hits = vec![MISS; rays];
        for (&i, hit) in self.kept.iter().zip(found) {
            hits[i as usize] = *hit;
        }
        hits
    }
}

/// What a batch asks of each ray (query_types.wgsl's `counts.y` and `counts.w`).
#[derive(Clone, Copy, PartialEq)]
enum Ask {
    /// The nearest hit, its distance, patch and normal.
    Nearest,
    /// The first hit found, its distance, patch and normal.
    AnyHit,
    /// Whether anything is hit (shadow rays): the first hit found, its normal left unread.
    Blocked,
}

/// A ray (world-space start, unit direction) and the stretch of t along it that counts.
pub(crate) type RangedRay = ((DVec3, DVec3), (f64, f64));

/// What a query found, per ray.
pub struct RayHits {
    /// Distance to the hit along the ray's unit direction; +inf for a miss.
    pub distance: Vec<f64>,
    /// Patch id (0.. across the scene's texture sets in order), -2 - k for the scene's k-th mesh
    /// (as in frames); -1 for a miss.
    pub patch_id: Vec<i32>,
    /// World-space unit normal at the hit (xyz per ray); 0 for a miss.
    pub normal: Vec<f32>,
}

/// Group 2 of ray queries (query_bindings.wgsl).
pub(crate) fn query_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let compute = wgpu::ShaderStages::COMPUTE;
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("ray query"),
        entries: &[
            storage_entry(0, compute, true),
            storage_entry(1, compute, true),
            storage_entry(2, compute, false),
            storage_entry(3, compute, true),
        ],
    })
}

/// The direction every ray runs along, when they all share one (shadow rays toward a
/// directional light; the query's frame only translates, so it is the same there).
fn shared_direction(rays: &[(DVec3, DVec3)]) -> Option<DVec3> {
    let first = rays.first()?.1;
    rays.iter().all(|r| r.1 == first).then_some(first)
}

/// The stretch of t that counts for ray `i`: its own where `ranges` are given, else all of it.
fn stretch(ranges: Option<&[(f64, f64)]>, i: usize) -> (f64, f64) {
    ranges.map_or((0.0, f64::from(f32::MAX)), |r| r[i])
}

/// Unit directions, or an error naming the first ray that has no direction or is not finite.
/// Checked in parallel: a million rays is a common query, and a real GPU traces them in less
/// time than one core takes to prepare them.
pub(crate) fn checked_rays(rays: &[(DVec3, DVec3)]) -> Result<Vec<(DVec3, DVec3)>> {
    check_rays(rays)?;
    Ok(rays.par_iter().map(|&(o, d)| unit_ray(o, d)).collect())
}

/// An error naming the first ray whose origin or direction is not finite or whose direction
/// is zero (what `checked_rays` refuses), found without copying the rays.
pub(crate) fn check_rays(rays: &[(DVec3, DVec3)]) -> Result<()> {
    let usable = |&(o, d): &(DVec3, DVec3)| {
        let length = d.length();
        o.is_finite() && d.is_finite() && length > 0.0 && length.is_finite()
    };
    match rays.par_iter().position_first(|r| !usable(r)) {
        Some(i) => {
            let (o, d) = rays[i];
            Err(GeomtexError::Parameter(format!(
                "ray {i}: origin {o:?} and direction {d:?} must be finite and the direction non-zero"
            )))
        }
        None => Ok(()),
    }
}

/// A ray with its direction made unit (a checked ray: `check_rays`).
pub(crate) fn unit_ray(o: DVec3, d: DVec3) -> (DVec3, DVec3) {
    (o, d / d.length())
}

/// The traces whose test keeps a ray (query frame): bit k for trace k below 63, bit 63 for any
/// of the rest (`masked_reach` tests those again).
fn reach_mask(traces: &[TraceCall], ray: &TestRay) -> u64 {
    (traces.iter().enumerate())
        .filter(|(_, t)| (t.reaches)(ray))
        .fold(0, |mask, (k, _)| mask | 1 << k.min(63))
}

/// Per trace, the rays (indices into `count` rays, `ray(i)` in world space) its test keeps.
fn reached_by<F>(traces: &[TraceCall], count: usize, ray: F, centre: DVec3) -> Vec<Vec<u32>>
where
    F: Fn(usize) -> RangedRay + Sync,
{
    let masks: Vec<u64> = (0..count)
        .into_par_iter()
        .map(|i| {
            let ((o, d), range) = ray(i);
            reach_mask(traces, &TestRay::new(o - centre, d, range))
        })
        .collect();
    masked_reach(traces, &masks, ray, centre)
}

/// `reached_by` from each ray's `reach_mask`: traces past the 63rd test the rays of bit 63 again.
fn masked_reach<F>(traces: &[TraceCall], masks: &[u64], ray: F, centre: DVec3) -> Vec<Vec<u32>>
where
    F: Fn(usize) -> RangedRay + Sync,
{
    (traces.iter().enumerate())
        .map(|(k, trace)| {
            (0..masks.len() as u32)
                .into_par_iter()
                .filter(|&i| {
                    let mask = masks[i as usize];
                    if k < 63 {
                        return mask >> k & 1 == 1;
                    }
                    let ((o, d), range) = ray(i as usize);
                    mask >> 63 == 1 && (trace.reaches)(&TestRay::new(o - centre, d, range))
                })
                .collect()
        })
        .collect()
}

impl Renderer {
    /// The nearest hit of each ray (origin, direction) against the scene's texture sets and
    /// meshes, or with `any_hit` whether it hits anything (its first hit found, not the nearest).
    /// `cancel` is checked between batches.
    pub fn intersect(
        &mut self,
        scene: &Scene,
        rays: &[(DVec3, DVec3)],
        search: &SearchOptions,
        any_hit: bool,
        cancel: &Cancel,
    ) -> Result<RayHits> {
        // A hybrid set's triangles are drawn as a mesh beside it (Scene::drawn).
        let scene = &scene.drawn();
        let rays = checked_rays(rays)?;
        self.trace_rays(scene, &rays, None, BATCH, search, any_hit, cancel)
    }

    /// The most rays one batch can hold under the adapter's binding limit (rays and hits are
    /// each one binding). A frame's shadow rays go in one batch: each batch waits for its
    /// read-back, and the whole frame is no longer to cancel than the frame itself.
    pub(crate) fn largest_batch(&self) -> usize {
        let limit = self.gpu.device.limits().max_storage_buffer_binding_size;
        let per_ray = size_of::<QueryRayGpu>().max(size_of::<QueryHitGpu>());
        (limit as usize / per_ray).max(1)
    }

    /// `intersect` for rays with unit directions, each counting hits only for t in its
    /// (t_min, t_max) when `ranges` are given (shadow rays), `batch` rays at a time.
    #[allow(clippy::too_many_arguments)] // the query's own settings, passed through
    pub(crate) fn trace_rays(
        &mut self,
        scene: &Scene,
        rays: &[(DVec3, DVec3)],
        ranges: Option<&[(f64, f64)]>,
        batch: usize,
        search: &SearchOptions,
        any_hit: bool,
        cancel: &Cancel,
    ) -> Result<RayHits> {
        search.validate()?;
        let device = self.gpu.device.clone();
        guarded(&device, || {
            let centre = rays.iter().map(|r| r.0).sum::<DVec3>() / rays.len().max(1) as f64;
            let spread =
                (rays.iter()).fold(0.0f64, |m, r| m.max((r.0 - centre).abs().max_element()));
            check_view_distance(spread, "the rays' centre")?;
            let parallel = shared_direction(rays);
            let view_from_world = DMat4::from_translation(-centre);
            let traces = self.prepare_query(scene, view_from_world, search, parallel)?;
            let mut hits = RayHits {
                distance: Vec::with_capacity(rays.len()),
                patch_id: Vec::with_capacity(rays.len()),
                normal: Vec::with_capacity(3 * rays.len()),
            };
            for (k, chunk) in rays.chunks(batch).enumerate() {
                cancel.check("tracing rays")?;
                let chunk_ranges = ranges.map(|r| &r[k * batch..k * batch + chunk.len()]);
                let range = |i| stretch(chunk_ranges, i);
                let reached = reached_by(&traces, chunk.len(), |i| (chunk[i], range(i)), centre);
                let ask = if any_hit { Ask::AnyHit } else { Ask::Nearest };
                let found = self.run_batch(&traces, &reached, chunk, chunk_ranges, centre, ask)?;
                for h in found {
                    let hit = h.id != -1;
                    hits.distance
                        .push(if hit { h.t as f64 } else { f64::INFINITY });
                    hits.patch_id.push(if hit { h.id } else { -1 });
                    hits.normal.extend(if hit { h.normal } else { [0.0; 3] });
                }
            }
            Ok(hits)
        })
    }

    /// Which of `count` rays hit anything (any hit), their indices in order, and how many rays
    /// were traced on the device, where `ray(i)`
    /// makes ray i (world-space start, unit direction, the stretch of t that counts) or `None`
    /// for no ray. Rays are made on the fly in parallel, and only those some object's test keeps
    /// become records: a frame's shadow rays are most of its pixels, and most pass beside every
    /// caster (on the bunny over its ground plane at 512², 29k of 173k rays reach the set and
    /// none the plane), so making, testing and reading back all of them cost more than the
    /// dispatch of the rest. `origin` is the query frame's origin in world space (any point near
    /// the rays: f32 keeps their detail there); `parallel` the rays' shared direction, if any.
    #[allow(clippy::too_many_arguments)] // the query's own settings, passed through
    pub(crate) fn occluded<F>(
        &mut self,
        scene: &Scene,
        origin: DVec3,
        parallel: Option<DVec3>,
        count: usize,
        ray: F,
        search: &SearchOptions,
        cancel: &Cancel,
    ) -> Result<(Vec<usize>, usize)>
    where
        F: Fn(usize) -> Option<RangedRay> + Sync,
    {
        search.validate()?;
        let device = self.gpu.device.clone();
        guarded(&device, || {
            let mut t = std::time::Instant::now();
            let view_from_world = DMat4::from_translation(-origin);
            let traces = self.prepare_query(scene, view_from_world, search, parallel)?;
            profile::mark(format_args!("prepare_query"), &mut t);
            // Each kept ray with the traces it reaches (`reach_mask`), so that no test runs twice.
            // Rays that share a direction share its inverse.
            let inverse = parallel.map(DVec3::recip);
            let kept: Vec<(usize, RangedRay, u64)> = (0..count)
                .into_par_iter()
                .filter_map(|i| {
                    let ((o, d), range) = ray(i)?;
                    debug_assert!(parallel.is_none_or(|p| p == d));
                    let test_ray = TestRay {
                        origin: o - origin,
                        inverse: inverse.unwrap_or_else(|| d.recip()),
                        range,
                    };
                    let mask = reach_mask(&traces, &test_ray);
                    (mask != 0).then_some((i, ((o, d), range), mask))
                })
                .collect();
            profile::mark(format_args!("make+reach ({} kept)", kept.len()), &mut t);
            let batch = self.largest_batch();
            let mut hit = Vec::new();
            for chunk in kept.chunks(batch) {
                cancel.check("tracing rays")?;
                let rays: Vec<(DVec3, DVec3)> = chunk.iter().map(|k| k.1 .0).collect();
                let ranges: Vec<(f64, f64)> = chunk.iter().map(|k| k.1 .1).collect();
                let masks: Vec<u64> = chunk.iter().map(|k| k.2).collect();
                let reached = masked_reach(&traces, &masks, |i| chunk[i].1, origin);
                let counts: Vec<usize> = reached.iter().map(Vec::len).collect();
                profile::mark(format_args!("  rays per trace {counts:?}"), &mut t);
                let found = self.run_batch(
                    &traces,
                    &reached,
                    &rays,
                    Some(&ranges),
                    origin,
                    Ask::Blocked,
                )?;
                let ids = chunk.iter().zip(found).filter(|(_, h)| h.id != -1);
                hit.extend(ids.map(|(k, _)| k.0));
            }
            profile::mark(format_args!("batches ({} hit)", hit.len()), &mut t);
            Ok((hit, kept.len()))
        })
    }

    /// Uploads what is new and makes each object's dispatch in the query's frame (for rays all
    /// along `parallel`, when given).
    fn prepare_query(
        &mut self,
        scene: &Scene,
        view_from_world: DMat4,
        search: &SearchOptions,
        parallel: Option<DVec3>,
    ) -> Result<Vec<TraceCall>> {
        let (owners, depth) = self.upload_scene(scene, view_from_world)?;
        let (z_min, z_max) = depth.or_default();
        check_view_distance(z_min.abs().max(z_max.abs()), "the rays")?;
        self.frame_bindings.write_search(&self.gpu.queue, search);
        let mut ids = Tally::default();
        let mut traces = Vec::new();
        for (placed, owner) in scene.objects.iter().zip(owners) {
            let kind = &self.kinds.kinds[owner];
            traces.extend(kind.trace(&self.gpu, view_from_world, placed, &mut ids, parallel)?);
        }
        Ok(traces)
    }

    /// Traces one batch through every object's dispatch in turn (each no further than the
    /// nearest hit so far, and each only for the rays `reached` lists for it) and reads the
    /// hits back. Only the rays some object's test keeps go to the device (`Compact`): the
    /// others are misses already, and on a software adapter uploading, clearing and reading
    /// back their records cost more than the dispatches they skip (most of a frame's shadow
    /// rays pass beside every caster).
    fn run_batch(
        &self,
        traces: &[TraceCall],
        reached: &[Vec<u32>],
        rays: &[(DVec3, DVec3)],
        ranges: Option<&[(f64, f64)]>,
        centre: DVec3,
        ask: Ask,
    ) -> Result<Vec<QueryHitGpu>> {
        let device = &self.gpu.device;
        let mut t = std::time::Instant::now();
        let range = |i| stretch(ranges, i);
        let compact = Compact::new(rays.len(), reached);
        let gpu_rays: Vec<QueryRayGpu> = (compact.kept.par_iter())
            .map(|&i| {
                let (o, d) = rays[i as usize];
                QueryRayGpu {
                    origin: (o - centre).as_vec3().to_array(),
                    t_min: range(i as usize).0 as f32,
                    dir: d.as_vec3().to_array(),
                    _pad: 0,
                }
            })
            .collect();
        // Each ray's far bound is where its search stops: no hit beyond it counts.
        let hits_init: Vec<QueryHitGpu> = (compact.kept.par_iter())
            .map(|&i| QueryHitGpu {
                t: range(i as usize).1 as f32,
                ..MISS
            })
            .collect();
        if gpu_rays.is_empty() {
            return Ok(vec![MISS; rays.len()]);
        }
        profile::mark(format_args!("  records"), &mut t);
        let storage = wgpu::BufferUsages::STORAGE;
        let rays_buffer = storage_buffer(device, "query rays", bytemuck::cast_slice(&gpu_rays));
        let hits = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("query hits"),
            contents: bytemuck::cast_slice(&hits_init),
            usage: storage | wgpu::BufferUsages::COPY_SRC,
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_bind_group(0, &self.frame_bindings.group, &[]);
            for (trace, reached) in traces.iter().zip(reached) {
                if reached.is_empty() {
                    continue;
                }
                let active: Vec<u32> = reached.iter().map(|&i| compact.slot[i as usize]).collect();
                let (settings, per_row, rows) = self.dispatch_settings(active.len(), ask);
                let settings = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("query"),
                    contents: bytemuck::bytes_of(&settings),
                    usage: wgpu::BufferUsages::STORAGE,
                });
                let active =
                    storage_buffer(device, "query rays traced", bytemuck::cast_slice(&active));
                let buffers = [&settings, &rays_buffer, &hits, &active];
                let group = bind_buffers(device, "ray query", &self.query_layout, &buffers);
                pass.set_bind_group(2, &group, &[]);
                pass.set_pipeline(&trace.pipeline);
                pass.set_bind_group(1, &trace.group, &[]);
                pass.dispatch_workgroups(per_row, rows, 1);
            }
        }
        profile::mark(format_args!("  encode"), &mut t);
        let bytes = super::targets::read_buffer(&self.gpu, encoder, &hits)?;
        profile::mark(format_args!("  submit+wait+read"), &mut t);
        Ok(compact.expand(bytemuck::cast_slice(&bytes), rays.len()))
    }

    /// A dispatch of `rays` invocations in rows under the adapter's per-dimension limit.
    fn dispatch_settings(&self, rays: usize, ask: Ask) -> (QueryGpu, u32, u32) {
        let workgroups = (rays as u32).div_ceil(WORKGROUP);
        let limit = self
            .gpu
            .device
            .limits()
            .max_compute_workgroups_per_dimension;
        let per_row = workgroups.min(limit);
        let rows = workgroups.div_ceil(per_row.max(1));
        let settings = QueryGpu {
            counts: [
                rays as u32,
                (ask != Ask::Nearest) as u32,
                per_row * WORKGROUP,
                (ask == Ask::Blocked) as u32,
            ],
        };
        (settings, per_row, rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compaction_keeps_every_ray_some_object_reaches_in_order() {
        // Ten rays; one object reaches 1, 4 and 7, another 4, 8 and 9.
        let reached = [vec![1, 4, 7], vec![4, 8, 9]];
        let compact = Compact::new(10, &reached);
        assert_eq!(compact.kept, [1, 4, 7, 8, 9]);
        for (k, &i) in compact.kept.iter().enumerate() {
            assert_eq!(compact.slot[i as usize], k as u32);
        }
        let dropped = [0, 2, 3, 5, 6];
        assert!(dropped.iter().all(|&i| compact.slot[i] == u32::MAX));
        // Hits of the kept rays land on their own rays; the rest are misses.
        let found: Vec<QueryHitGpu> = (0..5)
            .map(|k| QueryHitGpu {
                t: k as f32,
                id: 100 + k,
                ..MISS
            })
            .collect();
        let hits = compact.expand(&found, 10);
        for (k, &i) in compact.kept.iter().enumerate() {
            assert_eq!(
                (hits[i as usize].id, hits[i as usize].t),
                (100 + k as i32, k as f32)
            );
        }
        assert!(dropped.iter().all(|&i| hits[i].id == -1));
    }
}
