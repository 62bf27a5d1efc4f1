//! Rasterizing a chart's triangles into its height, normal and color maps, and dilating the
//! normal/color maps into empty texels.
//!
//! Space: patch-local with x/y measured in texels (texel (i, j) has its centre at (i+0.5, j+0.5))
//! and z in world units above the box floor; heights are stored as 8- or 16-bit codes of
//! z / extent.z.

use glam::{DVec2, DVec3};

use crate::gtex::{encode_height, encode_snorm8, Patch};
use crate::mesh::{Mesh, MeshGeometry};

/// The box a chart is drawn into.
#[derive(Clone, Copy, Debug)]
pub struct PatchBox {
    pub origin: DVec3,
    pub axes: [DVec3; 3],
    pub extent: DVec3,
    pub width: u32,
    pub height: u32,
    /// Bits per height code (8 or 16).
    pub height_bits: u8,
}

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
        }
    }
}

/// Which normal goes into the normal map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalSource {
    /// Area-weighted vertex normals interpolated across each face.
    Smooth,
    /// The face's own normal (keeps CAD creases sharp).
    Flat,
}

#[derive(Default)]
pub struct Maps {
    pub heights: Vec<u16>,
    pub normals: Vec<[i8; 4]>,
    pub colors: Vec<[u8; 4]>,
    /// Texels filled by conservative coverage alone (index, world distance from the texel's
    /// centre to the point of the triangle it copies): how far the surface reaches past the mesh.
    pub lips: Vec<(usize, f64)>,
    /// Texel corners where the height field has a surface but no drawn triangle lies under
    /// them: the world distance (in the patch plane) to the nearest triangle, at most two texels
    /// (larger gaps are not searched). A coarse map's cells and flat border reach over a chart's
    /// notches and past its outline; this is how far.
    pub overhangs: Vec<f64>,
}

