//! Geometry textures: a set of height-map patches, each in its own oriented box.
//!
//! Spaces:
//! - world: the source mesh's coordinates (f64).
//! - patch-local: the patch box is the unit cube; x/y are texture u/v, z is height:
//!   world = origin + axes[0] (u extent.x) + axes[1] (v extent.y) + axes[2] (h extent.z),
//!   the matrix `Patch::world_from_patch`.
//!
//! Texel (i, j) (column i along u, row j along v) covers u in [i/w, (i+1)/w] and is sampled at its
//! centre. Maps are row-major with row 0 at v = 0. Heights are codes of a patch's `height_bits`
//! (8 or 16): 0 = empty, 1..=code_max map linearly to h in [0, 1]. Normals are patch-local unit
//! vectors in two signed bytes, octahedral (`encode_normal`; `NO_NORMAL` where a texel has none).
//! Colors are RGBA8, or absent (an empty map: every texel `NEUTRAL_COLOR`) when the source mesh
//! had no colors. The outline map holds, per texel, the signed distance
//! from its centre to the outline of the faces the patch draws (texel units, positive inside,
//! clamped to ±OUTLINE_REACH texels, see `encode_outline`): the surface ends where its bilinear
//! blend is negative, so it stops where the mesh stops, not at the texel grid.

use glam::{DMat4, DVec3, DVec4};

pub use bound::ErrorBoundMap;

pub mod bound;
pub mod file;
#[cfg(test)]
mod fuzz_tests;
pub mod triangles;
pub mod validate;

pub use triangles::{KeptBecause, SetTriangles};
pub use validate::MAX_PATCH_SIDE;

/// Bits per height code a patch may use.
pub const HEIGHT_BITS: [u8; 2] = [8, 16];

/// Largest height code of `bits`-bit heights (code 0 means "no surface").
#[inline]
pub fn code_max(bits: u8) -> u16 {
    ((1u32 << bits) - 1) as u16
}

/// Color of texels whose source has no color.
pub const NEUTRAL_COLOR: [u8; 4] = [200, 200, 200, 255];

/// A box's thickness and height bits for a surface spanning `height` at texel size `texel`.
///
/// At least a texel thick, flat surfaces centred: a box of (near) zero height would turn
/// patch-local z into huge numbers that f32 on the GPU cannot resolve. A margin above and below
/// the surface keeps a ray entering through the box's top or bottom strictly off the surface, so
/// its first sample knows which side it is on. The margin is also at least one height code step,
/// so rounding never puts the surface on the box's top or bottom (8-bit codes would, with 0.02
/// texel alone). 8-bit codes only where their rounding (half a code step) stays within half a
/// texel, so the map is never coarser across than along: a surface more than ~250 texels tall
/// keeps 16 bits.
pub fn vertical_extent(height: f64, texel: f64, requested_bits: u8) -> (f64, u8) {
    let base = height.max(texel);
    let thickness = |bits: u8| {
        let code_max = code_max(bits) as f64;
        base + 2.0 * (0.02 * texel).max(base / (code_max - 3.0))
    };
    let bits = if requested_bits == 8 && thickness(8) / (code_max(8) - 1) as f64 > texel {
        16
    } else {
        requested_bits
    };
    (thickness(bits), bits)
}

