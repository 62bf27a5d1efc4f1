//! Rasterizing a chart's triangles into its height, normal and color maps, and dilating the
//! normal/color maps into empty texels.
//!
//! Space: patch-local with x/y measured in texels (texel (i, j) has its centre at (i+0.5, j+0.5))
//! and z in world units above the box floor; heights are stored as 8- or 16-bit codes of
//! z / extent.z.

use glam::{DVec2, DVec3};

use crate::appearance::FaceColor;
use crate::charts::frame::PatchBox;
use crate::gtex::{
    decode_normal, encode_height, encode_normal, encode_outline, Patch, NO_NORMAL, OUTLINE_REACH,
};
use crate::mesh::{CornerNormals, Mesh};

impl PatchBox {
    /// The patch this box and its maps make, drawing `faces` then `ring_faces`.
    pub fn into_patch(self, maps: Maps, faces: Vec<u32>, ring_faces: Vec<u32>) -> Patch {
        Patch {
            origin: self.origin,
            axes: self.axes,
            extent: self.extent,
            width: self.width,
            height: self.height,
            height_bits: self.height_bits,
            heights: maps.heights,
            normals: maps.normals,
            colors: maps.colors,
            faces,
            ring_faces,
            outline: maps.outline,
            error_bound: None,
        }
    }
}

/// A texel filled by conservative coverage alone whose centre still lies inside the outline (by
/// the outline map's rounding), and the world distance (in the patch plane) from its centre to
/// the point of the triangle it copies: how far the surface reaches past the mesh there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lip {
    pub texel: usize,
    pub distance: f64,
}

#[derive(Default)]
pub struct Maps {
    pub heights: Vec<u16>,
    /// Octahedral normal codes (gtex::encode_normal).
    pub normals: Vec<[i8; 2]>,
    /// Empty when the mesh has no colors (no color map).
    pub colors: Vec<[u8; 4]>,
    /// Outline codes (gtex::encode_outline): signed distance from each texel centre to the
    /// outline of the drawn faces, positive inside.
    pub outline: Vec<i8>,
    pub lips: Vec<Lip>,
    /// Texel corners where the height field has a surface (inside the outline) but no drawn
    /// triangle lies under them: the world distance (in the patch plane) to the nearest triangle, at most two texels
    /// (larger gaps are not searched). A coarse map's cells and flat border reach over a chart's
    /// notches and past its outline; this is how far.
    pub overhangs: Vec<f64>,
}

/// How a face covers a texel; a texel keeps the best coverage any face gives it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Coverage {
    Empty,
    /// The square of a texel's width around the texel centre (the cells that centre is a
    /// corner of) touches the face, but the centre lies outside it.
    Lip,
    /// The texel centre lies inside the face.
    Centre,
}

/// A face in texel units (x, y) and world height above the box floor (z), with what the
/// coverage tests need.
struct LocalFace {
    corners: [DVec3; 3],
    /// Sign of the face's area in the patch plane (its winding there).
    sign: f64,
    inv_area: f64,
    /// Tolerance so texel centres on a shared edge are never missed by both faces.
    eps: f64,
    /// A texel's extent along each edge's normal: the conservative margin.
    margins: [f64; 3],
    lo: DVec3,
    hi: DVec3,
}

impl LocalFace {
    /// None for a face seen edge-on, which covers no area.
    fn new(corners: [DVec3; 3]) -> Option<LocalFace> {
        let [a, b, c] = corners;
        let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        if area.abs() < 1e-300 {
            return None;
        }
        let margin = |p: DVec3, q: DVec3| (q.x - p.x).abs() + (q.y - p.y).abs();
        Some(LocalFace {
            corners,
            sign: area.signum(),
            inv_area: 1.0 / area,
            eps: -1e-9 * area.abs(),
            margins: [margin(b, c), margin(c, a), margin(a, b)],
            lo: a.min(b).min(c),
            hi: a.max(b).max(c),
        })
    }

    fn flat(&self) -> [DVec2; 3] {
        self.corners.map(|p| p.truncate())
    }

    /// How the texel centred at (px, py) is covered, and the barycentric coordinates of the
    /// point whose values it takes (the centre, or the face's point nearest to it for a lip).
    fn coverage(&self, px: f64, py: f64, lips: bool) -> Option<(Coverage, [f64; 3])> {
        let ([a, b, c], sign) = (self.corners, self.sign);
        let wa = ((b.x - px) * (c.y - py) - (b.y - py) * (c.x - px)) * sign;
        let wb = ((c.x - px) * (a.y - py) - (c.y - py) * (a.x - px)) * sign;
        let wc = ((a.x - px) * (b.y - py) - (a.y - py) * (b.x - px)) * sign;
        if wa >= self.eps && wb >= self.eps && wc >= self.eps {
            let inv = self.inv_area;
            return Some((
                Coverage::Centre,
                [wa * sign * inv, wb * sign * inv, wc * sign * inv],
            ));
        }
        // The square of a texel's width around the centre overlaps the triangle iff no
        // separating axis exists among the three edge normals and the two box axes (so at most
        // a texel diagonal out): then every cell with a corner here that the face touches has
        // this corner filled, and the outline map trims the cell back to the face.
        let (lo, hi) = (self.lo, self.hi);
        let overlaps_box =
            px + 1.0 >= lo.x && px - 1.0 <= hi.x && py + 1.0 >= lo.y && py - 1.0 <= hi.y;
        let [ma, mb, mc] = self.margins;
        if lips && overlaps_box && wa >= -ma && wb >= -mb && wc >= -mc {
            let (la, lb, lc) = nearest_on_triangle(DVec2::new(px, py), self.flat());
            return Some((Coverage::Lip, [la, lb, lc]));
        }
        None
    }