/// Draws `faces` into the box's maps; where faces overlap in projection the highest wins, as a
/// ray coming down the box's z would see it.
///
/// Coverage is conservative for the first `chart_faces` faces (the chart's own): a texel whose
/// square touches one but whose centre lies outside every face takes the values of the face's
/// nearest point (a flat lip at most half a texel diagonal wide, never an extrapolated plane,
/// which a steep face would send far off). Texels whose centre is covered always win over lips.
/// The overlap-ring faces that follow get no lips: the neighbouring chart covers past them, and
/// a lip on a ring face that is steep in this frame would stick out as a shelf. Without this, patches meeting at a sharp crease
/// (where the overlap ring cannot reach, its faces pointing down) leave a crack of up to a texel
/// that rays fall through.
pub fn rasterize(
    mesh: &Mesh,
    geo: &MeshGeometry,
    faces: &[u32],
    chart_faces: usize,
    bx: &PatchBox,
    normals: NormalSource,
) -> Maps {
    let (w, h) = (bx.width as usize, bx.height as usize);
    let texel = DVec2::new(bx.extent.x / w as f64, bx.extent.y / h as f64);
    let mut depth = vec![f64::NEG_INFINITY; w * h];
    // 0 = empty, 1 = covered by extrapolation, 2 = centre covered.
    let mut class = vec![0u8; w * h];
    let mut lip_offset = vec![0.0f64; w * h];
    // Texel corner (i, j) sits at (i, j) in texel units; (w + 1) x (h + 1) of them.
    let mut corner_offset = vec![f64::INFINITY; (w + 1) * (h + 1)];
    let mut normal_map = vec![[0i8; 4]; w * h];
    let mut color_map = vec![[0u8; 4]; w * h];
    let to_local = |p: DVec3| {
        let d = p - bx.origin;
        DVec3::new(
            d.dot(bx.axes[0]) / texel.x,
            d.dot(bx.axes[1]) / texel.y,
            d.dot(bx.axes[2]),
        )
    };
    let to_patch_dir =
        |n: DVec3| DVec3::new(n.dot(bx.axes[0]), n.dot(bx.axes[1]), n.dot(bx.axes[2]));
    for (n, &f) in faces.iter().enumerate() {
        let lips = n < chart_faces;
        let tri = mesh.faces[f as usize];
        let [a, b, c] = tri.map(|v| to_local(mesh.positions[v as usize]));
        let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        if area.abs() < 1e-300 {
            continue; // edge-on in this frame: covers no area
        }
        let sign = area.signum();
        // Half the texel square's extent along each edge's normal: the conservative margin.
        let margin = |p: DVec3, q: DVec3| 0.5 * ((q.x - p.x).abs() + (q.y - p.y).abs());
        let (ma, mb, mc) = (margin(b, c), margin(c, a), margin(a, b));
        let lo = a.min(b).min(c);
        let hi = a.max(b).max(c);
        let i0 = (lo.x - 1.0).floor().max(0.0) as usize;
        let j0 = (lo.y - 1.0).floor().max(0.0) as usize;
        let i1 = (hi.x.ceil()).min(w as f64 - 1.0);
        let j1 = (hi.y.ceil()).min(h as f64 - 1.0);
        if i1 < 0.0 || j1 < 0.0 {
            continue;
        }
        let (i1, j1) = (i1 as usize, j1 as usize);
        // Corners within two texels of the triangle: their in-plane distance to it.
        let tri2 = [a.truncate(), b.truncate(), c.truncate()];
        for cj in j0.saturating_sub(1)..=(j1 + 3).min(h) {
            for ci in i0.saturating_sub(1)..=(i1 + 3).min(w) {
                let q = DVec2::new(ci as f64, cj as f64);
                let k = cj * (w + 1) + ci;
                if corner_offset[k] == 0.0 {
                    continue;
                }
                let inside = {
                    let e = |p: DVec2, r: DVec2| {
                        ((p.x - q.x) * (r.y - q.y) - (p.y - q.y) * (r.x - q.x)) * sign
                    };
                    e(tri2[1], tri2[2]) >= 0.0
                        && e(tri2[2], tri2[0]) >= 0.0
                        && e(tri2[0], tri2[1]) >= 0.0
                };
                let d = if inside {
                    0.0
                } else {
                    let (la, lb, lc) = nearest_on_triangle(q, tri2);
                    let near = tri2[0] * la + tri2[1] * lb + tri2[2] * lc;
                    DVec2::new((q.x - near.x) * texel.x, (q.y - near.y) * texel.y).length()
                };
                corner_offset[k] = corner_offset[k].min(d);
            }
        }
        // Tolerance so texel centres on a shared edge are never missed by both faces.
        let eps = -1e-9 * area.abs();
        let inv = 1.0 / area;
        let vn = match normals {
            NormalSource::Smooth => tri.map(|v| geo.vertex_normals[v as usize]),
            NormalSource::Flat => [geo.face_normals[f as usize]; 3],
        };
        let vc = mesh.colors.as_ref().map(|cs| tri.map(|v| cs[v as usize]));
        for j in j0..=j1 {
            let py = j as f64 + 0.5;
            for i in i0..=i1 {
                let px = i as f64 + 0.5;
                let wa = ((b.x - px) * (c.y - py) - (b.y - py) * (c.x - px)) * sign;
                let wb = ((c.x - px) * (a.y - py) - (c.y - py) * (a.x - px)) * sign;
                let wc = ((a.x - px) * (b.y - py) - (a.y - py) * (b.x - px)) * sign;
                // The texel square overlaps the triangle iff no separating axis exists among the
                // three edge normals and the two box axes (so at most half a texel diagonal out).
                let overlaps_box =
                    px + 0.5 >= lo.x && px - 0.5 <= hi.x && py + 0.5 >= lo.y && py - 0.5 <= hi.y;
                let here = if wa >= eps && wb >= eps && wc >= eps {
                    2
                } else if lips && overlaps_box && wa >= -ma && wb >= -mb && wc >= -mc {
                    1
                } else {
                    continue;
                };
                let (la, lb, lc) = if here == 2 {
                    (wa * sign * inv, wb * sign * inv, wc * sign * inv)
                } else {
                    nearest_on_triangle(
                        DVec2::new(px, py),
                        [a.truncate(), b.truncate(), c.truncate()],
                    )
                };
                let z = la * a.z + lb * b.z + lc * c.z;
                let t = j * w + i;
                if here < class[t] || (here == class[t] && z <= depth[t]) {
                    continue;
                }
                class[t] = here;
                depth[t] = z;
                if here == 1 {
                    let near = a * la + b * lb + c * lc;
                    lip_offset[t] =
                        DVec2::new((px - near.x) * texel.x, (py - near.y) * texel.y).length();
                }
                let n = (vn[0] * la + vn[1] * lb + vn[2] * lc).normalize_or_zero();
                normal_map[t] = encode_snorm8(to_patch_dir(n).normalize_or(DVec3::Z));
                color_map[t] = match vc {
                    Some([ca, cb, cc]) => std::array::from_fn(|k| {
                        (la * ca[k] as f64 + lb * cb[k] as f64 + lc * cc[k] as f64)
                            .round()
                            .clamp(0.0, 255.0) as u8
                    }),
                    None => crate::gtex::NEUTRAL_COLOR,
                };
            }
        }
    }
    let heights = depth
        .iter()
        .map(|&z| {
            if z == f64::NEG_INFINITY {
                0
            } else {
                encode_height(z / bx.extent.z, bx.height_bits)
            }
        })
        .collect();
    // A corner has surface where the texels the bilinear rule blends around it (clamped at the
    // map's border) are all filled.
    let filled = |i: usize, j: usize| depth[j.min(h - 1) * w + i.min(w - 1)] > f64::NEG_INFINITY;
    let far = 2.0 * texel.x.max(texel.y);
    let mut overhangs = Vec::new();
    for cj in 0..=h {
        for ci in 0..=w {
            let (i0, j0) = (ci.saturating_sub(1), cj.saturating_sub(1));
            if filled(i0, j0) && filled(ci, j0) && filled(i0, cj) && filled(ci, cj) {
                let d = corner_offset[cj * (w + 1) + ci];
                if d > 0.0 {
                    overhangs.push(d.min(far));
                }
            }
        }
    }
    Maps {
        heights,
        normals: normal_map,
        colors: color_map,
        overhangs,
        lips: (0..w * h)
            .filter(|&t| class[t] == 1)
            .map(|t| (t, lip_offset[t]))
            .collect(),
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
                            let q = maps.normals[s];
                            n += DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64);
                            for (acc, v) in c.iter_mut().zip(maps.colors[s]) {
                                *acc += v as u32;
                            }
                            k += 1;
                        }
                    }
                }
                if k > 0 {
                    let color = c.map(|v| ((v + k / 2) / k) as u8);
                    updates.push((t, encode_snorm8(n.normalize_or(DVec3::Z)), color));
                }
            }
        }
        if updates.is_empty() {
            break;
        }
        for (t, n, c) in updates {
            maps.normals[t] = n;
            maps.colors[t] = c;
            filled[t] = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tilted_plane_is_sampled_exactly_and_dilated() {
        // Plane z = 0.25 x over [0, 4] x [0, 2], two triangles, drawn into a 8 x 4 texel box.
        let m = Mesh::from_flat(
            &[0., 0., 0., 4., 0., 1., 4., 2., 1., 0., 2., 0.],
            &[0, 1, 2, 0, 2, 3],
            None,
        )
        .unwrap();
        let geo = MeshGeometry::new(&m);
        let bx = PatchBox {
            origin: DVec3::ZERO,
            axes: [DVec3::X, DVec3::Y, DVec3::Z],
            extent: DVec3::new(4.0, 2.0, 1.0),
            width: 8,
            height: 4,
            height_bits: 16,
        };
        let mut maps = rasterize(&m, &geo, &[0, 1], 2, &bx, NormalSource::Flat);
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
        let mut half = rasterize(&m, &geo, &[0], 1, &bx, NormalSource::Flat);
        let empty = half.heights.iter().filter(|&&q| q == 0).count();
        assert!(empty > 0 && empty < 32);
        dilate(&mut half, 8, 4, 8);
        assert!(half.normals.iter().all(|n| n[2] > 100));
        assert!(half.heights.iter().filter(|&&q| q == 0).count() == empty);
        maps.heights.clear();
    }

    #[test]
    fn overhang_is_how_far_a_coarse_map_reaches_past_the_outline() {
        // The triangle (0,0), (4,0), (0,4) at z = 0 in a 2 x 2 map of 2-unit texels: all four
        // texels fill (the far one as a lip), so the field covers the whole 4 x 4 square.
        let m = Mesh::from_flat(
            &[0., 0., 0., 4., 0., 0., 0., 4., 0., 4., 4., 0.],
            &[0, 1, 2, 1, 3, 2],
            None,
        )
        .unwrap();
        let geo = MeshGeometry::new(&m);
        let bx = PatchBox {
            origin: DVec3::new(0.0, 0.0, -0.5),
            axes: [DVec3::X, DVec3::Y, DVec3::Z],
            extent: DVec3::new(4.0, 4.0, 1.0),
            width: 2,
            height: 2,
            height_bits: 16,
        };
        let one = rasterize(&m, &geo, &[0], 1, &bx, NormalSource::Flat);
        assert!(one.heights.iter().all(|&q| q != 0));
        assert_eq!(one.lips.len(), 1);
        assert!((one.lips[0].1 - 2f64.sqrt()).abs() < 1e-9);
        // The far corner (4, 4) is 2√2 from the hypotenuse; no corner is farther.
        let worst = one.overhangs.iter().copied().fold(0.0, f64::max);
        assert!((worst - 8f64.sqrt()).abs() < 1e-9, "{:?}", one.overhangs);
        // Both triangles: the square is all mesh, nothing overhangs.
        let both = rasterize(&m, &geo, &[0, 1], 2, &bx, NormalSource::Flat);
        assert!(both.overhangs.is_empty() && both.lips.is_empty());
    }
}
