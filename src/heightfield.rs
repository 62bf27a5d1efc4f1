//! The surface a patch's height map stands for, its exact first intersection with a ray (the CPU
//! reference every GPU search is tested against), and the max pyramid that lets a ray skip what
//! it cannot hit.
//!
//! Space: patch-local (the box is the unit cube, heights h in [0, 1]). Inside it we also use
//! texel-centre coordinates x = u W - 1/2, y = v H - 1/2, where texel (i, j) sits at (i, j).
//!
//! The surface: the bilinear blend of the four texels around (x, y) (heights and outline
//! distances continued linearly past the map's edge, over the box's border half-texel), where all
//! four hold surface and the bilinear blend of their outline distances (gtex::decode_outline) is
//! not negative; none elsewhere. Inside a cell the
//! height along a ray is a quadratic in t, so its crossings are found in closed form; the first
//! one inside the outline is the hit. (A cell with an empty corner would need a made-up height
//! there; conversion fills every texel of the cells a drawn face touches, and the outline cuts
//! the surface back to the faces, so neighbouring patches overlap by their overlap rings.) The
//! shader (shaders/heightfield_functions.wgsl) implements the same rule.

use glam::DVec3;

use crate::bvh::ItemWalk;
use crate::gtex::{decode_outline, Patch};

/// The four corners of a cell, in the order (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1):
/// height codes and outline distances (texels).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cell {
    pub(crate) codes: [f64; 4],
    pub(crate) outline: [f64; 4],
}

impl Cell {
    /// Bilinear blend of the corner outline distances at fractions (fx, fy) in the cell.
    pub(crate) fn outline_at(&self, fx: f64, fy: f64) -> f64 {
        let o = self.outline;
        (o[0] * (1.0 - fx) + o[1] * fx) * (1.0 - fy) + (o[2] * (1.0 - fx) + o[3] * fx) * fy
    }
}

/// A map's value at texel (i, j), continued linearly past the map's edge: the cells at the map's
/// sides reach one texel beyond it, over the box's border half-texel, and the box hugs the faces,
/// so the surface and its outline often run through that half-texel. Repeating the edge texel
/// there (as before) made the surface flat across it, and the outline reach the box's side.
/// `value` is a texel's value, None where it has none: then so is the continued one, and a
/// neighbour without one counts as level with the edge. The GPU reads the same values from the
/// atlas's border (`padded_heights`, `padded_outline`).
fn continued(p: &Patch, i: i64, j: i64, value: impl Fn(usize) -> Option<f64>) -> Option<f64> {
    let (w, h) = (p.width as i64, p.height as i64);
    let at = |x: i64, y: i64| value((y * w + x) as usize);
    let (x, y) = (i.clamp(0, w - 1), j.clamp(0, h - 1));
    let (past_x, past_y) = (i - x, j - y);
    let here = at(x, y)?;
    if past_x == 0 && past_y == 0 {
        return Some(here);
    }
    // One step back inside along each axis that is past the edge (none on a one-texel axis).
    let back_x = at((x - past_x.signum()).clamp(0, w - 1), y).unwrap_or(here);
    let back_y = at(x, (y - past_y.signum()).clamp(0, h - 1)).unwrap_or(here);
    Some(here + (here - back_x) * past_x.abs() as f64 + (here - back_y) * past_y.abs() as f64)
}

/// Height code at texel (i, j), continued past the map's edge, rounded to a code and kept
/// within the box (1..=code_max); 0 where the texel is empty. Rounded, because the GPU reads the
/// continued border from the atlas as codes (`padded_heights`).
pub(crate) fn code_at_texel(p: &Patch, i: i64, j: i64) -> f64 {
    let code = |t: usize| (p.heights[t] > 0).then(|| f64::from(p.heights[t]));
    continued(p, i, j, code).map_or(0.0, |c| c.round().clamp(1.0, f64::from(p.code_max())))
}

/// Outline code at texel (i, j), continued past the map's edge and rounded to a code.
fn outline_at_texel(p: &Patch, i: i64, j: i64) -> f64 {
    let code = |t: usize| Some(f64::from(p.outline[t]));
    continued(p, i, j, code).map_or(0.0, |c| c.round().clamp(-127.0, 127.0))
}

/// The map of `value` with a one-texel border continuing it past each edge: (w + 2) x (h + 2),
/// row by row from texel (-1, -1). The atlas stores maps so (src/render/atlas.rs), so that the
/// shader reads the continued border with a plain clamped load instead of computing it per
/// read (which cost lavapipe a third of a tiled frame).
/// `inside` gives a texel's value inside the map (what `border` gives there, read directly),
/// `border` one continued past the edge.
fn padded<T>(p: &Patch, inside: impl Fn(usize) -> T, border: impl Fn(i64, i64) -> T) -> Vec<T> {
    let (w, h) = (i64::from(p.width), i64::from(p.height));
    (-1..=h)
        .flat_map(|j| (-1..=w).map(move |i| (i, j)))
        .map(|(i, j)| {
            if (0..w).contains(&i) && (0..h).contains(&j) {
                inside((j * w + i) as usize)
            } else {
                border(i, j)
            }
        })
        .collect()
}

/// Height codes with the continued border (`padded`). Inside, `code_at_texel` is the stored
/// code kept within 1..=code_max (0 for an empty texel).
pub(crate) fn padded_heights(p: &Patch) -> Vec<u16> {
    let code_max = p.code_max();
    padded(
        p,
        |t| match p.heights[t] {
            0 => 0,
            q => q.clamp(1, code_max),
        },
        |i, j| code_at_texel(p, i, j) as u16,
    )
}

/// Outline codes with the continued border (`padded`). Inside, `outline_at_texel` is the
/// stored code kept within -127..=127.
pub(crate) fn padded_outline(p: &Patch) -> Vec<i8> {
    padded(
        p,
        |t| p.outline[t].max(-127),
        |i, j| outline_at_texel(p, i, j) as i8,
    )
}

/// The cell whose lower-left texel centre is (i, j) (values continued past the map's edge);
/// None unless all four corners hold a height and some of the cell lies inside the outline.
pub(crate) fn cell_at(p: &Patch, i: i64, j: i64) -> Option<Cell> {
    let corners = [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)];
    let codes = corners.map(|(x, y)| code_at_texel(p, x, y));
    let outline = corners.map(|(x, y)| decode_outline(outline_at_texel(p, x, y)));
    let some_inside = outline.iter().any(|&d| d >= 0.0);
    (codes.iter().all(|&c| c > 0.0) && some_inside).then_some(Cell { codes, outline })
}

/// Surface height at patch-local (u, v), or None where there is no surface.
pub fn height_at(p: &Patch, u: f64, v: f64) -> Option<f64> {
    height_and_slope(p, u, v).map(|(h, _)| h)
}

/// Surface height at patch-local (u, v) and its derivatives along u and v (the bilinear
/// cell's own gradient, patch-local units), or None where there is no surface.
pub fn height_and_slope(p: &Patch, u: f64, v: f64) -> Option<(f64, [f64; 2])> {
    let (x, y) = (u * p.width as f64 - 0.5, v * p.height as f64 - 0.5);
    let (i, j) = (x.floor(), y.floor());
    let (fx, fy) = (x - i, y - j);
    let cell = cell_at(p, i as i64, j as i64)?;
    if cell.outline_at(fx, fy) < 0.0 {
        return None;
    }
    let q = cell.codes;
    let code = q[0] * (1.0 - fx) * (1.0 - fy)
        + q[1] * fx * (1.0 - fy)
        + q[2] * (1.0 - fx) * fy
        + q[3] * fx * fy;
    // Codes per texel along x and y; decoding is linear, so its step scales them.
    let dx = (q[1] - q[0]) * (1.0 - fy) + (q[3] - q[2]) * fy;
    let dy = (q[2] - q[0]) * (1.0 - fx) + (q[3] - q[1]) * fx;
    let per_code = p.decode_height(2.0) - p.decode_height(1.0);
    Some((
        p.decode_height(code),
        [
            dx * per_code * p.width as f64,
            dy * per_code * p.height as f64,
        ],
    ))
}

/// Unit normal of a regular height grid at sample (i, j) from central differences, one-sided
/// where a neighbour is missing (off the grid, or `at` gives None for no data). `at(i, j)` is
/// the height at a sample; `step` the sample spacing along x and y, in the heights' units.
pub fn grid_normal(
    at: impl Fn(usize, usize) -> Option<f64>,
    (w, h): (usize, usize),
    (i, j): (usize, usize),
    step: (f64, f64),
) -> DVec3 {
    let c = at(i, j);
    let slope = |before: Option<f64>, after: Option<f64>, step: f64| match (before, after, c) {
        (Some(a), Some(b), _) => (b - a) / (2.0 * step),
        (None, Some(b), Some(c)) => (b - c) / step,
        (Some(a), None, Some(c)) => (c - a) / step,
        _ => 0.0,
    };
    let left = (i > 0).then(|| at(i - 1, j)).flatten();
    let right = (i + 1 < w).then(|| at(i + 1, j)).flatten();
    let down = (j > 0).then(|| at(i, j - 1)).flatten();
    let up = (j + 1 < h).then(|| at(i, j + 1)).flatten();
    DVec3::new(-slope(left, right, step.0), -slope(down, up, step.1), 1.0).normalize()
}

