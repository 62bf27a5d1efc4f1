//! A shell over a base mesh: each base triangle extruded along its vertices' shared normals into
//! a prism (neighbours share their fins, so there are no cracks), whose map takes texture space
//! into the base mesh's object space:
//!   P(b, h) = sum_k b_k (p_k + h * thickness * n_k),
//! b the barycentric coordinates of (u, v) in the face's texture triangle, h = z / nz.
//!
//! Spaces: the base mesh's object space (positions, normals, output); texture space in voxel
//! units (volume.rs): u, v in tiles times (nx, ny), z in voxels.

use glam::{DVec2, DVec3};

/// A base mesh ready to be extruded.
pub struct Shell {
    pub positions: Vec<DVec3>,
    /// Unit normal per vertex, shared by every face around it.
    pub normals: Vec<DVec3>,
    pub faces: Vec<[u32; 3]>,
    /// Texture coordinates of each face's corners, in tiles (1.0 = one tile).
    pub uv: Vec<[DVec2; 3]>,
    pub thickness: f64,
    /// The tile's voxels along x, y, z.
    pub size: [usize; 3],
}

/// A point of a clipped polygon: texture space, and the base edge (vertex ids, smaller first)
/// it was cut on, so both prisms sharing that edge map it to the very same position.
#[derive(Clone, Copy)]
pub(crate) struct Corner {
    pub p: DVec3,
    pub edge: Option<[u32; 2]>,
}

/// The 2D cross product's z: twice the signed area of the triangle (0, a, b).
pub(crate) fn cross2(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

impl Shell {
    /// Object-space position of texture point `p` (voxel units) in face `f`'s prism.
    pub(crate) fn place(&self, f: usize, c: Corner) -> DVec3 {
        let h = c.p.z / self.size[2] as f64;
        let lift =
            |k: u32| self.positions[k as usize] + self.normals[k as usize] * (h * self.thickness);
        if let Some([a, b]) = c.edge {
            // On a shared edge: the same arithmetic from either side.
            let (ua, ub) = (self.corner_uv(f, a), self.corner_uv(f, b));
            let d = ub - ua;
            let s = (c.p.truncate() - ua).dot(d) / d.length_squared();
            return lift(a) * (1.0 - s) + lift(b) * s;
        }
        let tri = self.faces[f];
        let [a, b, c2] = self.uv_voxels(f);
        let area = cross2(b - a, c2 - a);
        let q = c.p.truncate();
        let w1 = cross2(q - a, c2 - a) / area;
        let w2 = cross2(b - a, q - a) / area;
        lift(tri[0]) * (1.0 - w1 - w2) + lift(tri[1]) * w1 + lift(tri[2]) * w2
    }

    pub(crate) fn uv_voxels(&self, f: usize) -> [DVec2; 3] {
        let scale = DVec2::new(self.size[0] as f64, self.size[1] as f64);
        self.uv[f].map(|t| t * scale)
    }

    fn corner_uv(&self, f: usize, vertex: u32) -> DVec2 {
        let k = self.faces[f]
            .iter()
            .position(|&v| v == vertex)
            .expect("vertex of the face");
        self.uv_voxels(f)[k]
    }
}
