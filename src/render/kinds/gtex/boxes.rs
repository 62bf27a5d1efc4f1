//! The boxes the tracer's hierarchy holds for a texture set: each patch's box cut into the nodes
//! of its min-max pyramid at one level (nodes about 2^BOX_LEVEL texels wide), each piece only as
//! tall as the heights under it, pieces with no surface left out. Thin pieces are what keep the
//! searches per pixel near one: a ray enters few of them before its hit, where it would enter
//! several whole boxes (neighbouring charts' boxes are thick where the surface curves).
//!
//! Spaces: pieces are stored in patch-local space (the unit cube; x/y texture u/v, z height);
//! `placed` puts one in the space a matrix maps patch-local space to.

use bytemuck::{Pod, Zeroable};
use glam::{DMat3, DMat4, DVec3};

use crate::gtex::Patch;
use crate::render::bvh::Aabb;

/// The pyramid level the boxes are cut at (16 x 16 cells); a patch with fewer levels is one box.
pub(crate) const BOX_LEVEL: u32 = 4;

/// `PatchBox` in gtex_types.wgsl: a piece of patch `patch_index`'s box, in its patch-local space,
/// and the pyramid level its node is at (where the search inside it starts).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug)]
pub(crate) struct PatchBoxGpu {
    pub lo: [f32; 3],
    pub patch_index: u32,
    pub hi: [f32; 3],
    pub level: u32,
}

const _: () = assert!(size_of::<PatchBoxGpu>() == 32);

/// The pieces of patch `index`, from its min-max pyramid (heightfield::min_max_pyramid).
pub(crate) fn patch_boxes(
    index: u32,
    p: &Patch,
    pyramid: &[(u32, u32, Vec<u32>)],
) -> Vec<PatchBoxGpu> {
    let level = BOX_LEVEL.min(pyramid.len().saturating_sub(1) as u32);
    let (nw, nh, values) = &pyramid[level as usize];
    let cells = f64::from(1u32 << level);
    let code_max = f64::from(p.code_max());
    let decode = |code: u32| (f64::from(code) - 1.0) / (code_max - 1.0);
    // Heights are known to half a code (the search's graze tolerance); a hair in u/v so that
    // a ray along a shared side enters one of the two pieces.
    let dz = 0.5 / (code_max - 1.0);
    let duv = 1e-6;
    // Node column c spans cells [c 2^L, (c + 1) 2^L), i.e. u in [(c 2^L - 1/2) / W, ...].
    let span = |n: u32, texels: u32| {
        let at = |k: f64| ((k * cells - 0.5) / f64::from(texels)).clamp(0.0, 1.0);
        (at(f64::from(n)) - duv, at(f64::from(n + 1)) + duv)
    };
    let mut boxes = Vec::new();
    for r in 0..*nh {
        for c in 0..*nw {
            let value = values[(r * nw + c) as usize];
            if value == 0 {
                continue;
            }
            let (u0, u1) = span(c, p.width);
            let (v0, v1) = span(r, p.height);
            let (z0, z1) = (decode(value & 0xffff) - dz, decode(value >> 16) + dz);
            boxes.push(PatchBoxGpu {
                lo: [u0, v0, z0].map(|x| x as f32),
                patch_index: index,
                hi: [u1, v1, z1].map(|x| x as f32),
                level,
            });
        }
    }
    boxes
}

/// The axis-aligned bounds of a piece placed by `to_space` (from patch-local space).
pub(crate) fn placed(b: &PatchBoxGpu, to_space: &DMat4) -> Aabb {
    let lo = DVec3::from(b.lo.map(f64::from));
    let hi = DVec3::from(b.hi.map(f64::from));
    let centre = to_space.transform_point3(0.5 * (lo + hi));
    let linear = DMat3::from_mat4(*to_space);
    let abs = DMat3::from_cols(
        linear.x_axis.abs(),
        linear.y_axis.abs(),
        linear.z_axis.abs(),
    );
    let half = abs * (0.5 * (hi - lo));
    Aabb {
        lo: centre - half,
        hi: centre + half,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::heightfield::{height_at, min_max_pyramid, test_patch};

    /// A w x h patch of waves over the unit square, empty in one corner.
    fn wavy_patch(w: u32, h: u32) -> Patch {
        test_patch(w, h, 16, |i, j| {
            let (x, y) = (i as f64 / w as f64, j as f64 / h as f64);
            (x + y > 0.3).then(|| 0.5 + 0.4 * (9.0 * x).sin() * (7.0 * y).cos())
        })
    }

    /// Every surface point of a patch lies in one of its pieces, and the pieces are thinner
    /// than the whole box.
    #[test]
    fn pieces_hold_the_surface() {
        let p = wavy_patch(200, 150);
        let boxes = patch_boxes(3, &p, &min_max_pyramid(&p));
        assert!(boxes
            .iter()
            .all(|b| b.patch_index == 3 && b.level == BOX_LEVEL));
        let mean_height: f32 =
            boxes.iter().map(|b| b.hi[2] - b.lo[2]).sum::<f32>() / boxes.len() as f32;
        // The surface spans heights 0.1..0.9; 16-cell pieces of these waves measure 0.19.
        assert!(
            mean_height < 0.3,
            "pieces are thin: mean height {mean_height}"
        );
        for k in 0..4000 {
            let (u, v) = ((k % 97) as f64 / 96.0, (k / 97) as f64 / 41.0);
            let Some(h) = height_at(&p, u, v) else {
                continue;
            };
            let inside = boxes.iter().any(|b| {
                let q = [u, v, h];
                (0..3).all(|a| f64::from(b.lo[a]) <= q[a] && q[a] <= f64::from(b.hi[a]))
            });
            assert!(inside, "surface point ({u}, {v}, {h}) in no piece");
        }
    }
}
