//! A patch's error-bound map: for each bilinear cell of its height field, a bound on the world
//! distance from any point of the stored surface in that cell to the source mesh (computed at
//! conversion in closed form: convert::bound), kept per block of `BLOCK` x `BLOCK` cells as
//! one-byte codes on a logarithmic scale, rounded up so that a decoded bound never falls below
//! the computed one.
//!
//! Space: cells are indexed in texel-centre coordinates (heightfield.rs): cell (i, j) spans
//! x in [i, i + 1], y in [j, j + 1] where texel (i, j) sits at (i, j); a patch of w x h texels has
//! (w + 1) x (h + 1) cells, from (-1, -1) (the cells over the box's border half-texel). Bounds
//! are world units.

/// Cells per block side of a patch of ordinary size: one code stands for the largest bound of
/// a block's cells. Two keeps the map at a quarter byte per texel (about 5% of the maps' bytes)
/// at a small cost in tightness. Files of versions 6 and 7 use it for every patch.
pub const BLOCK: u32 = 2;

/// Codes per doubling of the bound: a step of 2^(1/16), about 4.4%.
const CODES_PER_OCTAVE: f64 = 16.0;

/// Code of the largest bound (the map's `scale`).
const TOP: f64 = 255.0;

/// The exponent byte of a zero scale (every bound zero).
const ZERO_SCALE: i8 = i8::MIN;

/// How a map's scale is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScaleStorage {
    /// One signed byte e, the scale 2^e (e = -128: a zero scale); the block side follows from
    /// the patch's size (`block_side`). What conversion makes: a 2 x 2-texel patch's bound then
    /// takes 2 bytes (the exponent and one code), where an f32 scale and 2 x 2 blocks took 8,
    /// 40% of its maps' 20 bytes.
    Exponent,
    /// An f32 and 2 x 2-cell blocks, as files of versions 6 and 7 hold them.
    F32,
}

/// One patch's bounds: `codes` row by row over its blocks of `block` x `block` cells, `scale`
/// the largest bound's power of two or above (world units). Code 0 is a bound of exactly zero
/// (no surface, or surface on the mesh); code c > 0 decodes to scale * 2^((c - 255) / 16), so
/// codes span about 16 octaves below `scale` (smaller bounds round up to code 1).
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorBoundMap {
    pub scale: f32,
    pub codes: Vec<u8>,
    /// Cells per block side.
    pub block: u32,
    pub storage: ScaleStorage,
}

/// Blocks along each side of a patch of `width` x `height` texels: (w + 1) x (h + 1) cells in
/// blocks of `block`.
pub fn block_dims(width: u32, height: u32, block: u32) -> (usize, usize) {
    let blocks = |n: u32| (n as usize + 1).div_ceil(block as usize);
    (blocks(width), blocks(height))
}

/// The block side of a patch of `width` x `height` texels whose maps take `map_bytes`: `BLOCK`,
/// or the least power of two above it that keeps the exponent byte and the codes within a tenth
/// of the maps' bytes (never under two bytes: the exponent and one code). Only patches of a
/// few texels a side take more than `BLOCK`; a reader finds the same side from the patch's
/// header.
pub fn block_side(width: u32, height: u32, map_bytes: usize) -> u32 {
    let budget = (map_bytes / 10).max(2);
    let mut side = BLOCK;
    loop {
        let (bw, bh) = block_dims(width, height, side);
        // The codes and the exponent byte within the budget.
        if bw * bh < budget || bw * bh == 1 {
            return side;
        }
        side *= 2;
    }
}

/// Block (column, row) of cell (i, j) (cells from -1) in blocks of `block`, or None outside
/// the patch's cells.
pub fn block_of_cell(
    width: u32,
    height: u32,
    block: u32,
    i: i64,
    j: i64,
) -> Option<(usize, usize)> {
    let inside = (-1..i64::from(width)).contains(&i) && (-1..i64::from(height)).contains(&j);
    let block = i64::from(block);
    inside.then(|| (((i + 1) / block) as usize, ((j + 1) / block) as usize))
}

/// 2^e as an f32, exact for e in [-149, 127] (below -126 a subnormal).
fn power_of_two(e: i32) -> f32 {
    if e >= -126 {
        f32::from_bits(((e + 127) as u32) << 23)
    } else {
        f32::from_bits(1u32 << (e + 149))
    }
}

