//! Texel sizes: the set's one texel (the largest chart just fits `max_resolution`), or with
//! `max_error` each chart's own, the coarsest that keeps the chart's (`ErrorScope::Chart`) or
//! the set's (`ErrorScope::Set`) reconstruction error within the bound.
//!
//! Space: world lengths (texel sizes, errors, chart sides); resolutions in texels.

use super::accuracy::ERROR_QUANTILE;
use super::draw::{ChartDrawer, ChartJob, Drawn};
use crate::charts::frame::ChartFrame;
use crate::convert_options::{ConvertOptions, ErrorScope};
use crate::error::Result;
use crate::progress::{each_chart, Progress};

/// The set's one texel size: the largest chart just fits `max_resolution`, or `texel_size` if
/// that is coarser.
pub fn common_texel(frames: &[ChartFrame], opts: &ConvertOptions, diagonal: f64) -> f64 {
    let longest = frames.iter().map(ChartFrame::long_side).fold(0.0, f64::max);
    let fit = longest / opts.resolution_cap() as f64;
    let texel = opts.texel_size.map_or(fit, |t| t.max(fit));
    if texel <= 0.0 {
        return diagonal.max(f64::MIN_POSITIVE) * 1e-6; // every chart is a point
    }
    texel
}

/// Each chart's texel size for `max_error`, measured by drawing it at the levels the search
/// tries. With `hybrid` (each chart's own triangles' bytes), a chart gets the coarsest level
/// within the bound among those whose maps would take fewer bytes than its triangles, or None
/// where none of them meets the bound (it stays triangles): levels dearer than the triangles
/// are never drawn, so a rough chart costs a few coarse draws, not a search up to 1024².
pub fn chart_texels(
    jobs: &[ChartJob],
    drawer: &ChartDrawer,
    max_error: f64,
    hybrid: Option<&[f64]>,
    progress: Progress,
) -> Result<Vec<Option<f64>>> {
    let levels = resolution_levels(drawer.opts.resolution_cap());
    if let Some(caps) = hybrid {
        let capped: Vec<_> = jobs.iter().zip(caps).collect();
        return each_chart(&capped, progress, "resolution", |&(j, &cap)| {
            let colored = drawer.mesh.has_colors();
            let affordable: Vec<u32> = (levels.iter().copied())
                .filter(|&r| estimated_bytes(j, r, drawer.opts.height_bits, colored) < cap)
                .collect();
            let s = drawer.samples(j);
            let draw = |r| drawer.measure(j, j.texel_for(r), &s);
            affordable_within(&affordable, max_error, draw).map(|r| j.texel_for(r))
        });
    }
    // Under `guarantee` every chart's own bound must hold: the chart scope, measured by bounds.
    let scope = if drawer.opts.guarantee {
        ErrorScope::Chart
    } else {
        drawer.opts.error_scope
    };
    let picks = match scope {
        ErrorScope::Chart => each_chart(jobs, progress, "resolution", |j| {
            let s = drawer.samples(j);
            coarsest_within(&levels, max_error, |r| {
                drawer.measure(j, j.texel_for(r), &s)
            })
        })?,
        ErrorScope::Set => {
            let budget = drawer.opts.max_bytes.map(|b| b as f64);
            let areas: Vec<f64> = jobs.iter().map(|j| chart_area(drawer, j)).collect();
            let total: f64 = areas.iter().sum::<f64>().max(f64::MIN_POSITIVE);
            let with_area: Vec<_> = jobs.iter().zip(&areas).collect();
            let colored = drawer.mesh.has_colors();
            let costs = each_chart(&with_area, progress, "resolution", |&(j, &area)| {
                let s = drawer.samples(j);
                // A chart's levels dearer than its share of a budget, several times over,
                // would never be chosen: not worth drawing (a rough mesh's charts never get
                // within a tight bound, and the search had drawn them all at 1024²).
                let cap = budget.map_or(f64::INFINITY, |b| SHARE_MEASURED * b * area / total);
                level_costs(&levels, (max_error, cap), colored, |r| {
                    drawer.measure(j, j.texel_for(r), &s)
                })
            })?;
            allocate(&costs, ERROR_QUANTILE, budget)
        }
    };
    Ok(jobs
        .iter()
        .zip(picks)
        .map(|(j, r)| Some(j.texel_for(r)))
        .collect())
}

