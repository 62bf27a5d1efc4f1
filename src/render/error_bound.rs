//! Per-pixel error bounds of a frame (`Frame::error_bound`): for each drawn pixel a bound on the
//! distance from the point it shows to the source mesh, computed on the CPU after read-back from
//! the depth and patch ids. A set's pixel takes the bound of the cell its point falls in
//! (`Patch::error_bound_near`), or its patch's level bound when drawn at a coarser level of
//! detail (kinds/gtex/lod.rs); a plain mesh's pixel is the mesh itself (a hybrid set's triangles
//! add their stored positions' rounding). Every bound adds a term for the rounding of the drawn
//! point (`Rounding`): the GPU's f32 arithmetic (`FLOAT_ULPS`), or on the CPU backend, whose hits
//! are f64, the f32 depth alone. NaN where nothing is drawn or no bound is known: sets without
//! bound maps, surfels, IGT meshes and displacement shells.
//!
//! Spaces: world (the scene's), each object's own (placed by `world_from_object`), patch-local and
//! texel-centre coordinates x = u w - 1/2, y = v h - 1/2 (heightfield.rs); images row-major from
//! the top; bounds in world units.

use std::ops::Range;
use std::sync::Arc;

use glam::{DMat3, DMat4, DVec3};
use rayon::prelude::*;

use super::camera::{Lens, PixelLines};
use super::kinds::LodPick;
use super::scene::{Scene, ShadedMesh};
use crate::bvh::{Aabb, Bvh};
use crate::gtex::GeometryTextureSet;
use crate::render::cull::placed_unit_cube;

/// Texels of slack around a point's cell: the point comes from an f32 depth and an f32 search,
/// so it may lie a hair across the side of the cell its surface was found in.
const CELL_SLACK: f64 = 0.02;

/// f32 steps (relative to the drawn point's distance from the eye plus the size of what drew it)
/// that cover the rounding of a drawn point: the GPU works in f32 relative to the camera, the
/// depth is stored in f32 and a mesh's vertices are f32 about its centre. Measured on the bunny
/// (three views, 256², distance across the surface: along-ray error x |cos| to the shading
/// normal): a set's drawn points lie within 2.0 of these steps of the exact f64 hits of its stored
/// surface (GeometryTextureSet.first_hits; p99 1.3), a mesh's within 2.5 of trimesh's f64 hits
/// (p99 0.8). Along the ray, at grazing angles, they reach 25 steps.
pub(crate) const FLOAT_ULPS: f64 = 4.0;

/// Texels a patch's drawn outline may stand off the mesh's beyond its surface's bound (its
/// outline codes and their bilinear blend round by about that).
const OUTLINE_TEXELS: f64 = 0.1;

/// f64 steps (relative to the drawn point's distance from the eye plus the size of what drew it)
/// that cover the CPU backend's own arithmetic: its hits are f64 (ray set-up, placement, the
/// exact face or height-field crossing), a few steps each; this is generous and still some
/// hundred thousand times less than the f32 depth's rounding.
const F64_ULPS: f64 = 1024.0;

/// How a backend computes the points it draws, as far as their rounding goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Rounding {
    /// The GPU's tracers: f32 relative to the camera, f32 vertices (`FLOAT_ULPS`).
    F32Tracer,
    /// The CPU backend: f64 hits, rounded once to the frame's f32 depth.
    F64Hits,
}

/// Where each id of a frame came from, as far as its bound goes: `patches` indexed by patch id,
/// `meshes` by k for id -2 - k.
pub(crate) struct PixelSources {
    sets: Vec<PlacedSet>,
    patches: Vec<IdSource>,
    meshes: Vec<IdSource>,
    eye: DVec3,
    rounding: Rounding,
    /// The hybrid sets with patches (`seams` of each, made when first asked for: only coverage
    /// probes ask).
    hybrid: Vec<(Arc<GeometryTextureSet>, DMat4, f64)>,
    seams: std::sync::OnceLock<Vec<SeamBoxes>>,
    /// Whether the frame's search finds the stored surface exactly (the max-pyramid descent);
    /// a linear search's hits stop within its last step, off the surface by more than a cell's
    /// bound, so its patch pixels get NaN.
    pub exact_search: bool,
}