    /// Height of the face's plane over (px, py), clamped to the face's own height range: what
    /// a lip holds, so the cells it is a corner of continue the face (bilinear blends reproduce a
    /// plane) without a steep face sending it far off.
    fn plane_z(&self, px: f64, py: f64) -> f64 {
        let [a, b, c] = self.corners;
        let wa = (b.x - px) * (c.y - py) - (b.y - py) * (c.x - px);
        let wb = (c.x - px) * (a.y - py) - (c.y - py) * (a.x - px);
        let wc = (a.x - px) * (b.y - py) - (a.y - py) * (b.x - px);
        ((wa * a.z + wb * b.z + wc * c.z) * self.inv_area).clamp(self.lo.z, self.hi.z)
    }

    /// Whether the point q (texel units) lies inside the face's projection.
    fn contains(&self, q: DVec2) -> bool {
        let t = self.flat();
        let e = |p: DVec2, r: DVec2| {
            ((p.x - q.x) * (r.y - q.y) - (p.y - q.y) * (r.x - q.x)) * self.sign
        };
        e(t[1], t[2]) >= 0.0 && e(t[2], t[0]) >= 0.0 && e(t[0], t[1]) >= 0.0
    }
}

/// The normals and colors a face gives the points of its surface.
struct FaceShading<'m> {
    normals: [DVec3; 3],
    colors: FaceColor<'m>,
}

impl<'m> FaceShading<'m> {
    /// Face `f` with its corners' normals (`MeshGeometry::corner_normals`); `face` places it on
    /// the texel grid, so a texture is averaged over a texel.
    fn new(
        mesh: &'m Mesh,
        corner_normals: &CornerNormals,
        f: u32,
        face: &LocalFace,
    ) -> FaceShading<'m> {
        FaceShading {
            normals: corner_normals.face(f as usize),
            colors: mesh.face_color(f, Some(face.flat())),
        }
    }

    /// The world unit normal at barycentric coordinates `l` (zero if they cancel).
    fn normal(&self, [la, lb, lc]: [f64; 3]) -> DVec3 {
        let vn = &self.normals;
        (vn[0] * la + vn[1] * lb + vn[2] * lc).normalize_or_zero()
    }

    fn color(&self, l: [f64; 3]) -> [u8; 4] {
        self.colors.at(l)
    }
}

/// The texels (columns i0..=i1, rows j0..=j1) a face's bounds touch.
#[derive(Clone, Copy)]
struct TexelSpan {
    i0: usize,
    j0: usize,
    i1: usize,
    j1: usize,
}

/// How far `v` lies outside [lo, hi] (0 inside): a point's distance from a face's bounds along
/// one axis, so no nearer than that to the face.
fn outside(v: f64, lo: f64, hi: f64) -> f64 {
    (lo - v).max(v - hi).max(0.0)
}

/// The texel corners (columns, rows: ci0..=ci1, cj0..=cj1) whose distance a face with texel
/// span `span` measures: two texels past its texels and one before (a corner (i, j) sits at
/// the texel-unit point (i, j)), within the map's (w + 1) x (h + 1) corners.
fn corner_range(span: TexelSpan, w: usize, h: usize) -> (usize, usize, usize, usize) {
    (
        span.i0.saturating_sub(1),
        span.j0.saturating_sub(1),
        (span.i1 + 3).min(w),
        (span.j1 + 3).min(h),
    )
}

/// A grid's cells that satisfy a test, as running counts (a summed-area table), so whether a
/// rectangle holds any costs four reads however large it is.
struct Counts {
    w: usize,
    h: usize,
    /// (w + 1) x (h + 1): the cells (i', j') with i' < i and j' < j at (i, j).
    sums: Vec<u32>,
}

impl Counts {
    fn new(w: usize, h: usize, test: impl Fn(usize) -> bool) -> Counts {
        let mut sums = vec![0u32; (w + 1) * (h + 1)];
        for j in 0..h {
            let mut row = 0;
            for i in 0..w {
                row += test(j * w + i) as u32;
                sums[(j + 1) * (w + 1) + i + 1] = sums[j * (w + 1) + i + 1] + row;
            }
        }
        Counts { w, h, sums }
    }