#[derive(Clone, Debug, PartialEq)]
pub struct Patch {
    pub origin: DVec3,
    /// Orthonormal, right-handed x, y, z (z = the chart's "up", the height direction).
    pub axes: [DVec3; 3],
    /// Box size along each axis in world units.
    pub extent: DVec3,
    pub width: u32,
    pub height: u32,
    /// 8 or 16: the range of the codes in `heights` (kept in u16 either way in memory).
    pub height_bits: u8,
    pub heights: Vec<u16>,
    /// Octahedral normal codes (`encode_normal`), one per texel.
    pub normals: Vec<[i8; 2]>,
    /// RGBA8 colors, one per texel, or empty: no color map (every texel `NEUTRAL_COLOR`).
    pub colors: Vec<[u8; 4]>,
    /// The chart's own faces in the source mesh.
    pub faces: Vec<u32>,
    /// Overlap-ring faces also drawn into this patch's maps.
    pub ring_faces: Vec<u32>,
    /// Signed distance codes to the drawn faces' outline, one per texel (`decode_outline`).
    pub outline: Vec<i8>,
    /// Per-cell bounds on the distance from the stored surface to the source mesh (`bound`),
    /// None where unknown (files written before version 6, filtered or hand-made sets).
    pub error_bound: Option<ErrorBoundMap>,
}

impl Patch {
    /// 4x4 matrix taking the unit cube (patch-local) to world space.
    pub fn world_from_patch(&self) -> DMat4 {
        DMat4::from_cols(
            (self.axes[0] * self.extent.x).extend(0.0),
            (self.axes[1] * self.extent.y).extend(0.0),
            (self.axes[2] * self.extent.z).extend(0.0),
            DVec4::new(self.origin.x, self.origin.y, self.origin.z, 1.0),
        )
    }

    /// Patch-local position of texel (i, j) holding height code `q` (> 0).
    #[inline]
    pub fn texel_local(&self, i: u32, j: u32, q: u16) -> DVec3 {
        DVec3::new(
            (i as f64 + 0.5) / self.width as f64,
            (j as f64 + 0.5) / self.height as f64,
            self.decode_height(q as f64),
        )
    }

    #[inline]
    pub fn code_max(&self) -> u16 {
        code_max(self.height_bits)
    }

    /// Height code (or a blend of codes) → patch-local height.
    #[inline]
    pub fn decode_height(&self, code: f64) -> f64 {
        (code - 1.0) / (self.code_max() - 1) as f64
    }

    /// Largest error of a quantized height, in world units: half a code step.
    pub fn quantization_error(&self) -> f64 {
        0.5 * self.extent.z / (self.code_max() - 1) as f64
    }

    #[inline]
    pub fn local_to_world(&self, l: DVec3) -> DVec3 {
        self.origin
            + self.axes[0] * (l.x * self.extent.x)
            + self.axes[1] * (l.y * self.extent.y)
            + self.axes[2] * (l.z * self.extent.z)
    }

    /// Patch-local coordinates (the box is the unit cube) of a world point.
    #[inline]
    pub fn world_to_local(&self, x: DVec3) -> DVec3 {
        let d = x - self.origin;
        DVec3::new(
            d.dot(self.axes[0]) / self.extent.x,
            d.dot(self.axes[1]) / self.extent.y,
            d.dot(self.axes[2]) / self.extent.z,
        )
    }

    /// Whether texel `t` holds surface: a height, and its centre inside the outline.
    #[inline]
    pub fn is_surface(&self, t: usize) -> bool {
        self.heights[t] != 0 && self.outline[t] >= 0
    }