/// A set as a scene places it.
struct PlacedSet {
    set: Arc<GeometryTextureSet>,
    object_from_world: DMat4,
    /// How much the placement stretches a length at most (its largest singular value).
    scale: f64,
}

#[derive(Clone, Copy)]
enum IdSource {
    /// Patch `patch` of `sets[set]`; `lod_bound` its level bound (world units) when drawn at a
    /// level of detail coarser than the exact cells.
    Patch {
        set: usize,
        patch: usize,
        lod_bound: Option<f64>,
    },
    /// A plain mesh: the source itself, or a hybrid set's triangles, whose vertices lie within
    /// `stored` of the source's (world units); `reach` is its bounding box's diagonal.
    Mesh {
        reach: f64,
        stored: f64,
    },
    Unknown,
}

/// The ids each scene object took in a frame (patch ids, and k of mesh ids -2 - k).
#[derive(Clone, Debug, Default)]
pub(crate) struct ObjectIds {
    pub patches: Range<i32>,
    pub meshes: Range<usize>,
}

impl PixelSources {
    /// The sources of a frame of `scene` whose objects took `ids` (in scene order), with the
    /// level-of-detail picks of its patches, seen from `eye`, drawn by a backend that rounds as
    /// `rounding` says.
    pub fn new(
        scene: &Scene,
        ids: &[ObjectIds],
        lod_picks: &[LodPick],
        (eye, rounding): (DVec3, Rounding),
    ) -> Self {
        let patch_count = ids.iter().map(|r| r.patches.end).max().unwrap_or(0).max(0);
        let mesh_count = ids.iter().map(|r| r.meshes.end).max().unwrap_or(0);
        let mut sources = PixelSources {
            sets: Vec::new(),
            exact_search: true,
            patches: vec![IdSource::Unknown; patch_count as usize],
            meshes: vec![IdSource::Unknown; mesh_count],
            eye,
            rounding,
            hybrid: Vec::new(),
            seams: std::sync::OnceLock::new(),
        };
        for (placed, taken) in scene.objects.iter().zip(ids) {
            let scale = largest_singular_value(&placed.world_from_object);
            if let Some(set) = placed.object.payload::<GeometryTextureSet>() {
                if set.triangles.is_some() && !set.patches.is_empty() {
                    (sources.hybrid).push((set.clone(), placed.world_from_object, scale));
                }
                for (patch, id) in taken.patches.clone().enumerate() {
                    sources.patches[id as usize] = IdSource::Patch {
                        set: sources.sets.len(),
                        patch,
                        lod_bound: None,
                    };
                }
                sources.sets.push(PlacedSet {
                    set,
                    object_from_world: placed.world_from_object.inverse(),
                    scale,
                });
            } else if let Some(shaded) = placed.object.payload::<ShadedMesh>() {
                let reach = shaded.diagonal() * scale;
                let stored = shaded.stored_rounding * scale;
                for k in taken.meshes.clone() {
                    sources.meshes[k] = IdSource::Mesh { reach, stored };
                }
            }
        }
        for pick in lod_picks.iter().filter(|p| p.level > 0) {
            if let Some(IdSource::Patch { lod_bound, .. }) =
                sources.patches.get_mut(pick.patch_id as usize)
            {
                *lod_bound = Some(pick.bound);
            }
        }
        sources
    }

    fn source(&self, id: i32) -> IdSource {
        let found = match id {
            0.. => self.patches.get(id as usize),
            ..=-2 => self.meshes.get((-2 - id) as usize),
            _ => None,
        };
        found.copied().unwrap_or(IdSource::Unknown)
    }

