//! Triangle meshes: validation, per-face geometry and adjacency.
//!
//! Space: everything here is in the mesh's own (world) coordinates, f64, as given by the user.

use glam::DVec3;

use crate::appearance::Appearance;
use crate::error::{GeomtexError, Result};

/// A validated triangle mesh. Positions are f64 so large offsets keep their detail.
#[derive(Clone, Debug)]
pub struct Mesh {
    pub positions: Vec<DVec3>,
    pub faces: Vec<[u32; 3]>,
    /// Optional RGBA8 color per vertex.
    pub colors: Option<Vec<[u8; 4]>>,
    /// Face colors and texture (appearance.rs, which also gives the color at a face's point).
    pub appearance: Appearance,
}

impl Mesh {
    /// Builds a mesh from flat arrays (`positions` is N*3, `faces` is M*3, `colors` is N*4),
    /// checking everything a user can get wrong. Faces come as i64 so negative indices can be
    /// reported instead of wrapping around.
    pub fn from_flat(positions: &[f64], faces: &[i64], colors: Option<&[u8]>) -> Result<Mesh> {
        if !positions.len().is_multiple_of(3) {
            return Err(GeomtexError::Mesh(format!(
                "vertex array holds {} numbers, not a multiple of 3",
                positions.len()
            )));
        }
        if !faces.len().is_multiple_of(3) {
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
            appearance: Appearance::default(),
        })
    }

    /// The mesh with the faces marked in `flips` wound the other way (face indices kept).
    pub fn rewound(&self, flips: &[bool]) -> Mesh {
        Mesh {
            faces: self
                .faces
                .iter()
                .zip(flips)
                .map(|(&[a, b, c], &flip)| if flip { [a, c, b] } else { [a, b, c] })
                .collect(),
            appearance: self.appearance.rewound(flips),
            ..self.clone()
        }
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

/// Edges (between welded vertices, over non-degenerate faces) by how many faces share them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EdgeCounts {
    /// Used by one face: an open scan's rim or a hole's.
    pub boundary: usize,
    /// Used by more than two faces.
    pub nonmanifold: usize,
    /// Shared by two faces that disagree on orientation (both walk it the same way).
    pub inconsistent: usize,
}

const AGREE_BIT: u32 = 1 << 31;

/// Per-face and per-vertex quantities every conversion stage reads.
pub struct MeshGeometry {
    /// Unit face normals (zero for degenerate faces).
    pub face_normals: Vec<DVec3>,
    pub face_areas: Vec<f64>,
    pub centroids: Vec<DVec3>,
    /// Faces with (near) zero area or a repeated vertex: no normal, left out of every chart.
    pub degenerate: Vec<bool>,
    /// Area-weighted unit vertex normals (shared by vertices at the same position).
    pub vertex_normals: Vec<DVec3>,
    /// Per vertex, the lowest index of a vertex at exactly the same position: adjacency is
    /// geometric, so an unwelded triangle soup (STL-style, or a scan split at UV seams) has the
    /// same neighbours as its welded twin.
    pub weld: Vec<u32>,
    /// Vertices that repeat an earlier vertex's position.
    pub duplicate_vertices: usize,
    /// Faces sharing an edge (all of them on a non-manifold edge).
    pub face_neighbors: Csr,
    /// Edges by how many faces share them, for the conversion report.
    pub edge_counts: EdgeCounts,
    /// Faces across each manifold edge, with `AGREE_BIT` set where the two are wound alike.
    manifold_neighbors: Csr,
    /// Faces around each vertex (indexed by vertex; welded vertices list the same faces).
    pub vertex_faces: Csr,
    pub diagonal: f64,
}

/// Per vertex, the lowest index of a vertex at exactly the same position (by the bits of its
/// coordinates, -0 and +0 alike), and how many vertices repeat an earlier one.
fn weld(mesh: &Mesh) -> (Vec<u32>, usize) {
    let nv = mesh.positions.len();
    let mut order: Vec<u32> = (0..nv as u32).collect();
    let key = |v: u32| {
        mesh.positions[v as usize]
            .to_array()
            .map(|x| (x + 0.0).to_bits())
    };
    order.sort_unstable_by_key(|&v| (key(v), v));
    let mut weld: Vec<u32> = (0..nv as u32).collect();
    let mut duplicate_vertices = 0;
    for k in 1..order.len() {
        if key(order[k]) == key(order[k - 1]) {
            weld[order[k] as usize] = weld[order[k - 1] as usize];
            duplicate_vertices += 1;
        }
    }
    (weld, duplicate_vertices)
}

/// Normals, areas and centroids of the faces, which are degenerate, and the vertex normals.
struct FaceGeometry {
    normals: Vec<DVec3>,
    areas: Vec<f64>,
    centroids: Vec<DVec3>,
    degenerate: Vec<bool>,
    vertex_normals: Vec<DVec3>,
}

