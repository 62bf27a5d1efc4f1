//! Chart frames: the height direction z and the in-plane axes x/y of each patch box, the
//! chart's bounds in them, and its box at a texel size.
//!
//! Space: world directions and positions (f64). Projections are taken relative to a point of the
//! chart so that models far from the origin keep full precision.

use geo::{ConvexHull, MinimumRotatedRect, MultiPoint, Point};
use glam::{DVec2, DVec3};

use crate::convert_options::InPlane;
use crate::gtex::vertical_extent;
use crate::mesh::{Mesh, MeshGeometry};

/// A face with normal·z at or below this folds in a frame with that z. Slightly above the
/// paper's 0 so round-off can never let a vertical face through.
pub const FOLD_COS: f64 = 1e-6;

/// Smallest normal·z over the faces: at or below `FOLD_COS`, they fold in a frame with that z.
pub fn min_dot(geo: &MeshGeometry, faces: &[u32], z: DVec3) -> f64 {
    faces
        .iter()
        .map(|&f| geo.face_normals[f as usize].dot(z))
        .fold(f64::INFINITY, f64::min)
}

/// Area-weighted median of each normal component, normalized: the paper's "median normal".
pub fn median_normal(geo: &MeshGeometry, faces: &[u32]) -> DVec3 {
    let mut out = [0.0; 3];
    let mut vals: Vec<(f64, f64)> = Vec::with_capacity(faces.len());
    for (axis, o) in out.iter_mut().enumerate() {
        vals.clear();
        vals.extend(faces.iter().map(|&f| {
            (
                geo.face_normals[f as usize].to_array()[axis],
                geo.face_areas[f as usize],
            )
        }));
        vals.sort_by(|a, b| a.0.total_cmp(&b.0));
        let half = vals.iter().map(|v| v.1).sum::<f64>() * 0.5;
        let mut acc = 0.0;
        for &(v, a) in &vals {
            acc += a;
            if acc >= half {
                *o = v;
                break;
            }
        }
    }
    DVec3::from_array(out)
}

pub fn mean_normal(geo: &MeshGeometry, faces: &[u32]) -> DVec3 {
    faces
        .iter()
        .map(|&f| geo.face_normals[f as usize] * geo.face_areas[f as usize])
        .sum::<DVec3>()
}

/// The height direction of a chart: the median normal as in the paper; if that folds, the
/// better of the mean normal and an approximate centre of the smallest cap holding every normal
/// (Badoiu-Clarkson iterations), which maximizes the smallest normal·z. Returns z and that minimum.
pub fn choose_z(geo: &MeshGeometry, faces: &[u32]) -> (DVec3, f64) {
    let fallback = geo.face_normals[faces[0] as usize];
    let median = median_normal(geo, faces)
        .try_normalize()
        .unwrap_or(fallback);
    let m0 = min_dot(geo, faces, median);
    if m0 > FOLD_COS {
        return (median, m0);
    }
    let mut best = (median, m0);
    let mean = mean_normal(geo, faces).try_normalize().unwrap_or(fallback);
    let m1 = min_dot(geo, faces, mean);
    if m1 > best.1 {
        best = (mean, m1);
    }
    let mut centre = best.0;
    for k in 1..=64 {
        let worst = faces
            .iter()
            .map(|&f| geo.face_normals[f as usize])
            .min_by(|a, b| a.dot(centre).total_cmp(&b.dot(centre)))
            .unwrap();
        centre += (worst - centre) / (k as f64 + 1.0);
        if let Some(z) = centre.try_normalize() {
            let m = min_dot(geo, faces, z);
            if m > best.1 {
                best = (z, m);
            }
        }
    }
    best
}

/// Any unit vector perpendicular to z, chosen stably.
pub fn perpendicular(z: DVec3) -> DVec3 {
    let helper = if z.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    (helper - z * helper.dot(z)).normalize()
}

/// Right-handed axes (x, y, z) for a chart whose vertices are `points`.
pub fn in_plane_axes(points: &[DVec3], z: DVec3, method: InPlane) -> [DVec3; 3] {
    let u0 = perpendicular(z);
    let v0 = z.cross(u0);
    let reference = points.first().copied().unwrap_or(DVec3::ZERO);
    let flat: Vec<DVec2> = points
        .iter()
        .map(|p| {
            let d = *p - reference;
            DVec2::new(d.dot(u0), d.dot(v0))
        })
        .collect();
    let dir = match method {
        InPlane::MinAreaRect => min_rect_direction(&flat).or_else(|| pca_direction(&flat)),
        InPlane::Pca => pca_direction(&flat),
    }
    .unwrap_or(DVec2::X);
    let x = (u0 * dir.x + v0 * dir.y).normalize();
    [x, z.cross(x), z]
}