    /// Every texel holding surface: (index in the maps, world point, world unit normal).
    pub fn surface_texels(&self) -> impl Iterator<Item = (usize, DVec3, DVec3)> + '_ {
        self.filled_texels()
            .filter(|&(t, _, _)| self.outline[t] >= 0)
    }

    /// Every texel holding a height, inside the outline or not (those outside only shape the
    /// bilinear cells the outline cuts): (index in the maps, world point, world unit normal).
    pub fn filled_texels(&self) -> impl Iterator<Item = (usize, DVec3, DVec3)> + '_ {
        (0..self.height)
            .flat_map(move |j| (0..self.width).map(move |i| (i, j)))
            .filter_map(move |(i, j)| {
                let t = (j * self.width + i) as usize;
                let q = self.heights[t];
                (q != 0).then(|| {
                    let point = self.local_to_world(self.texel_local(i, j, q));
                    (t, point, self.world_normal(t))
                })
            })
    }

    /// The world unit normal texel `t` holds (zero where it holds none).
    pub fn world_normal(&self, t: usize) -> DVec3 {
        let n = decode_normal(self.normals[t]);
        (self.axes[0] * n.x + self.axes[1] * n.y + self.axes[2] * n.z).normalize_or_zero()
    }

    pub fn texels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// World size of a texel: the shorter of its two sides.
    pub fn texel_size(&self) -> f64 {
        (self.extent.x / self.width as f64).min(self.extent.y / self.height as f64)
    }

    /// Texels holding no surface: no height, or a centre outside the outline.
    pub fn empty_texels(&self) -> usize {
        (0..self.texels()).filter(|&t| !self.is_surface(t)).count()
    }

    /// Whether the patch has a color map (else every texel shows `NEUTRAL_COLOR`).
    pub fn has_colors(&self) -> bool {
        !self.colors.is_empty()
    }

    /// The color of texel `t`: its color map's, or `NEUTRAL_COLOR` without one.
    pub fn color(&self, t: usize) -> [u8; 4] {
        self.colors.get(t).copied().unwrap_or(NEUTRAL_COLOR)
    }

    /// The normal map as (x, y, z, 0) / 127 signed bytes per texel, zero where there is none.
    pub fn normals_snorm8(&self) -> Vec<[i8; 4]> {
        self.normals
            .iter()
            .map(|&n| encode_snorm8(decode_normal(n)))
            .collect()
    }

    /// The error bound (world units) of the cell holding texel-centre point (x, y) (see
    /// `bound`), taking the largest of the cells within `slack` texels (a point found in f32 may
    /// lie a hair across a cell's side); None without a bound map.
    pub fn error_bound_near(&self, x: f64, y: f64, slack: f64) -> Option<f64> {
        let map = self.error_bound.as_ref()?;
        let (i0, i1) = ((x - slack).floor() as i64, (x + slack).floor() as i64);
        let (j0, j1) = ((y - slack).floor() as i64, (y + slack).floor() as i64);
        let mut bound = 0.0f64;
        for j in j0..=j1 {
            for i in i0..=i1 {
                bound = bound.max(map.at_cell(self.width, self.height, i, j));
            }
        }
        Some(bound)
    }

    /// Bytes the maps take (`map_bytes`).
    pub fn map_bytes(&self) -> usize {
        map_bytes(self.texels(), self.height_bits, self.has_colors()) + self.error_bound_bytes()
    }

    /// Bytes the error-bound map takes (0 without one).
    pub fn error_bound_bytes(&self) -> usize {
        self.error_bound.as_ref().map_or(0, ErrorBoundMap::bytes)
    }
}

/// Bytes `texels` texels take: an 8- or 16-bit height + a 2-byte normal + an outline byte each,
/// and an RGBA8 color each where there is a color map.
pub fn map_bytes(texels: usize, height_bits: u8, colors: bool) -> usize {
    texels * (height_bits as usize / 8 + 2 + 1 + if colors { 4 } else { 0 })
}

/// Height in [0, 1] to its `bits`-bit code in [1, code_max(bits)].
#[inline]
pub fn encode_height(h: f64, bits: u8) -> u16 {
    1 + (h.clamp(0.0, 1.0) * (code_max(bits) - 1) as f64).round() as u16
}

/// How far (texels) the outline map reaches on either side of the outline.
pub const OUTLINE_REACH: f64 = 2.0;

/// Outline code of a texel wholly inside (and of every texel of a map without outlines).
pub const OUTLINE_INSIDE: i8 = 127;

/// Signed distance to the outline (texels, positive inside) → its code: 127 steps per
/// OUTLINE_REACH, rounded up so the surface never ends short of the outline (at most 1/64 texel
/// past it), which keeps patches meeting on a shared edge from leaving a hairline between them.
#[inline]
pub fn encode_outline(distance: f64) -> i8 {
    (distance / OUTLINE_REACH * 127.0)
        .ceil()
        .clamp(-127.0, 127.0) as i8
}