/// Heights are known to half a code; a ray dipping less than that under the surface and coming
/// back up (two close roots) only grazes it and is not a hit. Patch-local height units.
pub fn graze(p: &Patch) -> f64 {
    0.5 / (p.code_max() - 1) as f64
}

/// The roots of a t^2 + b t + c in [lo, hi] where the ray really crosses, in increasing order
/// (NaN for none); a dip shallower than `graze` between two roots is no crossing.
fn crossings(a: f64, b: f64, c: f64, lo: f64, hi: f64, graze: f64) -> [f64; 2] {
    // Each term's size over the stretch: t counts world units, so a model 1e12 across has a
    // tiny `a` whose term still bends the curve over a cell (comparing the coefficients
    // themselves dropped it there, and hits moved by 0.8% of the distance).
    let span = (hi - lo).abs();
    let span = if span.is_finite() && span > 0.0 {
        span
    } else {
        1.0
    };
    let (qa, qb) = (a.abs() * span * span, b.abs() * span);
    let scale = qa.max(qb).max(c.abs());
    if scale == 0.0 {
        return [lo, f64::NAN]; // identically zero: the ray runs along the surface
    }
    let mut roots = [f64::NAN; 2];
    if qa <= 1e-14 * scale {
        if b != 0.0 {
            roots[0] = -c / b;
        }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return roots;
        }
        // Stable form: no cancellation between -b and the square root.
        let qv = -0.5 * (b + b.signum() * disc.sqrt());
        roots = [qv / a, if qv != 0.0 { c / qv } else { f64::NAN }];
        // Both roots inside and the dip between them shallower than `graze`: a graze.
        let inside = roots
            .iter()
            .filter(|t| t.is_finite() && **t >= lo && **t <= hi)
            .count();
        if inside == 2 && (c - b * b / (4.0 * a)).abs() < graze {
            return [f64::NAN; 2];
        }
    }
    let mut kept = roots.map(|t| {
        if t.is_finite() && t >= lo && t <= hi {
            t
        } else {
            f64::NAN
        }
    });
    if kept[0].is_nan() || kept[1] < kept[0] {
        kept.swap(0, 1);
    }
    kept
}

/// The span of t in [t0, t1] where o + t d (patch-local) is inside the unit box, or None.
fn clip_to_unit_box(o: DVec3, d: DVec3, t0: f64, t1: f64) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (t0, t1);
    for k in 0..3 {
        let (ok, dk) = (o[k], d[k]);
        if dk.abs() < 1e-300 {
            if !(0.0..=1.0).contains(&ok) {
                return None;
            }
            continue;
        }
        // One division per axis, and plain comparisons (this runs for every piece a ray
        // enters; a NaN origin or direction gives NaN bounds, caught below).
        let inverse = 1.0 / dk;
        let (a, b) = (-ok * inverse, (1.0 - ok) * inverse);
        let (near, far) = if a < b { (a, b) } else { (b, a) };
        lo = if near <= lo { lo } else { near };
        hi = if far >= hi { hi } else { far };
    }
    // NaN bounds (a ray with no direction) clip to nothing too.
    (!(lo.is_nan() || hi.is_nan() || hi <= lo)).then_some((lo, hi))
}

/// A patch-local ray made ready for descents: its cell-walk form and the span of t where it is
/// inside the unit box (over all t; a descent's own span is cut from it). Made once per ray and
/// patch, not per piece: the bunny's rays visit 1.9 (frames) to 2.2 (shadow rays) pieces of each
/// patch they enter, and the setup is seven divisions.
struct LocalRay<'p> {
    cells: CellRay<'p>,
    inside: (f64, f64),
}

impl<'p> LocalRay<'p> {
    /// The ray o + t d (patch-local) of patch `p`, or None where no t puts it inside the box.
    fn new(p: &'p Patch, o: DVec3, d: DVec3) -> Option<Self> {
        let inside = clip_to_unit_box(o, d, f64::NEG_INFINITY, f64::INFINITY)?;
        Some(LocalRay {
            cells: CellRay::new(p, o, d),
            inside,
        })
    }

    /// The part of [t0, t1] inside the box (as `clip_to_unit_box(o, d, t0, t1)`), or None.
    #[inline]
    fn within(&self, (t0, t1): (f64, f64)) -> Option<(f64, f64)> {
        let lo = if self.inside.0 <= t0 {
            t0
        } else {
            self.inside.0
        };
        let hi = if self.inside.1 >= t1 {
            t1
        } else {
            self.inside.1
        };
        (!(lo.is_nan() || hi.is_nan() || hi <= lo)).then_some((lo, hi))
    }
}

/// A patch-local ray in the map's texel-centre coordinates: x(t) = x0 + dx t, y(t) = y0 + dy t,
/// height z(t) = oz + dz t (patch-local units), as both searches below walk it.
struct CellRay<'p> {
    p: &'p Patch,
    x0: f64,
    dx: f64,
    y0: f64,
    dy: f64,
    oz: f64,
    dz: f64,
    graze: f64,
    /// 1 / dx and 1 / dy (0 where the ray runs along the lines: `slab`), and the height of
    /// one code step: the descent multiplies where it divided (four divisions per child node;
    /// measured, a set frame 5% faster).
    inverse_dx: f64,
    inverse_dy: f64,
    per_code: f64,
}

impl<'p> CellRay<'p> {
    fn new(p: &'p Patch, o: DVec3, d: DVec3) -> Self {
        let (w, h) = (p.width as f64, p.height as f64);
        let per_code = 1.0 / f64::from(p.code_max() - 1);
        CellRay {
            p,
            x0: o.x * w - 0.5,
            dx: d.x * w,
            y0: o.y * h - 0.5,
            dy: d.y * h,
            oz: o.z,
            dz: d.z,
            inverse_dx: along_lines_or_inverse(d.x * w),
            inverse_dy: along_lines_or_inverse(d.y * h),
            graze: graze(p),
            per_code,
        }
    }

    /// The first crossing for t in [t, t_next] of the ray with the surface of cell (i, j)
    /// inside the outline (the ray's stretch over the cell), or None.
    fn crossing(&self, i: f64, j: f64, t: f64, t_next: f64) -> Option<f64> {
        self.crossing_in(&cell_at(self.p, i as i64, j as i64)?, i, j, t, t_next)
    }

    /// `crossing` with the cell's codes and outline already read.
    fn crossing_in(&self, cell: &Cell, i: f64, j: f64, t: f64, t_next: f64) -> Option<f64> {
        // fx = ax + bx t, fy = ay + by t; code(t) = bilinear → quadratic in t.
        let (ax, bx) = (self.x0 - i, self.dx);
        let (ay, by) = (self.y0 - j, self.dy);
        // `Patch::decode_height`, by the code step's height.
        let [c00, c10, c01, c11] = cell.codes.map(|c| (c - 1.0) * self.per_code);
        // h = c00 + (c10-c00) fx + (c01-c00) fy + (c00-c10-c01+c11) fx fy
        let (e, f, g) = (c10 - c00, c01 - c00, c00 - c10 - c01 + c11);
        let h2 = g * bx * by;
        let h1 = e * bx + f * by + g * (ax * by + ay * bx);
        let h0 = c00 + e * ax + f * ay + g * ax * ay;
        // z(t) - h(t) = 0; a crossing outside the outline is none, the next one may be.
        let roots = crossings(-h2, self.dz - h1, self.oz - h0, t, t_next, self.graze);
        let inside = |r: f64| cell.outline_at(ax + bx * r, ay + by * r) >= 0.0;
        roots.into_iter().find(|&r| r.is_finite() && inside(r))
    }

    /// The span of t in [t0, t1] where the ray is over x in [xa, xb], y in [ya, yb].
    #[inline]
    fn over(&self, (xa, xb): (f64, f64), (ya, yb): (f64, f64), t0: f64, t1: f64) -> (f64, f64) {
        let (xs, ys) = (
            slab(self.x0, self.inverse_dx, xa, xb),
            slab(self.y0, self.inverse_dy, ya, yb),
        );
        // Plain comparisons: no NaN reaches here (`slab` gives none), and the NaN-aware
        // f64::max costs three instructions more each.
        let larger = |a: f64, b: f64| if a > b { a } else { b };
        let smaller = |a: f64, b: f64| if a < b { a } else { b };
        (
            larger(larger(t0, xs.0), ys.0),
            smaller(smaller(t1, xs.1), ys.1),
        )
    }
}

