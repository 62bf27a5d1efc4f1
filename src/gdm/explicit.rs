//! The explicit reference geometry of a shell (gdm_data/shell.rs): the tile's own surface
//! (marching cubes, made by the caller) repeated over texture space, clipped to each prism's
//! texture triangle and mapped through the prism's map.
//!
//! Spaces: the base mesh's object space (positions, normals, output); texture space in voxel
//! units (gdm_data/volume.rs): u, v in tiles times (nx, ny), z in voxels.

use std::collections::HashMap;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::caps::Seams;
use crate::error::{GeomtexError, Result};
use crate::gdm_data::shell::{cross2, Corner, Shell};

/// The tile's surface, its triangles binned over the tile's footprint for lookup.
pub struct TileSurface {
    pub vertices: Vec<DVec3>,
    pub faces: Vec<[u32; 3]>,
    bins: Vec<Vec<u32>>,
    side: usize,
    /// Footprint of one tile copy: [lo, lo + extent) in x and y.
    lo: DVec2,
    extent: DVec2,
}

const BINS: usize = 16;

impl TileSurface {
    /// The tile's surface over one period, x and y in [0.5, n + 0.5] (voxel centres to the next
    /// tile's first centre), z in [0, nz].
    pub fn new(vertices: Vec<DVec3>, faces: Vec<[u32; 3]>, size: [usize; 3]) -> Result<Self> {
        if let Some(bad) = faces
            .iter()
            .flatten()
            .find(|&&k| k as usize >= vertices.len())
        {
            return Err(GeomtexError::Parameter(format!(
                "tile surface face references vertex {bad} but there are {}",
                vertices.len()
            )));
        }
        let lo = DVec2::splat(0.5);
        let extent = DVec2::new(size[0] as f64, size[1] as f64);
        let mut bins = vec![Vec::new(); BINS * BINS];
        let cell = |x: f64, axis: usize| {
            let t = (x - lo[axis]) / extent[axis] * BINS as f64;
            (t.floor().max(0.0) as usize).min(BINS - 1)
        };
        for (f, tri) in faces.iter().enumerate() {
            let pts = tri.map(|k| vertices[k as usize]);
            let (x0, x1) = span(pts.map(|p| p.x));
            let (y0, y1) = span(pts.map(|p| p.y));
            for bx in cell(x0, 0)..=cell(x1, 0) {
                for by in cell(y0, 1)..=cell(y1, 1) {
                    bins[bx * BINS + by].push(f as u32);
                }
            }
        }
        Ok(TileSurface {
            vertices,
            faces,
            bins,
            side: BINS,
            lo,
            extent,
        })
    }

    /// Faces of the copy at `offset` (x, y shift) whose bins meet the rectangle [a, b].
    fn candidates(&self, offset: DVec2, a: DVec2, b: DVec2) -> Vec<u32> {
        let n = self.side as f64;
        let range = |axis: usize| {
            let t0 = ((a[axis] - offset[axis] - self.lo[axis]) / self.extent[axis] * n).floor();
            let t1 = ((b[axis] - offset[axis] - self.lo[axis]) / self.extent[axis] * n).floor();
            (t0.max(0.0) as usize, t1.min(n - 1.0))
        };
        let ((x0, x1), (y0, y1)) = (range(0), range(1));
        if x1 < 0.0 || y1 < 0.0 {
            return Vec::new();
        }
        let mut out = Vec::new();
        for bx in x0..=x1 as usize {
            for by in y0..=y1 as usize {
                out.extend_from_slice(&self.bins[bx * self.side + by]);
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }
}

fn span<const N: usize>(v: [f64; N]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        })
}

impl Shell {
    /// The pieces of `tile` inside face `f`'s prism, as object-space triangles.
    fn prism_pieces(&self, f: usize, tile: &TileSurface) -> Vec<[DVec3; 3]> {
        let uv = self.uv_voxels(f);
        let ids = self.faces[f];
        let area = cross2(uv[1] - uv[0], uv[2] - uv[0]);
        if area.abs() < 1e-12 {
            return Vec::new();
        }
        let (u0, u1) = span(uv.map(|t| t.x));
        let (v0, v1) = span(uv.map(|t| t.y));
        let (lo, hi) = (DVec2::new(u0, v0), DVec2::new(u1, v1));
        let ext = tile.extent;
        let mut out = Vec::new();
        let copies = |a: f64, b: f64, e: f64| (a / e).floor() as i64 - 1..=(b / e).floor() as i64;
        for ci in copies(u0, u1, ext.x) {
            for cj in copies(v0, v1, ext.y) {
                let offset = DVec2::new(ci as f64 * ext.x, cj as f64 * ext.y);
                for t in tile.candidates(offset, lo, hi) {
                    let tri = tile.faces[t as usize];
                    let mut poly: Vec<Corner> = tri
                        .iter()
                        .map(|&k| Corner {
                            p: tile.vertices[k as usize] + offset.extend(0.0),
                            edge: None,
                        })
                        .collect();
                    for e in 0..3 {
                        let (a, b) = (e, (e + 1) % 3);
                        poly = clip(&poly, [ids[a], ids[b]], [uv[a], uv[b]], area.signum());
                        if poly.len() < 3 {
                            break;
                        }
                    }
                    let placed: Vec<DVec3> = poly.iter().map(|&c| self.place(f, c)).collect();
                    for k in 1..placed.len().saturating_sub(1) {
                        let tri = [placed[0], placed[k], placed[k + 1]];
                        // A mirrored texture triangle mirrors the map: keep the tile's winding.
                        out.push(if area < 0.0 {
                            [tri[0], tri[2], tri[1]]
                        } else {
                            tri
                        });
                    }
                }
            }
        }
        out
    }