    /// Whether any cell in columns i0..=i1, rows j0..=j1 (clipped to the grid) passed.
    fn any(&self, (i0, j0, i1, j1): (usize, usize, usize, usize)) -> bool {
        let (i1, j1) = ((i1 + 1).min(self.w), (j1 + 1).min(self.h));
        if i0 >= i1 || j0 >= j1 {
            return false;
        }
        let at = |i: usize, j: usize| self.sums[j * (self.w + 1) + i] as i64;
        at(i1, j1) - at(i0, j1) - at(i1, j0) + at(i0, j0) > 0
    }
}

/// The maps while faces are drawn into them, with what conservative coverage and the overhang
/// figures need to know about each texel and texel corner.
struct Canvas<'a> {
    bx: &'a PatchBox,
    w: usize,
    h: usize,
    /// World size of a texel along x and y.
    texel: DVec2,
    /// Height above the box floor (world units) of the surface drawn so far.
    depth: Vec<f64>,
    coverage: Vec<Coverage>,
    lip_distance: Vec<f64>,
    /// In-plane world distance from each texel corner to the nearest face; corner (i, j) sits at
    /// (i, j) in texel units, (w + 1) x (h + 1) of them.
    corner_distance: Vec<f64>,
    /// World unit normal of what each texel holds, encoded once at the end: a texel is often
    /// covered several times (lips, ring faces, overlaps) and encoding is most of a cover's cost.
    normals: Vec<DVec3>,
    /// Empty when the mesh has no colors: no color map is kept.
    colors: Vec<[u8; 4]>,
}

