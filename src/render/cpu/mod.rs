//! The CPU backend: frames, ray queries and shadows of texture sets and meshes traced natively on
//! every core (rayon), with no graphics driver at all. It answers as the GPU backend does — the
//! same `Frame` and `RayHits`, ids, depth convention and headlight shading — from exact searches
//! in f64: a set's min-max pyramid descent (heightfield.rs) and a mesh's triangle hierarchy
//! (mesh.rs). Other kinds (surfels, IGT meshes, displacement shells) need the GPU backend and are
//! refused with the reason. Each object's hierarchy is built on its first frame or query and kept
//! while the object lives (`UploadCache`, as the GPU keeps uploads).
//!
//! A render reads as the GPU's: prepare (hierarchies, depth range, lens) → trace (one ray per
//! pixel centre, in 8 x 8 tiles, each tile's candidates found once: `SceneTrace::bundle`) →
//! finish (error bounds, coverage, shadows as asked).
//!
//! Spaces: world (f64); each object's own, placed by `world_from_object`; camera rays are the
//! GPU's (`Camera::pixel_lines`), whose parameter is the view's z-depth.

mod mesh;
mod scene;
mod set;

use std::sync::Arc;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::query::RangedRay;
use super::search::Method;
use super::shadow::{cast_shadows, Light};
use super::{
    check_image_size, finish_outputs, BoundInputs, Camera, Frame, FrameRequest, Object, RayBackend,
    RayHits, Renderer, Scene, SearchOptions, ShadedMesh,
};
use crate::cancel::Cancel;
use crate::error::{GeomtexError, Result};
use crate::gtex::GeometryTextureSet;
use crate::heightfield::Plane;
use crate::mesh::{Mesh, NormalRule};
use crate::render::cull::DepthRange;
use crate::render::kinds::UploadCache;
pub(crate) use mesh::MeshTracer;
use scene::{Bundle, SceneTrace, Traced};
use set::SetSearch;

/// The largest image side the CPU backend draws (the GPU's usual limit; memory is the bound).
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// A shadow ray's start offset in texels of a set and in diagonals of a mesh: the GPU backend's
/// (kinds/gtex, kinds/mesh), so both shadow alike.
const SET_OFFSET_TEXELS: f64 = 0.25;
const MESH_OFFSET_DIAGONAL: f64 = 1e-5;

/// Frames, queries and shadows on the CPU. Hierarchies are kept per object while it lives.
#[derive(Default)]
pub struct CpuRenderer {
    sets: UploadCache<GeometryTextureSet, Arc<SetSearch>>,
    /// A mesh's hierarchy per normal rule it was drawn with (the normals differ).
    meshes: UploadCache<Mesh, Vec<(NormalRule, Arc<MeshTracer>)>>,
}

/// What the CPU backend traces of an object, or the error that names why not.
fn traced_kind(object: &Object) -> Result<()> {
    if object.payload::<GeometryTextureSet>().is_some() || object.payload::<ShadedMesh>().is_some()
    {
        return Ok(());
    }
    Err(GeomtexError::Device(format!(
        "the CPU backend draws and traces texture sets and meshes only; a {} needs the GPU \
         backend (Renderer(..., device=\"gpu\") with a Vulkan, Metal or DX12 adapter)",
        object.payload_name()
    )))
}

impl CpuRenderer {
    pub fn new() -> CpuRenderer {
        CpuRenderer::default()
    }

    /// Whether this backend draws and traces `object` (texture sets and meshes).
    pub fn draws(object: &Object) -> bool {
        traced_kind(object).is_ok()
    }

    /// The adapter-like description `gt.info()` and `Renderer.adapter_info` give.
    pub fn info() -> Vec<(&'static str, String)> {
        vec![
            ("name", "geomtex CPU tracer".into()),
            ("backend", "cpu".into()),
            ("device_type", "Cpu".into()),
            ("driver", "native".into()),
            (
                "driver_info",
                format!("{} threads", rayon::current_num_threads()),
            ),
        ]
    }

