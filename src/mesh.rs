//! Triangle meshes: validation, per-face geometry and adjacency.
//!
//! Space: everything here is in the mesh's own (world) coordinates, f64, as given by the user.

use glam::DVec3;

use crate::error::{GeomtexError, Result};

/// A validated triangle mesh. Positions are f64 so large offsets keep their detail.
#[derive(Clone, Debug)]
pub struct Mesh {
    pub positions: Vec<DVec3>,
    pub faces: Vec<[u32; 3]>,
    /// Optional RGBA8 color per vertex.
    pub colors: Option<Vec<[u8; 4]>>,
}

impl Mesh {
    /// Builds a mesh from flat arrays (`positions` is N*3, `faces` is M*3, `colors` is N*4),
    /// checking everything a user can get wrong. Faces come as i64 so negative indices can be
    /// reported instead of wrapping around.
    pub fn from_flat(positions: &[f64], faces: &[i64], colors: Option<&[u8]>) -> Result<Mesh> {
        if positions.len() % 3 != 0 {
            return Err(GeomtexError::Mesh(format!(
                "vertex array holds {} numbers, not a multiple of 3",
                positions.len()
            )));
        }
        if faces.len() % 3 != 0 {
            return Err(GeomtexError::Mesh(format!(
                "face array holds {} indices, not a multiple of 3",
                faces.len()
            )));
        }
        let n_vertices = positions.len() / 3;
        if n_vertices == 0 {
            return Err(GeomtexError::Mesh("the mesh has no vertices".into()));
        }
        if faces.is_empty() {
            return Err(GeomtexError::Mesh("the mesh has no faces".into()));
        }
        if n_vertices > u32::MAX as usize - 1 {
            return Err(GeomtexError::Mesh(format!(
                "{n_vertices} vertices is more than 2^32 - 2"
            )));
        }
        let mut pos = Vec::with_capacity(n_vertices);
        for (i, p) in positions.chunks_exact(3).enumerate() {
            if let Some(axis) = p.iter().position(|c| !c.is_finite()) {
                return Err(GeomtexError::Mesh(format!(
                    "vertex {i} has a non-finite {} coordinate ({})",
                    ["x", "y", "z"][axis],
                    p[axis]
                )));
            }
            pos.push(DVec3::new(p[0], p[1], p[2]));
        }
        let mut tris = Vec::with_capacity(faces.len() / 3);
        for (f, idx) in faces.chunks_exact(3).enumerate() {
            let mut t = [0u32; 3];
            for k in 0..3 {
                let v = idx[k];
                if v < 0 {
                    return Err(GeomtexError::Mesh(format!(
                        "face {f} has a negative vertex index ({v})"
                    )));
                }
                if v as u64 >= n_vertices as u64 {
                    return Err(GeomtexError::Mesh(format!(
                        "face {f} references vertex {v} but the mesh has {n_vertices} vertices"
                    )));
                }
                t[k] = v as u32;
            }
            tris.push(t);
        }
        let colors = match colors {
            None => None,
            Some(c) => {
                if c.len() != n_vertices * 4 {
                    return Err(GeomtexError::Mesh(format!(
                        "vertex colors hold {} values; expected {} (RGBA for each of {n_vertices} vertices)",
                        c.len(),
                        n_vertices * 4
                    )));
                }
                Some(
                    c.chunks_exact(4)
                        .map(|q| [q[0], q[1], q[2], q[3]])
                        .collect(),
                )
            }
        };
        Ok(Mesh {
            positions: pos,
            faces: tris,
            colors,
        })
    }

    pub fn bounds(&self) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in &self.positions {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        (lo, hi)
    }

    /// Length of the bounding-box diagonal, the yardstick for every relative tolerance.
    pub fn diagonal(&self) -> f64 {
        let (lo, hi) = self.bounds();
        (hi - lo).length()
    }
}

/// Compressed sparse rows: `items[offsets[i]..offsets[i+1]]` belong to row i.
#[derive(Clone, Debug, Default)]
pub struct Csr {
    pub offsets: Vec<u32>,
    pub items: Vec<u32>,
}

impl Csr {
    /// Builds rows from (row, item) pairs.
    pub fn from_pairs(n_rows: usize, pairs: &[(u32, u32)]) -> Csr {
        let mut counts = vec![0u32; n_rows + 1];
        for &(r, _) in pairs {
            counts[r as usize + 1] += 1;
        }
        for i in 0..n_rows {
            counts[i + 1] += counts[i];
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; pairs.len()];
        for &(r, it) in pairs {
            items[fill[r as usize] as usize] = it;
            fill[r as usize] += 1;
        }
        Csr {
            offsets: counts,
            items,
        }
    }

