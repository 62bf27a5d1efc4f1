//! A texture set made ready for the CPU backend: the exact search of heightfield.rs (a BVH over
//! the patches' boxes, each patch's min-max pyramid), and what a hit shows, read from the maps as
//! the GPU's `gtex_surface` reads them (shaders/gtex_piece_functions.wgsl): the crease-aware
//! bilinear normal and the bilinear color.
//!
//! Spaces: rays in the set's own space (its object space in a scene), t preserved; patch-local
//! unit boxes; texel-centre coordinates (texel i's centre at i + 0.5) for the maps.

use std::sync::Arc;

use glam::DVec3;

use crate::bvh::Aabb;
use crate::gtex::{decode_normal, GeometryTextureSet, Patch, NEUTRAL_COLOR};
use crate::heightfield::SetTracer;

/// cos 20°: neighbouring texels whose normals differ by more lie across a crease (the shader's
/// CREASE_COS; the maps do not record the crease angle a set was converted with).
const CREASE_COS: f64 = 0.9397;

pub(crate) struct SetSearch {
    pub set: Arc<GeometryTextureSet>,
    pub tracer: SetTracer,
    /// The set's bounding box (its patches' boxes).
    pub bounds: Aabb,
}

impl SetSearch {
    /// The search over the texels each patch owns, as the GPU's pieces (so both backends pick
    /// the same patch where two hold one surface along a seam).
    pub fn new(set: Arc<GeometryTextureSet>) -> SetSearch {
        let owned = crate::render::kinds::gtex::owners::owned_heights(&set);
        let tracer = SetTracer::with_heights(&set, &owned);
        let bounds = Aabb::of_points(
            (set.patches.iter())
                .flat_map(|p| crate::render::cull::placed_unit_cube(&p.world_from_patch())),
        );
        SetSearch {
            set,
            tracer,
            bounds,
        }
    }

    /// The nearest hit for t in `span`: (t, patch), or None.
    pub fn nearest(&self, o: DVec3, d: DVec3, span: (f64, f64)) -> Option<(f64, u32)> {
        let (t, k) = self.tracer.first_hit_within(&self.set, o, d, span);
        (k >= 0).then_some((t, k as u32))
    }

    /// `nearest` of a ray of the bundle `pieces` came from (`SetTracer::pieces_within`).
    pub fn nearest_among(
        &self,
        pieces: &[(f64, u32)],
        o: DVec3,
        d: DVec3,
        span: (f64, f64),
    ) -> Option<(f64, u32)> {
        let (t, k) = (self.tracer).first_hit_among(&self.set, pieces, (o, d), span);
        (k >= 0).then_some((t, k as u32))
    }

    /// Whether the ray meets the set within `span`, the piece a neighbouring ray was stopped
    /// by in `last` (`SetTracer::any_hit`).
    pub fn any(
        &self,
        o: DVec3,
        d: DVec3,
        span: (f64, f64),
        last: &std::cell::Cell<Option<u32>>,
    ) -> bool {
        self.tracer.any_hit(&self.set, (o, d), span, last)
    }

    pub fn all(&self, o: DVec3, d: DVec3, span: (f64, f64)) -> Vec<(f64, i32)> {
        self.tracer.all_hits(&self.set, o, d, span)
    }

    /// Patch `k` and the texel-centre coordinates of the hit of ray o + t d in it, clamped to
    /// the outer texels' centres as the shader clamps them.
    fn at(&self, k: u32, o: DVec3, d: DVec3, t: f64) -> (&Patch, f64, f64) {
        let p = &self.set.patches[k as usize];
        let local = p.world_to_local(o + d * t);
        let size = (f64::from(p.width), f64::from(p.height));
        let x = (local.x * size.0).clamp(0.5, size.0 - 0.5) - 0.5;
        let y = (local.y * size.1).clamp(0.5, size.1 - 0.5) - 0.5;
        (p, x, y)
    }

    /// The set-space unit normal at the hit of ray o + t d in patch `k`.
    pub fn normal(&self, k: u32, o: DVec3, d: DVec3, t: f64) -> DVec3 {
        let (p, x, y) = self.at(k, o, d, t);
        set_normal(p, x, y)
    }

    /// The set-space unit normal and the base color (RGBA8) at the hit of ray o + t d in
    /// patch `k`, the hit's map coordinates found once for both.
    pub fn shade(&self, k: u32, o: DVec3, d: DVec3, t: f64) -> (DVec3, [u8; 4]) {
        let (p, x, y) = self.at(k, o, d, t);
        (set_normal(p, x, y), bilinear_color(p, x, y))
    }
}

/// The set-space unit normal of patch `p` at texel-centre point (x, y).
fn set_normal(p: &Patch, x: f64, y: f64) -> DVec3 {
    let n_local = crease_aware_normal(p, x, y);
    // Normal maps hold unit normals in the box's axes (not stretched by its extent).
    (p.axes[0] * n_local.x + p.axes[1] * n_local.y + p.axes[2] * n_local.z).normalize_or_zero()
}

/// The four texels around texel-centre point (x, y) (clamped to the map) and their weights.
fn around(p: &Patch, x: f64, y: f64) -> [(usize, f64); 4] {
    let (cx, cy) = (x.floor(), y.floor());
    let (wx, wy) = (x - cx, y - cy);
    let (last_x, last_y) = (i64::from(p.width) - 1, i64::from(p.height) - 1);
    std::array::from_fn(|k| {
        let (dx, dy) = ((k & 1) as i64, (k >> 1) as i64);
        let i = (cx as i64 + dx).clamp(0, last_x);
        let j = (cy as i64 + dy).clamp(0, last_y);
        let w = if dx == 1 { wx } else { 1.0 - wx } * if dy == 1 { wy } else { 1.0 - wy };
        ((j * (last_x + 1) + i) as usize, w)
    })
}

/// The patch-local normal at (x, y), not normalized: bilinear over the four texels around it,
/// leaving out those across a crease from the nearest texel (gtex_piece_functions.wgsl's
/// `crease_aware_normal`).
fn crease_aware_normal(p: &Patch, x: f64, y: f64) -> DVec3 {
    let texels = around(p, x, y);
    let normals = texels.map(|(t, _)| decode_normal(p.normals[t]));
    let nearest = (0..4).fold(0, |best, k| {
        if texels[k].1 > texels[best].1 {
            k
        } else {
            best
        }
    });
    // Decoded normals are unit or zero (`decode_normal`): the anchor needs no normalizing and a
    // normal's length is 1 or 0 (four square roots a pixel saved).
    let anchor = normals[nearest];
    let length = |n: &DVec3| if *n == DVec3::ZERO { 0.0 } else { 1.0 };
    let (mut all, mut same_side) = (DVec3::ZERO, DVec3::ZERO);
    for (n, (_, w)) in normals.iter().zip(texels) {
        all += w * *n;
        if n.dot(anchor) >= CREASE_COS * length(n) {
            same_side += w * *n;
        }
    }
    if same_side.length_squared() > 1e-12 {
        same_side
    } else {
        all
    }
}

/// The color map read bilinearly at (x, y) (the shader's linear sampler), or NEUTRAL_COLOR.
fn bilinear_color(p: &Patch, x: f64, y: f64) -> [u8; 4] {
    if p.colors.is_empty() {
        return NEUTRAL_COLOR;
    }
    let mut sum = [0.0f64; 4];
    for (t, w) in around(p, x, y) {
        for (s, c) in sum.iter_mut().zip(p.colors[t]) {
            *s += w * f64::from(c);
        }
    }
    sum.map(|v| v.round().clamp(0.0, 255.0) as u8)
}