/// The least e in [-127, 127] with 2^e >= `v`, or None past 2^127.
fn least_power_at_or_above(v: f64) -> Option<i32> {
    (-127..=127).find(|&e| f64::from(power_of_two(e)) >= v)
}

/// The exponent byte of the least power of two at or above `scale` (the zero scale's for 0): the
/// scale itself for every map made here (a larger one would only loosen the decoded bounds).
pub fn exponent_at_least(scale: f32) -> i8 {
    if scale == 0.0 {
        return ZERO_SCALE;
    }
    least_power_at_or_above(f64::from(scale)).unwrap_or(127) as i8
}

/// The scale of exponent byte `e`.
pub fn scale_of_exponent(e: i8) -> f32 {
    if e == ZERO_SCALE {
        0.0
    } else {
        power_of_two(i32::from(e))
    }
}

impl ErrorBoundMap {
    /// The map of per-cell bounds `cell_bounds` ((w + 1) x (h + 1), row by row from cell
    /// (-1, -1), world units, each finite and >= 0) in blocks of `block` cells a side: each
    /// block keeps its largest, rounded up; the scale is a power of two (an f32 in 2 x 2 blocks
    /// past 2^127, which no exponent byte holds).
    pub fn from_cells(width: u32, height: u32, block: u32, cell_bounds: &[f64]) -> Self {
        let block_max = Self::block_maxima(width, height, block, cell_bounds);
        let largest = block_max.iter().copied().fold(0.0, f64::max);
        let (scale, storage) = if largest == 0.0 {
            (0.0, ScaleStorage::Exponent)
        } else {
            match least_power_at_or_above(largest) {
                Some(e) => (power_of_two(e), ScaleStorage::Exponent),
                None => return Self::with_f32_scale(width, height, cell_bounds),
            }
        };
        Self::encoded(&block_max, scale, block, storage)
    }

    /// `from_cells` for patch `p`, in blocks of its `block_side`.
    pub fn for_patch(p: &super::Patch, cell_bounds: &[f64]) -> Self {
        let map_bytes = super::map_bytes(p.texels(), p.height_bits, p.has_colors());
        let block = block_side(p.width, p.height, map_bytes);
        Self::from_cells(p.width, p.height, block, cell_bounds)
    }