impl<'a> Canvas<'a> {
    /// Without `shaded` no normal or color map is drawn (heights and outline only).
    fn new(bx: &'a PatchBox, shaded: bool, colored: bool) -> Canvas<'a> {
        let (w, h) = (bx.width as usize, bx.height as usize);
        Canvas {
            bx,
            w,
            h,
            texel: DVec2::new(bx.extent.x / w as f64, bx.extent.y / h as f64),
            depth: vec![f64::NEG_INFINITY; w * h],
            coverage: vec![Coverage::Empty; w * h],
            lip_distance: vec![f64::INFINITY; w * h],
            corner_distance: vec![f64::INFINITY; (w + 1) * (h + 1)],
            normals: vec![DVec3::ZERO; if shaded { w * h } else { 0 }],
            colors: if shaded && colored {
                vec![[0; 4]; w * h]
            } else {
                Vec::new()
            },
        }
    }

    /// A world point in texel units (x, y) and world height above the box floor (z).
    fn to_local(&self, p: DVec3) -> DVec3 {
        let (bx, texel) = (self.bx, self.texel);
        let d = p - bx.origin;
        DVec3::new(
            d.dot(bx.axes[0]) / texel.x,
            d.dot(bx.axes[1]) / texel.y,
            d.dot(bx.axes[2]),
        )
    }

    /// A world direction in patch axes.
    fn to_patch_dir(&self, n: DVec3) -> DVec3 {
        let axes = &self.bx.axes;
        DVec3::new(n.dot(axes[0]), n.dot(axes[1]), n.dot(axes[2]))
    }

    /// The texels a face's bounds touch (one more around them, for the conservative margin),
    /// or None if it lies wholly before the map.
    fn span(&self, face: &LocalFace) -> Option<TexelSpan> {
        let (lo, hi) = (face.lo, face.hi);
        let i0 = (lo.x - 1.5).floor().max(0.0) as usize;
        let j0 = (lo.y - 1.5).floor().max(0.0) as usize;
        let i1 = (hi.x.ceil()).min(self.w as f64 - 1.0);
        let j1 = (hi.y.ceil()).min(self.h as f64 - 1.0);
        if i1 < 0.0 || j1 < 0.0 {
            return None;
        }
        Some(TexelSpan {
            i0,
            j0,
            i1: i1 as usize,
            j1: j1 as usize,
        })
    }

    /// The face in texel units, and the texels its bounds touch; None for a face seen edge-on
    /// or wholly before the map.
    fn place(&self, mesh: &Mesh, f: u32) -> Option<(LocalFace, TexelSpan)> {
        let corners = mesh.faces[f as usize].map(|v| self.to_local(mesh.positions[v as usize]));
        let face = LocalFace::new(corners)?;
        let span = self.span(&face)?;
        Some((face, span))
    }

    /// The first pass over the faces: the texel centres and texel corners each face covers.
    /// Only the texels within its own bounds are tested (one or none when faces are smaller
    /// than texels, as at the coarse levels the resolution search draws), not the margin
    /// around them that lips and corner distances need: those only matter where no face
    /// covers the centre or the corner, which the second pass finds.
    fn draw_centres(
        &mut self,
        mesh: &Mesh,
        corner_normals: Option<&CornerNormals>,
        f: u32,
        face: &LocalFace,
    ) {
        // Centres a hair outside the bounds still pass `coverage`'s tolerance (1e-9 of the
        // area): test them too.
        const HAIR: f64 = 1e-3;
        let (lo, hi) = (face.lo, face.hi);
        let first = |v: f64| (v - 0.5 - HAIR).ceil().max(0.0) as usize;
        let last = |v: f64, n: usize| (v - 0.5 + HAIR).floor().min(n as f64 - 1.0);
        let (i1, j1) = (last(hi.x, self.w), last(hi.y, self.h));
        let mut shading = None;
        if i1 >= 0.0 && j1 >= 0.0 {
            for j in first(lo.y)..=j1 as usize {
                let py = j as f64 + 0.5;
                for i in first(lo.x)..=i1 as usize {
                    let px = i as f64 + 0.5;
                    if let Some((here, l)) = face.coverage(px, py, false) {
                        if shading.is_none() {
                            shading = corner_normals.map(|n| FaceShading::new(mesh, n, f, face));
                        }
                        self.cover(j * self.w + i, (px, py), face, here, l, shading.as_ref());
                    }
                }
            }
        }
        // Corners inside the face are at distance zero from it.
        let (ci1, cj1) = (
            hi.x.floor().min(self.w as f64),
            hi.y.floor().min(self.h as f64),
        );
        if ci1 < 0.0 || cj1 < 0.0 {
            return;
        }
        for cj in lo.y.ceil().max(0.0) as usize..=cj1 as usize {
            for ci in lo.x.ceil().max(0.0) as usize..=ci1 as usize {
                if face.contains(DVec2::new(ci as f64, cj as f64)) {
                    self.corner_distance[cj * (self.w + 1) + ci] = 0.0;
                }
            }
        }
    }

    /// The second pass: a chart face's lips on the texels no face covers the centre of, done
    /// only when its margin holds such a texel (`open`). A covered centre is final after the
    /// first pass (it beats any lip), so the maps are the same as drawing each face's margin
    /// in one pass.
    fn draw_lips(
        &mut self,
        (mesh, corner_normals): (&Mesh, Option<&CornerNormals>),
        f: u32,
        (face, span): (&LocalFace, TexelSpan),
        open: &Counts,
    ) {
        if !open.any((span.i0, span.j0, span.i1, span.j1)) {
            return;
        }
        let (lo, hi, texel) = (face.lo, face.hi, self.texel);
        let mut shading = None;
        for j in span.j0..=span.j1 {
            let py = j as f64 + 0.5;
            for i in span.i0..=span.i1 {
                let t = j * self.w + i;
                let px = i as f64 + 0.5;
                // Skipped where a centre is covered or the face cannot come nearer than the
                // lip already there (its bounds are farther; a margin over rounding): the
                // nearest lip wins, so the maps are the same at a fraction of the cost.
                let known = self.lip_distance[t];
                let (dx, dy) = (
                    outside(px, lo.x, hi.x) * texel.x,
                    outside(py, lo.y, hi.y) * texel.y,
                );
                if self.coverage[t] == Coverage::Centre
                    || dx * dx + dy * dy > known * known * (1.0 + 1e-9)
                {
                    continue;
                }
                if let Some((here, l)) = face.coverage(px, py, true) {
                    if shading.is_none() {
                        shading = corner_normals.map(|n| FaceShading::new(mesh, n, f, face));
                    }
                    self.cover(t, (px, py), face, here, l, shading.as_ref());
                }
            }
        }
    }

    /// Texel `t` (centred at `centre`) takes the face's values at barycentric `l` if the face
    /// covers it better than what is there, or as well and higher (a ray coming down the box's
    /// z sees the highest) or, for a lip, nearer.
    fn cover(
        &mut self,
        t: usize,
        (px, py): (f64, f64),
        face: &LocalFace,
        here: Coverage,
        l: [f64; 3],
        shading: Option<&FaceShading<'_>>,
    ) {
        let [a, b, c] = face.corners;
        let [la, lb, lc] = l;
        let near = a * la + b * lb + c * lc;
        let lip_distance =
            DVec2::new((px - near.x) * self.texel.x, (py - near.y) * self.texel.y).length();
        let z = match here {
            Coverage::Lip => face.plane_z(px, py),
            _ => near.z,
        };
        // Between lips the nearest face wins (the cells around continue it), else the highest.
        let worse = match here {
            Coverage::Lip => lip_distance >= self.lip_distance[t],
            _ => z <= self.depth[t],
        };
        if here < self.coverage[t] || (here == self.coverage[t] && worse) {
            return;
        }
        self.coverage[t] = here;
        self.depth[t] = z;
        if here == Coverage::Lip {
            self.lip_distance[t] = lip_distance;
        }
        if let Some(shading) = shading {
            self.normals[t] = shading.normal(l);
            if let Some(c) = self.colors.get_mut(t) {
                *c = shading.color(l);
            }
        }
    }

    /// Lowers the distance of the `wanted` corners within two texels of the face to the face's.
    fn measure_corners(&mut self, face: &LocalFace, span: TexelSpan, wanted: &[bool]) {
        let tri = face.flat();
        let (lo, hi, texel) = (face.lo, face.hi, self.texel);
        let (ci0, cj0, ci1, cj1) = corner_range(span, self.w, self.h);
        for cj in cj0..=cj1 {
            let dy = outside(cj as f64, lo.y, hi.y) * texel.y;
            for ci in ci0..=ci1 {
                let q = DVec2::new(ci as f64, cj as f64);
                let k = cj * (self.w + 1) + ci;
                if !wanted[k] {
                    continue;
                }
                let known = self.corner_distance[k];
                let dx = outside(ci as f64, lo.x, hi.x) * texel.x;
                // Skipped where the face cannot come nearer (a margin over rounding): the
                // minimum is the same, at a fraction of the cost.
                if known == 0.0 || dx * dx + dy * dy > known * known * (1.0 + 1e-9) {
                    continue;
                }
                let d = if face.contains(q) {
                    0.0
                } else {
                    let (la, lb, lc) = nearest_on_triangle(q, tri);
                    let near = tri[0] * la + tri[1] * lb + tri[2] * lc;
                    DVec2::new((q.x - near.x) * self.texel.x, (q.y - near.y) * self.texel.y)
                        .length()
                };
                self.corner_distance[k] = self.corner_distance[k].min(d);
            }
        }
    }

    /// Corners where the surface may reach past every face: those whose four neighbouring
    /// texels (the bilinear rule's blend around them, clamped at the map's border) are all
    /// filled, whose blend of outline codes is not negative, and that no face covers. Only
    /// their distances to the faces are measured: no other corner's is ever read.
    fn overhang_corners(&self, outline: &[i8]) -> Vec<bool> {
        let (w, h) = (self.w, self.h);
        let texel = |i: usize, j: usize| j.min(h - 1) * w + i.min(w - 1);
        let filled = |i: usize, j: usize| self.depth[texel(i, j)] > f64::NEG_INFINITY;
        let mut wanted = vec![false; (w + 1) * (h + 1)];
        for cj in 0..=h {
            for ci in 0..=w {
                let k = cj * (w + 1) + ci;
                if self.corner_distance[k] == 0.0 {
                    continue;
                }
                let (i0, j0) = (ci.saturating_sub(1), cj.saturating_sub(1));
                let around = [(i0, j0), (ci, j0), (i0, cj), (ci, cj)];
                let inside = around
                    .iter()
                    .map(|&(i, j)| outline[texel(i, j)] as i32)
                    .sum::<i32>()
                    >= 0;
                wanted[k] = inside && around.iter().all(|&(i, j)| filled(i, j));
            }
        }
        wanted
    }

    /// How far the surface reaches past every face at the `wanted` corners it does (at most two
    /// texels: larger gaps are not searched).
    fn overhangs(&self, wanted: &[bool]) -> Vec<f64> {
        let far = 2.0 * self.texel.x.max(self.texel.y);
        wanted
            .iter()
            .zip(&self.corner_distance)
            .filter(|&(&want, &d)| want && d > 0.0)
            .map(|(_, &d)| d.min(far))
            .collect()
    }

    /// Outline codes from the in-plane distance of each texel centre to the drawn faces'
    /// outline (texel units, at most OUTLINE_REACH): positive where a face covers the centre.
    fn outline_codes(&self, distance: &[f64]) -> Vec<i8> {
        (0..self.w * self.h)
            .map(|t| {
                let d = distance[t].min(OUTLINE_REACH);
                encode_outline(if self.coverage[t] == Coverage::Centre {
                    d
                } else {
                    -d
                })
            })
            .collect()
    }

    fn into_maps(self, outline: Vec<i8>, wanted: &[bool]) -> Maps {
        let heights = self
            .depth
            .iter()
            .map(|&z| {
                if z == f64::NEG_INFINITY {
                    0
                } else {
                    encode_height(z / self.bx.extent.z, self.bx.height_bits)
                }
            })
            .collect();
        let overhangs = self.overhangs(wanted);
        let lips = (0..self.w * self.h)
            .filter(|&t| self.coverage[t] == Coverage::Lip && outline[t] >= 0)
            .map(|t| Lip {
                texel: t,
                distance: self.lip_distance[t],
            })
            .collect();
        let normals = (0..self.normals.len())
            .map(|t| match self.coverage[t] {
                Coverage::Empty => NO_NORMAL,
                _ => encode_normal(self.to_patch_dir(self.normals[t]).normalize_or(DVec3::Z)),
            })
            .collect();
        Maps {
            heights,
            normals,
            colors: self.colors,
            outline,
            lips,
            overhangs,
        }
    }
}

/// Draws `faces` into the box's maps; where faces overlap in projection the highest wins, as a
/// ray coming down the box's z would see it.
///
/// Coverage is conservative for the first `chart_faces` faces (the chart's own): a texel within
/// a texel's width (along x and y) of one but whose centre lies outside every face takes the
/// height of the face's plane there, clamped to the face's own height range (so a steep face
/// cannot send it far off), and the normal and color of the face's nearest point: a lip at most
/// a texel diagonal wide, so every point of the face lies in a cell whose four texels are
/// filled, and that cell continues the face's plane. Texels whose centre is covered always win over lips.
/// The overlap-ring faces that follow get no lips: the neighbouring chart covers past them, and
/// a lip on a ring face that is steep in this frame would bend the cells it is a corner of.
/// Without lips, patches meeting at a sharp crease (where the overlap ring cannot reach, its
/// faces pointing down) would leave a crack of up to a texel that rays fall through. Normals are
/// interpolated from each face's `corner_normals` (`MeshGeometry::corner_normals`, indexed by
/// face); without them only heights and outline are drawn (the normal and color maps are
/// empty), which is all the resolution search measures.
///
/// The outline map then cuts the surface back to the faces: the signed distance from each
/// texel centre to the outline of all drawn faces (their edges used by one drawn face only).
/// `outline` is `boundary_edges(mesh, faces)`, found once for every texel size a chart is drawn at.
pub fn rasterize(
    mesh: &Mesh,
    corner_normals: Option<&CornerNormals>,
    (faces, chart_faces): (&[u32], usize),
    outline: &[[u32; 2]],
    bx: &PatchBox,
) -> Maps {
    use crate::profile::{timed, Phase};
    let mut canvas = Canvas::new(bx, corner_normals.is_some(), mesh.has_colors());
    let placed: Vec<_> = faces.iter().map(|&f| canvas.place(mesh, f)).collect();
    timed(Phase::Centres, || {
        for (&f, p) in faces.iter().zip(&placed) {
            if let Some((face, _)) = p {
                canvas.draw_centres(mesh, corner_normals, f, face);
            }
        }
    });
    // Then the margins: lips where no centre is covered, and the distances to the faces of
    // the corners the overhang figures read.
    timed(Phase::Margins, || {
        let open = Counts::new(canvas.w, canvas.h, |t| {
            canvas.coverage[t] != Coverage::Centre
        });
        for (&f, p) in faces[..chart_faces].iter().zip(&placed) {
            if let Some((face, span)) = p {
                canvas.draw_lips((mesh, corner_normals), f, (face, *span), &open);
            }
        }
    });
    let distance = timed(Phase::OutlineDistance, || {
        canvas.outline_distance(mesh, outline)
    });
    let outline = canvas.outline_codes(&distance);
    let wanted = timed(Phase::Corners, || {
        let wanted = canvas.overhang_corners(&outline);
        let open = Counts::new(canvas.w + 1, canvas.h + 1, |k| wanted[k]);
        for (face, span) in placed.iter().flatten() {
            if open.any(corner_range(*span, canvas.w, canvas.h)) {
                canvas.measure_corners(face, *span, &wanted);
            }
        }
        wanted
    });
    timed(Phase::IntoMaps, || canvas.into_maps(outline, &wanted))
}

/// The edges of `faces` that only one of them uses (as vertex pairs): their outline.
pub fn boundary_edges(mesh: &Mesh, faces: &[u32]) -> Vec<[u32; 2]> {
    let mut edges: Vec<[u32; 2]> = faces
        .iter()
        .flat_map(|&f| {
            let [a, b, c] = mesh.faces[f as usize];
            [[a, b], [b, c], [c, a]].map(|[p, q]| [p.min(q), p.max(q)])
        })
        .collect();
    edges.sort_unstable();
    let mut once = Vec::new();
    let mut k = 0;
    while k < edges.len() {
        let run = edges[k..].iter().take_while(|&&e| e == edges[k]).count();
        if run == 1 {
            once.push(edges[k]);
        }
        k += run;
    }
    once
}

impl Canvas<'_> {
    /// In-plane distance (texel units) from each texel centre to the nearest edge of
    /// `outline`, measured out to OUTLINE_REACH (farther texels get that).
    fn outline_distance(&self, mesh: &Mesh, outline: &[[u32; 2]]) -> Vec<f64> {
        let (w, h) = (self.w as i64, self.h as i64);
        let mut distance = vec![OUTLINE_REACH; self.w * self.h];
        for &[a, b] in outline {
            let [a, b] = [a, b].map(|v| self.to_local(mesh.positions[v as usize]).truncate());
            let (lo, hi) = (a.min(b), a.max(b));
            // Texel centres (i + 1/2, j + 1/2) within reach of the edge's bounds.
            let first = |v: f64| ((v - OUTLINE_REACH - 0.5).floor() as i64).max(0);
            let last = |v: f64, n: i64| ((v + OUTLINE_REACH - 0.5).ceil() as i64).min(n - 1);
            for j in first(lo.y)..=last(hi.y, h) {
                for i in first(lo.x)..=last(hi.x, w) {
                    let c = DVec2::new(i as f64 + 0.5, j as f64 + 0.5);
                    let ab = b - a;
                    let s = ((c - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE))
                        .clamp(0.0, 1.0);
                    let t = (j * w + i) as usize;
                    distance[t] = distance[t].min((a + ab * s - c).length());
                }
            }
        }
        distance
    }
}