impl FaceGeometry {
    fn new(mesh: &Mesh, weld: &[u32], diagonal: f64) -> FaceGeometry {
        let (nf, nv) = (mesh.faces.len(), mesh.positions.len());
        // Relative to the model size so a micrometre part and a 1e6-offset scan behave alike.
        let area_eps = (diagonal * 1e-10).powi(2);
        let mut g = FaceGeometry {
            normals: vec![DVec3::ZERO; nf],
            areas: vec![0.0; nf],
            centroids: vec![DVec3::ZERO; nf],
            degenerate: vec![false; nf],
            vertex_normals: vec![DVec3::ZERO; nv],
        };
        for (f, t) in mesh.faces.iter().enumerate() {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            // Edges from the centroid-free form keep precision for far-from-origin models.
            let cross = (b - a).cross(c - a);
            let twice_area = cross.length();
            g.centroids[f] = (a + b + c) / 3.0;
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || twice_area * 0.5 <= area_eps {
                g.degenerate[f] = true;
                continue;
            }
            g.areas[f] = twice_area * 0.5;
            g.normals[f] = cross / twice_area;
            for &v in t {
                g.vertex_normals[weld[v as usize] as usize] += cross; // |cross| = 2 area
            }
        }
        // In vertex order: a vertex welded to an earlier one takes its (normalized) normal.
        for (v, &w) in weld.iter().enumerate() {
            g.vertex_normals[v] = g.vertex_normals[w as usize].normalize_or_zero();
        }
        g
    }
}

/// Faces sharing an edge (all of them on a non-manifold edge), the faces across each manifold
/// edge with `AGREE_BIT`, and the edge counts.
struct EdgeAdjacency {
    face_neighbors: Csr,
    manifold_neighbors: Csr,
    edge_counts: EdgeCounts,
}