    /// The explicit mesh: every prism's pieces, welded where they meet exactly, and with
    /// `seams` the caps closing the solid where a seam fin cuts it (caps.rs).
    pub fn explicit_mesh(
        &self,
        tile: &TileSurface,
        seams: Option<&Seams>,
    ) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let pieces: Vec<Vec<[DVec3; 3]>> = (0..self.faces.len())
            .into_par_iter()
            .map(|f| {
                let mut out = self.prism_pieces(f, tile);
                if let Some(s) = seams {
                    for e in (0..3).filter(|&e| s.fins[f] >> e & 1 == 1) {
                        out.extend(self.fin_cap(f, e, s.volume));
                    }
                }
                out
            })
            .collect();
        let mut index: HashMap<[u64; 3], u32> = HashMap::new();
        let mut vertices = Vec::new();
        let mut faces = Vec::new();
        for tri in pieces.iter().flatten() {
            let ids = tri.map(|p| {
                *index
                    .entry(p.to_array().map(f64::to_bits))
                    .or_insert_with(|| {
                        vertices.push(p);
                        vertices.len() as u32 - 1
                    })
            });
            if ids[0] != ids[1] && ids[1] != ids[2] && ids[0] != ids[2] {
                faces.push(ids);
            }
        }
        (vertices, faces)
    }
}

/// `poly` clipped to the inner side of the texture-space line through base edge `ids` (at
/// `uv`), the inner side being where the triangle's interior lies (`orient`: its area's sign).
/// Cut points are computed from the edge taken in vertex-id order and the polygon edge taken in
/// a fixed order, so the prism on the edge's other side finds bit-identical points.
fn clip(poly: &[Corner], ids: [u32; 2], uv: [DVec2; 2], orient: f64) -> Vec<Corner> {
    let (edge, a, b) = if ids[0] < ids[1] {
        (ids, uv[0], uv[1])
    } else {
        ([ids[1], ids[0]], uv[1], uv[0])
    };
    // Positive inside; the canonical edge's own orientation flips the sign as needed.
    let flip = if ids[0] < ids[1] { orient } else { -orient };
    let side = |p: DVec3| cross2(b - a, p.truncate() - a);
    let inside = |p: DVec3| side(p) * flip >= 0.0;
    let mut out = Vec::with_capacity(poly.len() + 1);
    for k in 0..poly.len() {
        let (c, d) = (poly[k], poly[(k + 1) % poly.len()]);
        if inside(c.p) {
            out.push(c);
        }
        if inside(c.p) != inside(d.p) {
            let (x, y) = if c.p.to_array() < d.p.to_array() {
                (c.p, d.p)
            } else {
                (d.p, c.p)
            };
            let (sx, sy) = (side(x), side(y));
            let t = sx / (sx - sy);
            out.push(Corner {
                p: x + (y - x) * t,
                edge: Some(edge),
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat quad tile: a slab surface z = 2 over the whole footprint, as two triangles.
    fn slab(size: [usize; 3]) -> TileSurface {
        let (x0, x1, y0, y1) = (0.5, size[0] as f64 + 0.5, 0.5, size[1] as f64 + 0.5);
        let v = vec![
            DVec3::new(x0, y0, 2.0),
            DVec3::new(x1, y0, 2.0),
            DVec3::new(x1, y1, 2.0),
            DVec3::new(x0, y1, 2.0),
        ];
        TileSurface::new(v, vec![[0, 1, 2], [0, 2, 3]], size).unwrap()
    }

    #[test]
    fn a_flat_slab_maps_to_the_offset_surface_without_cracks() {
        let size = [8, 8, 4];
        // Two triangles of a unit square in the z = 0 plane, normals +z, uv = 1.5 tiles a side.
        let positions = vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        let uv = |p: DVec3| DVec2::new(p.x, p.y) * 1.5;
        let faces = vec![[0, 1, 2], [0, 2, 3]];
        let shell = Shell {
            uv: faces
                .iter()
                .map(|t: &[u32; 3]| t.map(|k| uv(positions[k as usize])))
                .collect(),
            normals: vec![DVec3::Z; 4],
            positions,
            faces,
            thickness: 0.2,
            size,
        };
        let (v, f) = shell.explicit_mesh(&slab(size), None);
        // The slab at z = 2 of 4 voxels lies at half the thickness.
        assert!(v.iter().all(|p| (p.z - 0.1).abs() < 1e-12));
        let area: f64 = f
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|k| v[k as usize]);
                (b - a).cross(c - a).z * 0.5
            })
            .sum();
        assert!((area - 1.0).abs() < 1e-9, "area {area}");
        // Welded: only the square's outline is open (each edge used once there).
        let mut uses: HashMap<[u32; 2], i32> = HashMap::new();
        for t in &f {
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                *uses.entry([a.min(b), a.max(b)]).or_default() += 1;
            }
        }
        for (e, n) in uses {
            let [a, b] = e.map(|k| v[k as usize]);
            let on_outline = |p: DVec3| {
                p.x.abs() < 1e-9
                    || p.y.abs() < 1e-9
                    || (p.x - 1.0).abs() < 1e-9
                    || (p.y - 1.0).abs() < 1e-9
            };
            let border = on_outline(a) && on_outline(b) && on_outline((a + b) * 0.5);
            assert_eq!(n, if border { 1 } else { 2 }, "edge {a} {b}");
        }
    }
}