/// 1 / dv, or 0 for a ray running along the lines of that coordinate (|dv| < 1e-300): the mark
/// `slab` reads.
fn along_lines_or_inverse(dv: f64) -> f64 {
    if dv.abs() < 1e-300 {
        0.0
    } else {
        1.0 / dv
    }
}

/// The span of t where v0 + t / inverse lies in [a, b]; `inverse` 0 marks a ray along the
/// lines: every t where v0 lies in [a, b], none elsewhere.
#[inline]
fn slab(v0: f64, inverse: f64, a: f64, b: f64) -> (f64, f64) {
    if inverse == 0.0 {
        return if (a..=b).contains(&v0) {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            (f64::INFINITY, f64::NEG_INFINITY)
        };
    }
    let (ta, tb) = ((a - v0) * inverse, (b - v0) * inverse);
    // Ordered by comparing the two (minsd and maxsd), not by the direction's sign: a branch
    // on it was mispredicted as often as rays turn.
    (if ta < tb { ta } else { tb }, if ta < tb { tb } else { ta })
}

/// The exact first intersection of the ray o + t d (patch-local) with the patch's surface for t
/// in [t0, t1] (clipped to the box), or None: every cell along the ray, in order.
pub fn first_hit(p: &Patch, o: DVec3, d: DVec3, t0: f64, t1: f64) -> Option<f64> {
    let (lo, hi) = clip_to_unit_box(o, d, t0, t1)?;
    let ray = CellRay::new(p, o, d);
    // Walk the cells: the stretches between texel-centre lines in x and y.
    let next_line = |v0: f64, dv: f64, t: f64| -> f64 {
        if dv.abs() < 1e-300 {
            return f64::INFINITY;
        }
        let v = v0 + dv * t;
        let k = if dv > 0.0 {
            v.floor() + 1.0
        } else {
            v.ceil() - 1.0
        };
        let tn = (k - v0) / dv;
        // Guard against landing on the line we are on.
        if tn <= t {
            t + 1e-12 * (1.0 + t.abs())
        } else {
            tn
        }
    };
    let mut t = lo;
    let mut guard = 0;
    while t < hi && guard < 1 << 22 {
        guard += 1;
        let t_next = next_line(ray.x0, ray.dx, t)
            .min(next_line(ray.y0, ray.dy, t))
            .min(hi);
        let tm = 0.5 * (t + t_next);
        let (i, j) = (
            (ray.x0 + ray.dx * tm).floor(),
            (ray.y0 + ray.dy * tm).floor(),
        );
        if let Some(r) = ray.crossing(i, j, t, t_next) {
            return Some(r);
        }
        t = t_next;
    }
    None
}

/// A patch made ready for `first_hit` through a min-max pyramid (`min_max_pyramid`): nodes whose
/// height range the ray's stays clear of over the node are skipped whole, the rest visited
/// nearest first down to the cells, where the same exact test as the cell walk decides (the
/// same answers, tests below, in about log(cells) node visits instead of one per cell). The
/// cells' codes and outline are read from the maps with their continued border, made once.
pub struct PatchSearch {
    pyramid: Vec<(u32, u32, Vec<u32>)>,
    /// `padded_heights` and `padded_outline` of the whole patch.
    heights: Vec<u16>,
    outline: Vec<i8>,
}

/// Nodes the descent keeps at most: each level leaves at most three siblings waiting, and maps
/// are at most 2^16 texels a side (17 levels).
const DESCENT_STACK: usize = 4 * 24;

impl PatchSearch {
    /// The search over the patch's own pyramid.
    pub fn new(p: &Patch) -> PatchSearch {
        Self::with_pyramid(p, min_max_pyramid(p))
    }

    /// The search skipping what `pyramid` leaves empty (one made from fewer heights), the cells
    /// still tested on the whole maps.
    pub fn with_pyramid(p: &Patch, pyramid: Vec<(u32, u32, Vec<u32>)>) -> PatchSearch {
        PatchSearch {
            pyramid,
            heights: padded_heights(p),
            outline: padded_outline(p),
        }
    }

    /// Level-0 cell (c, r) (`cell_at(p, c - 1, r - 1)`) from the padded maps.
    fn cell(&self, p: &Patch, c: u32, r: u32) -> Option<Cell> {
        let padded_width = p.width as usize + 2;
        let at = r as usize * padded_width + c as usize;
        cell_of(&self.heights, &self.outline, at, padded_width)
    }

    /// The pyramid's top level.
    fn top(&self) -> usize {
        self.pyramid.len() - 1
    }

    /// The exact first intersection of the ray o + t d (patch-local) with `p`'s surface for t
    /// in [t0, t1] (clipped to the box), or None; `p` is the patch this search was made for.
    pub fn first_hit(&self, p: &Patch, o: DVec3, d: DVec3, t0: f64, t1: f64) -> Option<f64> {
        self.first_hit_under(p, (self.top(), 0, 0), o, d, (t0, t1))
    }

    /// The level, column and row of every non-empty node at `level` (at most the top), with its
    /// patch-local box: what the ray must enter to meet the surface under that node.
    pub(crate) fn pieces(
        &self,
        p: &Patch,
        level: usize,
    ) -> Vec<((usize, u32, u32), crate::bvh::Aabb)> {
        let level = level.min(self.top());
        let (w, h, values) = &self.pyramid[level];
        let size = 1u32 << level;
        let (base_w, base_h) = (self.pyramid[0].0, self.pyramid[0].1);
        let per_code = 1.0 / f64::from(p.code_max() - 1);
        let mut pieces = Vec::new();
        for r in 0..*h {
            for c in 0..*w {
                let v = values[(r * w + c) as usize];
                if v == 0 {
                    continue;
                }
                // Texel-centre coordinates x are at u = (x + 1/2) / width.
                let side = |k: u32, cells: u32, texels: u32| {
                    let to_u = |x: f64| ((x + 0.5) / f64::from(texels)).clamp(0.0, 1.0);
                    (
                        to_u(f64::from(k * size) - 1.0),
                        to_u(f64::from(((k + 1) * size).min(cells)) - 1.0),
                    )
                };
                let (u, v_) = (side(c, base_w, p.width), side(r, base_h, p.height));
                let z = (
                    f64::from((v & 0xffff).max(1) - 1) * per_code,
                    f64::from((v >> 16).max(1) - 1) * per_code,
                );
                let lo = DVec3::new(u.0, v_.0, z.0) - 1e-9;
                let hi = DVec3::new(u.1, v_.1, z.1) + 1e-9;
                pieces.push(((level, c, r), crate::bvh::Aabb { lo, hi }));
            }
        }
        pieces
    }

    /// `first_hit` below pyramid node (level, column, row) only: the cells under it.
    pub fn first_hit_under(
        &self,
        p: &Patch,
        node: (usize, u32, u32),
        o: DVec3,
        d: DVec3,
        span: (f64, f64),
    ) -> Option<f64> {
        if self.top() >= DESCENT_STACK / 4 {
            return first_hit(p, o, d, span.0, span.1); // deeper than any map made: the plain walk
        }
        descend(self, node, &LocalRay::new(p, o, d)?, span)
    }
}

/// The cell whose corners are texels `at`, `at + 1`, `at + row` and `at + row + 1` of the
/// height and outline codes `heights`, `outline` (rows `row` apart), or None where it holds
/// no surface: every corner a height, some corner inside the outline.
fn cell_of(heights: &[u16], outline: &[i8], at: usize, row: usize) -> Option<Cell> {
    let corners = [at, at + 1, at + row, at + row + 1];
    let codes = corners.map(|t| f64::from(heights[t]));
    let outline = corners.map(|t| decode_outline(f64::from(outline[t])));
    let some_inside = outline.iter().any(|&d| d >= 0.0);
    (codes.iter().all(|&c| c > 0.0) && some_inside).then_some(Cell { codes, outline })
}

/// Every piece's pyramid values and cell corners, each piece's in one stretch of each array
/// (`PackedPiece`): a descent reads a few hundred contiguous bytes, where the whole patch's
/// pyramid levels and maps, megabytes apart, missed the cache at every level (measured: a load
/// of a pyramid value stalled for a quarter of a frame's search time).
#[derive(Default)]
struct PackedPieces {
    pieces: Vec<PackedPiece>,
    values: Vec<u32>,
    heights: Vec<u16>,
    outline: Vec<i8>,
}