/// Outline code (or a blend of codes) → signed distance in texels.
#[inline]
pub fn decode_outline(code: f64) -> f64 {
    code * OUTLINE_REACH / 127.0
}

/// Normal code of a texel that holds no normal (decodes to the zero vector).
pub const NO_NORMAL: [i8; 2] = [i8::MIN, i8::MIN];

/// Steps per unit of an octahedral code: 126 = 2 · 3² · 7, so the directions CAD models are made
/// of (axes, 45° chamfers, cube diagonals: octahedron coordinates 0, 1/2, 1/3) are exact.
pub const NORMAL_STEPS: f64 = 126.0;

/// Octahedral code of direction `n` (two signed bytes, / NORMAL_STEPS): the point of the
/// octahedron |x| + |y| + |z| = 1 along n, its lower half folded over the upper, so x and y
/// alone say where. Of the four roundings the one decoding closest to n is kept (over random
/// directions: mean error 0.32°, at most 0.64°). The zero vector gets `NO_NORMAL`.
pub fn encode_normal(n: DVec3) -> [i8; 2] {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    // Zero or not finite (NaN compares false): no direction.
    if l1.is_nan() || l1 <= 0.0 || l1.is_infinite() {
        return NO_NORMAL;
    }
    let n = n / l1;
    let sign = |v: f64| if v >= 0.0 { 1.0 } else { -1.0 };
    let (x, y) = if n.z >= 0.0 {
        (n.x, n.y)
    } else {
        ((1.0 - n.y.abs()) * sign(n.x), (1.0 - n.x.abs()) * sign(n.y))
    };
    let (fx, fy) = ((x * NORMAL_STEPS).floor(), (y * NORMAL_STEPS).floor());
    let unit = n.normalize();
    let mut best = (f64::NEG_INFINITY, NO_NORMAL);
    for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
        let code = [
            (fx + dx).clamp(-NORMAL_STEPS, NORMAL_STEPS) as i8,
            (fy + dy).clamp(-NORMAL_STEPS, NORMAL_STEPS) as i8,
        ];
        let cos = decode_normal(code).dot(unit);
        if cos > best.0 {
            best = (cos, code);
        }
    }
    best.1
}

/// Two chamfer sweeps over a `w` x `h` map in place (rows of `w`, from the top left, then from
/// the bottom right): each value becomes the least of itself and a neighbour's plus the step
/// to it (`axis.0` across, `axis.1` down, `diagonal` on the diagonals). Outside the map a
/// neighbour holds `outside`, or none when that is None. Patches use it for distances to or
/// from their surface texels.
pub(crate) fn chamfer<T>(
    d: &mut [T],
    w: usize,
    h: usize,
    axis: (T, T),
    diagonal: T,
    outside: Option<T>,
) where
    T: Copy + PartialOrd + std::ops::Add<Output = T>,
{
    let steps = [
        (-1, 0, axis.0),
        (0, -1, axis.1),
        (-1, -1, diagonal),
        (1, -1, diagonal),
    ];
    for forward in [true, false] {
        for k in 0..w * h {
            let t = if forward { k } else { w * h - 1 - k };
            let (i, j) = ((t % w) as i64, (t / w) as i64);
            for &(di, dj, cost) in &steps {
                let (ni, nj) = if forward {
                    (i + di, j + dj)
                } else {
                    (i - di, j - dj)
                };
                let inside = ni >= 0 && nj >= 0 && (ni as usize) < w && (nj as usize) < h;
                let neighbour = if inside {
                    Some(d[nj as usize * w + ni as usize])
                } else {
                    outside
                };
                if let Some(n) = neighbour {
                    if n + cost < d[t] {
                        d[t] = n + cost;
                    }
                }
            }
        }
    }
}

