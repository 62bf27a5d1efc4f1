//! Geometry textures straight from regular height grids (geological horizons, terrain): no mesh,
//! no partition; each grid is cut into tiles that fit one patch.
//!
//! Space: world. Grid sample (column i, row j) lies at (x0 + i dx, y0 + j dy, z[j][i]); NaN
//! means no data. Each sample becomes a texel centre, so the patch surface (bilinear in cells
//! whose four texels hold surface, src/heightfield.rs) passes through every sample and matches
//! the grid's two-triangles-per-cell surface to within the cell's bilinear twist. Neighbouring
//! tiles share their border row or column of samples, so their surfaces meet without a crack.

use glam::{DVec2, DVec3};

use crate::error::{GeomtexError, Result};
use crate::gtex::{
    encode_height, encode_normal, vertical_extent, GeometryTextureSet, Patch, Stats, OUTLINE_INSIDE,
};
use crate::heightfield::grid_normal;

/// One regular grid of heights with optional RGBA8 colors (row-major, `width` samples a row).
pub struct HeightGrid {
    pub width: usize,
    pub height: usize,
    pub origin: DVec2,
    pub spacing: DVec2,
    pub z: Vec<f64>,
    pub colors: Option<Vec<[u8; 4]>>,
}

impl HeightGrid {
    fn validate(&self, k: usize) -> Result<()> {
        let bad = |m: String| Err(GeomtexError::Parameter(format!("grid {k}: {m}")));
        if self.width < 2 || self.height < 2 {
            return bad(format!(
                "needs at least 2 x 2 samples, got {} x {}",
                self.height, self.width
            ));
        }
        if self.z.len() != self.width * self.height {
            return bad(format!(
                "{} heights for {} x {} samples",
                self.z.len(),
                self.height,
                self.width
            ));
        }
        if !(self.origin.is_finite()
            && self.spacing.is_finite()
            && self.spacing.min_element() > 0.0)
        {
            return bad(format!(
                "extent must be finite with x0 < x1 and y0 < y1 (origin {}, spacing {})",
                self.origin, self.spacing
            ));
        }
        if let Some(t) = self.z.iter().position(|z| z.is_infinite()) {
            return bad(format!(
                "height at row {}, column {} is infinite (use NaN for no data)",
                t / self.width,
                t % self.width
            ));
        }
        if self.z.iter().all(|z| z.is_nan()) {
            return bad("every height is NaN: nothing to convert".into());
        }
        if let Some(c) = &self.colors {
            if c.len() != self.z.len() {
                return bad(format!("{} colors for {} samples", c.len(), self.z.len()));
            }
        }
        Ok(())
    }

    fn at(&self, i: usize, j: usize) -> f64 {
        self.z[j * self.width + i]
    }

    /// Unit normal from central differences (one-sided at edges and next to missing data).
    fn normal(&self, i: usize, j: usize) -> DVec3 {
        let at = |i: usize, j: usize| Some(self.at(i, j)).filter(|z| !z.is_nan());
        grid_normal(
            at,
            (self.width, self.height),
            (i, j),
            (self.spacing.x, self.spacing.y),
        )
    }
}

/// Tile starts along one axis of `n` samples for tiles of at most `tile` samples sharing their
/// border sample; a last tile of one sample would add nothing, so it is never made.
fn tile_starts(n: usize, tile: usize) -> Vec<usize> {
    (0..)
        .map(|k| k * (tile - 1))
        .take_while(|&s| s + 1 < n)
        .collect()
}

/// `max_resolution` (the longest tile side, in samples) when none is given.
pub const DEFAULT_MAX_RESOLUTION: i64 = 256;
/// `height_bits` when none is given.
pub const DEFAULT_HEIGHT_BITS: i64 = 16;