    /// The scene's hierarchies, built where new (on every core), and the ms the building took
    /// (0 when every one was kept).
    fn prepare(&mut self, scene: &Scene) -> Result<(SceneTrace, f64)> {
        let mut built = std::time::Duration::ZERO;
        self.sets.purge();
        self.meshes.purge();
        let mut objects = Vec::with_capacity(scene.objects.len());
        for (index, placed) in scene.objects.iter().enumerate() {
            placed.check_placement(index)?;
            traced_kind(&placed.object)?;
            let traced = if let Some(set) = placed.object.payload::<GeometryTextureSet>() {
                let search = self.sets.get_or_upload(&set, |_| {
                    let start = Instant::now();
                    let made = Arc::new(SetSearch::new(set.clone()));
                    built += start.elapsed();
                    Ok(made)
                })?;
                Traced::Set(search.clone())
            } else {
                let shaded = placed
                    .object
                    .payload::<ShadedMesh>()
                    .expect("checked above");
                let rules = self.meshes.entry(&shaded.mesh);
                let tracer = match rules.iter().find(|(rule, _)| *rule == shaded.rule) {
                    Some((_, t)) => t.clone(),
                    None => {
                        let start = Instant::now();
                        let made = Arc::new(MeshTracer::new(shaded.mesh.clone(), shaded.rule));
                        built += start.elapsed();
                        rules.push((shaded.rule, made.clone()));
                        made
                    }
                };
                Traced::Mesh(tracer)
            };
            objects.push((traced, placed.world_from_object));
        }
        Ok((SceneTrace::new(objects), built.as_secs_f64() * 1e3))
    }

    /// Renders `scene` seen by `camera` as `request` asks, on every core. The search is always
    /// the exact one (`method` "maxmip" in the frame's stats); `lod` and `count_fetches` are
    /// GPU-only and refused.
    pub fn render(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        search: &SearchOptions,
        request: &FrameRequest,
        cancel: &Cancel,
    ) -> Result<Frame> {
        // A hybrid set's triangles are drawn as a mesh beside it (Scene::drawn).
        let scene = &scene.drawn();
        let search = exact_search(search)?;
        check_image_size(request.width, request.height, MAX_IMAGE_SIDE)?;
        let start = Instant::now();
        let (trace, setup_ms) = self.prepare(scene)?;
        let mut depth_range = DepthRange::empty();
        let view_from_world = camera.view_from_world();
        for b in trace.world_boxes() {
            depth_range.include_box(&view_from_world, b.lo, b.hi);
        }
        let (z_min, z_max) = depth_range.or_default();
        // f64 throughout: no float32 range to keep (the GPU backend refuses past it).
        let lens = camera.lens_unchecked(request.width, request.height, z_min, z_max)?;
        let background = request.background.unwrap_or(Renderer::DEFAULT_BACKGROUND);
        let pixels = trace_pixels(&trace, camera, &lens, request, cancel)?;
        let mut frame = pixels.into_frame(request, background, lens.near, &search);
        frame.setup_ms = setup_ms;
        frame.cpu_ms = start.elapsed().as_secs_f64() * 1e3;
        let inputs = BoundInputs {
            lens,
            ids: trace.ids,
            lod_picks: Vec::new(),
        };
        let outputs = request.outputs;
        finish_outputs(
            self,
            (scene, camera, &search),
            outputs,
            &inputs,
            frame,
            start,
        )
    }

    /// Shadows of a frame this backend drew (shadow.rs, traced here).
    pub fn cast_shadows(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        light: &Light,
        frame: &mut Frame,
        cancel: &Cancel,
    ) -> Result<()> {
        // A hybrid set's triangles are drawn as a mesh beside it (Scene::drawn).
        let scene = &scene.drawn();
        let search = SearchOptions::default();
        cast_shadows(self, scene, camera, &search, light, frame, cancel)
    }