/// About the bytes of a chart's maps at long side `r` (its box, a texel of padding each side,
/// and the bound map), from its frame: close enough to skip levels dearer than its triangles
/// (the drawn patch's real bytes are checked after).
fn estimated_bytes(job: &ChartJob, r: u32, height_bits: u8, colored: bool) -> f64 {
    let size = job.frame.hi - job.frame.lo;
    let short = (r as f64 * size.x.min(size.y) / job.long_side).ceil();
    let texels = (r as f64 + 2.0) * (short + 2.0);
    crate::gtex::map_bytes(texels as usize, height_bits, colored) as f64 + texels / 4.0
}

/// The coarsest of `levels` (finest first) whose measured error is within `max_error`, or None
/// if even the finest misses it (it is drawn first, so a hopeless chart costs one draw).
fn affordable_within(levels: &[u32], max_error: f64, draw: impl Fn(u32) -> Drawn) -> Option<u32> {
    let finest = *levels.first()?;
    if draw(finest).error > max_error {
        return None;
    }
    Some(coarsest_within(levels, max_error, draw))
}

/// Long-side resolutions the error-driven search tries, finest first: `max` down to 2 in
/// steps of 2^(1/4), so neighbouring levels differ by ~30% in texel count.
fn resolution_levels(max: u32) -> Vec<u32> {
    let mut levels: Vec<u32> = (0..)
        .map(|k| (max as f64 * 0.5f64.powf(k as f64 / 4.0)).round() as u32)
        .take_while(|&r| r > 2)
        .collect();
    levels.push(2);
    levels.dedup();
    levels
}

/// The coarsest level whose measured error is within `max_error`, by bisection (error grows as
/// the resolution falls, up to aliasing); the finest level if none is. Whatever is returned
/// was measured, so a chart said to be within the bound is.
fn coarsest_within(levels: &[u32], max_error: f64, draw: impl Fn(u32) -> Drawn) -> u32 {
    let (mut lo, mut hi) = (0, levels.len());
    let mut within = None;
    while lo < hi {
        let mid = (lo + hi) / 2;
        if draw(levels[mid]).error <= max_error {
            lo = mid + 1;
            within = Some(levels[mid]); // each later success is coarser
        } else {
            hi = mid;
        }
    }
    within.unwrap_or(levels[0])
}

/// Bounds a budget too small for the bound weighs errors by (`allocate`), each `RUNG_STEP`
/// times the last from the one asked for up (to 2^19 times it).
const RUNGS: usize = 20;
const RUNG_STEP: f64 = 2.0;

/// A chart at one resolution: its bytes, and the area of its surface over each rung of bounds
/// (`over[k]`: over the bound times RUNG_STEP^k) out of all the area its errors stand for.
#[derive(Clone, Copy, Debug)]
struct LevelCost {
    resolution: u32,
    bytes: f64,
    over: [f64; RUNGS],
    area: f64,
}

/// The area of `errors` over each rung of bounds from `max_error` up.
fn over_rungs(errors: &[super::accuracy::WeightedError], max_error: f64) -> [f64; RUNGS] {
    // The area each error adds to the rungs below it, by the first rung it is within.
    let mut first_within = [0.0; RUNGS + 1];
    for e in errors.iter().filter(|e| e.value > max_error) {
        let k = (1..RUNGS)
            .find(|&k| e.value <= max_error * RUNG_STEP.powi(k as i32))
            .unwrap_or(RUNGS);
        first_within[k] += e.area;
    }
    let mut over = [0.0; RUNGS];
    let mut above = 0.0;
    for k in (0..RUNGS).rev() {
        above += first_within[k + 1];
        over[k] = above;
    }
    over
}

/// Levels a chart may take of a byte budget, as a multiple of its share by area, and still be
/// measured.
const SHARE_MEASURED: f64 = 4.0;