/// Unit direction of an octahedral code (`encode_normal`); zero for `NO_NORMAL`.
#[inline]
pub fn decode_normal(c: [i8; 2]) -> DVec3 {
    if c[0] == i8::MIN {
        return DVec3::ZERO;
    }
    let (x, y) = (c[0] as f64 / NORMAL_STEPS, c[1] as f64 / NORMAL_STEPS);
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    let fold = |v: f64| if v >= 0.0 { v - t } else { v + t };
    DVec3::new(fold(x), fold(y), z).normalize()
}

/// A normal as three signed bytes (x, y, z, 0) / 127: the maps' layout before .gtex version 5,
/// and what `patch(i)["normal"]` shows.
#[inline]
pub fn encode_snorm8(n: DVec3) -> [i8; 4] {
    let c = |x: f64| (x.clamp(-1.0, 1.0) * 127.0).round() as i8;
    [c(n.x), c(n.y), c(n.z), 0]
}

#[inline]
pub fn decode_snorm8(n: [i8; 4]) -> DVec3 {
    DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64) / 127.0
}

/// Named figures of a conversion: counts in `values`, per-stage wall-clock seconds in `seconds`,
/// one value per patch in `per_patch`. Ordered name/value lists, so the file format and the
/// Python dict need no schema.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stats {
    pub values: Vec<(String, f64)>,
    pub seconds: Vec<(String, f64)>,
    pub per_patch: Vec<(String, Vec<f64>)>,
}

impl Stats {
    pub fn set(&mut self, name: &str, v: f64) {
        match self.values.iter_mut().find(|(n, _)| n == name) {
            Some(e) => e.1 = v,
            None => self.values.push((name.to_string(), v)),
        }
    }

    pub fn get(&self, name: &str) -> Option<f64> {
        self.values.iter().find(|(n, _)| n == name).map(|e| e.1)
    }

    /// Every scalar stat typed for display: counts as integers, fractions and lengths as floats.
    pub fn typed(&self) -> Vec<(&str, StatValue)> {
        self.values
            .iter()
            .map(|(name, v)| {
                let count =
                    !FLOAT_STATS.contains(&name.as_str()) && v.fract() == 0.0 && v.abs() < 9e15;
                let value = if count {
                    StatValue::Int(*v as i64)
                } else {
                    StatValue::Float(*v)
                };
                (name.as_str(), value)
            })
            .collect()
    }
}

/// Stats that are fractions or lengths; every other stat is a count.
const FLOAT_STATS: &[&str] = &[
    "empty_fraction",
    "texel_size",
    "diagonal",
    "vsa_mean_error",
    "reconstruction_error_p99",
    "reconstruction_error_max",
    "max_quantization_error",
];

/// One figure of a conversion or a frame, typed as it should be shown (Python int, float, str).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StatValue {
    Int(i64),
    Float(f64),
    Text(&'static str),
    /// Not measured in this run (Python None).
    Absent,
}

/// A set's error bounds in brief (`GeometryTextureSet::error_bound_figures`), world units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorBoundFigures {
    pub max: f64,
    pub p99: f64,
    pub bytes: usize,
}

impl ErrorBoundFigures {
    /// Sets stats error_bound_max, _p99 and _bytes (in place where present).
    pub fn write(&self, stats: &mut Stats) {
        stats.set("error_bound_max", self.max);
        stats.set("error_bound_p99", self.p99);
        stats.set("error_bound_bytes", self.bytes as f64);
    }
}

/// `face_patch` of a face a hybrid set keeps as a triangle.
pub const KEPT_AS_TRIANGLES: i32 = -2;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct GeometryTextureSet {
    pub patches: Vec<Patch>,
    /// World size of one texel (the same for every patch).
    pub texel_size: f64,
    pub stats: Stats,
    /// The regions kept as the source's own faces (a hybrid conversion), drawn as a mesh.
    pub triangles: Option<SetTriangles>,
}