impl EdgeAdjacency {
    /// By sorting (min, max, face, direction) keys: O(M log M), no hash map.
    fn new(mesh: &Mesh, weld: &[u32], degenerate: &[bool]) -> EdgeAdjacency {
        let nf = mesh.faces.len();
        let mut edges: Vec<(u32, u32, u32, bool)> = Vec::with_capacity(nf * 3);
        for (f, t) in mesh.faces.iter().enumerate() {
            if degenerate[f] {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (weld[t[k] as usize], weld[t[(k + 1) % 3] as usize]);
                edges.push((a.min(b), a.max(b), f as u32, a < b));
            }
        }
        edges.sort_unstable();
        let mut pairs = Vec::with_capacity(edges.len() * 2);
        let mut edge_counts = EdgeCounts::default();
        // Across each manifold edge: (face, other face | AGREE_BIT if the two agree on
        // orientation).
        let mut manifold = Vec::with_capacity(edges.len());
        let mut i = 0;
        while i < edges.len() {
            let mut j = i + 1;
            while j < edges.len() && edges[j].0 == edges[i].0 && edges[j].1 == edges[i].1 {
                j += 1;
            }
            match j - i {
                1 => edge_counts.boundary += 1,
                // Two faces agreeing on orientation walk their shared edge in opposite
                // directions.
                2 => {
                    let agree = edges[i].3 != edges[i + 1].3;
                    edge_counts.inconsistent += usize::from(!agree);
                    let bit = if agree { AGREE_BIT } else { 0 };
                    manifold.push((edges[i].2, edges[i + 1].2 | bit));
                    manifold.push((edges[i + 1].2, edges[i].2 | bit));
                }
                _ => edge_counts.nonmanifold += 1,
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
        EdgeAdjacency {
            face_neighbors: Csr::from_pairs(nf, &pairs),
            manifold_neighbors: Csr::from_pairs(nf, &manifold),
            edge_counts,
        }
    }
}

/// Faces around each vertex (welded vertices list the same faces).
fn vertex_faces(mesh: &Mesh, weld: &[u32], degenerate: &[bool], duplicates: usize) -> Csr {
    let (nf, nv) = (mesh.faces.len(), mesh.positions.len());
    let mut vf = Vec::with_capacity(nf * 3);
    for (f, t) in mesh.faces.iter().enumerate() {
        if !degenerate[f] {
            for &v in t {
                vf.push((weld[v as usize], f as u32));
            }
        }
    }
    vf.sort_unstable();
    vf.dedup();
    let welded_faces = Csr::from_pairs(nv, &vf);
    // Every vertex lists its weld group's faces.
    let mut all = Vec::with_capacity(vf.len() + duplicates * 6);
    for (v, &w) in weld.iter().enumerate() {
        for &f in welded_faces.row(w as usize) {
            all.push((v as u32, f));
        }
    }
    Csr::from_pairs(nv, &all)
}

impl MeshGeometry {
    pub fn new(mesh: &Mesh) -> MeshGeometry {
        let diagonal = mesh.diagonal();
        let (weld, duplicate_vertices) = weld(mesh);
        let faces = FaceGeometry::new(mesh, &weld, diagonal);
        let edges = EdgeAdjacency::new(mesh, &weld, &faces.degenerate);
        let vertex_faces = vertex_faces(mesh, &weld, &faces.degenerate, duplicate_vertices);
        MeshGeometry {
            face_normals: faces.normals,
            face_areas: faces.areas,
            centroids: faces.centroids,
            degenerate: faces.degenerate,
            vertex_normals: faces.vertex_normals,
            weld,
            duplicate_vertices,
            face_neighbors: edges.face_neighbors,
            edge_counts: edges.edge_counts,
            manifold_neighbors: edges.manifold_neighbors,
            vertex_faces,
            diagonal,
        }
    }

    /// Which faces to flip so that faces sharing a manifold edge agree on orientation (a scan
    /// exported with some triangles reversed). Each edge-connected piece keeps the winding of the
    /// larger part of its area, so a consistently wound mesh is never touched. Written here
    /// because it needs this adjacency; a non-orientable piece keeps its first assignment.
    pub fn winding_flips(&self) -> Vec<bool> {
        let nf = self.degenerate.len();
        let mut flip = vec![false; nf];
        let mut seen = vec![false; nf];
        let mut stack = Vec::new();
        let mut piece = Vec::new();
        for start in 0..nf {
            if seen[start] || self.degenerate[start] {
                continue;
            }
            seen[start] = true;
            stack.push(start as u32);
            piece.clear();
            while let Some(f) = stack.pop() {
                piece.push(f);
                for &item in self.manifold_neighbors.row(f as usize) {
                    let g = (item & !AGREE_BIT) as usize;
                    if !seen[g] {
                        seen[g] = true;
                        flip[g] = flip[f as usize] ^ (item & AGREE_BIT == 0);
                        stack.push(g as u32);
                    }
                }
            }
            let area = |want: bool| -> f64 {
                piece
                    .iter()
                    .filter(|&&f| flip[f as usize] == want)
                    .map(|&f| self.face_areas[f as usize])
                    .sum()
            };
            if area(true) > area(false) {
                for &f in &piece {
                    flip[f as usize] = !flip[f as usize];
                }
            }
        }
        flip
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

    /// A 4x4 grid of unit squares at z = 0, each split into two triangles, wound up (+z).
    fn grid() -> Mesh {
        let mut positions = Vec::new();
        for y in 0..5 {
            for x in 0..5 {
                positions.extend([x as f64, y as f64, 0.0]);
            }
        }
        let mut faces = Vec::new();
        for y in 0..4 {
            for x in 0..4 {
                let i = y * 5 + x;
                faces.extend([i, i + 1, i + 6, i, i + 6, i + 5]);
            }
        }
        Mesh::from_flat(&positions, &faces, None).unwrap()
    }

    #[test]
    fn edge_counts_and_winding_repair() {
        let mut mesh = grid();
        let clean = MeshGeometry::new(&mesh);
        // The rim is 16 unit edges.
        assert_eq!(
            clean.edge_counts,
            EdgeCounts {
                boundary: 16,
                nonmanifold: 0,
                inconsistent: 0
            }
        );
        assert!(clean.winding_flips().iter().all(|&f| !f));
        // Reverse three faces: they are the minority of the area, so exactly they flip back.
        for f in [0, 7, 20] {
            mesh.faces[f].swap(1, 2);
        }
        let geo = MeshGeometry::new(&mesh);
        assert_eq!(geo.edge_counts.inconsistent, 2 + 3 + 3); // face 0 has a rim edge
        let flips = geo.winding_flips();
        let flipped: Vec<usize> = (0..flips.len()).filter(|&f| flips[f]).collect();
        assert_eq!(flipped, vec![0, 7, 20]);
        // A fin on an interior edge makes it non-manifold; a soup copy welds back to the same
        // counts.
        mesh.positions.push(DVec3::new(1.5, 1.5, 1.0));
        mesh.faces.push([6, 12, 25]);
        assert_eq!(MeshGeometry::new(&mesh).edge_counts.nonmanifold, 1);
        let soup = Mesh {
            positions: grid()
                .faces
                .iter()
                .flatten()
                .map(|&v| grid().positions[v as usize])
                .collect(),
            faces: (0..32).map(|f| [3 * f, 3 * f + 1, 3 * f + 2]).collect(),
            colors: None,
            appearance: Appearance::default(),
        };
        let welded = MeshGeometry::new(&soup);
        assert_eq!(welded.duplicate_vertices, 96 - 25);
        assert_eq!(welded.edge_counts, clean.edge_counts);
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
