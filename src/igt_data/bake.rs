//! The shader LoD's plain texture: per cell of the primary space, the detailed surface's
//! attributes at the cell's centre, baked once so that far away (where a cell covers less than
//! a pixel) the shader reads four cells bilinearly instead of walking a list
//! (shaders/igt_functions.wgsl, igt_baked). The primary space is itself the atlas: the same
//! projection serves both, so no second parameterization is needed and the switch shows the
//! same surface point.
//!
//! A cell's value is that of the lookup at its centre (lookup.rs: the listed triangle
//! containing it, or the nearest listed one, which also extends each chart's values a cell past
//! its border, as dilation would); the texture is filtered over the cell's footprint in the
//! image, and ambient occlusion is multiplied into the color.
//!
//! Spaces: primary space in cell units (primary.rs).

use glam::{DVec2, Vec3};
use rayon::prelude::*;

use super::InverseGeometricTexture;

/// The base color of a face without colors or a texture (as the shader's neutral).
pub const NEUTRAL: [u8; 4] = [200, 200, 200, 255];

/// A baked cell: the unit normal (object space) and the base color, occlusion applied.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Baked {
    pub normal: Vec3,
    pub color: [u8; 4],
}

impl InverseGeometricTexture {
    /// One record per cell (global order); None where nothing is listed near its centre.
    pub fn bake(&self) -> Vec<Option<Baked>> {
        let footprint = self.texels_per_cell();
        let owner: Vec<usize> = (self.grids.iter().enumerate())
            .flat_map(|(g, grid)| std::iter::repeat_n(g, grid.cells() as usize))
            .collect();
        (0..self.cells())
            .into_par_iter()
            .map(|c| {
                let g = owner[c];
                let grid = &self.grids[g];
                let local = c as u32 - grid.first_cell;
                let (i, j) = (local % grid.width, local / grid.width);
                let hit = self.lookup_uv(g, DVec2::new(i as f64 + 0.5, j as f64 + 0.5));
                (hit.face >= 0).then(|| self.baked_at(hit.face as usize, hit.bary, &footprint))
            })
            .collect()
    }

    /// The attributes of detailed face `f` at barycentrics `bary`.
    fn baked_at(&self, f: usize, bary: [f64; 3], footprint: &[f64]) -> Baked {
        let a = &self.attributes;
        let normal = (0..3)
            .map(|k| Vec3::from_array(a.normals[f][k]) * bary[k] as f32)
            .sum::<Vec3>()
            .normalize_or_zero();
        let mix = |v: [f64; 3]| v[0] * bary[0] + v[1] * bary[1] + v[2] * bary[2];
        let mut color = match (&a.uv, &a.image, &a.colors) {
            (Some(uv), Some(image), _) => {
                let at = |d: usize| mix(uv[f].map(|c| c[d] as f64));
                let rgba = image.sample(DVec2::new(at(0), at(1)), footprint[f]);
                rgba.map(|v| v * 255.0)
            }
            (_, _, Some(colors)) => std::array::from_fn(|d| mix(colors[f].map(|c| c[d] as f64))),
            _ => NEUTRAL.map(f64::from),
        };
        if let Some(ao) = &a.ao {
            let open = mix(ao[f].map(f64::from)) / 255.0;
            color[..3].iter_mut().for_each(|v| *v *= open);
        }
        Baked {
            normal,
            color: color.map(|v| v.round().clamp(0.0, 255.0) as u8),
        }
    }

    /// Per face, how many of the image's pixels one cell spans across it (its texture area
    /// over its area in the primary space, as a length): the footprint a baked color averages.
    /// Empty without a texture.
    fn texels_per_cell(&self) -> Vec<f64> {
        let (Some(uv), Some(image)) = (&self.attributes.uv, &self.attributes.image) else {
            return Vec::new();
        };
        let area = |t: [DVec2; 3]| 0.5 * (t[1] - t[0]).perp_dot(t[2] - t[0]).abs();
        let size = DVec2::new(image.width() as f64, image.height() as f64);
        // Any entry of a face will do: the grids share one cell size, or (wrapping) there is
        // one grid.
        let mut primary = vec![0.0; self.face_count()];
        for e in &self.entries {
            primary[e.face as usize] = area(e.corners64());
        }
        (uv.iter().zip(primary))
            .map(|(t, p)| {
                let in_image = area(t.map(|c| DVec2::new(c[0] as f64, c[1] as f64) * size));
                if p > 0.0 {
                    (in_image / p).sqrt()
                } else {
                    1.0
                }
            })
            .collect()
    }
}