/// A chart's levels are measured up to the first with at most this fraction of the set's
/// slack (`1 - ERROR_QUANTILE`) of its area over the bound. The finest levels cost the most to
/// draw (a quarter-octave finer draws 1.4x the texels), and few are chosen: at 0.5 instead of
/// 0.1 the bunny's default set came out the same to the byte and the rocker arm's at 1.6e-4
/// within 0.4% of its bytes (the same IoU and depth p99 against trimesh), in 1.8x instead of
/// 2.6x the time of a fixed 256-texel conversion (one run each, loaded; README "The default").
const LEVEL_STOP: f64 = 0.5;

/// The area of a chart's own faces.
fn chart_area(drawer: &ChartDrawer, job: &ChartJob) -> f64 {
    let m = drawer.mesh;
    job.faces[..job.chart_faces]
        .iter()
        .map(|&f| {
            let [a, b, c] = m.faces[f as usize].map(|v| m.positions[v as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

/// A chart's costs from its coarsest level up to the first that has next to nothing over the
/// bound, the first dearer than `cap` bytes, or the finest; `colored`: whether its maps would
/// carry a color map (the search draws none).
fn level_costs(
    levels: &[u32],
    (max_error, cap): (f64, f64),
    colored: bool,
    draw: impl Fn(u32) -> Drawn,
) -> Vec<LevelCost> {
    let mut costs = Vec::new();
    for &resolution in levels.iter().rev() {
        let d = draw(resolution);
        let over = over_rungs(&d.errors, max_error);
        let area: f64 = d.errors.iter().map(|e| e.area).sum();
        let texels = d.bx.width as usize * d.bx.height as usize;
        // The final raster adds the error-bound map (`gtex::bound`), counted in the set's bytes.
        let map_bytes = crate::gtex::map_bytes(texels, d.bx.height_bits, colored);
        let (width, height) = (d.bx.width, d.bx.height);
        let block = crate::gtex::bound::block_side(width, height, map_bytes);
        let (bw, bh) = crate::gtex::bound::block_dims(width, height, block);
        // Its codes and exponent byte.
        let bytes = (map_bytes + bw * bh + 1) as f64;
        costs.push(LevelCost {
            resolution,
            bytes,
            over,
            area,
        });
        // Finer levels could lower this chart's share of the set's slack by LEVEL_STOP of its
        // density at most: not worth measuring.
        if over[0] <= LEVEL_STOP * (1.0 - ERROR_QUANTILE) * area || bytes > cap {
            break;
        }
    }
    costs
}

/// Each chart's level for the fewest bytes with at most `1 - quantile` of all the area over the
/// bound, so the set's error quantile is within it (`within_bound`). If that takes more than
/// `budget` bytes, the levels within the budget with the least area over each rung of bounds,
/// summed (`least_over`): an error's area counts once per rung it exceeds (about its log2 over
/// the bound), so the bytes go where the error is largest. Counting the area over the bound
/// alone, a bound far below what the budget affords left every chart over it at every level:
/// the budget went to the charts nearest the bound and the rough ones kept their coarsest levels
/// (the noisy isosurface within its bytes at 1e-5 of the diagonal: reported p99 0.07 of it,
/// rendered IoU 0.953). Without a budget, a bound even the finest levels miss gets the finest.
fn allocate(costs: &[Vec<LevelCost>], quantile: f64, budget: Option<f64>) -> Vec<u32> {
    let slack = 1.0 - quantile;
    match (within_bound(costs, slack), budget) {
        (Some(picks), Some(b)) if picks_bytes(costs, &picks) > b => least_over(costs, b),
        (Some(picks), _) => picks,
        (None, Some(b)) => least_over(costs, b),
        (None, None) => costs.iter().map(|c| c.last().unwrap().resolution).collect(),
    }
}

/// Each chart's cheapest level at price `lambda` per unit of `over` (a Lagrangian of the
/// multiple-choice knapsack), where `over` is the area a level leaves over the bound, less
/// the chart's share of the slack: the picks, the sum of their `over`, and their bytes.
fn choose(
    costs: &[Vec<LevelCost>],
    lambda: f64,
    over: impl Fn(&LevelCost) -> f64,
) -> (Vec<u32>, f64, f64) {
    let (mut excess, mut bytes) = (0.0, 0.0);
    let price = |c: &LevelCost| c.bytes + lambda * over(c);
    let picks = costs
        .iter()
        .map(|levels| {
            let best = (levels.iter())
                .min_by(|a, b| price(a).total_cmp(&price(b)))
                .expect("every chart has a level");
            excess += over(best);
            bytes += best.bytes;
            best.resolution
        })
        .collect();
    (picks, excess, bytes)
}

/// The price per unit area the bisections bracket `lambda` around (in powers of ten): the
/// finest levels' bytes over their area.
fn price_unit(costs: &[Vec<LevelCost>]) -> f64 {
    let bytes: f64 = costs.iter().filter_map(|c| c.last()).map(|c| c.bytes).sum();
    let area: f64 = costs.iter().filter_map(|c| c.last()).map(|c| c.area).sum();
    bytes / area.max(f64::MIN_POSITIVE)
}

/// The cheapest levels with at most the slack of all area over the bound (the lowest price
/// whose choice is within it, bisecting log10 of lambda / unit: bytes rise and the area over
/// falls as the price rises), or `None` if even the finest levels are over.
fn within_bound(costs: &[Vec<LevelCost>], slack: f64) -> Option<Vec<u32>> {
    let unit = price_unit(costs);
    let over = |c: &LevelCost| c.over[0] - slack * c.area;
    let at = |log: f64| choose(costs, unit * 10f64.powf(log), over);
    let (mut lo, mut hi) = (-12.0f64, 24.0f64);
    let (fine, excess, _) = at(hi);
    if excess > 0.0 {
        return None;
    }
    let mut best = fine;
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        let (picks, excess, _) = at(mid);
        if excess <= 0.0 {
            hi = mid;
            best = picks;
        } else {
            lo = mid;
        }
    }
    Some(best)
}

/// The levels with the least area over each rung, summed, within `budget` bytes (the highest
/// price whose choice fits), or the coarsest if even they do not fit.
fn least_over(costs: &[Vec<LevelCost>], budget: f64) -> Vec<u32> {
    let unit = price_unit(costs);
    let over = |c: &LevelCost| c.over.iter().sum::<f64>();
    let at = |log: f64| choose(costs, unit * 10f64.powf(log), over);
    let coarsest = at(-12.0).0;
    if picks_bytes(costs, &coarsest) > budget {
        return coarsest;
    }
    let (mut lo, mut hi) = (-12.0f64, 24.0f64);
    let mut best = coarsest;
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        let (picks, _, bytes) = at(mid);
        if bytes <= budget {
            lo = mid;
            best = picks;
        } else {
            hi = mid;
        }
    }
    best
}

/// The bytes of the levels `picks` chose, one per chart.
fn picks_bytes(costs: &[Vec<LevelCost>], picks: &[u32]) -> f64 {
    costs
        .iter()
        .zip(picks)
        .map(|(levels, &r)| {
            levels
                .iter()
                .find(|c| c.resolution == r)
                .map_or(0.0, |c| c.bytes)
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::super::accuracy::WeightedError;
    use super::*;

    #[test]
    fn resolution_levels_step_by_a_quarter_octave_down_to_two() {
        let l = resolution_levels(256);
        assert_eq!(l[..5], [256, 215, 181, 152, 128]);
        assert_eq!(*l.last().unwrap(), 2);
        assert!(l.windows(2).all(|w| w[0] > w[1]));
        assert_eq!(resolution_levels(2), [2]);
    }

    /// A level whose area over the bound is `over` at every rung.
    fn cost(resolution: u32, bytes: f64, over: f64, area: f64) -> LevelCost {
        LevelCost {
            resolution,
            bytes,
            over: [over; RUNGS],
            area,
        }
    }

    #[test]
    fn allocation_is_the_cheapest_that_fits_the_quantile() {
        // Three charts of equal area, coarse to fine; at most 1% of all area may be over.
        let costs = vec![
            // Cheap to fix: 4% over at 10 bytes, nothing over at 40.
            vec![cost(2, 10.0, 4.0, 100.0), cost(4, 40.0, 0.0, 100.0)],
            // Dear to fix: 2% over at 10 bytes, 1% at 1000, nothing at 5000.
            vec![
                cost(2, 10.0, 2.0, 100.0),
                cost(4, 1000.0, 1.0, 100.0),
                cost(8, 5000.0, 0.0, 100.0),
            ],
            // Within the bound already.
            vec![cost(2, 10.0, 0.0, 100.0)],
        ];
        // Budget 3 units of area: fix the first chart, keep the second's tail.
        assert_eq!(allocate(&costs, 0.99, None), vec![4, 2, 2]);
        // Budget 1.5: the second must reach 1%, and the first must be fixed too.
        assert_eq!(allocate(&costs, 0.995, None), vec![4, 4, 2]);
        // Brute force agrees on the cheapest feasible choice for a range of budgets.
        for q in [0.9, 0.97, 0.98, 0.99, 0.995, 0.999, 1.0] {
            let mut best = (f64::INFINITY, vec![]);
            for a in &costs[0] {
                for b in &costs[1] {
                    let c = &costs[2][0];
                    let over = a.over[0] + b.over[0] + c.over[0];
                    let bytes = a.bytes + b.bytes + c.bytes;
                    if over <= (1.0 - q) * 300.0 + 1e-9 && bytes < best.0 {
                        best = (bytes, vec![a.resolution, b.resolution, c.resolution]);
                    }
                }
            }
            assert_eq!(allocate(&costs, q, None), best.1, "quantile {q}");
        }
        // Nothing fits when even the finest levels are over: the finest.
        let over = [vec![cost(2, 1.0, 60.0, 100.0), cost(4, 4.0, 50.0, 100.0)]];
        assert_eq!(allocate(&over, 0.99, None), vec![4]);
        // A budget below what the bound needs: the least area over within it. 60 bytes buy
        // the first chart's 40-byte fix (4 units over less) but not the second's 1000.
        assert_eq!(allocate(&costs, 0.995, Some(60.0)), vec![4, 2, 2]);
        // A budget that even the coarsest levels exceed: the coarsest.
        assert_eq!(allocate(&costs, 0.995, Some(5.0)), vec![2, 2, 2]);
        // A budget the bound fits in changes nothing.
        assert_eq!(allocate(&costs, 0.995, Some(1e9)), vec![4, 4, 2]);
        // Over the bound with a budget: the least area over within it.
        assert_eq!(allocate(&over, 0.99, Some(3.0)), vec![2]);
        assert_eq!(allocate(&over, 0.99, Some(4.0)), vec![4]);
    }

    /// A level with the area over each rung: `over[k]` for the first rungs, 0 after them.
    fn rungs(resolution: u32, bytes: f64, over: &[f64]) -> LevelCost {
        let mut by_rung = [0.0; RUNGS];
        by_rung[..over.len()].copy_from_slice(over);
        LevelCost {
            resolution,
            bytes,
            over: by_rung,
            area: 100.0,
        }
    }

    #[test]
    fn a_budget_below_the_bound_goes_where_the_error_is_largest() {
        // A rough chart, 16x the bound coarse and 3x fine, and a smooth one just over it
        // coarse and within it fine; the budget refines one.
        let costs = vec![
            vec![rungs(2, 10.0, &[100.0; 5]), rungs(4, 40.0, &[100.0, 100.0])],
            vec![rungs(2, 10.0, &[50.0]), rungs(4, 40.0, &[])],
        ];
        // Counting the area over the bound alone, only the smooth chart's refinement would
        // count (the allocation before the rungs chose [2, 4]); over each rung, the rough
        // chart's gains 300 units against 50.
        assert_eq!(allocate(&costs, 0.99, Some(50.0)), vec![4, 2]);
        // A budget for both: both.
        assert_eq!(allocate(&costs, 0.99, Some(80.0)), vec![4, 4]);
        // Not even the rough one: the coarsest.
        assert_eq!(allocate(&costs, 0.99, Some(20.0)), vec![2, 2]);
        assert_eq!(over_rungs(&[], 1.0), [0.0; RUNGS]);
        let errors = [0.5, 1.5, 3.0, 1e9].map(|value| WeightedError { value, area: 1.0 });
        let over = over_rungs(&errors, 1.0);
        // Over 1x: three; 2x: two (3.0 and 1e9); 4x and on: one.
        assert_eq!(over[..4], [3.0, 2.0, 1.0, 1.0]);
        assert_eq!(over[RUNGS - 1], 1.0);
    }
}
