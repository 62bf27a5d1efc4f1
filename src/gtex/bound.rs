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

/// Cells per block side: one code stands for the largest bound of a block's cells. Two keeps
/// the map at a quarter byte per texel (about 5% of the maps' bytes) at a small cost in tightness.
pub const BLOCK: i64 = 2;

/// Codes per doubling of the bound: a step of 2^(1/16), about 4.4%.
const CODES_PER_OCTAVE: f64 = 16.0;

/// Code of the largest bound (the map's `scale`).
const TOP: f64 = 255.0;

/// One patch's bounds: `codes` row by row over its blocks, `scale` the largest bound (world
/// units). Code 0 is a bound of exactly zero (no surface, or surface on the mesh); code c > 0
/// decodes to scale * 2^((c - 255) / 16), so codes span about 16 octaves below `scale` (smaller
/// bounds round up to code 1).
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorBoundMap {
    pub scale: f32,
    pub codes: Vec<u8>,
}

/// Blocks along each side of a patch of `width` x `height` texels: (w + 1) x (h + 1) cells in
/// blocks of BLOCK.
pub fn block_dims(width: u32, height: u32) -> (usize, usize) {
    let blocks = |n: u32| (i64::from(n) + 1 + BLOCK - 1) / BLOCK;
    (blocks(width) as usize, blocks(height) as usize)
}

/// Block (column, row) of cell (i, j) (cells from -1), or None outside the patch's cells.
pub fn block_of_cell(width: u32, height: u32, i: i64, j: i64) -> Option<(usize, usize)> {
    let inside = (-1..i64::from(width)).contains(&i) && (-1..i64::from(height)).contains(&j);
    inside.then(|| (((i + 1) / BLOCK) as usize, ((j + 1) / BLOCK) as usize))
}

impl ErrorBoundMap {
    /// The map of per-cell bounds `cell_bounds` ((w + 1) x (h + 1), row by row from cell
    /// (-1, -1), world units, each finite and >= 0): each block keeps its largest, rounded up.
    pub fn from_cells(width: u32, height: u32, cell_bounds: &[f64]) -> ErrorBoundMap {
        let (cw, ch) = (width as usize + 1, height as usize + 1);
        assert_eq!(cell_bounds.len(), cw * ch, "one bound per cell");
        let (bw, bh) = block_dims(width, height);
        let mut block_max = vec![0.0f64; bw * bh];
        for (c, &b) in cell_bounds.iter().enumerate() {
            let (ci, cj) = (c % cw, c / cw);
            let k = (cj / BLOCK as usize) * bw + ci / BLOCK as usize;
            block_max[k] = block_max[k].max(b);
        }
        let scale = block_max.iter().copied().fold(0.0, f64::max);
        // f32 rounded up, so that the top code never decodes below the largest bound.
        let mut scale32 = scale as f32;
        if f64::from(scale32) < scale {
            scale32 = f32::from_bits(scale32.to_bits() + 1);
        }
        let codes = block_max
            .iter()
            .map(|&b| Self::encode(b, f64::from(scale32)))
            .collect();
        ErrorBoundMap {
            scale: scale32,
            codes,
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
        let (bw, _) = block_dims(width, height);
        block_of_cell(width, height, i, j).map_or(0.0, |(bi, bj)| {
            Self::decode(self.codes[bj * bw + bi], f64::from(self.scale))
        })
    }

    /// Every block's decoded bound, row by row.
    pub fn decoded(&self) -> impl Iterator<Item = f64> + '_ {
        let scale = f64::from(self.scale);
        self.codes.iter().map(move |&c| Self::decode(c, scale))
    }

    /// Bytes the map takes: a code per block and the f32 scale.
    pub fn bytes(&self) -> usize {
        self.codes.len() + 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decoded_bounds_never_fall_below_and_stay_within_one_step() {
        let (w, h) = (5u32, 3u32);
        let cells: Vec<f64> = (0..(w + 1) * (h + 1))
            .map(|k| {
                if k == 7 {
                    0.0
                } else {
                    1e-3 * (1.0 + (k as f64 * 0.7).sin().abs() * 40.0)
                }
            })
            .collect();
        let map = ErrorBoundMap::from_cells(w, h, &cells);
        for j in -1..h as i64 {
            for i in -1..w as i64 {
                let c = ((j + 1) * (w as i64 + 1) + i + 1) as usize;
                let got = map.at_cell(w, h, i, j);
                assert!(got >= cells[c], "cell ({i}, {j}): {got} < {}", cells[c]);
            }
        }
        // The block holding the largest cell decodes within one code step of it.
        let max = cells.iter().copied().fold(0.0, f64::max);
        let top = map.decoded().fold(0.0, f64::max);
        assert!(top >= max && top <= max * 1.0001, "{top} vs {max}");
        assert_eq!(block_dims(w, h), (3, 2));
        assert_eq!(map.codes.len(), 6);
    }

    #[test]
    fn tiny_bounds_round_up_to_the_smallest_code_and_zero_stays_zero() {
        let map = ErrorBoundMap::from_cells(1, 1, &[1.0, 1e-12, 0.0, 0.0]);
        assert_eq!(map.codes, vec![255]);
        let map = ErrorBoundMap::from_cells(3, 3, &[0.0; 16]);
        assert!(map.codes.iter().all(|&c| c == 0));
        assert_eq!(map.at_cell(3, 3, 0, 0), 0.0);
    }
}