/// Major principal axis of 2D points.
fn pca_direction(pts: &[DVec2]) -> Option<DVec2> {
    if pts.len() < 2 {
        return None;
    }
    let mean = pts.iter().copied().sum::<DVec2>() / pts.len() as f64;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in pts {
        let d = *p - mean;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    // Angle of the major eigenvector of [[sxx, sxy], [sxy, syy]].
    let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    Some(DVec2::new(theta.cos(), theta.sin()))
}

/// Direction of the longer side of the minimum-area enclosing rectangle (geo's convex hull and
/// rotating rectangle).
fn min_rect_direction(pts: &[DVec2]) -> Option<DVec2> {
    let mp: MultiPoint<f64> = pts.iter().map(|p| Point::new(p.x, p.y)).collect();
    if mp.convex_hull().exterior().0.len() < 4 {
        return None; // collinear or a single point: no area to minimize
    }
    let rect = mp.minimum_rotated_rect()?;
    let c: Vec<DVec2> = rect
        .exterior()
        .0
        .iter()
        .map(|c| DVec2::new(c.x, c.y))
        .collect();
    if c.len() < 3 {
        return None;
    }
    let (e0, e1) = (c[1] - c[0], c[2] - c[1]);
    let longer = if e0.length_squared() >= e1.length_squared() {
        e0
    } else {
        e1
    };
    longer.try_normalize()
}

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

/// A chart's frame: its axes, a reference point (one of its vertices) and the tight bounds, in
/// those axes relative to the reference, of everything it draws.
#[derive(Clone, Copy, Debug)]
pub struct ChartFrame {
    /// Right-handed x, y, z (z = the chart's height direction).
    pub axes: [DVec3; 3],
    pub reference: DVec3,
    pub lo: DVec3,
    pub hi: DVec3,
}

impl ChartFrame {
    /// The frame of a chart drawing its `faces` and `ring` faces with height direction `z`.
    pub fn new(mesh: &Mesh, faces: &[u32], ring: &[u32], z: DVec3, method: InPlane) -> ChartFrame {
        let mut verts: Vec<u32> = faces
            .iter()
            .chain(ring)
            .flat_map(|&f| mesh.faces[f as usize])
            .collect();
        verts.sort_unstable();
        verts.dedup();
        let points: Vec<DVec3> = verts.iter().map(|&v| mesh.positions[v as usize]).collect();
        let axes = in_plane_axes(&points, z, method);
        let reference = points[0];
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for p in &points {
            let d = *p - reference;
            let l = DVec3::new(d.dot(axes[0]), d.dot(axes[1]), d.dot(axes[2]));
            lo = lo.min(l);
            hi = hi.max(l);
        }
        ChartFrame {
            axes,
            reference,
            lo,
            hi,
        }
    }

    /// The longer in-plane side of the bounds.
    pub fn long_side(&self) -> f64 {
        (self.hi - self.lo).x.max((self.hi - self.lo).y)
    }

    /// The box the chart is drawn into at texel size `texel`: whole texels, at most
    /// `max_resolution` on a side, with the chart centred in it.
    pub fn patch_box(&self, texel: f64, max_resolution: u32, height_bits: u8) -> PatchBox {
        let size = self.hi - self.lo;
        let res = |s: f64| ((s / texel).ceil() as u32).clamp(2, max_resolution.max(2));
        let (w, h) = (res(size.x), res(size.y));
        let pad_x = (w as f64 * texel - size.x) * 0.5;
        let pad_y = (h as f64 * texel - size.y) * 0.5;
        let (thickness, height_bits) = vertical_extent(size.z, texel, height_bits);
        let pad_z = (thickness - size.z) * 0.5;
        let corner = DVec3::new(self.lo.x - pad_x, self.lo.y - pad_y, self.lo.z - pad_z);
        let axes = self.axes;
        PatchBox {
            origin: self.reference + axes[0] * corner.x + axes[1] * corner.y + axes[2] * corner.z,
            axes,
            extent: DVec3::new(w as f64 * texel, h as f64 * texel, thickness),
            width: w,
            height: h,
            height_bits,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_rect_aligns_with_a_rotated_rectangle() {
        let a = 0.3f64;
        let (d, n) = (DVec2::new(a.cos(), a.sin()), DVec2::new(-a.sin(), a.cos()));
        let mut pts = vec![];
        for i in 0..=10 {
            for j in 0..=3 {
                pts.push(d * (i as f64) + n * (j as f64 * 0.5));
            }
        }
        let got = min_rect_direction(&pts).unwrap();
        assert!(got.dot(d).abs() > 1.0 - 1e-9, "{got:?}");
        let pca = pca_direction(&pts).unwrap();
        assert!(pca.dot(d).abs() > 1.0 - 1e-9, "{pca:?}");
    }

    #[test]
    fn axes_are_right_handed_and_orthonormal() {
        let z = DVec3::new(0.2, -0.5, 0.8).normalize();
        let pts = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.3)];
        for m in [InPlane::Pca, InPlane::MinAreaRect] {
            let [x, y, zz] = in_plane_axes(&pts, z, m);
            assert!((x.cross(y) - zz).length() < 1e-12);
            assert!(x.dot(z).abs() < 1e-12 && (x.length() - 1.0).abs() < 1e-12);
        }
    }
}