    /// The map in the blocks a file holds for patch `p` (`block_side` for an exponent scale; an
    /// f32 scale keeps its 2 x 2 blocks): itself, or re-blocked from its decoded cell bounds
    /// where it was made with other blocks (each new block keeps the largest it covers, so no
    /// bound falls), so that a reader finds the blocks the header implies.
    pub fn in_file_blocks(&self, p: &super::Patch) -> std::borrow::Cow<'_, Self> {
        let map_bytes = super::map_bytes(p.texels(), p.height_bits, p.has_colors());
        let block = match self.storage {
            ScaleStorage::Exponent => block_side(p.width, p.height, map_bytes),
            ScaleStorage::F32 => BLOCK,
        };
        if block == self.block {
            return std::borrow::Cow::Borrowed(self);
        }
        let cells = self.decoded_cells(p.width, p.height);
        std::borrow::Cow::Owned(match self.storage {
            ScaleStorage::Exponent => Self::from_cells(p.width, p.height, block, &cells),
            ScaleStorage::F32 => Self::with_f32_scale(p.width, p.height, &cells),
        })
    }

    /// The map as files of versions 6 and 7 hold it: 2 x 2 blocks under an f32 scale.
    pub fn with_f32_scale(width: u32, height: u32, cell_bounds: &[f64]) -> Self {
        let block_max = Self::block_maxima(width, height, BLOCK, cell_bounds);
        let largest = block_max.iter().copied().fold(0.0, f64::max);
        // f32 rounded up, so that the top code never decodes below the largest bound.
        let mut scale = largest as f32;
        if f64::from(scale) < largest {
            scale = f32::from_bits(scale.to_bits() + 1);
        }
        Self::encoded(&block_max, scale, BLOCK, ScaleStorage::F32)
    }

    /// Each block's largest cell bound, row by row.
    fn block_maxima(width: u32, height: u32, block: u32, cell_bounds: &[f64]) -> Vec<f64> {
        let (cw, ch) = (width as usize + 1, height as usize + 1);
        assert_eq!(cell_bounds.len(), cw * ch, "one bound per cell");
        let (bw, bh) = block_dims(width, height, block);
        let mut block_max = vec![0.0f64; bw * bh];
        for (c, &b) in cell_bounds.iter().enumerate() {
            let (ci, cj) = (c % cw, c / cw);
            let k = (cj / block as usize) * bw + ci / block as usize;
            block_max[k] = block_max[k].max(b);
        }
        block_max
    }

    fn encoded(block_max: &[f64], scale: f32, block: u32, storage: ScaleStorage) -> Self {
        let codes = (block_max.iter())
            .map(|&b| Self::encode(b, f64::from(scale)))
            .collect();
        ErrorBoundMap {
            scale,
            codes,
            block,
            storage,
        }
    }

    /// The smallest code whose bound is >= `bound` (0 only for a zero bound).
    fn encode(bound: f64, scale: f64) -> u8 {
        if bound <= 0.0 || scale <= 0.0 {
            return 0;
        }
        let mut c = (TOP + CODES_PER_OCTAVE * (bound / scale).log2())
            .ceil()
            .clamp(1.0, TOP) as u8;
        // Guard the last bit of rounding in log2/exp2: step up until the decoded bound holds.
        while c < u8::MAX && Self::decode(c, scale) < bound {
            c += 1;
        }
        c
    }

    /// World bound of code `c` under `scale`.
    pub fn decode(c: u8, scale: f64) -> f64 {
        if c == 0 {
            0.0
        } else {
            scale * ((f64::from(c) - TOP) / CODES_PER_OCTAVE).exp2()
        }
    }

    /// The bound of cell (i, j) (cells from -1), 0 outside the patch's cells.
    pub fn at_cell(&self, width: u32, height: u32, i: i64, j: i64) -> f64 {
        let (bw, _) = block_dims(width, height, self.block);
        block_of_cell(width, height, self.block, i, j).map_or(0.0, |(bi, bj)| {
            Self::decode(self.codes[bj * bw + bi], f64::from(self.scale))
        })
    }

    /// Every cell's decoded bound ((w + 1) x (h + 1), row by row from cell (-1, -1), as
    /// `from_cells` takes them) of a patch of `width` x `height` texels.
    pub fn decoded_cells(&self, width: u32, height: u32) -> Vec<f64> {
        (-1..i64::from(height))
            .flat_map(|j| (-1..i64::from(width)).map(move |i| (i, j)))
            .map(|(i, j)| self.at_cell(width, height, i, j))
            .collect()
    }

    /// Every block's decoded bound, row by row.
    pub fn decoded(&self) -> impl Iterator<Item = f64> + '_ {
        let scale = f64::from(self.scale);
        self.codes.iter().map(move |&c| Self::decode(c, scale))
    }

    /// Bytes the map takes: a code per block and the scale (an exponent byte or an f32); a
    /// zero exponent-byte scale leaves its codes out (all 0).
    pub fn bytes(&self) -> usize {
        match self.storage {
            ScaleStorage::Exponent if self.scale == 0.0 => 1,
            ScaleStorage::Exponent => 1 + self.codes.len(),
            ScaleStorage::F32 => 4 + self.codes.len(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bounds over the cells of a `w` x `h` patch, one of them zero.
    fn some_cells(w: u32, h: u32) -> Vec<f64> {
        (0..(w + 1) * (h + 1))
            .map(|k| {
                if k == 7 {
                    0.0
                } else {
                    1e-3 * (1.0 + (k as f64 * 0.7).sin().abs() * 40.0)
                }
            })
            .collect()
    }

    #[test]
    fn decoded_bounds_never_fall_below_and_stay_within_one_step() {
        let (w, h) = (5u32, 3u32);
        let cells = some_cells(w, h);
        let max = cells.iter().copied().fold(0.0, f64::max);
        let f32_map = ErrorBoundMap::with_f32_scale(w, h, &cells);
        for map in [
            ErrorBoundMap::from_cells(w, h, BLOCK, &cells),
            ErrorBoundMap::from_cells(w, h, 4, &cells),
            f32_map.clone(),
        ] {
            for j in -1..h as i64 {
                for i in -1..w as i64 {
                    let c = ((j + 1) * (w as i64 + 1) + i + 1) as usize;
                    let got = map.at_cell(w, h, i, j);
                    assert!(got >= cells[c], "cell ({i}, {j}): {got} < {}", cells[c]);
                }
            }
            // The block holding the largest cell decodes within one code step of it.
            let top = map.decoded().fold(0.0, f64::max);
            let step = (1.0 / CODES_PER_OCTAVE).exp2();
            assert!(top >= max && top <= max * step, "{top} vs {max}");
        }
        // An f32 scale is the largest bound itself; an exponent scale the power of two above.
        assert!(f64::from(f32_map.scale) >= max && f64::from(f32_map.scale) <= max * 1.0001);
        let map = ErrorBoundMap::from_cells(w, h, BLOCK, &cells);
        assert_eq!(map.scale, 0.0625);
        assert!(max > 0.03125 && max <= 0.0625);
        assert_eq!(block_dims(w, h, BLOCK), (3, 2));
        assert_eq!(block_dims(w, h, 4), (2, 1));
        assert_eq!((map.codes.len(), map.bytes()), (6, 7));
        assert_eq!((f32_map.codes.len(), f32_map.bytes()), (6, 10));
    }

    #[test]
    fn tiny_bounds_round_up_to_the_smallest_code_and_zero_stays_zero() {
        let map = ErrorBoundMap::from_cells(1, 1, BLOCK, &[1.0, 1e-12, 0.0, 0.0]);
        assert_eq!(map.codes, vec![255]);
        let map = ErrorBoundMap::from_cells(3, 3, BLOCK, &[0.0; 16]);
        assert!(map.codes.iter().all(|&c| c == 0));
        assert_eq!(map.at_cell(3, 3, 0, 0), 0.0);
        assert_eq!((map.scale, exponent_at_least(map.scale)), (0.0, ZERO_SCALE));
        assert_eq!(map.bytes(), 1); // the exponent alone
    }

    #[test]
    fn exponent_bytes_hold_every_power_of_two_of_f32_and_larger_bounds_keep_an_f32() {
        for e in -127..=127 {
            let scale = power_of_two(e);
            assert_eq!(f64::from(scale), 2f64.powi(e));
            assert_eq!(scale_of_exponent(exponent_at_least(scale)), scale);
        }
        // Between two powers: the one above.
        assert_eq!(scale_of_exponent(exponent_at_least(0.3)), 0.5);
        // Past 2^127 no exponent byte holds the scale: 2 x 2 blocks under an f32.
        let huge = ErrorBoundMap::from_cells(1, 1, 4, &[1e39, 0.0, 0.0, 0.0]);
        assert_eq!((huge.storage, huge.block), (ScaleStorage::F32, BLOCK));
        assert!(f64::from(huge.scale) >= 1e39);
    }

    #[test]
    fn small_patches_take_larger_blocks_to_stay_within_a_tenth_of_their_maps() {
        // 16-bit heights, no colors: 5 bytes a texel.
        let bytes = |w: u32, h: u32| {
            let map_bytes = w as usize * h as usize * 5;
            let side = block_side(w, h, map_bytes);
            let (bw, bh) = block_dims(w, h, side);
            (side, bw * bh + 1, map_bytes)
        };
        // 2 x 2 texels: one code and the exponent, 2 of 20 bytes (2 x 2 blocks took 8).
        assert_eq!(bytes(2, 2), (4, 2, 20));
        assert_eq!(bytes(2, 5), (4, 3, 50));
        assert_eq!(bytes(4, 4), (4, 5, 80));
        // From about six texels a side, the usual blocks.
        assert_eq!(bytes(6, 6).0, BLOCK);
        assert_eq!(bytes(256, 256).0, BLOCK);
        for w in 2..40 {
            for h in 2..40 {
                let (_, bound, maps) = bytes(w, h);
                assert!(bound * 10 <= maps, "{w} x {h}: {bound} of {maps} bytes");
            }
        }
        // A 1 x 1 patch still keeps a code: 2 bytes at least.
        assert_eq!(bytes(1, 1).1, 2);
    }
}