impl GeometryTextureSet {
    /// Every non-empty texel as a world point (f64) and world unit normal (f32).
    /// A hybrid set's triangles add points about a texel apart over each face
    /// (`SetTriangles::points`).
    pub fn to_points(&self) -> (Vec<[f64; 3]>, Vec<[f32; 3]>) {
        let texels = self
            .patches
            .iter()
            .flat_map(Patch::surface_texels)
            .map(|(_, point, normal)| (point, normal));
        let faces = (self.triangles.iter()).flat_map(|t| t.points(self.texel_size));
        texels
            .chain(faces)
            .map(|(point, normal)| (point.to_array(), normal.as_vec3().to_array()))
            .unzip()
    }

    pub fn texels(&self) -> usize {
        self.patches.iter().map(Patch::texels).sum()
    }

    pub fn empty_texels(&self) -> usize {
        self.patches.iter().map(Patch::empty_texels).sum()
    }

    pub fn map_bytes(&self) -> usize {
        self.patches.iter().map(Patch::map_bytes).sum()
    }

    /// What the set holds: its patches' maps and its triangles (`SetTriangles::bytes`).
    pub fn bytes(&self) -> usize {
        self.map_bytes() + self.triangles.as_ref().map_or(0, SetTriangles::bytes)
    }

    /// Sets the `error_bound_*` stats from the maps, or drops them where a patch has none: the
    /// stats say what the set holds, whatever a file or an older set claimed. `bytes` follows.
    pub fn sync_error_bound_stats(&mut self) {
        // In place where present: the stats' order is part of the file's bytes.
        match self.error_bound_figures() {
            Some(b) => b.write(&mut self.stats),
            None => self
                .stats
                .values
                .retain(|(name, _)| !name.starts_with("error_bound")),
        }
        if self.stats.get("bytes").is_some() {
            self.stats.set("bytes", self.bytes() as f64);
        }
    }

    /// The error bounds of the whole set (`bound`): the largest, the 99th percentile over the
    /// blocks holding surface, and the maps' bytes; None unless every patch has a bound map.
    pub fn error_bound_figures(&self) -> Option<ErrorBoundFigures> {
        let maps: Option<Vec<&ErrorBoundMap>> = self
            .patches
            .iter()
            .map(|p| p.error_bound.as_ref())
            .collect();
        let maps = maps?;
        let mut bounds: Vec<f64> = maps
            .iter()
            .flat_map(|m| m.decoded())
            .filter(|&b| b > 0.0)
            .collect();
        bounds.sort_by(f64::total_cmp);
        let p99 = bounds
            .get(((bounds.len() as f64 * 0.99) as usize).min(bounds.len().saturating_sub(1)))
            .copied()
            .unwrap_or(0.0);
        Some(ErrorBoundFigures {
            max: bounds.last().copied().unwrap_or(0.0),
            p99,
            bytes: maps.iter().map(|m| m.bytes()).sum(),
        })
    }

    /// The patch holding each source face, -1 for faces left out (degenerate ones),
    /// `KEPT_AS_TRIANGLES` (-2) for those a hybrid set keeps as triangles. As long as
    /// the source mesh's face count (the "faces" stat), or as the largest face listed.
    pub fn face_patch(&self) -> Vec<i32> {
        let counted = self.stats.get("faces").unwrap_or(0.0) as usize;
        let listed = self
            .patches
            .iter()
            .flat_map(|p| p.faces.iter())
            .chain(self.triangles.iter().flat_map(|t| &t.source_faces))
            .max()
            .map_or(0, |&m| m as usize + 1);
        let mut out = vec![-1i32; counted.max(listed)];
        for (k, p) in self.patches.iter().enumerate() {
            for &f in &p.faces {
                out[f as usize] = k as i32;
            }
        }
        if let Some(t) = &self.triangles {
            for &f in &t.source_faces {
                out[f as usize] = KEPT_AS_TRIANGLES;
            }
        }
        out
    }
}