    /// The nearest hit of each ray (origin, direction of any length but zero), or with `any_hit`
    /// the first hit found: distance along the unit direction, id, world normal (as
    /// `Renderer::intersect`). `cancel` is polled per ray.
    pub fn intersect(
        &mut self,
        scene: &Scene,
        rays: &[(DVec3, DVec3)],
        any_hit: bool,
        cancel: &Cancel,
    ) -> Result<RayHits> {
        // A hybrid set's triangles are drawn as a mesh beside it (Scene::drawn).
        let scene = &scene.drawn();
        super::query::check_rays(rays)?;
        let (trace, _) = self.prepare(scene)?;
        let miss = (f64::INFINITY, (-1, [0.0; 3]));
        // Directions made unit ray by ray (a normalized copy of a million rays cost more than
        // its tracing saved); three outputs filled in one pass.
        let (distance, (patch_id, normal)): Columns = rays
            .par_iter()
            .map(|&ray| {
                if cancel.is_cancelled() {
                    return miss;
                }
                let (o, d) = super::query::unit_ray(ray.0, ray.1);
                let span = (0.0, f64::INFINITY);
                let hit = if any_hit {
                    trace.first_found(o, d, span)
                } else {
                    trace.nearest(o, d, span)
                };
                hit.map_or(miss, |h| {
                    let n = trace.query_normal(&h, o, d);
                    (h.t, (trace.id(&h), n.as_vec3().to_array()))
                })
            })
            .unzip();
        cancel.check("tracing rays on the CPU")?;
        Ok(RayHits {
            distance,
            patch_id,
            normal: normal.into_flattened(),
        })
    }

    /// Every crossing of each ray with the scene, nearest first: per ray (distances along its
    /// unit direction, ids). Meshes give one crossing per face crossed; sets one per crossing
    /// of a patch's surface (patches overlap at their rings, so a crossing there may come
    /// twice, from both patches).
    pub fn list_intersections(
        &mut self,
        scene: &Scene,
        rays: &[(DVec3, DVec3)],
        cancel: &Cancel,
    ) -> Result<Vec<Vec<(f64, i32)>>> {
        // A hybrid set's triangles are drawn as a mesh beside it (Scene::drawn).
        let scene = &scene.drawn();
        super::query::check_rays(rays)?;
        let (trace, _) = self.prepare(scene)?;
        let lists = rays
            .par_iter()
            .map(|&ray| {
                if cancel.is_cancelled() {
                    return Vec::new();
                }
                let (o, d) = super::query::unit_ray(ray.0, ray.1);
                trace.all(o, d, (0.0, f64::INFINITY))
            })
            .collect();
        cancel.check("listing intersections on the CPU")?;
        Ok(lists)
    }
}

/// A query's outputs made in one pass: distances, (ids, normals).
type Columns = (Vec<f64>, (Vec<i32>, Vec<[f32; 3]>));

/// The search a CPU frame draws with: always the exact one; the GPU-only options refused.
fn exact_search(search: &SearchOptions) -> Result<SearchOptions> {
    search.validate()?;
    if search.lod || search.count_fetches {
        let what = if search.lod { "lod" } else { "count_fetches" };
        return Err(GeomtexError::Parameter(format!(
            "{what} is a GPU tracer option; the CPU backend always searches exactly and counts \
             no fetches (use Renderer(..., device=\"gpu\"))"
        )));
    }
    Ok(SearchOptions {
        method: Method::MaxMip,
        ..*search
    })
}

/// What a pixel shows: z-depth (f32, and how far it lies from the exact hit's), id, world
/// normal, base color and its headlight factor.
type PixelHit = ((f32, f32), i32, [f32; 3], [u8; 4], f64);

/// A frame's per-pixel results, as traced.
struct Pixels {
    /// Per pixel: z-depth (and its rounding), id, world normal, base color and its headlight
    /// factor; None where nothing is hit.
    hits: Vec<Option<PixelHit>>,
    patches: usize,
    meshes: usize,
}