/// One piece: pyramid node (level, column, row) of patch `patch`, its values level by level
/// from its own down to 0 (each row-major, 4^(level - l) at level l) from `values_at`, and the
/// (2^level + 1)^2 padded texels its cells read from `texels_at`.
#[derive(Clone, Copy)]
struct PackedPiece {
    patch: u32,
    node: PyramidNode,
    /// The patch's level-0 cells across and down.
    base: (u32, u32),
    values_at: usize,
    texels_at: usize,
}

impl PackedPieces {
    /// Appends the piece at `node` of `search` (patch `patch`, `p`).
    fn push(&mut self, search: &PatchSearch, p: &Patch, patch: u32, node: PyramidNode) {
        let (level, nc, nr) = node;
        let base = search.base();
        self.pieces.push(PackedPiece {
            patch,
            node,
            base,
            values_at: self.values.len(),
            texels_at: self.heights.len(),
        });
        for l in (0..=level).rev() {
            let n = 1u32 << (level - l);
            let size = 1u32 << l;
            let (w, h) = (base.0.div_ceil(size), base.1.div_ceil(size));
            for y in nr * n..(nr + 1) * n {
                for x in nc * n..(nc + 1) * n {
                    let inside = x < w && y < h;
                    self.values
                        .push(if inside { search.value(l, x, y) } else { 0 });
                }
            }
        }
        let side = (1u32 << level) + 1;
        let (first_c, first_r) = (nc << level, nr << level);
        let padded = (p.width + 2, p.height + 2);
        for y in first_r..first_r + side {
            for x in first_c..first_c + side {
                let t = (x < padded.0 && y < padded.1).then(|| (y * padded.0 + x) as usize);
                self.heights.push(t.map_or(0, |t| search.heights[t]));
                self.outline.push(t.map_or(0, |t| search.outline[t]));
            }
        }
    }
}

/// A descent's view of one packed piece (nodes outside it are never asked for: a descent
/// stays under its start node).
struct PieceView<'a> {
    packed: &'a PackedPieces,
    piece: PackedPiece,
}

impl PyramidView for PieceView<'_> {
    fn base(&self) -> (u32, u32) {
        self.piece.base
    }

    fn value(&self, l: usize, c: u32, r: u32) -> u32 {
        let (level, nc, nr) = self.piece.node;
        let n = 1u32 << (level - l);
        // Levels above l hold 1 + 4 + ... + 4^(level - l - 1) = (n^2 - 1) / 3 values.
        let above = ((n * n - 1) / 3) as usize;
        let (x, y) = (c - nc * n, r - nr * n);
        self.packed.values[self.piece.values_at + above + (y * n + x) as usize]
    }

    fn cell(&self, _p: &Patch, c: u32, r: u32) -> Option<Cell> {
        let (level, nc, nr) = self.piece.node;
        let side = (1usize << level) + 1;
        let (x, y) = ((c - (nc << level)) as usize, (r - (nr << level)) as usize);
        let at = self.piece.texels_at + y * side + x;
        cell_of(&self.packed.heights, &self.packed.outline, at, side)
    }
}

/// What a pyramid descent reads: a patch's min-max pyramid and the cells' corners, from the
/// whole patch (`PatchSearch`) or from one piece's packed copy (`PackedPieces`).
trait PyramidView {
    /// The level-0 cells across and down (the map's texels plus one).
    fn base(&self) -> (u32, u32);
    /// The pyramid's value at node (level, column, row): its cells' least and largest code,
    /// 0 where it holds no surface.
    fn value(&self, level: usize, c: u32, r: u32) -> u32;
    /// Level-0 cell (c, r) (`cell_at(p, c - 1, r - 1)`), or None where it holds no surface.
    fn cell(&self, p: &Patch, c: u32, r: u32) -> Option<Cell>;
}

impl PyramidView for PatchSearch {
    fn base(&self) -> (u32, u32) {
        (self.pyramid[0].0, self.pyramid[0].1)
    }

    fn value(&self, level: usize, c: u32, r: u32) -> u32 {
        let (w, _, values) = &self.pyramid[level];
        values[(r * w + c) as usize]
    }

    fn cell(&self, p: &Patch, c: u32, r: u32) -> Option<Cell> {
        PatchSearch::cell(self, p, c, r)
    }
}

/// The exact first crossing of the patch-local ray `local` for t in the span with the cells
/// under pyramid node `start` of `view`, nearest nodes first, skipping nodes whose height range
/// the ray clears (at most 2^16 cells a side: DESCENT_STACK).
fn descend(
    view: &impl PyramidView,
    (start, c0, r0): (usize, u32, u32),
    local: &LocalRay,
    span: (f64, f64),
) -> Option<f64> {
    let (lo, hi) = local.within(span)?;
    let ray = &local.cells;
    let p = ray.p;
    // Node k of `size` level-0 cells spans texel-centre coordinates
    // [k size - 1, (k + 1) size - 1] (level-0 cell c lies left of texel c), cut at the map's
    // last cell.
    let (base_w, base_h) = view.base();
    let extent = |k: u32, size: u32, cells: u32| {
        (
            f64::from(k * size) - 1.0,
            f64::from(((k + 1) * size).min(cells)) - 1.0,
        )
    };
    let span_of = |level: usize, c: u32, r: u32, t1: f64| {
        let size = 1u32 << level;
        let (xs, ys) = (extent(c, size, base_w), extent(r, size, base_h));
        ray.over(xs, ys, lo, t1)
    };
    let per_code = ray.per_code;
    // (level, column, row, the ray's span over the node), nearest popped first among
    // siblings; inline and never zero-filled, as this runs for every piece a ray enters (a
    // zeroed array of DESCENT_STACK entries cost a 4 KB memset each time).
    let mut stack: smallvec::SmallVec<[DescentEntry; DESCENT_STACK]> = smallvec::SmallVec::new();
    stack.push((start, c0, r0, span_of(start, c0, r0, hi)));
    let mut best = hi;
    while let Some((level, c, r, (ta, tb))) = stack.pop() {
        // Plain comparisons here and below: spans and heights are never NaN (f64::min/max's
        // NaN handling cost three instructions each).
        let tb = if best < tb { best } else { tb };
        if ta > tb {
            continue;
        }
        let v = view.value(level, c, r);
        if v == 0 {
            continue;
        }
        // The bilinear surface stays within its corners' range; the ray's height is
        // monotone.
        let (za, zb) = (ray.oz + ray.dz * ta, ray.oz + ray.dz * tb);
        let hmin = f64::from((v & 0xffff).max(1) - 1) * per_code;
        let hmax = f64::from((v >> 16).max(1) - 1) * per_code;
        const SLACK: f64 = 1e-9;
        let (z_low, z_high) = if za < zb { (za, zb) } else { (zb, za) };
        if z_high < hmin - SLACK || z_low > hmax + SLACK {
            continue;
        }
        if level == 0 {
            let (i, j) = (f64::from(c) - 1.0, f64::from(r) - 1.0);
            let hit = (view.cell(p, c, r)).and_then(|cell| ray.crossing_in(&cell, i, j, ta, tb));
            if let Some(t) = hit {
                best = best.min(t);
            }
            continue;
        }
        // The child level's node counts: cells over the nodes' size, rounded up.
        // By shifts: the sizes are powers of two (div_ceil divided, twice per node).
        let shift = level - 1;
        let (cw, ch) = (
            (base_w + (1 << shift) - 1) >> shift,
            (base_h + (1 << shift) - 1) >> shift,
        );
        // The (at most four) children, pushed farthest first so the nearest is next.
        let mut children = [(0usize, 0u32, 0u32, (f64::INFINITY, 0.0)); 4];
        let mut n = 0;
        for (dc, dr) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let (x, y) = (2 * c + dc, 2 * r + dr);
            if x < cw && y < ch {
                let span = span_of(level - 1, x, y, best);
                if span.0 <= span.1 {
                    children[n] = (level - 1, x, y, span);
                    n += 1;
                }
            }
        }
        // Farthest first (an insertion sort: at most four).
        for k in 1..n {
            let mut j = k;
            while j > 0 && children[j - 1].3 .0 < children[j].3 .0 {
                children.swap(j - 1, j);
                j -= 1;
            }
        }
        stack.extend_from_slice(&children[..n]);
    }
    (best < hi).then_some(best)
}

/// A node of a patch's min-max pyramid: level, column, row.
type PyramidNode = (usize, u32, u32);

/// A node waiting in a descent: level, column, row, and the ray's span over it.
type DescentEntry = (usize, u32, u32, (f64, f64));

/// Pyramid level of the pieces a `SetTracer`'s hierarchy holds: nodes of 8 x 8 cells, whose
/// boxes hug the surface (a patch's own box holds the whole curved chart, so a ray entered
/// several patches' boxes before its hit and searched each from the top).
const PIECE_LEVEL: usize = 3;