    #[inline]
    pub fn row(&self, i: usize) -> &[u32] {
        &self.items[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }
}

/// Per-face and per-vertex quantities every conversion stage reads.
pub struct MeshGeometry {
    /// Unit face normals (zero for degenerate faces).
    pub face_normals: Vec<DVec3>,
    pub face_areas: Vec<f64>,
    pub centroids: Vec<DVec3>,
    /// Faces with (near) zero area or a repeated vertex: no normal, left out of every chart.
    pub degenerate: Vec<bool>,
    /// Area-weighted unit vertex normals.
    pub vertex_normals: Vec<DVec3>,
    /// Faces sharing an edge (all of them on a non-manifold edge).
    pub face_neighbors: Csr,
    /// Faces around each vertex.
    pub vertex_faces: Csr,
    pub diagonal: f64,
}

impl MeshGeometry {
    pub fn new(mesh: &Mesh) -> MeshGeometry {
        let nf = mesh.faces.len();
        let nv = mesh.positions.len();
        let diagonal = mesh.diagonal();
        // Relative to the model size so a micrometre part and a 1e6-offset scan behave alike.
        let area_eps = (diagonal * 1e-10).powi(2);
        let mut face_normals = vec![DVec3::ZERO; nf];
        let mut face_areas = vec![0.0; nf];
        let mut centroids = vec![DVec3::ZERO; nf];
        let mut degenerate = vec![false; nf];
        let mut vertex_normals = vec![DVec3::ZERO; nv];
        for (f, t) in mesh.faces.iter().enumerate() {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            // Edges from the centroid-free form keep precision for far-from-origin models.
            let cross = (b - a).cross(c - a);
            let twice_area = cross.length();
            centroids[f] = (a + b + c) / 3.0;
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || twice_area * 0.5 <= area_eps {
                degenerate[f] = true;
                continue;
            }
            face_areas[f] = twice_area * 0.5;
            face_normals[f] = cross / twice_area;
            for &v in t {
                vertex_normals[v as usize] += cross; // area weighting: |cross| = 2 area
            }
        }
        for n in vertex_normals.iter_mut() {
            *n = n.normalize_or_zero();
        }

        // Edge adjacency by sorting (min, max, face) keys: O(M log M), no hash map.
        let mut edges: Vec<(u32, u32, u32)> = Vec::with_capacity(nf * 3);
        for (f, t) in mesh.faces.iter().enumerate() {
            if degenerate[f] {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                edges.push((a.min(b), a.max(b), f as u32));
            }
        }
        edges.sort_unstable();
        let mut pairs = Vec::with_capacity(edges.len() * 2);
        let mut i = 0;
        while i < edges.len() {
            let mut j = i + 1;
            while j < edges.len() && edges[j].0 == edges[i].0 && edges[j].1 == edges[i].1 {
                j += 1;
            }
            for p in i..j {
                for q in i..j {
                    if p != q && edges[p].2 != edges[q].2 {
                        pairs.push((edges[p].2, edges[q].2));
                    }
                }
            }
            i = j;
        }
        pairs.sort_unstable();
        pairs.dedup();
        let face_neighbors = Csr::from_pairs(nf, &pairs);

        let mut vf = Vec::with_capacity(nf * 3);
        for (f, t) in mesh.faces.iter().enumerate() {
            if !degenerate[f] {
                for &v in t {
                    vf.push((v, f as u32));
                }
            }
        }
        let vertex_faces = Csr::from_pairs(nv, &vf);

        MeshGeometry {
            face_normals,
            face_areas,
            centroids,
            degenerate,
            vertex_normals,
            face_neighbors,
            vertex_faces,
            diagonal,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Mesh {
        Mesh::from_flat(
            &[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.],
            &[0, 1, 2, 0, 2, 3],
            None,
        )
        .unwrap()
    }

    #[test]
    fn rejects_bad_input_with_location() {
        let e = Mesh::from_flat(
            &[0., 0., f64::NAN, 1., 0., 0., 0., 1., 0.],
            &[0, 1, 2],
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("vertex 0") && e.contains("z"), "{e}");
        let e = Mesh::from_flat(&[0.; 9], &[0, 1, 5], None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("face 0 references vertex 5"), "{e}");
        let e = Mesh::from_flat(&[0.; 9], &[0, -1, 2], None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("negative"), "{e}");
        assert!(Mesh::from_flat(&[], &[], None).is_err());
        assert!(Mesh::from_flat(&[0.; 9], &[], None).is_err());
        assert!(Mesh::from_flat(&[0.; 9], &[0, 1, 2], Some(&[0; 5])).is_err());
    }

    #[test]
    fn adjacency_and_normals() {
        let m = quad();
        let g = MeshGeometry::new(&m);
        assert_eq!(g.face_neighbors.row(0), &[1]);
        assert_eq!(g.face_neighbors.row(1), &[0]);
        assert!((g.face_normals[0] - DVec3::Z).length() < 1e-12);
        assert!((g.face_areas[0] + g.face_areas[1] - 1.0).abs() < 1e-12);
        assert_eq!(g.vertex_faces.row(0).len(), 2);
    }

    #[test]
    fn degenerate_faces_are_flagged_not_fatal() {
        let m = Mesh::from_flat(
            &[0., 0., 0., 1., 0., 0., 2., 0., 0.],
            &[0, 1, 2, 0, 0, 1],
            None,
        )
        .unwrap();
        let g = MeshGeometry::new(&m);
        assert_eq!(g.degenerate, vec![true, true]);
    }
}