    /// The bound (world units) of world point `point` drawn with id `id`, whose f32 depth's
    /// rounding moves it by up to `depth_step` (`DrawnPixels::point_and_depth_step`); NaN where
    /// none is known.
    pub fn bound_at(&self, point: DVec3, id: i32, depth_step: f64) -> f64 {
        let rounding = |reach: f64| {
            let size = (point - self.eye).length() + reach;
            match self.rounding {
                Rounding::F32Tracer => FLOAT_ULPS * f64::from(f32::EPSILON) * size,
                Rounding::F64Hits => depth_step + F64_ULPS * f64::EPSILON * size,
            }
        };
        match self.source(id) {
            IdSource::Unknown => f64::NAN,
            IdSource::Mesh { reach, stored } => stored + rounding(reach),
            IdSource::Patch { .. } if !self.exact_search => f64::NAN,
            IdSource::Patch {
                set,
                patch,
                lod_bound,
            } => {
                let placed = &self.sets[set];
                let p = &placed.set.patches[patch];
                let reach = p.extent.length() * placed.scale;
                // Without a map nothing is known, whatever the level.
                let Some(cell) = p.error_bound.as_ref().and_then(|_| {
                    let local = p.world_to_local(placed.object_from_world.transform_point3(point));
                    let (x, y) = (
                        local.x * f64::from(p.width) - 0.5,
                        local.y * f64::from(p.height) - 0.5,
                    );
                    p.error_bound_near(x, y, CELL_SLACK)
                }) else {
                    return f64::NAN;
                };
                lod_bound.map_or(cell * placed.scale, |b| b.max(cell * placed.scale))
                    + rounding(reach)
            }
        }
    }

    /// How far (world units) a drawn outline may stand off the mesh's beyond the surface's own
    /// bound: a tenth of a texel for a set's patch (its outline codes and their bilinear blend
    /// round by about that), none for a mesh, NaN where unknown.
    pub fn outline_allowance(&self, id: i32) -> f64 {
        match self.source(id) {
            IdSource::Unknown => f64::NAN,
            IdSource::Mesh { .. } => 0.0,
            IdSource::Patch { set, patch, .. } => {
                let placed = &self.sets[set];
                OUTLINE_TEXELS * placed.set.patches[patch].texel_size() * placed.scale
            }
        }
    }

    /// Where a hybrid set's patch meets its triangles, the patch's outline may leave a crack
    /// that draws nothing, with no pixel of that patch beside it: the largest outline allowance
    /// (world units) of the patches whose boxes (widened by it) the world ray o + t d meets
    /// for t >= 0, with the least t it meets one at; (0, inf) where it meets none.
    pub fn seam_allowance(&self, o: DVec3, d: DVec3) -> (f64, f64) {
        let seams = self.seams.get_or_init(|| {
            (self.hybrid.iter())
                .map(|(set, world_from_object, scale)| {
                    SeamBoxes::new(set, world_from_object, *scale)
                })
                .collect()
        });
        (seams.iter()).fold((0.0, f64::INFINITY), |(most, first), seam| {
            let (a, t) = seam.met_by(o, d);
            (most.max(a), first.min(t))
        })
    }
}

/// A hybrid set's patches in world space, for `PixelSources::seam_allowance`: their boxes
/// widened by their outline allowances, a tree over them, and the allowances.
struct SeamBoxes {
    boxes: Vec<Aabb>,
    allowance: Vec<f64>,
    bvh: Bvh,
    bounds: Vec<Aabb>,
}