/// Builds a set from grids, cut into tiles of at most `max_resolution` x `max_resolution`
/// samples (default `DEFAULT_MAX_RESOLUTION`) with `height_bits`-bit heights (default
/// `DEFAULT_HEIGHT_BITS`, else 8).
pub fn from_grids(
    grids: &[HeightGrid],
    max_resolution: Option<i64>,
    height_bits: Option<i64>,
) -> Result<GeometryTextureSet> {
    let tile = max_resolution.unwrap_or(DEFAULT_MAX_RESOLUTION);
    let bits = height_bits.unwrap_or(DEFAULT_HEIGHT_BITS);
    if grids.is_empty() {
        return Err(GeomtexError::Parameter("no grids given".into()));
    }
    let longest = i64::from(crate::gtex::MAX_PATCH_SIDE);
    if !(2..=longest).contains(&tile) {
        return Err(GeomtexError::Parameter(format!(
            "max_resolution must be in [2, {longest}], got {tile}"
        )));
    }
    let bits = match u8::try_from(bits) {
        Ok(b) if crate::gtex::HEIGHT_BITS.contains(&b) => b,
        _ => {
            return Err(GeomtexError::Parameter(format!(
                "height_bits must be 8 or 16, got {bits}"
            )))
        }
    };
    for (k, g) in grids.iter().enumerate() {
        g.validate(k)?;
    }
    let tile = tile as usize;
    let mut patches = Vec::new();
    let mut per_patch_grid = Vec::new();
    for (k, g) in grids.iter().enumerate() {
        for &j0 in &tile_starts(g.height, tile) {
            for &i0 in &tile_starts(g.width, tile) {
                if let Some(p) = tile_patch(g, (i0, j0), tile, bits) {
                    patches.push(p);
                    per_patch_grid.push(k as f64);
                }
            }
        }
    }
    let mut set = GeometryTextureSet {
        texel_size: grids
            .iter()
            .map(|g| g.spacing.max_element())
            .fold(0.0, f64::max),
        patches,
        stats: Stats::default(),
        triangles: None,
    };
    set.stats = grid_stats(grids, &set, bits);
    set.stats.per_patch = vec![("patch_grid".into(), per_patch_grid)];
    // Heights spanning more than f64 holds (1e308 above -1e308) would make an infinite box.
    set.validate()
        .map_err(|e| GeomtexError::Parameter(format!("the grids give no renderable set: {e}")))?;
    Ok(set)
}

/// The patch of the tile of `g` starting at sample (i0, j0), at most `tile` samples a side;
/// None if the tile holds no data.
fn tile_patch(g: &HeightGrid, (i0, j0): (usize, usize), tile: usize, bits: u8) -> Option<Patch> {
    let (tw, th) = (tile.min(g.width - i0), tile.min(g.height - j0));
    let samples = (j0..j0 + th).flat_map(|j| (i0..i0 + tw).map(move |i| (i, j)));
    let (lo, hi) = samples
        .clone()
        .map(|(i, j)| g.at(i, j))
        .filter(|z| !z.is_nan())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), z| {
            (lo.min(z), hi.max(z))
        });
    if lo > hi {
        return None;
    }
    let texel = g.spacing.min_element();
    let (thickness, bits) = vertical_extent(hi - lo, texel, bits);
    let origin = DVec3::new(
        g.origin.x + (i0 as f64 - 0.5) * g.spacing.x,
        g.origin.y + (j0 as f64 - 0.5) * g.spacing.y,
        lo - 0.5 * (thickness - (hi - lo)),
    );
    let mut p = Patch {
        origin,
        axes: [DVec3::X, DVec3::Y, DVec3::Z],
        extent: DVec3::new(tw as f64 * g.spacing.x, th as f64 * g.spacing.y, thickness),
        width: tw as u32,
        height: th as u32,
        height_bits: bits,
        heights: Vec::with_capacity(tw * th),
        normals: Vec::with_capacity(tw * th),
        // No property, no color map.
        colors: Vec::with_capacity(if g.colors.is_some() { tw * th } else { 0 }),
        faces: vec![],
        ring_faces: vec![],
        // A grid's surface ends at its missing samples: the texel grid is its outline.
        outline: vec![OUTLINE_INSIDE; tw * th],
        error_bound: None,
    };
    for (i, j) in samples {
        let z = g.at(i, j);
        let filled = !z.is_nan();
        p.heights.push(if filled {
            encode_height((z - origin.z) / thickness, bits)
        } else {
            0
        });
        p.normals.push(encode_normal(if filled {
            g.normal(i, j)
        } else {
            DVec3::Z
        }));
        if let Some(c) = &g.colors {
            p.colors.push(c[j * g.width + i]);
        }
    }
    Some(p)
}

