//! Caps where a shell's texture seams cut the mesostructure. Across a seam fin (a base edge
//! whose two faces disagree on its texture coordinates by more than whole tiles, or an open
//! edge) the tile does not continue, so the solid is cut there. The renderer's march sees the
//! cut as solid (a ray entering a prism through such a fin inside the solid stops at the fin);
//! the explicit mesh, the tile's surface clipped to each prism, would leave the cut open and let
//! reference rays into the hollow links. These caps close it: the part of the fin where the
//! occupancy's trilinear field (the level the march and marching cubes follow) is >= 0.5,
//! found by marching squares on a grid over the fin and mapped through the prism's map.
//!
//! Spaces: as gdm_data/shell.rs; a fin is the vertical rectangle over a texture edge, (s, z) with s the
//! fraction along the edge and z in voxels.

use glam::{DVec2, DVec3};

use crate::gdm_data::shell::{Corner, Shell};
use crate::gdm_data::Volume;

/// Grid step over a fin, in voxels: the cap's outline follows the field's 0.5 level to well
/// under a voxel (the level is piecewise trilinear between voxel centres).
const STEP: f64 = 0.5;

/// Which fins of each face are seams: bit e for the fin from corner e to corner e + 1.
pub struct Seams<'a> {
    pub volume: &'a Volume,
    pub fins: &'a [u8],
}

/// The occupancy sampled at voxel centres, interpolated trilinearly at texture point `p` (the
/// tile repeated in x and y, empty outside z), as the shader's gdm_field.
pub fn field(volume: &Volume, p: DVec3) -> f64 {
    let s = p - DVec3::splat(0.5);
    let b = s.floor();
    let f = s - b;
    let mut acc = 0.0;
    for k in 0..8 {
        let o = [k & 1, (k >> 1) & 1, (k >> 2) & 1];
        if volume.solid_at(
            b.x as i64 + o[0] as i64,
            b.y as i64 + o[1] as i64,
            b.z as i64 + o[2] as i64,
        ) {
            let w = |axis: usize| if o[axis] == 1 { f[axis] } else { 1.0 - f[axis] };
            acc += w(0) * w(1) * w(2);
        }
    }
    acc
}

/// The part of one grid cell where the bilinear interpolant of its corner values is >= 0.5, cut
/// along the cell's edges (as marching squares): corners in order around the cell, the polygon
/// a convex one (a square with corners cut off), or empty.
fn cell_polygon(corners: [DVec2; 4], values: [f64; 4]) -> Vec<DVec2> {
    let mut out = Vec::with_capacity(8);
    for k in 0..4 {
        let (a, b) = (k, (k + 1) % 4);
        let inside = values[a] >= 0.5;
        if inside {
            out.push(corners[a]);
        }
        if inside != (values[b] >= 0.5) {
            let t = (0.5 - values[a]) / (values[b] - values[a]);
            out.push(corners[a].lerp(corners[b], t));
        }
    }
    out
}

impl Shell {
    /// The cap of face `f`'s fin `e` (corner e to e + 1), as object-space triangles wound to
    /// face out of the prism.
    pub fn fin_cap(&self, f: usize, e: usize, volume: &Volume) -> Vec<[DVec3; 3]> {
        let ids = self.faces[f];
        let uv = self.uv_voxels(f);
        let (a, b, c) = (e, (e + 1) % 3, (e + 2) % 3);
        let edge = [ids[a].min(ids[b]), ids[a].max(ids[b])];
        let nz = self.size[2] as f64;
        let (ns, nh) = (
            ((uv[b] - uv[a]).length() / STEP).ceil().max(1.0) as usize,
            (nz / STEP).ceil() as usize,
        );
        let texture = |q: DVec2| (uv[a] + (uv[b] - uv[a]) * q.x).extend(q.y);
        let grid: Vec<f64> = (0..=ns)
            .flat_map(|i| (0..=nh).map(move |j| (i, j)))
            .map(|(i, j)| {
                let q = DVec2::new(i as f64 / ns as f64, j as f64 * nz / nh as f64);
                field(volume, texture(q))
            })
            .collect();
        let at = |i: usize, j: usize| grid[i * (nh + 1) + j];
        // Out of the prism: away from the opposite corner's edge at the same height.
        let opposite = |h: f64| {
            self.positions[ids[c] as usize] + self.normals[ids[c] as usize] * (h * self.thickness)
        };
        let mut out = Vec::new();
        for i in 0..ns {
            for j in 0..nh {
                let values = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                if values.iter().all(|&v| v < 0.5) {
                    continue;
                }
                let q = |di: usize, dj: usize| {
                    DVec2::new(
                        (i + di) as f64 / ns as f64,
                        (j + dj) as f64 * nz / nh as f64,
                    )
                };
                let poly = cell_polygon([q(0, 0), q(1, 0), q(1, 1), q(0, 1)], values);
                let placed: Vec<DVec3> = poly
                    .iter()
                    .map(|&p| {
                        let corner = Corner {
                            p: texture(p),
                            edge: Some(edge),
                        };
                        self.place(f, corner)
                    })
                    .collect();
                for k in 1..placed.len().saturating_sub(1) {
                    let tri = [placed[0], placed[k], placed[k + 1]];
                    let normal = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
                    let centre = (tri[0] + tri[1] + tri[2]) / 3.0;
                    let h = (poly[0].y + poly[k].y + poly[k + 1].y) / (3.0 * nz);
                    let outward = normal.dot(centre - opposite(h)) >= 0.0;
                    out.push(if outward {
                        tri
                    } else {
                        [tri[0], tri[2], tri[1]]
                    });
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_polygons_cover_the_inside_corners() {
        let sq = [DVec2::ZERO, DVec2::X, DVec2::ONE, DVec2::Y];
        assert!(cell_polygon(sq, [0.0; 4]).is_empty());
        assert_eq!(cell_polygon(sq, [1.0; 4]), sq.to_vec());
        // One corner in: a triangle cut at the edges' midpoints when the values are 1 and 0.
        let one = cell_polygon(sq, [1.0, 0.0, 0.0, 0.0]);
        assert_eq!(
            one,
            vec![DVec2::ZERO, DVec2::new(0.5, 0.0), DVec2::new(0.0, 0.5)]
        );
        // Opposite corners in (a saddle): one hexagon joining them.
        assert_eq!(cell_polygon(sq, [1.0, 0.0, 1.0, 0.0]).len(), 6);
    }

    #[test]
    fn the_field_is_one_at_a_solid_voxel_centre_and_half_on_its_bottom_face() {
        let mut solid = vec![false; 4 * 4 * 4];
        solid[(4 + 1) * 4] = true; // voxel (1, 1, 0)
        let v = Volume {
            size: [4, 4, 4],
            solid,
            colors: None,
        };
        assert!((field(&v, DVec3::new(1.5, 1.5, 0.5)) - 1.0).abs() < 1e-12);
        assert!((field(&v, DVec3::new(1.5, 1.5, 0.0)) - 0.5).abs() < 1e-12);
        // Wrapped in x: voxel (1, 1, 0) seen again one tile over.
        assert!((field(&v, DVec3::new(5.5, 1.5, 0.5)) - 1.0).abs() < 1e-12);
    }
}
