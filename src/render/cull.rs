//! View-dependent choices made on the CPU before drawing: the scene's depth range (which sets the
//! near plane), frustum culling of boxes, and the level of detail of each patch.
//!
//! Spaces: a box is the unit cube under a `*_from_box` matrix (patch-local space for patches);
//! view space is OpenGL-style (looks down -Z), so depth along the view is -z; clip space is the
//! lens's (reversed Z).

use glam::{DMat4, DVec3, DVec4};

use super::camera::Lens;
use crate::gtex::Patch;

/// The corners of the box [lo, hi]; corner k takes hi on x, y, z where bit 0, 1, 2 of k is set.
pub(crate) fn box_corners(lo: DVec3, hi: DVec3) -> [DVec3; 8] {
    crate::bvh::Aabb { lo, hi }.corners()
}

/// The corners of the unit cube (a patch's box in patch-local space).
pub(crate) fn unit_cube_corners() -> [DVec3; 8] {
    box_corners(DVec3::ZERO, DVec3::ONE)
}

/// The unit cube's corners under `m` (a patch's or tile's box placed in another space).
pub(crate) fn placed_unit_cube(m: &glam::DMat4) -> [DVec3; 8] {
    unit_cube_corners().map(|c| m.transform_point3(c))
}

/// The range of view depths (distances along the view direction) the scene's bounds occupy.
pub(crate) struct DepthRange {
    pub z_min: f64,
    pub z_max: f64,
}

impl DepthRange {
    pub fn empty() -> DepthRange {
        DepthRange {
            z_min: f64::INFINITY,
            z_max: f64::NEG_INFINITY,
        }
    }

    /// Widens the range by the corners of the box [lo, hi] of a space placed by `view_from_box`.
    pub fn include_box(&mut self, view_from_box: &DMat4, lo: DVec3, hi: DVec3) {
        for corner in box_corners(lo, hi) {
            let z = -view_from_box.transform_point3(corner).z;
            self.z_min = self.z_min.min(z);
            self.z_max = self.z_max.max(z);
        }
    }

    /// The range, or an arbitrary valid one for an empty scene.
    pub fn or_default(&self) -> (f64, f64) {
        if self.z_min.is_finite() {
            (self.z_min, self.z_max)
        } else {
            (1.0, 2.0)
        }
    }
}

/// Whether a box (the unit cube under `clip_from_box`) may reach the view: false only when all
/// eight corners lie outside one side of the frustum (left, right, bottom, top, or, for a
/// perspective camera, behind the eye). Conservative: a box across a corner of the frustum is
/// kept; the ray caster then draws nothing for it.
pub(crate) fn in_frustum(clip_from_box: &DMat4, perspective: bool) -> bool {
    let corners = unit_cube_corners().map(|c| *clip_from_box * c.extend(1.0));
    let outside = |test: &dyn Fn(&DVec4) -> bool| corners.iter().all(test);
    // A relative slack so rounding never culls a box that touches the frustum.
    let slack = |c: &DVec4| c.w.abs() * 1e-9;
    !(outside(&|c| c.x > c.w + slack(c))
        || outside(&|c| c.x < -c.w - slack(c))
        || outside(&|c| c.y > c.w + slack(c))
        || outside(&|c| c.y < -c.w - slack(c))
        || (perspective && outside(&|c| c.w <= 0.0)))
}

/// World size of a pixel at a patch's nearest box corner (never nearer than the near plane):
/// the footprint both level-of-detail rules project to.
pub(crate) fn nearest_pixel(view_from_patch: &DMat4, lens: &Lens) -> f64 {
    let nearest = unit_cube_corners()
        .iter()
        .map(|&c| -view_from_patch.transform_point3(c).z)
        .fold(f64::INFINITY, f64::min)
        .max(lens.near);
    if lens.orthographic {
        lens.ray[1].abs()
    } else {
        nearest * lens.ray[1].abs()
    }
}

/// The pyramid level at which a patch's nodes are about one pixel: from its texel size and the
/// pixel footprint at the nearest corner of its box (so no part of the patch gets coarser than
/// a pixel; far parts of a long patch get finer than they need).
pub(crate) fn lod_level(view_from_patch: &DMat4, p: &Patch, lens: &Lens, levels: u32) -> u32 {
    let pixel = nearest_pixel(view_from_patch, lens);
    let texel = (p.extent.x / p.width as f64).min(p.extent.y / p.height as f64);
    let texels_per_pixel = pixel / texel;
    if texels_per_pixel.is_nan() || texels_per_pixel < 2.0 {
        return 0;
    }
    (texels_per_pixel.log2().floor() as u32).min(levels.saturating_sub(1))
}

/// The coarsest pyramid level whose bound (`level_bounds`: per level, world units, growing with
/// the level) projects to at most `max_pixels` pixels at the patch's nearest corner, as
/// `lod_level` projects; 0 when none does.
pub(crate) fn bound_lod_level(
    view_from_patch: &DMat4,
    lens: &Lens,
    level_bounds: &[f64],
    max_pixels: f64,
) -> u32 {
    let pixel = nearest_pixel(view_from_patch, lens);
    let fits = |b: &f64| *b / pixel <= max_pixels;
    // Bounds grow with the level, so the levels that fit are a prefix.
    level_bounds
        .iter()
        .take_while(|b| fits(b))
        .count()
        .saturating_sub(1) as u32
}