/// The stats of a set built from `grids` with `height_bits` requested.
fn grid_stats(grids: &[HeightGrid], set: &GeometryTextureSet, height_bits: u8) -> Stats {
    let samples: usize = grids.iter().map(|g| g.z.len()).sum();
    let missing: usize = grids
        .iter()
        .map(|g| g.z.iter().filter(|z| z.is_nan()).count())
        .sum();
    let mut stats = Stats::default();
    for (name, v) in [
        ("grids", grids.len() as f64),
        ("samples", samples as f64),
        ("missing_samples", missing as f64),
        ("charts", set.patches.len() as f64),
        ("texels", set.texels() as f64),
        ("empty_texels", set.empty_texels() as f64),
        ("bytes", set.map_bytes() as f64),
        ("height_bits", height_bits as f64),
        (
            "max_quantization_error",
            set.patches
                .iter()
                .map(Patch::quantization_error)
                .fold(0.0, f64::max),
        ),
        ("texel_size", set.texel_size),
    ] {
        stats.set(name, v);
    }
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::heightfield::height_at;

    fn grid(w: usize, h: usize, f: impl Fn(f64, f64) -> f64) -> HeightGrid {
        let (origin, spacing) = (DVec2::new(10.0, -5.0), DVec2::new(0.5, 0.25));
        let z = (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .map(|(i, j)| {
                f(
                    origin.x + i as f64 * spacing.x,
                    origin.y + j as f64 * spacing.y,
                )
            })
            .collect();
        HeightGrid {
            width: w,
            height: h,
            origin,
            spacing,
            z,
            colors: None,
        }
    }

    #[test]
    fn tiles_share_borders_and_pass_through_every_sample() {
        assert_eq!(tile_starts(10, 4), vec![0, 3, 6]);
        assert_eq!(tile_starts(7, 4), vec![0, 3]);
        let mut g = grid(23, 17, |x, y| (0.3 * x).sin() + 0.2 * y);
        g.z[5 * 23 + 7] = f64::NAN;
        let set = from_grids(&[g], Some(8), Some(16)).unwrap();
        assert_eq!(set.patches.len(), 4 * 3);
        let g = grid(23, 17, |x, y| (0.3 * x).sin() + 0.2 * y);
        // Every sample is on the surface of every tile that holds it (to the 16-bit rounding).
        for j in 0..17 {
            for i in 0..23 {
                let (x, y) = (10.0 + i as f64 * 0.5, -5.0 + j as f64 * 0.25);
                let mut seen = 0;
                for p in &set.patches {
                    let (u, v) = ((x - p.origin.x) / p.extent.x, (y - p.origin.y) / p.extent.y);
                    if (0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v) {
                        if let Some(h) = height_at(p, u, v) {
                            let z = p.origin.z + h * p.extent.z;
                            assert!((z - g.at(i, j)).abs() <= 2.0 * p.quantization_error());
                            seen += 1;
                        }
                    }
                }
                // The missing sample's four cells are empty; every other sample has a surface.
                let near_hole = (6..=8).contains(&i) && (4..=6).contains(&j);
                assert!(seen >= 1 || near_hole, "sample {i},{j}");
            }
        }
    }

    #[test]
    fn bad_grids_are_errors_with_their_place() {
        let mut g = grid(4, 3, |_, _| 0.0);
        g.z[5] = f64::INFINITY;
        let e = from_grids(&[grid(4, 3, |_, _| 0.0), g], Some(256), Some(16))
            .unwrap_err()
            .to_string();
        assert!(e.contains("grid 1") && e.contains("row 1, column 1"), "{e}");
        let mut g = grid(4, 3, |_, _| f64::NAN);
        assert!(from_grids(&[g], Some(256), Some(16))
            .unwrap_err()
            .to_string()
            .contains("NaN"));
        g = grid(1, 3, |_, _| 0.0);
        assert!(from_grids(&[g], Some(256), Some(16)).is_err());
        assert!(from_grids(&[], Some(256), Some(16)).is_err());
    }

    #[test]
    fn out_of_range_keywords_are_parameter_errors_and_defaults_apply() {
        let message = |r: Option<i64>, b: Option<i64>| {
            from_grids(&[grid(4, 3, |_, _| 0.0)], r, b)
                .unwrap_err()
                .to_string()
        };
        assert_eq!(
            message(Some(-5), None),
            "max_resolution must be in [2, 4096], got -5"
        );
        assert_eq!(
            message(Some(1 << 40), None),
            format!("max_resolution must be in [2, 4096], got {}", 1i64 << 40)
        );
        assert_eq!(
            message(None, Some(12)),
            "height_bits must be 8 or 16, got 12"
        );
        assert_eq!(
            message(None, Some(-8)),
            "height_bits must be 8 or 16, got -8"
        );
        let set = from_grids(&[grid(300, 3, |x, _| x)], None, None).unwrap();
        assert_eq!(
            set.patches.len(),
            2,
            "tiles of DEFAULT_MAX_RESOLUTION samples"
        );
        assert!(set.patches.iter().all(|p| p.height_bits == 16));
    }
}