/// One camera ray per pixel centre, rows on every core; `cancel` polled per row.
fn trace_pixels(
    trace: &SceneTrace,
    camera: &Camera,
    lens: &super::Lens,
    request: &FrameRequest,
    cancel: &Cancel,
) -> Result<Pixels> {
    let lines = camera.pixel_lines(lens);
    let (w, h) = (request.width as usize, request.height as usize);
    // The rays' parameter is the view's z-depth (their direction has z = -1 in view space, or
    // is the unit forward axis for an orthographic camera): the span is the lens's.
    let span = (lens.near, lens.far);
    // The rays' t as a function of the point: its view z-depth.
    let row = camera.view_from_world().row(2);
    let depth = (-row.truncate(), -row.w);
    let pixel = |bundle: &Bundle, x: usize, y: usize| -> Option<PixelHit> {
        let (o, d) = lines.at(x as f64 + 0.5, y as f64 + 0.5);
        let hit = trace.nearest_in(bundle, o, d, span)?;
        let (n, color) = trace.shade(&hit, o, d);
        // Headlight (camera_functions.wgsl): light comes from the eye.
        let light = 0.25 + 0.75 * n.dot(d.normalize()).abs();
        let normal = n.as_vec3().to_array();
        // The rays' t is their z-depth: rounded once to f32, by a known amount.
        let z = hit.t as f32;
        let rounding = super::error_bound::f32_at_least((f64::from(z) - hit.t).abs());
        Some(((z, rounding), trace.id(&hit), normal, color, light))
    };
    // Bands of TILE rows on every core, each cut into TILE x TILE tiles. What a tile's rays
    // may meet is found once for the tile (`SceneTrace::bundle`: a set's pieces inside the
    // tile's frustum, nearest first), so each ray tests a few pieces in order instead of
    // walking the whole hierarchy; and a tile's rays meet the same nodes and cells, which stay
    // in cache.
    const TILE: usize = 8;
    let mut hits = vec![None; w * h];
    hits.par_chunks_mut(w * TILE)
        .enumerate()
        .for_each(|(band, rows)| {
            if cancel.is_cancelled() {
                return;
            }
            let y0 = band * TILE;
            let y1 = y0 + rows.len() / w;
            for x0 in (0..w).step_by(TILE) {
                let x1 = (x0 + TILE).min(w);
                let bundle = trace.bundle(&tile_planes(&lines, (x0, x1), (y0, y1)), depth);
                for (dy, row) in rows.chunks_mut(w).enumerate() {
                    for (x, out) in row.iter_mut().enumerate().take(x1).skip(x0) {
                        *out = pixel(&bundle, x, y0 + dy);
                    }
                }
            }
        });
    cancel.check("rendering on the CPU")?;
    let patches = trace.ids.iter().map(|i| i.patches.len()).sum();
    let meshes = trace.ids.iter().map(|i| i.meshes.len()).sum();
    Ok(Pixels {
        hits,
        patches,
        meshes,
    })
}

/// The four planes around the rays through pixels [x0, x1) x [y0, y1) (through the tile's
/// corners, pixel centres strictly inside): (n, c) with n . p + c >= 0 inside.
fn tile_planes(
    lines: &super::camera::PixelLines,
    (x0, x1): (usize, usize),
    (y0, y1): (usize, usize),
) -> [Plane; 4] {
    let (x0, x1, y0, y1) = (x0 as f64, x1 as f64, y0 as f64, y1 as f64);
    let corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)].map(|(x, y)| lines.at(x, y));
    let (oc, dc) = lines.at(0.5 * (x0 + x1), 0.5 * (y0 + y1));
    std::array::from_fn(|k| {
        let ((oa, da), (ob, db)) = (corners[k], corners[(k + 1) % 4]);
        // The side through lines a and b: for a pinhole the origins coincide and its normal is
        // da x db; for an orthographic camera the directions do and it is da x (ob - oa). The
        // sum serves both, each term exactly 0 where it does not apply (da x (ob + db - oa)
        // lost db to rounding with the eye far from the origin, and so did the side test).
        let n = da.cross(db) + da.cross(ob - oa);
        // Facing the centre line's point oc + dc, taken from oa without forming oc + dc.
        let n = if n.dot(dc + (oc - oa)) < 0.0 { -n } else { n };
        (n, -n.dot(oa))
    })
}