/// A set made ready for ray queries on the CPU: a BVH over pieces of the patches (pyramid nodes
/// of `PIECE_LEVEL`, each in a box around its cells' surface), each searched down its own
/// packed copy of its patch's min-max pyramid (`PackedPieces`). It holds no reference to the set: the caller passes the
/// same set it was made from (the CPU backend keeps both together). Spaces: rays in the set's
/// space; each patch tests the ray in its patch-local unit box, where t keeps its meaning
/// (world distance, for unit directions) since the map is affine.
pub struct SetTracer {
    /// Per piece: its patch, pyramid node and packed values.
    pieces: PackedPieces,
    /// Per piece, its box in the set's space.
    boxes: Vec<crate::bvh::Aabb>,
    /// For bundles of rays (`pieces_within`: a frustum test per node, in f64).
    bvh: crate::bvh::Bvh,
    bounds: Vec<crate::bvh::Aabb>,
    /// For single rays: the same boxes in an 8-wide tree (four box tests at once).
    wide: crate::wide_bvh::BoxBvh,
    /// Per patch, its world-to-local map.
    frames: Vec<LocalFrame>,
}

/// A patch's world-to-local map by multiplications: its origin, and its axes over their
/// extents (`Patch::world_to_local` divides: six divisions for each piece a ray entered).
#[derive(Clone, Copy)]
struct LocalFrame {
    origin: DVec3,
    rows: [DVec3; 3],
}

impl LocalFrame {
    fn of(p: &Patch) -> LocalFrame {
        LocalFrame {
            origin: p.origin,
            rows: std::array::from_fn(|k| p.axes[k] / p.extent[k]),
        }
    }

    /// The world ray (origin, dir) in the patch's local unit box, with t unchanged.
    #[inline]
    fn ray(&self, origin: DVec3, dir: DVec3) -> (DVec3, DVec3) {
        let [x, y, z] = self.rows;
        let o = origin - self.origin;
        (
            DVec3::new(o.dot(x), o.dot(y), o.dot(z)),
            DVec3::new(dir.dot(x), dir.dot(y), dir.dot(z)),
        )
    }
}

/// A plane n . p + c = 0 as (n, c); a bundle of rays lies where n . p + c >= 0 for each of
/// its planes.
pub type Plane = (DVec3, f64);

/// The pieces a bundle of rays may meet, each with the least t its box allows, nearest first
/// (`SetTracer::pieces_within`).
pub type BundlePieces = Vec<(f64, u32)>;

impl SetTracer {
    /// The pyramids are made on every core; the BVH over the pieces by the surface-area rule.
    pub fn new(set: &crate::gtex::GeometryTextureSet) -> Self {
        use rayon::prelude::*;
        Self::with_searches(set, set.patches.par_iter().map(PatchSearch::new).collect())
    }

    /// A tracer whose pyramids hold only `heights[k]` of patch k (the others empty), while the
    /// cells' exact test still reads the whole maps: searches skip the stretches where those
    /// heights are empty and find the surface there in another patch (the GPU's pieces over the
    /// texels each patch owns, render/kinds/gtex/owners.rs).
    pub fn with_heights(set: &crate::gtex::GeometryTextureSet, heights: &[Vec<u16>]) -> Self {
        use rayon::prelude::*;
        let searches = (set.patches.par_iter().zip(heights))
            .map(|(p, h)| {
                let kept = Patch {
                    heights: h.clone(),
                    ..p.clone()
                };
                PatchSearch::with_pyramid(p, min_max_pyramid(&kept))
            })
            .collect();
        Self::with_searches(set, searches)
    }

    fn with_searches(set: &crate::gtex::GeometryTextureSet, patches: Vec<PatchSearch>) -> Self {
        use crate::bvh::{Aabb, Bvh};
        use rayon::prelude::*;
        let per_patch: Vec<Vec<(u32, PyramidNode, Aabb)>> = (set.patches.par_iter())
            .zip(&patches)
            .enumerate()
            .map(|(k, (p, search))| {
                let world_from_patch = p.world_from_patch();
                (search.pieces(p, PIECE_LEVEL).into_iter())
                    .map(|(node, local)| {
                        let corners = local
                            .corners()
                            .map(|c| world_from_patch.transform_point3(c));
                        (k as u32, node, Aabb::of_points(corners))
                    })
                    .collect()
            })
            .collect();
        let all: Vec<_> = per_patch.into_iter().flatten().collect();
        let boxes: Vec<Aabb> = all.iter().map(|piece| piece.2).collect();
        let bvh = Bvh::build(&boxes);
        let bounds = bvh.node_bounds(&boxes);
        let wide = crate::wide_bvh::BoxBvh::build(&boxes);
        // Packed in the hierarchy's leaf order would be better still; in patch order each
        // patch's pieces lie together, as its neighbours in space mostly do.
        let mut pieces = PackedPieces::default();
        for &(k, node, _) in &all {
            pieces.push(&patches[k as usize], &set.patches[k as usize], k, node);
        }
        SetTracer {
            pieces,
            boxes,
            bvh,
            bounds,
            wide,
            frames: set.patches.iter().map(LocalFrame::of).collect(),
        }
    }

    /// The hit of the ray (origin, direction: t along it) under piece `i`, within the span:
    /// (t, patch). `local` keeps the ray made ready for the last patch descended (None, or a
    /// patch whose box the ray misses), reused while the pieces are that patch's.
    fn piece_hit<'s>(
        &self,
        set: &'s crate::gtex::GeometryTextureSet,
        i: u32,
        (origin, dir): (DVec3, DVec3),
        span: (f64, f64),
        local: &mut Option<(u32, Option<LocalRay<'s>>)>,
    ) -> Option<(f64, u32)> {
        let piece = self.pieces.pieces[i as usize];
        let patch = piece.patch;
        if local.as_ref().is_none_or(|(k, _)| *k != patch) {
            let (o, d) = self.frames[patch as usize].ray(origin, dir);
            *local = Some((patch, LocalRay::new(&set.patches[patch as usize], o, d)));
        }
        let ray = local.as_ref().and_then(|(_, ray)| ray.as_ref())?;
        let view = PieceView {
            packed: &self.pieces,
            piece,
        };
        let t = descend(&view, piece.node, ray, span)?;
        Some((t, patch))
    }

    /// The nearest exact hit of the ray (origin, direction) for t in `span`: (t, patch index),
    /// or (inf, -1).
    pub fn first_hit_within(
        &self,
        set: &crate::gtex::GeometryTextureSet,
        origin: DVec3,
        dir: DVec3,
        span: (f64, f64),
    ) -> (f64, i32) {
        let mut patch = -1;
        let mut local = None;
        let (t, _) = self.wide.nearest(origin, dir, span, |i, t1| {
            let (t, k) = self.piece_hit(set, i, (origin, dir), (span.0, t1), &mut local)?;
            patch = k as i32;
            Some(t)
        });
        if patch < 0 {
            return (f64::INFINITY, -1);
        }
        (t, patch)
    }

    /// The pieces whose boxes may meet a ray of a bundle that lies inside `planes` (a frame's
    /// tile: the rays through its pixels), each with the least of `depth` (an affine function
    /// a . p + b, the rays' t) over its box, in increasing order of it.
    pub fn pieces_within(&self, planes: &[Plane], (a, b): (DVec3, f64)) -> BundlePieces {
        let corner =
            |bx: &crate::bvh::Aabb, n: DVec3| DVec3::select(n.cmpge(DVec3::ZERO), bx.hi, bx.lo);
        // Kept unless wholly outside a plane, past rounding: the box's farthest corner
        // inside, with a margin of 1e-9 of the terms' size.
        let keep = |bx: &crate::bvh::Aabb| {
            planes.iter().all(|&(n, c)| {
                let p = corner(bx, n);
                let value = n.dot(p) + c;
                value >= -1e-9 * (n.abs().dot(p.abs()) + c.abs())
            })
        };
        let mut found = Vec::new();
        self.bvh.select(&self.bounds, keep, |i| {
            let least = a.dot(corner(&self.boxes[i as usize], -a)) + b;
            found.push((least - 1e-9 * least.abs(), i));
        });
        found.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
        found
    }

    /// `first_hit_within` of a ray of the bundle `pieces` came from (`pieces_within`, whose
    /// depth is this ray's t): the pieces tested in their order until the nearest hit so far is
    /// nearer than the next one's box can be.
    pub fn first_hit_among(
        &self,
        set: &crate::gtex::GeometryTextureSet,
        pieces: &[(f64, u32)],
        (origin, dir): (DVec3, DVec3),
        span: (f64, f64),
    ) -> (f64, i32) {
        let inverse = dir.recip();
        let (mut best, mut patch) = (span.1, -1);
        let mut local = None;
        for &(least, i) in pieces {
            if least > best {
                break;
            }
            if !self.boxes[i as usize].meets_inverse(origin, inverse, (span.0, best)) {
                continue;
            }
            let hit = self.piece_hit(set, i, (origin, dir), (span.0, best), &mut local);
            if let Some((t, k)) = hit {
                if t < best {
                    (best, patch) = (t, k as i32);
                }
            }
        }
        if patch < 0 {
            return (f64::INFINITY, -1);
        }
        (best, patch)
    }