impl SeamBoxes {
    fn new(set: &GeometryTextureSet, world_from_object: &DMat4, scale: f64) -> SeamBoxes {
        let allowance: Vec<f64> = (set.patches.iter())
            .map(|p| OUTLINE_TEXELS * p.texel_size() * scale)
            .collect();
        let boxes: Vec<Aabb> = (set.patches.iter().zip(&allowance))
            .map(|(p, &a)| {
                let b = Aabb::of_points(placed_unit_cube(
                    &(*world_from_object * p.world_from_patch()),
                ));
                Aabb {
                    lo: b.lo - a,
                    hi: b.hi + a,
                }
            })
            .collect();
        let bvh = Bvh::build(&boxes);
        let bounds = bvh.node_bounds(&boxes);
        SeamBoxes {
            boxes,
            allowance,
            bvh,
            bounds,
        }
    }

    /// The largest allowance of the boxes the ray meets for t >= 0, and the least t it meets
    /// one at.
    fn met_by(&self, o: DVec3, d: DVec3) -> (f64, f64) {
        let inverse = d.recip();
        let ahead = (0.0, f64::INFINITY);
        let (mut most, mut first) = (0.0f64, f64::INFINITY);
        (self.bvh).select(
            &self.bounds,
            |b| b.meets_inverse(o, inverse, ahead),
            |i| {
                if let Some(t) = self.boxes[i as usize].entry_inverse(o, inverse, ahead) {
                    most = most.max(self.allowance[i as usize]);
                    first = first.min(t);
                }
            },
        );
        (most, first)
    }
}

/// What a frame's per-pixel bounds are made from: its size, pixel rays, depth and ids.
pub(crate) struct DrawnPixels<'a> {
    pub width: u32,
    pub lines: PixelLines,
    pub forward: DVec3,
    pub depth: &'a [f32],
    pub patch_id: &'a [i32],
    /// Per pixel how far `depth` lies from the exact hit's z-depth, where the backend knows it
    /// (`Frame::depth_rounding`); else half an f32 step of the depth stands for it.
    pub depth_rounding: Option<&'a [f32]>,
}

impl DrawnPixels<'_> {
    /// Pixel `i`'s ray through its centre (origin, direction; t counts z-depth over
    /// `direction . forward`).
    pub fn ray(&self, i: usize) -> (DVec3, DVec3) {
        let w = self.width as usize;
        self.lines.at((i % w) as f64 + 0.5, (i / w) as f64 + 0.5)
    }

    /// Whether pixel `i` shows something.
    pub fn drawn(&self, i: usize) -> bool {
        self.depth[i].is_finite() && self.patch_id[i] != -1
    }

    /// The world point pixel `i` shows (None where nothing is drawn), and how far (world units)
    /// the f32 rounding of its z-depth may move it along the pixel's ray: by the rounding the
    /// backend measured, else by half the f32 step above the depth (rounding to nearest never
    /// errs by more, even just under a power of two).
    pub fn point_and_depth_step(&self, i: usize) -> Option<(DVec3, f64)> {
        if !self.drawn(i) {
            return None;
        }
        let depth = self.depth[i];
        let (o, d) = self.ray(i);
        // d is not of unit length: the division makes the step one of z-depth all the same.
        let along = d.dot(self.forward);
        let point = o + d * (f64::from(depth) / along);
        let step = match self.depth_rounding {
            Some(rounding) => f64::from(rounding[i]),
            None => {
                let depth = depth.abs();
                0.5 * (f64::from(depth.next_up()) - f64::from(depth))
            }
        };
        Some((point, step * d.length() / along.abs()))
    }
}

/// Every pixel's bound (world units, rounded up to f32), rows in parallel; NaN where nothing is
/// drawn or no bound is known. And their figures, counted in the same pass (a second, serial
/// pass over the frame cost 0.37 ms of a 512² frame's 0.9 ms of bounds).
pub(crate) fn pixel_bounds(
    sources: &PixelSources,
    pixels: &DrawnPixels,
) -> (Vec<f32>, BoundFigures) {
    let mut bounds = vec![f32::NAN; pixels.depth.len()];
    let w = pixels.width as usize;
    let unknown_pixels = bounds
        .par_chunks_mut(w.max(1))
        .enumerate()
        .map(|(row, out)| {
            let mut unknown = 0;
            for (x, b) in out.iter_mut().enumerate() {
                let i = row * w + x;
                if let Some((point, step)) = pixels.point_and_depth_step(i) {
                    *b = f32_at_least(sources.bound_at(point, pixels.patch_id[i], step));
                    unknown += usize::from(b.is_nan());
                }
            }
            unknown
        })
        .sum();
    let figures = BoundFigures::of(&bounds, unknown_pixels);
    (bounds, figures)
}