impl Pixels {
    /// The frame of these pixels: every output made (`keep_only` drops the ones not asked).
    fn into_frame(
        self,
        request: &FrameRequest,
        background: [u8; 4],
        near: f64,
        search: &SearchOptions,
    ) -> Frame {
        let n = self.hits.len();
        let (mut color, mut albedo) = (vec![0u8; 4 * n], vec![0u8; 4 * n]);
        let (mut depth, mut normal, mut ids) = (vec![0f32; n], vec![0f32; 3 * n], vec![0i32; n]);
        let mut rounding = vec![0f32; n];
        // Every pixel's outputs on every core (one core took a tenth of a mesh's frame).
        (self.hits.par_iter())
            .zip(color.par_chunks_mut(4).zip(albedo.par_chunks_mut(4)))
            .zip((depth.par_iter_mut().zip(rounding.par_iter_mut())).zip(normal.par_chunks_mut(3)))
            .zip(ids.par_iter_mut())
            .for_each(
                |(((hit, (color, albedo)), ((depth, rounding), normal)), id)| match hit {
                    Some(((z, z_rounding), hit_id, nrm, base, light)) => {
                        let shaded = |c: u8| (f64::from(c) * light).round().min(255.0) as u8;
                        color.copy_from_slice(&[
                            shaded(base[0]),
                            shaded(base[1]),
                            shaded(base[2]),
                            base[3],
                        ]);
                        albedo.copy_from_slice(base);
                        (*depth, *rounding) = (*z, *z_rounding);
                        normal.copy_from_slice(nrm);
                        *id = *hit_id;
                    }
                    None => {
                        color.copy_from_slice(&background);
                        *depth = f32::INFINITY;
                        *id = -1;
                    }
                },
            );
        let outputs = request.outputs;
        Frame {
            width: request.width,
            height: request.height,
            color: outputs.color.then_some(color),
            albedo: outputs.albedo.then_some(albedo),
            depth: Some(depth),
            normal: Some(normal),
            patch_id: Some(ids),
            gpu_ms: None,
            cpu_ms: 0.0,
            patches_drawn: self.patches,
            patches_culled: 0,
            meshes_drawn: self.meshes,
            texture_bytes: 0,
            setup_ms: 0.0,
            near,
            method: search.method,
            primary: search.primary,
            searches: 0,
            fetches: None,
            piece_tests: None,
            shadow: None,
            surfels: None,
            face_id: None,
            barycentric: None,
            error_bound: None,
            depth_rounding: outputs.needs_bounds().then_some(rounding),
            bound_figures: None,
            coverage_uncertain: None,
            coverage: None,
            lod_levels: None,
            device: "cpu",
        }
    }
}

impl RayBackend for CpuRenderer {
    fn rounding(&self) -> crate::render::error_bound::Rounding {
        crate::render::error_bound::Rounding::F64Hits
    }

    fn traces(&self, object: &Object) -> Result<bool> {
        traced_kind(object).map(|()| true)
    }

    fn shadow_offset(&self, object: &Object, scale: f64) -> Result<f64> {
        traced_kind(object)?;
        Ok(match object.payload::<GeometryTextureSet>() {
            Some(set) => SET_OFFSET_TEXELS * set.texel_size * scale,
            None => {
                let shaded = object.payload::<ShadedMesh>().expect("checked above");
                let (lo, hi) = shaded.mesh.bounds();
                MESH_OFFSET_DIAGONAL * (hi - lo).length() * scale
            }
        })
    }

    fn occluded_rays(
        &mut self,
        scene: &Scene,
        _origin: DVec3,
        _parallel: Option<DVec3>,
        count: usize,
        ray: &(dyn Fn(usize) -> Option<RangedRay> + Sync),
        _search: &SearchOptions,
        cancel: &Cancel,
    ) -> Result<(Vec<usize>, usize)> {
        let (trace, _) = self.prepare(scene)?;
        // Runs of neighbouring rays (a frame's pixels in order) on every core, each ray first
        // testing the set piece that stopped the one before it; each run counts its own rays
        // (one shared atomic counter bounced its cache line between the cores on every ray).
        const RUN: usize = 64;
        let runs: Vec<(Vec<usize>, usize)> = (0..count.div_ceil(RUN))
            .into_par_iter()
            .map(|run| {
                let last = std::cell::Cell::new(None);
                let (mut occluded, mut traced) = (Vec::new(), 0);
                for i in run * RUN..(run * RUN + RUN).min(count) {
                    if cancel.is_cancelled() {
                        break;
                    }
                    let Some(((o, d), span)) = ray(i) else {
                        continue;
                    };
                    traced += 1;
                    if trace.any_after(o, d, span, &last) {
                        occluded.push(i);
                    }
                }
                (occluded, traced)
            })
            .collect();
        let traced = runs.iter().map(|r| r.1).sum();
        let occluded = runs.into_iter().flat_map(|r| r.0).collect();
        cancel.check("tracing shadow rays on the CPU")?;
        Ok((occluded, traced))
    }