    /// `first_hit_within` over the whole ray.
    pub fn first_hit(
        &self,
        set: &crate::gtex::GeometryTextureSet,
        origin: DVec3,
        dir: DVec3,
    ) -> (f64, i32) {
        self.first_hit_within(set, origin, dir, (0.0, f64::INFINITY))
    }

    /// Whether the ray hits any patch for t in `span` (stops at the first found). The piece in
    /// `last` (one a neighbouring ray hit) is tested first: shadow rays of neighbouring pixels
    /// are mostly stopped by one piece; `last` is left at the piece found, if any.
    pub fn any_hit(
        &self,
        set: &crate::gtex::GeometryTextureSet,
        (origin, dir): (DVec3, DVec3),
        span: (f64, f64),
        last: &std::cell::Cell<Option<u32>>,
    ) -> bool {
        let mut local = None;
        let mut hits = |i: u32| (self.piece_hit(set, i, (origin, dir), span, &mut local)).is_some();
        if let Some(i) = last.get() {
            if self.boxes[i as usize].meets_inverse(origin, dir.recip(), span) && hits(i) {
                return true;
            }
        }
        self.wide.any(origin, dir, span, |i| {
            let found = hits(i);
            if found {
                last.set(Some(i));
            }
            found
        })
    }

    /// Every crossing of the ray with the set's surfaces for t in `span`, nearest first:
    /// (t, patch index). Each piece's crossings are found one after the other (the search
    /// restarted just past the last one); patches that overlap (rings) may give a crossing twice.
    pub fn all_hits(
        &self,
        set: &crate::gtex::GeometryTextureSet,
        origin: DVec3,
        dir: DVec3,
        span: (f64, f64),
    ) -> Vec<(f64, i32)> {
        let mut hits = Vec::new();
        let mut local = None;
        self.wide.any(origin, dir, span, |i| {
            let mut from = span.0;
            while let Some((t, k)) =
                self.piece_hit(set, i, (origin, dir), (from, span.1), &mut local)
            {
                hits.push((t, k as i32));
                // Past this crossing by a relative step: the next root of the cell, if any.
                from = t + 1e-9 * (1.0 + t.abs());
            }
            false
        });
        hits.sort_by(|a, b| a.0.total_cmp(&b.0));
        hits
    }
}

/// The world ray (origin, dir) in patch `p`'s local unit box, with t unchanged (by divisions, as
/// `Patch::world_to_local`: the tests' reference walk; `LocalFrame` multiplies).
#[cfg(test)]
fn patch_local_ray(p: &Patch, origin: DVec3, dir: DVec3) -> (DVec3, DVec3) {
    let d = DVec3::new(
        dir.dot(p.axes[0]) / p.extent.x,
        dir.dot(p.axes[1]) / p.extent.y,
        dir.dot(p.axes[2]) / p.extent.z,
    );
    (p.world_to_local(origin), d)
}

/// The nearest exact hit of each world ray (origin, unit direction) over all patches of a set:
/// (distance along the ray, patch index), or (inf, -1), through a `SetTracer` on every core.
/// `cancel` is polled before every ray (Interrupted once set).
pub fn first_hits(
    set: &crate::gtex::GeometryTextureSet,
    rays: &[(DVec3, DVec3)],
    cancel: &crate::cancel::Cancel,
) -> crate::error::Result<Vec<(f64, i32)>> {
    use rayon::prelude::*;
    let tracer = SetTracer::new(set);
    let triangles = set.triangles.as_ref().map(TriangleHits::new);
    let hits = rays
        .par_iter()
        .map(|&(origin, dir)| {
            if cancel.is_cancelled() {
                return (f64::INFINITY, -1); // reported below
            }
            let on_maps = tracer.first_hit(set, origin, dir);
            match triangles
                .as_ref()
                .and_then(|t| t.nearest(origin, dir, on_maps.0))
            {
                Some(t) => (t, crate::gtex::KEPT_AS_TRIANGLES),
                None => on_maps,
            }
        })
        .collect();
    cancel.check("casting rays on the CPU")?;
    Ok(hits)
}

/// Exact first hits on a hybrid set's triangles, in f64: a hierarchy over the faces' boxes and
/// the Möller–Trumbore test with its inside test (a reference, not the renderers' watertight
/// f32 pick, so it shares none of their code).
struct TriangleHits<'a> {
    triangles: &'a crate::gtex::SetTriangles,
    bvh: crate::bvh::Bvh,
    bounds: Vec<crate::bvh::Aabb>,
}

impl<'a> TriangleHits<'a> {
    fn new(triangles: &'a crate::gtex::SetTriangles) -> Self {
        let boxes: Vec<crate::bvh::Aabb> = (triangles.face_corners())
            .map(crate::bvh::Aabb::of_points)
            .collect();
        let bvh = crate::bvh::Bvh::build(&boxes);
        let bounds = bvh.node_bounds(&boxes);
        TriangleHits {
            triangles,
            bvh,
            bounds,
        }
    }

    /// The nearest t in (0, before) where the ray o + t d meets a face.
    fn nearest(&self, o: DVec3, d: DVec3, before: f64) -> Option<f64> {
        let m = self.triangles.mesh();
        let (t, face) = self
            .bvh
            .with(&self.bounds)
            .nearest(o, d, (0.0, before), |f, t1| {
                let [a, b, c] = m.faces[f as usize].map(|v| m.positions[v as usize]);
                let (e1, e2) = (b - a, c - a);
                let p = d.cross(e2);
                let det = e1.dot(p);
                if det == 0.0 || !det.is_finite() {
                    return None;
                }
                let s = o - a;
                let u = s.dot(p) / det;
                let q = s.cross(e1);
                let v = d.dot(q) / det;
                let t = e2.dot(q) / det;
                (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 && t < t1).then_some(t)
            });
        face.map(|_| t)
    }
}

/// `first_hits` the slow, plain way: every patch's cells along every ray (`first_hit`), for
/// tests of the fast one.
#[cfg(test)]
fn first_hits_by_walking(
    set: &crate::gtex::GeometryTextureSet,
    rays: &[(DVec3, DVec3)],
) -> Vec<(f64, i32)> {
    rays.iter()
        .map(|&(origin, dir)| {
            let mut best = (f64::INFINITY, -1);
            for (k, p) in set.patches.iter().enumerate() {
                let (o, d) = patch_local_ray(p, origin, dir);
                if let Some(t) = first_hit(p, o, d, 0.0, best.0) {
                    if t < best.0 {
                        best = (t, k as i32);
                    }
                }
            }
            best
        })
        .collect()
}

/// Min-max pyramid over the cells between texel centres, for skipping what a ray cannot hit:
/// a node is skipped when the ray over it stays above its highest or below its lowest surface.
///
/// Level 0 has (W + 1) x (H + 1) cells: cell (c, r) spans x in [c - 1, c], y in [r - 1, r]
/// (texel-centre coordinates), so the clamped half-texel border has cells too. A value packs the
/// largest code of the cell's four (clamped) corner texels in its high 16 bits and the smallest
/// in its low 16 bits; 0 when the cell holds no surface (an empty corner, or all of it outside
/// the outline). Every further level
/// combines 2 x 2 nodes below it (max of maxes, min of the non-empty nodes' mins), down to 1 x 1.
pub fn min_max_pyramid(p: &Patch) -> Vec<(u32, u32, Vec<u32>)> {
    let pack = |codes: &mut dyn Iterator<Item = u32>| -> u32 {
        let (mut hi, mut lo) = (0u32, u32::MAX);
        for c in codes.filter(|&c| c > 0) {
            hi = hi.max(c);
            lo = lo.min(c);
        }
        if hi == 0 {
            0
        } else {
            (hi << 16) | lo
        }
    };
    let (cw, ch) = (p.width + 1, p.height + 1);
    // Cell (c - 1, r - 1) as `cell_at` makes it, read from the padded maps: its corners are
    // padded texels (c, r) to (c + 1, r + 1), each continued once rather than four times.
    let (codes, outline) = (padded_heights(p), padded_outline(p));
    let padded_width = p.width as usize + 2;
    let mut base = Vec::with_capacity((cw * ch) as usize);
    for r in 0..ch as usize {
        for c in 0..cw as usize {
            let corners = [0, 1, padded_width, padded_width + 1].map(|d| r * padded_width + c + d);
            let filled = corners.iter().all(|&t| codes[t] > 0);
            // decode_outline keeps the sign, so a corner inside has a code >= 0.
            let some_inside = corners.iter().any(|&t| outline[t] >= 0);
            base.push(if filled && some_inside {
                pack(&mut corners.iter().map(|&t| u32::from(codes[t])))
            } else {
                0
            });
        }
    }
    let mut levels = vec![(cw, ch, base)];
    while levels.last().is_some_and(|l| l.0 > 1 || l.1 > 1) {
        let (pw, ph, prev) = levels.last().unwrap();
        let (nw, nh) = (pw.div_ceil(2), ph.div_ceil(2));
        let mut next = vec![0u32; (nw * nh) as usize];
        for r in 0..nh {
            for c in 0..nw {
                let children = [(0, 0), (1, 0), (0, 1), (1, 1)]
                    .into_iter()
                    .map(|(dc, dr)| (2 * c + dc, 2 * r + dr))
                    .filter(|&(x, y)| x < *pw && y < *ph)
                    .map(|(x, y)| prev[(y * pw + x) as usize])
                    .filter(|&v| v > 0);
                next[(r * nw + c) as usize] =
                    pack(&mut children.flat_map(|v| [v >> 16, v & 0xffff]));
            }
        }
        levels.push((nw, nh, next));
    }
    levels
}