/// The least f32 not below `v` (NaN stays NaN).
pub(crate) fn f32_at_least(v: f64) -> f32 {
    let r = v as f32;
    if f64::from(r) < v {
        r.next_up()
    } else {
        r
    }
}

/// The largest singular value of a placement's linear part: the most it stretches a length.
/// Closed form over the eigenvalues of the symmetric MᵀM (the trigonometric solution).
pub(crate) fn largest_singular_value(m: &DMat4) -> f64 {
    let l = DMat3::from_mat4(*m);
    let a = l.transpose() * l;
    let off = a.x_axis.y.powi(2) + a.x_axis.z.powi(2) + a.y_axis.z.powi(2);
    let diagonal = [a.x_axis.x, a.y_axis.y, a.z_axis.z];
    let largest = if off <= 1e-30 * diagonal.iter().map(|d| d * d).sum::<f64>() {
        diagonal.into_iter().fold(0.0, f64::max)
    } else {
        let q = diagonal.iter().sum::<f64>() / 3.0;
        let p = ((diagonal.iter().map(|d| (d - q).powi(2)).sum::<f64>() + 2.0 * off) / 6.0).sqrt();
        let b = (a - DMat3::from_diagonal(DVec3::splat(q))) * (1.0 / p);
        let phi = (b.determinant() / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
        q + 2.0 * p * phi.cos()
    };
    // A hair up, so that rounding never makes it smaller than it is.
    largest.max(0.0).sqrt() * (1.0 + 1e-12)
}

/// A frame's bound figures: the largest and median bound over the drawn pixels with one, and
/// the drawn pixels without one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundFigures {
    pub max: Option<f64>,
    pub median: Option<f64>,
    pub unknown_pixels: usize,
}

impl BoundFigures {
    /// The figures of a frame's `bounds` (NaN where nothing is drawn or the bound is unknown),
    /// `unknown_pixels` of its drawn pixels without one.
    pub(crate) fn of(bounds: &[f32], unknown_pixels: usize) -> BoundFigures {
        let mut known: Vec<f32> = bounds.iter().copied().filter(|b| !b.is_nan()).collect();
        let max = known
            .iter()
            .copied()
            .fold(None, |m: Option<f32>, b| Some(m.map_or(b, |m| m.max(b))));
        let median = (!known.is_empty()).then(|| {
            let mid = known.len() / 2;
            *known.select_nth_unstable_by(mid, f32::total_cmp).1
        });
        BoundFigures {
            max: max.map(f64::from),
            median: median.map(f64::from),
            unknown_pixels,
        }
    }
}