    fn hits(
        &mut self,
        scene: &Scene,
        rays: &[(DVec3, DVec3)],
        ranges: &[(f64, f64)],
        _search: &SearchOptions,
        any_hit: bool,
    ) -> Result<(Vec<f64>, Vec<i32>)> {
        let (trace, _) = self.prepare(scene)?;
        Ok((rays.par_iter().zip(ranges))
            .map(|(&(o, d), &span)| {
                let hit = if any_hit {
                    trace.first_found(o, d, span)
                } else {
                    trace.nearest(o, d, span)
                };
                hit.map_or((f64::INFINITY, -1), |h| (h.t, trace.id(&h)))
            })
            .unzip())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat4, DQuat};

    /// Every pixel ray of a tile finds in the tile's bundle (its frustum's pieces) the hit the
    /// whole hierarchy gives it, for a perspective and an orthographic camera and a set placed
    /// turned, scaled and moved: the planes and the depth bound never drop a piece a ray meets.
    #[test]
    fn a_tiles_bundle_holds_what_its_rays_meet() {
        // The set at unit scale, and at 1e30 with the camera as far (planes through an eye at
        // 3e30 lost their directions' z to rounding, and culled what the rays met).
        for scale in [1.0, 1e30] {
            bundle_holds_what_its_rays_meet(scale);
        }
    }

    fn bundle_holds_what_its_rays_meet(scale: f64) {
        let set = Arc::new(crate::heightfield::turned_holed_set());
        let placement = DMat4::from_scale_rotation_translation(
            DVec3::splat(1.7 * scale),
            DQuat::from_rotation_y(0.4),
            DVec3::new(0.3, -0.2, 0.5) * scale,
        );
        let trace = SceneTrace::new(vec![(
            Traced::Set(Arc::new(SetSearch::new(set))),
            placement,
        )]);
        let target = placement.transform_point3(DVec3::new(0.8, 0.5, 0.0));
        let (w, h) = (96u32, 64u32);
        let cameras = [
            Camera::look_at(
                target + DVec3::new(1.0, 2.0, 3.5) * scale,
                target,
                DVec3::Y,
                40.0,
            )
            .unwrap(),
            // An eye on the z axis: its x and y exact, its z far larger than the rays'.
            Camera::look_at(
                DVec3::new(0.0, 0.0, target.z + 4.0 * scale),
                DVec3::new(0.0, 0.0, target.z),
                DVec3::Y,
                60.0,
            )
            .unwrap(),
            Camera::orthographic(
                DMat4::from_translation(target + DVec3::new(0.0, 0.0, 4.0) * scale),
                2.5 * scale,
            )
            .unwrap(),
        ];
        for camera in cameras {
            let lens = camera
                .lens_unchecked(w, h, 0.5 * scale, 20.0 * scale)
                .unwrap();
            let lines = camera.pixel_lines(&lens);
            let row = camera.view_from_world().row(2);
            let depth = (-row.truncate(), -row.w);
            let (mut hits, mut tiles) = (0, 0);
            for y0 in (0..h as usize).step_by(8) {
                for x0 in (0..w as usize).step_by(8) {
                    let planes = tile_planes(&lines, (x0, x0 + 8), (y0, y0 + 8));
                    let bundle = trace.bundle(&planes, depth);
                    tiles += usize::from(!bundle.is_empty());
                    for (x, y) in (y0..y0 + 8).flat_map(|y| (x0..x0 + 8).map(move |x| (x, y))) {
                        let (o, d) = lines.at(x as f64 + 0.5, y as f64 + 0.5);
                        let span = (lens.near, lens.far);
                        let whole = trace.nearest(o, d, span).map(|hit| (hit.t, trace.id(&hit)));
                        let tiled = trace.nearest_in(&bundle, o, d, span);
                        assert_eq!(
                            whole,
                            tiled.map(|hit| (hit.t, trace.id(&hit))),
                            "({x}, {y}) scale {scale}, camera {camera:?}"
                        );
                        hits += usize::from(whole.is_some());
                    }
                }
            }
            // Measured at both scales: 722, 263 and 266 of the 6,144 pixels hit; 45, 16 and 17
            // of the 96 tiles hold pieces (the rest are culled whole).
            assert!(
                hits > 150 && tiles < 70,
                "{hits} hits, {tiles} tiles with pieces"
            );
        }
    }
}