/// Barycentric coordinates of the point of triangle `t` nearest to `p` (p outside it): the
/// nearest point on one of its edges.
fn nearest_on_triangle(p: DVec2, t: [DVec2; 3]) -> (f64, f64, f64) {
    let mut best = (f64::INFINITY, (1.0, 0.0, 0.0));
    for k in 0..3 {
        let (a, b) = (t[k], t[(k + 1) % 3]);
        let ab = b - a;
        let s = ((p - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
        let d = (a + ab * s - p).length_squared();
        if d < best.0 {
            let mut l = [0.0; 3];
            l[k] = 1.0 - s;
            l[(k + 1) % 3] = s;
            best = (d, (l[0], l[1], l[2]));
        }
    }
    best.1
}

/// Fills normal and color of empty texels from their filled 8-neighbours, `iterations` texels
/// deep, so filtering at the surface's edge does not blend in garbage. Heights stay empty.
pub fn dilate(maps: &mut Maps, width: u32, height: u32, iterations: usize) {
    let (w, h) = (width as usize, height as usize);
    let mut filled: Vec<bool> = maps.heights.iter().map(|&q| q != 0).collect();
    for _ in 0..iterations {
        let mut updates = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let t = j * w + i;
                if filled[t] {
                    continue;
                }
                let (mut n, mut c, mut k) = (DVec3::ZERO, [0u32; 4], 0u32);
                for dj in -1i64..=1 {
                    for di in -1i64..=1 {
                        let (x, y) = (i as i64 + di, j as i64 + dj);
                        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                            continue;
                        }
                        let s = y as usize * w + x as usize;
                        if filled[s] {
                            n += decode_normal(maps.normals[s]);
                            if let Some(&color) = maps.colors.get(s) {
                                for (acc, v) in c.iter_mut().zip(color) {
                                    *acc += v as u32;
                                }
                            }
                            k += 1;
                        }
                    }
                }
                if k > 0 {
                    let color = c.map(|v| ((v + k / 2) / k) as u8);
                    updates.push((t, encode_normal(n.normalize_or(DVec3::Z)), color));
                }
            }
        }
        if updates.is_empty() {
            break;
        }
        for (t, n, c) in updates {
            maps.normals[t] = n;
            if let Some(stored) = maps.colors.get_mut(t) {
                *stored = c;
            }
            filled[t] = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{MeshGeometry, NormalRule, NormalSource};

    fn flat_corners(m: &Mesh) -> CornerNormals {
        let rule = NormalRule::from_keywords(Some(NormalSource::Flat), None).unwrap();
        MeshGeometry::new(m).corner_normals(m, rule)
    }

    /// `faces` of `m` (flat corner normals `flat`) rasterized into `bx`, with their outline.
    fn draw_flat(m: &Mesh, flat: &CornerNormals, faces: &[u32], bx: &PatchBox) -> Maps {
        rasterize(
            m,
            Some(flat),
            (faces, faces.len()),
            &boundary_edges(m, faces),
            bx,
        )
    }

    /// A 40 x 40 grid of triangles over [0, 4]² on the bump z = 0.3 sin x cos y: 3,200 faces.
    fn bumpy_grid() -> Mesh {
        let n = 40;
        let mut pos = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (4.0 * i as f64 / n as f64, 4.0 * j as f64 / n as f64);
                pos.extend_from_slice(&[x, y, 0.3 * x.sin() * y.cos()]);
            }
        }
        let v = |i: usize, j: usize| (j * (n + 1) + i) as i64;
        let mut faces = Vec::new();
        for j in 0..n {
            for i in 0..n {
                faces.extend_from_slice(&[v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
                faces.extend_from_slice(&[v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
            }
        }
        Mesh::from_flat(&pos, &faces, None).unwrap()
    }

    #[test]
    fn heights_and_outline_alone_are_those_of_the_shaded_maps() {
        // The resolution search draws without normals (`corner_normals` None): its heights,
        // outline, lips and overhangs must be the maps the final raster keeps, at levels from
        // many faces a texel to many texels a face. The box is offset so the grid's rim falls
        // inside texels (lips and overhangs, the second pass).
        let m = bumpy_grid();
        let flat = flat_corners(&m);
        // The lower-left 3,000 faces (a ragged rim), the rest as their ring.
        let faces: Vec<u32> = (0..m.faces.len() as u32).collect();
        let mut margins = (0, 0);
        // The last box puts its first row and column of centres 0.005 texel outside the rim,
        // which the outline codes still count as inside: lips there.
        let t = 4.04 / 50.0;
        let boxes = [(2, 2, -0.13, 4.3), (3, 5, -0.13, 4.3), (16, 16, -0.07, 4.2)];
        for (w, h, o, e) in boxes.into_iter().chain([(50, 50, -0.505 * t, 4.04)]) {
            let bx = PatchBox {
                origin: DVec3::new(o, o, -0.5),
                axes: [DVec3::X, DVec3::Y, DVec3::Z],
                extent: DVec3::new(e, e, 1.0),
                width: w,
                height: h,
                height_bits: 16,
            };
            let outline = boundary_edges(&m, &faces);
            let shaded = rasterize(&m, Some(&flat), (&faces, 3000), &outline, &bx);
            let bare = rasterize(&m, None, (&faces, 3000), &outline, &bx);
            assert_eq!(shaded.heights, bare.heights, "{w} x {h}");
            assert_eq!(shaded.outline, bare.outline, "{w} x {h}");
            assert_eq!(shaded.lips, bare.lips, "{w} x {h}");
            assert_eq!(shaded.overhangs, bare.overhangs, "{w} x {h}");
            assert!(bare.normals.is_empty() && bare.colors.is_empty());
            assert_eq!(shaded.normals.len(), (w * h) as usize);
            margins.0 += shaded.lips.len();
            margins.1 += shaded.overhangs.len();
        }
        // The second pass had work: the rim passes between texel centres.
        assert!(
            margins.0 > 0 && margins.1 > 0,
            "lips and overhangs {margins:?}"
        );
    }

    #[test]
    fn counts_find_a_passing_cell_in_any_rectangle() {
        // Against a scan of the rectangle, on a sparse pseudo-random pattern.
        let (w, h) = (13, 9);
        let pass = |t: usize| (t * 7919 + 13).is_multiple_of(17);
        let counts = Counts::new(w, h, pass);
        for j0 in 0..h + 2 {
            for j1 in j0.saturating_sub(1)..h + 2 {
                for i0 in 0..w + 2 {
                    for i1 in i0.saturating_sub(1)..w + 2 {
                        let scan = (j0..=j1.min(h - 1))
                            .any(|j| (i0..=i1.min(w - 1)).any(|i| pass(j * w + i)));
                        assert_eq!(
                            counts.any((i0, j0, i1, j1)),
                            scan,
                            "{i0}..{i1} x {j0}..{j1}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn a_tilted_plane_is_sampled_exactly_and_dilated() {
        // Plane z = 0.25 x over [0, 4] x [0, 2], two triangles, drawn into a 8 x 4 texel box.
        let m = Mesh::from_flat(
            &[0., 0., 0., 4., 0., 1., 4., 2., 1., 0., 2., 0.],
            &[0, 1, 2, 0, 2, 3],
            None,
        )
        .unwrap();
        let flat = flat_corners(&m);
        let bx = PatchBox {
            origin: DVec3::ZERO,
            axes: [DVec3::X, DVec3::Y, DVec3::Z],
            extent: DVec3::new(4.0, 2.0, 1.0),
            width: 8,
            height: 4,
            height_bits: 16,
        };
        let draw = |faces: &[u32], bx: &PatchBox| draw_flat(&m, &flat, faces, bx);
        let mut maps = draw(&[0, 1], &bx);
        for j in 0..4 {
            for i in 0..8 {
                let q = maps.heights[j * 8 + i];
                let x = (i as f64 + 0.5) * 0.5;
                let want = 0.25 * x;
                assert!(
                    ((q - 1) as f64 / 65534.0 - want).abs() < 1e-4,
                    "texel {i},{j}"
                );
            }
        }
        // Only one face: the other half stays empty, then dilation fills its normals.
        let mut half = draw(&[0], &bx);
        let empty = half.heights.iter().filter(|&&q| q == 0).count();
        assert!(empty > 0 && empty < 32);
        dilate(&mut half, 8, 4, 8);
        assert!(half.normals.iter().all(|&n| decode_normal(n).z > 0.78));
        assert!(half.heights.iter().filter(|&&q| q == 0).count() == empty);
        maps.heights.clear();
    }

    #[test]
    fn the_outline_cuts_a_coarse_map_back_to_its_triangle() {
        // The triangle (0,0), (4,0), (0,4) at z = 0 in a 2 x 2 map of 2-unit texels: all four
        // texels fill (the far one as a lip), so without the outline map the field would cover
        // the whole 4 x 4 square, its corner (4, 4) 2√2 past the hypotenuse.
        let m = Mesh::from_flat(
            &[0., 0., 0., 4., 0., 0., 0., 4., 0., 4., 4., 0.],
            &[0, 1, 2, 1, 3, 2],
            None,
        )
        .unwrap();
        let flat = flat_corners(&m);
        let bx = PatchBox {
            origin: DVec3::new(0.0, 0.0, -0.5),
            axes: [DVec3::X, DVec3::Y, DVec3::Z],
            extent: DVec3::new(4.0, 4.0, 1.0),
            width: 2,
            height: 2,
            height_bits: 16,
        };
        let draw = |faces: &[u32], bx: &PatchBox| draw_flat(&m, &flat, faces, bx);
        let one = draw(&[0], &bx);
        assert!(one.heights.iter().all(|&q| q != 0));
        // Signed distances (texels) of the centres to the outline: 1/2 from the two legs, on
        // the hypotenuse, and the lip's 1/√2 outside it (codes round up, by < 1/63 texel).
        let want = [0.5, 0.0, 0.0, -0.5f64.sqrt()];
        for (t, w) in want.into_iter().enumerate() {
            let d = crate::gtex::decode_outline(one.outline[t] as f64);
            assert!(d >= w && d - w < 1.0 / 63.0, "texel {t}: {d} for {w}");
        }
        // The lip's centre is outside, so no lip and no corner reaches past the triangle.
        assert!(
            one.lips.is_empty() && one.overhangs.is_empty(),
            "{:?}",
            one.overhangs
        );
        // Both triangles: the square is all mesh, every centre 1/2 texel or more inside.
        let both = draw(&[0, 1], &bx);
        assert!(both.overhangs.is_empty() && both.lips.is_empty());
        assert!(both
            .outline
            .iter()
            .all(|&c| c == crate::gtex::encode_outline(0.5)));
    }
}