/// A lens's smaller pixel side at z-depth `depth` (world units): a world distance over it is
/// never fewer pixels than the distance covers.
pub(crate) fn pixel_size(lens: &Lens, depth: f64) -> f64 {
    let side = lens.ray[0].abs().min(lens.ray[1].abs());
    if lens.orthographic {
        side
    } else {
        side * depth
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gtex::ErrorBoundMap;
    use crate::heightfield::test_patch;
    use crate::render::scene::{Object, SceneObject};
    use glam::DQuat;

    #[test]
    fn largest_singular_value_of_rotations_and_stretches() {
        let r = DMat4::from_quat(DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0));
        let stretch = DMat4::from_scale(DVec3::new(0.5, 3.0, 2.0));
        assert!((largest_singular_value(&(r * stretch * r.transpose())) - 3.0).abs() < 1e-9);
        assert!((largest_singular_value(&DMat4::from_scale(DVec3::splat(2.5))) - 2.5).abs() < 1e-9);
        let shear = DMat4::from_cols_array(&[
            1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ]);
        // [[1, 1], [0, 1]]: singular values are the golden ratio and its inverse.
        let golden = (1.0 + 5f64.sqrt()) / 2.0;
        assert!((largest_singular_value(&shear) - golden).abs() < 1e-9);
    }

    /// A scene of one flat 4 x 4 patch over the unit square (height 1/2) with cell bounds
    /// `cell(i, j)`, placed by `world_from_object`.
    fn flat_scene(world_from_object: DMat4, cell: impl Fn(i64, i64) -> f64) -> Scene {
        let mut p = test_patch(4, 4, 16, |_, _| Some(0.5));
        let cells: Vec<f64> = (-1..4)
            .flat_map(|j| (-1..4).map(move |i| (i, j)))
            .map(|(i, j)| cell(i, j))
            .collect();
        p.error_bound = Some(ErrorBoundMap::from_cells(
            4,
            4,
            crate::gtex::bound::BLOCK,
            &cells,
        ));
        let set = GeometryTextureSet {
            patches: vec![p],
            texel_size: 0.25,
            ..Default::default()
        };
        Scene {
            objects: vec![SceneObject {
                object: Object::new(Arc::new(set)),
                world_from_object,
            }],
        }
    }

    #[test]
    fn a_point_takes_its_cells_decoded_bound_scaled_by_the_placement() {
        // Blocks of 2 x 2 cells: cells (-1..1) x (-1..1) are block (0, 0), (1..3) block (1, 0).
        let bound = |i: i64, j: i64| if i >= 1 && j <= 0 { 0.02 } else { 0.001 };
        let ids = [ObjectIds {
            patches: 0..1,
            meshes: 0..0,
        }];
        let eye = DVec3::new(0.0, 0.0, 10.0);
        for scale in [1.0, 3.0] {
            let scene = flat_scene(DMat4::from_scale(DVec3::splat(scale)), bound);
            let sources = PixelSources::new(&scene, &ids, &[], (eye, Rounding::F32Tracer));
            // Texel-centre (1.5, 0.5) lies in cell (1, 0): u = 2 / 4, v = 1 / 4.
            let point = DVec3::new(0.5, 0.25, 0.5) * scale;
            let map =
                ErrorBoundMap::from_cells(1, 1, crate::gtex::bound::BLOCK, &[0.02, 0.0, 0.0, 0.0]);
            let decoded = ErrorBoundMap::decode(map.codes[0], f64::from(map.scale));
            let rounding = FLOAT_ULPS * f64::from(f32::EPSILON);
            let got = sources.bound_at(point, 0, 0.0);
            let float = rounding * ((point - eye).length() + 3f64.sqrt() * scale);
            assert!((got - (decoded * scale + float)).abs() < 1e-12, "{got}");
            // Cell (0, 2) is in a block of 0.001s.
            let low = sources.bound_at(DVec3::new(0.125, 0.625, 0.5) * scale, 0, 0.0);
            assert!(low < 0.0011 * scale + 1e-5, "{low}");
            let unknown = |id| sources.bound_at(point, id, 0.0).is_nan();
            assert!(unknown(1) && unknown(-2));
        }
    }

    #[test]
    fn figures_skip_the_background_and_keep_the_unknown_count() {
        let bounds = [f32::NAN, 1.0, 3.0, 2.0, f32::NAN];
        let f = BoundFigures::of(&bounds, 1);
        assert_eq!(
            (f.max, f.median, f.unknown_pixels),
            (Some(3.0), Some(2.0), 1)
        );
        assert_eq!(
            f32_at_least(0.1),
            0.1f32.max(f32::from_bits(0.1f32.to_bits()))
        );
        assert!(f64::from(f32_at_least(0.1)) >= 0.1);
    }
}