/// Three turned patches of different sizes and height bits around (0.8, 0.5, 0), with holes
/// and outlines through many cells, for tests.
#[cfg(test)]
pub(crate) fn turned_holed_set() -> crate::gtex::GeometryTextureSet {
    let mut patches = Vec::new();
    for k in 0..3u32 {
        let mut p = test_patch(17 + 5 * k, 11 + 3 * k, [16, 8, 16][k as usize], |i, j| {
            ((i * 7 + j * 3 + k) % 13 != 0).then(|| {
                0.5 + 0.4 * (f64::from(i) * 0.7 + f64::from(k)).sin() * (f64::from(j) * 0.5).cos()
            })
        });
        p.outline = (0..p.texels())
            .map(|t| [-128, -40, -1, 0, 3, 90, 127, 127, 127][(t + k as usize) % 9])
            .collect();
        let turn =
            glam::DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 0.5).normalize(), 0.6 * f64::from(k));
        p.axes = [DVec3::X, DVec3::Y, DVec3::Z].map(|a| turn * a);
        p.origin = DVec3::new(0.4 * f64::from(k), 0.1 * f64::from(k), -0.2 * f64::from(k));
        p.extent = DVec3::new(1.0, 0.8, 0.3);
        patches.push(p);
    }
    crate::gtex::GeometryTextureSet {
        patches,
        texel_size: 0.05,
        stats: Default::default(),
        triangles: None,
    }
}

