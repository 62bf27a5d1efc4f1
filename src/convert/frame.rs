//! Chart frames: the height direction z and the in-plane axes x/y of each patch box.
//!
//! Space: world directions and positions (f64). Projections are taken relative to a point of the
//! chart so that models far from the origin keep full precision.

use geo::{ConvexHull, MinimumRotatedRect, MultiPoint, Point};
use glam::{DVec2, DVec3};

use crate::mesh::MeshGeometry;

/// A face with normal·z at or below this folds in a frame with that z. Slightly above the
/// paper's 0 so round-off can never let a vertical face through.
pub const FOLD_COS: f64 = 1e-6;

/// How x/y are chosen inside the plane perpendicular to z.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InPlane {
    /// The principal axes of the projected vertices (the paper's 2D PCA).
    Pca,
    /// The sides of the minimum-area rectangle around the projected vertices.
    MinAreaRect,
}

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
fn perpendicular(z: DVec3) -> DVec3 {
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