/// A w x h patch over the unit cube with heights `f(i, j)` (None: empty texel), for tests.
#[cfg(test)]
pub(crate) fn test_patch(w: u32, h: u32, bits: u8, f: impl Fn(u32, u32) -> Option<f64>) -> Patch {
    let heights = (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| f(i, j).map_or(0, |v| crate::gtex::encode_height(v, bits)))
        .collect();
    Patch {
        origin: DVec3::ZERO,
        axes: [DVec3::X, DVec3::Y, DVec3::Z],
        extent: DVec3::ONE,
        width: w,
        height: h,
        height_bits: bits,
        heights,
        normals: vec![crate::gtex::encode_normal(DVec3::Z); (w * h) as usize],
        colors: vec![],
        faces: vec![],
        ring_faces: vec![],
        outline: vec![crate::gtex::OUTLINE_INSIDE; (w * h) as usize],
        error_bound: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The padded maps' fast interior read and the pyramid built from them agree with the
    /// per-texel definitions (`code_at_texel`, `outline_at_texel`, `cell_at`) everywhere, on a
    /// patch with holes, ragged outline codes (-128 included) and both code widths.
    #[test]
    fn padded_maps_and_pyramid_match_their_definitions() {
        for bits in [8, 16] {
            let mut p = patch_bits(13, 9, bits, |i, j| {
                ((i * 7 + j * 3) % 11 != 0).then(|| f64::from((i * 5 + j * 9) % 17) / 16.0)
            });
            p.outline = (0..p.texels())
                .map(|t| [-128, -40, -1, 0, 3, 90, 127][t % 7])
                .collect();
            let (heights, outline) = (padded_heights(&p), padded_outline(&p));
            let (w, h) = (i64::from(p.width), i64::from(p.height));
            for j in -1..=h {
                for i in -1..=w {
                    let t = ((j + 1) * (w + 2) + i + 1) as usize;
                    assert_eq!(f64::from(heights[t]), code_at_texel(&p, i, j), "{i} {j}");
                    assert_eq!(f64::from(outline[t]), outline_at_texel(&p, i, j), "{i} {j}");
                }
            }
            let base = &min_max_pyramid(&p)[0].2;
            for r in 0..=h {
                for c in 0..=w {
                    let want = cell_at(&p, c - 1, r - 1).map_or(0, |cell| {
                        let codes = cell.codes.map(|q| q as u32);
                        (codes.iter().max().unwrap() << 16) | codes.iter().min().unwrap()
                    });
                    assert_eq!(base[(r * (w + 1) + c) as usize], want, "cell {c} {r}");
                }
            }
        }
    }

    fn patch(w: u32, h: u32, f: impl Fn(u32, u32) -> Option<f64>) -> Patch {
        patch_bits(w, h, 16, f)
    }

    fn patch_bits(w: u32, h: u32, bits: u8, f: impl Fn(u32, u32) -> Option<f64>) -> Patch {
        test_patch(w, h, bits, f)
    }

    #[test]
    fn height_is_bilinear_between_texel_centres() {
        // h = 0.25 + 0.5 * (i / 7): linear in x, so bilinear reproduces it exactly.
        let p = patch(8, 4, |i, _| Some(0.25 + 0.5 * i as f64 / 7.0));
        for u in [0.1, 0.33, 0.5, 0.77] {
            let x = (u * 8.0 - 0.5f64).clamp(0.0, 7.0);
            let want = 0.25 + 0.5 * x / 7.0;
            assert!((height_at(&p, u, 0.5).unwrap() - want).abs() < 1e-4);
        }
    }

    #[test]
    fn exact_hit_agrees_with_dense_sampling() {
        for bits in [8, 16] {
            exact_hit_agrees_with_dense_sampling_of(bits);
        }
    }

    fn exact_hit_agrees_with_dense_sampling_of(bits: u8) {
        let p = patch_bits(16, 16, bits, |i, j| {
            Some(0.3 + 0.4 * ((i as f64 * 0.7).sin() * (j as f64 * 0.5).cos()).abs())
        });
        let mut rng = 12345u64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng % 1_000_000) as f64 / 1e6
        };
        for _ in 0..200 {
            let o = DVec3::new(next(), next(), 1.0);
            let d = DVec3::new(next() - 0.5, next() - 0.5, -0.2 - next());
            let got = first_hit(&p, o, d, 0.0, 10.0);
            // Dense march as an independent check.
            let mut prev_above = true;
            let mut want = None;
            let n = 200_000;
            for k in 0..=n {
                let t = 10.0 * k as f64 / n as f64;
                let q = o + d * t;
                if !(0.0..=1.0).contains(&q.x)
                    || !(0.0..=1.0).contains(&q.y)
                    || !(0.0..=1.0).contains(&q.z)
                {
                    continue;
                }
                let Some(hh) = height_at(&p, q.x, q.y) else {
                    continue;
                };
                let above = q.z > hh;
                if prev_above && !above {
                    want = Some(t);
                    break;
                }
                prev_above = above;
            }
            match (got, want) {
                (Some(a), Some(b)) => assert!((a - b).abs() < 1e-3, "{a} vs {b}"),
                (None, None) => {}
                other => panic!("{other:?} for o={o:?} d={d:?}"),
            }
        }
    }

    /// A flat 16 x 16 patch whose outline is the straight line through texel-centre point
    /// `through` at angle `angle` (inside to its left).
    fn cut_patch(angle: f64, through: (f64, f64)) -> (Patch, impl Fn(f64, f64) -> f64) {
        let (n, (cx, cy)) = ((-angle.sin(), angle.cos()), through);
        let signed = move |x: f64, y: f64| (x - cx) * n.0 + (y - cy) * n.1;
        let mut p = patch(16, 16, |_, _| Some(0.4));
        for j in 0..16 {
            for i in 0..16 {
                p.outline[j * 16 + i] = crate::gtex::encode_outline(signed(i as f64, j as f64));
            }
        }
        (p, signed)
    }

    #[test]
    fn a_straight_outline_ends_the_surface_within_a_twentieth_of_a_texel() {
        for (angle, through) in [(0.3, (7.2, 7.9)), (1.9, (8.6, 6.3)), (-2.7, (5.1, 9.4))] {
            let (p, signed) = cut_patch(angle, through);
            // Rays slanting down onto a fine grid of points of the plane h = 0.4.
            let (mut hits, mut worst) = (0, 0.0f64);
            for a in 0..120 {
                for b in 0..120 {
                    let (u, v) = (0.1 + 0.8 * a as f64 / 119.0, 0.1 + 0.8 * b as f64 / 119.0);
                    let d = DVec3::new(0.02, -0.03, -1.0);
                    let o = DVec3::new(u, v, 0.4) - d * 0.5;
                    let hit = first_hit(&p, o, d, 0.0, 1.0);
                    let (x, y) = (u * 16.0 - 0.5, v * 16.0 - 0.5);
                    let inside = signed(x, y);
                    if let Some(t) = hit {
                        hits += 1;
                        assert!((t - 0.5).abs() < 1e-4);
                    }
                    // A point wrongly in or out is at most this far from the outline.
                    if hit.is_some() != (inside >= 0.0) {
                        worst = worst.max(inside.abs());
                    }
                    assert_eq!(height_at(&p, u, v).is_some(), hit.is_some());
                }
            }
            // Measured 0.0095, 0.0115, 0.0103 texel (the codes round up, by 1/64 texel at
            // most); the issue asks for 1/20, the bound is 3x the largest measured.
            assert!(worst < 0.035, "{worst} texel off at angle {angle}");
            assert!(hits > 3000 && hits < 120 * 120 - 3000, "{hits}");
        }
    }

    #[test]
    fn a_plane_continues_across_the_border_half_texel() {
        // A tilted plane over a 12 x 9 map, sampled over the whole box, sides included: the
        // cells at the map's sides continue it to the box's side.
        let plane = |x: f64, y: f64| 0.3 + 0.04 * x - 0.025 * y;
        let p = patch(12, 9, |i, j| Some(plane(f64::from(i), f64::from(j))));
        let mut worst = 0.0f64;
        for a in 0..=60 {
            for b in 0..=60 {
                let (u, v) = (f64::from(a) / 60.0, f64::from(b) / 60.0);
                let h = height_at(&p, u, v).expect("surface everywhere in the box");
                worst = worst.max((h - plane(u * 12.0 - 0.5, v * 9.0 - 0.5)).abs());
            }
        }
        // Measured 1.6e-5 (16-bit codes round by 7.6e-6, and continuing past the edge adds two
        // texels' rounding); with the side texels repeated to the box's side the surface was
        // flat there: 0.02 off at a side, 0.0325 at a corner.
        assert!(worst < 3e-5, "{worst}");
    }

    #[test]
    fn an_outline_through_the_border_half_texel_ends_the_surface_there() {
        // Straight outlines running between the box's sides (x or y = -0.5 or 15.5) and the
        // edge texels' centres, and one crossing a corner: the whole map, border included.
        let cases = [
            (-std::f64::consts::FRAC_PI_2, (-0.3, 0.0)),
            (std::f64::consts::FRAC_PI_2, (15.2, 0.0)),
            (0.0, (0.0, 15.35)),
            (std::f64::consts::PI, (0.0, -0.2)),
            (2.3, (15.3, 15.1)),
        ];
        for (angle, through) in cases {
            let (p, signed) = cut_patch(angle, through);
            let (mut wrong, mut worst) = (0, 0.0f64);
            for a in 0..=160 {
                for b in 0..=160 {
                    let (u, v) = (a as f64 / 160.0, b as f64 / 160.0);
                    let (x, y) = (u * 16.0 - 0.5, v * 16.0 - 0.5);
                    if height_at(&p, u, v).is_some() != (signed(x, y) >= 0.0) {
                        wrong += 1;
                        worst = worst.max(signed(x, y).abs());
                    }
                }
            }
            // Measured 0.0079 texel at most (the slanted case; the codes round up by 1/64);
            // with the edge texels' distances clamped across the border instead, the surface
            // reached the box's side: 0.20 texel past the first outline (327 points).
            assert!(
                worst < 0.02,
                "{worst} texel off ({wrong} points) at angle {angle}"
            );
        }
    }

    #[test]
    fn a_crossing_outside_the_outline_lets_the_ray_go_on() {
        // Heights tilted along x, outline cutting off x < 7.5: a grazing ray along -x first
        // meets the surface past the outline and must go on to its crossing inside.
        let (mut p, _) = cut_patch(std::f64::consts::FRAC_PI_2 * 3.0, (7.5, 0.0));
        for j in 0..16 {
            for i in 0..16 {
                p.heights[j * 16 + i] = crate::gtex::encode_height(0.2 + 0.04 * i as f64, 16);
            }
        }
        // Inside is x >= 7.5 (texel centres); a ray going up the slope from the outside.
        let o = DVec3::new(0.02, 0.5, 0.5);
        let d = DVec3::new(1.0, 0.0, 0.05);
        let t = first_hit(&p, o, d, 0.0, 1.0).expect("a hit inside the outline");
        assert!((t * 16.0 + 0.02 * 16.0 - 0.5) >= 7.5 - 0.05, "{t}");
    }

    #[test]
    fn pyramid_bounds_every_cell() {
        for bits in [8, 16] {
            pyramid_bounds_every_cell_of(bits);
        }
    }

    fn pyramid_bounds_every_cell_of(bits: u8) {
        let p = patch_bits(13, 7, bits, |i, j| {
            if (i * 3 + j * 5) % 17 == 0 {
                None
            } else {
                Some(((i * 7 + j * 3) % 11) as f64 / 11.0 + 0.01)
            }
        });
        let levels = min_max_pyramid(&p);
        assert_eq!((levels[0].0, levels[0].1), (14, 8));
        assert_eq!((levels.last().unwrap().0, levels.last().unwrap().1), (1, 1));
        // The top holds every texel (and the map continued past its edge, within the box).
        let top = levels.last().unwrap().2[0];
        assert!(top >> 16 >= *p.heights.iter().max().unwrap() as u32);
        assert!(top >> 16 <= u32::from(p.code_max()));
        assert!(top & 0xffff <= *p.heights.iter().filter(|&&c| c > 0).min().unwrap() as u32);
        assert!(top & 0xffff >= 1);
        // Every surface height in a level-0 cell lies within that cell's [min, max].
        let mut checked = 0;
        for k in 0..2000 {
            let (u, v) = (
                (k % 50) as f64 / 50.0 + 0.003,
                (k / 50) as f64 / 40.0 + 0.004,
            );
            if let Some(hh) = height_at(&p, u, v) {
                let (x, y) = (u * 13.0 - 0.5, v * 7.0 - 0.5);
                let (c, r) = ((x.floor() + 1.0) as u32, (y.floor() + 1.0) as u32);
                let cell = levels[0].2[(r * 14 + c) as usize];
                assert!(
                    hh <= p.decode_height((cell >> 16) as f64) + 1e-12
                        && hh >= p.decode_height((cell & 0xffff) as f64) - 1e-12
                );
                checked += 1;
            }
        }
        assert!(checked > 1000);
    }

    /// The BVH and pyramid search (`first_hits`) finds exactly the hits of the plain walk over
    /// every cell of every patch: three rough patches (both code widths, holes, ragged outline
    /// codes), turned and overlapping, and 4,000 rays from around them.
    #[test]
    fn set_tracer_finds_the_walks_hits_exactly() {
        let set = turned_holed_set();
        // xorshift: rays from a sphere of radius 3 around (0.8, 0.5, 0) toward its unit ball.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut unit = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let centre = DVec3::new(0.8, 0.5, 0.0);
        let rays: Vec<(DVec3, DVec3)> = (0..4000)
            .map(|_| {
                let from = centre + 3.0 * DVec3::new(unit(), unit(), unit()).normalize();
                let to = centre + DVec3::new(unit(), unit(), unit());
                (from, (to - from).normalize())
            })
            .collect();
        let fast = first_hits(&set, &rays, &crate::cancel::NEVER).unwrap();
        let slow = first_hits_by_walking(&set, &rays);
        let hits = slow.iter().filter(|h| h.1 >= 0).count();
        // 698 of the 4,000 hit (the outline codes leave many holes).
        assert!(hits > 500, "{hits} hits");
        for (k, (a, b)) in fast.iter().zip(&slow).enumerate() {
            assert_eq!(a.1, b.1, "ray {k}: patch {a:?} against {b:?}");
            assert!(
                a.0 == b.0 || (a.0 - b.0).abs() <= 1e-12 * (1.0 + b.0),
                "ray {k}: {a:?} against {b:?}"
            );
        }
    }
}
