//! Triangle meshes: validation, per-face geometry and adjacency, the normal rules (flat,
//! smooth, crease-split) that conversion and the mesh rasterizer share, and a face's color
//! (from the sources appearance.rs holds).
//!
//! Space: everything here is in the mesh's own (world) coordinates, f64, as given by the user.

use std::str::FromStr;
use std::sync::Arc;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::appearance::{
    footprint, texture_coords, Appearance, FaceColor, Image, Texture, TextureCoords, TextureInput,
};
use crate::error::{parse_choice, GeomtexError, Result};

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

    /// Face `f`'s centroid, computed when asked: kept for every face it took 24 bytes a face
    /// through the whole conversion.
    #[inline]
    pub fn centroid(&self, f: usize) -> DVec3 {
        let [a, b, c] = self.faces[f].map(|v| self.positions[v as usize]);
        (a + b + c) / 3.0
    }

    /// Length of the bounding-box diagonal, the yardstick for every relative tolerance.
    pub fn diagonal(&self) -> f64 {
        let (lo, hi) = self.bounds();
        (hi - lo).length()
    }
}

// The mesh's colors (appearance.rs holds the sources and reads them).
impl Mesh {
    /// The mesh with face colors (M*4 RGBA8) and/or a texture added, checked like the rest.
    pub fn with_appearance(
        mut self,
        face_colors: Option<&[u8]>,
        texture: Option<TextureInput<'_>>,
    ) -> Result<Mesh> {
        let n_faces = self.faces.len();
        if let Some(c) = face_colors {
            if c.len() != n_faces * 4 {
                return Err(GeomtexError::Mesh(format!(
                    "face colors hold {} values; expected {} (RGBA for each of {n_faces} faces)",
                    c.len(),
                    n_faces * 4
                )));
            }
            let rows = c.chunks_exact(4).map(|q| [q[0], q[1], q[2], q[3]]);
            self.appearance.face_colors = Some(rows.collect());
        }
        if let Some(t) = texture {
            let coords = texture_coords(&t, self.positions.len(), n_faces)?;
            let image = Arc::new(Image::new(t.width, t.height, t.pixels)?);
            self.appearance.texture = Some(Texture { coords, image });
        }
        Ok(self)
    }

    /// How face `f` colors its points. `grid` places the face's corners on the grid it is drawn
    /// on (texels), so a texture is averaged over one grid cell's footprint; None samples it
    /// bilinearly at full size.
    pub fn face_color(&self, f: u32, grid: Option<[DVec2; 3]>) -> FaceColor<'_> {
        let f = f as usize;
        let tri = self.faces[f];
        if let Some(Texture { coords, image }) = &self.appearance.texture {
            let uv = match coords {
                TextureCoords::PerVertex(uv) => tri.map(|v| uv[v as usize]),
                TextureCoords::PerCorner(uv) => uv[f],
            };
            let footprint = grid.map_or(0.0, |g| footprint(g, uv, image));
            return FaceColor::Texture {
                image,
                uv,
                footprint,
            };
        }
        if let Some(fc) = &self.appearance.face_colors {
            return FaceColor::Uniform(fc[f]);
        }
        match &self.colors {
            Some(vc) => FaceColor::Corners(tri.map(|v| vc[v as usize])),
            None => FaceColor::Uniform(crate::gtex::NEUTRAL_COLOR),
        }
    }

    /// The base color at barycentric point `l` of face `f`, whatever the source (a texture
    /// sampled bilinearly at full size).
    pub fn base_color(&self, f: u32, l: [f64; 3]) -> [u8; 4] {
        self.face_color(f, None).at(l)
    }

    /// Whether the mesh carries any color source.
    pub fn has_colors(&self) -> bool {
        self.colors.is_some()
            || self.appearance.face_colors.is_some()
            || self.appearance.texture.is_some()
    }
}

/// Which normal a face's corners take: the keyword `normals` of `convert` and `Scene.add`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalSource {
    /// Smooth within a surface, split across edges sharper than the crease angle.
    Crease,
    /// One normal per vertex, averaged over all of its faces.
    Smooth,
    /// The face's own normal.
    Flat,
}

impl FromStr for NormalSource {
    type Err = GeomtexError;

    /// "crease" | "smooth" | "flat".
    fn from_str(s: &str) -> Result<Self> {
        parse_choice(
            "normals",
            s,
            &[
                ("crease", NormalSource::Crease),
                ("smooth", NormalSource::Smooth),
                ("flat", NormalSource::Flat),
            ],
        )
    }
}

/// The crease angle (degrees) when none is given: trimesh's `smooth_shade` default.
pub const DEFAULT_CREASE_ANGLE: f64 = 20.0;

/// A mesh and the rule its normals follow (the same as `convert`'s): the payload of the
/// renderers' mesh kind, and a hybrid set's triangles.
pub struct ShadedMesh {
    pub mesh: std::sync::Arc<Mesh>,
    pub rule: NormalRule,
    /// How far (object units) a vertex may lie from the source's it stands for: 0 for a mesh
    /// drawn as given; a hybrid set's triangles keep f32 offsets (gtex/triangles.rs).
    pub stored_rounding: f64,
    /// The diagonal of the box around its vertices, found once (`diagonal`): every frame's
    /// error bounds read it, and a pass over a million vertices took 0.6 ms.
    pub(crate) diagonal: std::sync::OnceLock<f64>,
}

impl ShadedMesh {
    /// `mesh` drawn as given, its normals under `rule`.
    pub fn new(mesh: std::sync::Arc<Mesh>, rule: NormalRule) -> ShadedMesh {
        ShadedMesh {
            mesh,
            rule,
            stored_rounding: 0.0,
            diagonal: std::sync::OnceLock::new(),
        }
    }

    /// The diagonal of the box around the mesh's vertices (0 without any).
    pub fn diagonal(&self) -> f64 {
        *self.diagonal.get_or_init(|| {
            let points = &self.mesh.positions;
            let (lo, hi) = points.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), &p| (lo.min(p), hi.max(p)),
            );
            if points.is_empty() {
                0.0
            } else {
                (hi - lo).length()
            }
        })
    }
}

/// How normals vary over a mesh's faces: a source and, for `Crease`, its angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalRule {
    pub source: NormalSource,
    /// Two faces sharing an edge are smoothed across it only if their normals differ by less
    /// than this many degrees, in (0, 180].
    pub crease_angle: f64,
}

impl Default for NormalRule {
    fn default() -> Self {
        NormalRule {
            source: NormalSource::Crease,
            crease_angle: DEFAULT_CREASE_ANGLE,
        }
    }
}

impl NormalRule {
    /// The rule the keywords `normals` and `crease_angle` (degrees) give, the default for each
    /// one not given. `crease_angle` must lie in (0, 180] and goes with `normals="crease"` only.
    pub fn from_keywords(source: Option<NormalSource>, crease_angle: Option<f64>) -> Result<Self> {
        let default = NormalRule::default();
        let source = source.unwrap_or(default.source);
        if let Some(a) = crease_angle {
            if !(a > 0.0 && a <= 180.0) {
                return Err(GeomtexError::Parameter(format!(
                    "crease_angle must be in (0, 180] degrees, got {a}"
                )));
            }
            if source != NormalSource::Crease {
                return Err(GeomtexError::Parameter(format!(
                    "crease_angle is used only with normals='crease', not with normals='{}'",
                    format!("{source:?}").to_lowercase()
                )));
            }
        }
        Ok(NormalRule {
            source,
            crease_angle: crease_angle.unwrap_or(default.crease_angle),
        })
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

    /// The same rows with each item once, sorted.
    pub fn deduplicated(self) -> Csr {
        let mut offsets = Vec::with_capacity(self.offsets.len());
        offsets.push(0u32);
        let mut items = Vec::with_capacity(self.items.len());
        for r in 0..self.offsets.len() - 1 {
            let start = items.len();
            items.extend_from_slice(self.row(r));
            items[start..].sort_unstable();
            let mut kept = start;
            for i in start..items.len() {
                if kept == start || items[i] != items[kept - 1] {
                    items[kept] = items[i];
                    kept += 1;
                }
            }
            items.truncate(kept);
            offsets.push(items.len() as u32);
        }
        Csr { offsets, items }
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
    /// Faces with (near) zero area or a repeated vertex: no normal, left out of every chart.
    pub degenerate: Vec<bool>,
    /// Unit vertex normals weighted by corner angle, as trimesh weights them (shared by vertices
    /// at the same position).
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
    order.par_sort_unstable_by_key(|&v| (key(v), v));
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

/// Normals, areas and corner angles of the faces, which are degenerate, and the
/// vertex normals.
struct FaceGeometry {
    normals: Vec<DVec3>,
    areas: Vec<f64>,
    degenerate: Vec<bool>,
    vertex_normals: Vec<DVec3>,
}

/// The angle at each corner of triangle (a, b, c), by atan2 so slivers keep their precision.
fn corner_angles([a, b, c]: [DVec3; 3]) -> [f64; 3] {
    let angle = |p: DVec3, q: DVec3, r: DVec3| {
        let (u, v) = (q - p, r - p);
        u.cross(v).length().atan2(u.dot(v))
    };
    [angle(a, b, c), angle(b, c, a), angle(c, a, b)]
}

impl FaceGeometry {
    fn new(mesh: &Mesh, weld: &[u32], diagonal: f64) -> FaceGeometry {
        let (nf, nv) = (mesh.faces.len(), mesh.positions.len());
        // Relative to the model size so a micrometre part and a 1e6-offset scan behave alike.
        let area_eps = (diagonal * 1e-10).powi(2);
        let mut g = FaceGeometry {
            normals: vec![DVec3::ZERO; nf],
            areas: vec![0.0; nf],
            degenerate: vec![false; nf],
            vertex_normals: vec![DVec3::ZERO; nv],
        };
        for (f, t) in mesh.faces.iter().enumerate() {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            // Edges from the centroid-free form keep precision for far-from-origin models.
            let cross = (b - a).cross(c - a);
            let twice_area = cross.length();
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || twice_area * 0.5 <= area_eps {
                g.degenerate[f] = true;
                continue;
            }
            g.areas[f] = twice_area * 0.5;
            g.normals[f] = cross / twice_area;
            for (&v, angle) in t.iter().zip(corner_angles([a, b, c])) {
                g.vertex_normals[weld[v as usize] as usize] += g.normals[f] * angle;
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

/// A face's corners by welded vertex.
fn welded_corners(mesh: &Mesh, weld: &[u32], f: usize) -> [u32; 3] {
    mesh.faces[f].map(|v| weld[v as usize])
}

/// The items of two ascending rows that both hold, ascending, into `out` (cleared first): each
/// item of the shorter row looked up in the longer, so a fan of thousands of faces around one
/// vertex costs its neighbours' few lookups, not thousands each.
fn common_items(a: &[u32], b: &[u32], out: &mut Vec<u32>) {
    let (short, long) = if a.len() <= b.len() { (a, b) } else { (b, a) };
    out.clear();
    out.extend(
        short
            .iter()
            .copied()
            .filter(|x| long.binary_search(x).is_ok()),
    );
}

impl EdgeAdjacency {
    /// Through the faces around each welded vertex: the faces on an edge are those around both
    /// of its ends. Linear in the faces, holding nothing beyond the rows it builds (a sort of
    /// every (edge, face) pair held 48 bytes per face, then 48 more of face pairs: the peak of a
    /// 1.1 M-face conversion). Rows are as that sort made them: face neighbours ascending,
    /// manifold neighbours by their shared edge's (lower, higher) welded vertex.
    fn new(mesh: &Mesh, weld: &[u32], degenerate: &[bool], vertex_faces: &Csr) -> EdgeAdjacency {
        let nf = mesh.faces.len();
        let mut edge_counts = EdgeCounts::default();
        let mut neighbors = CsrBuilder::with_capacity(nf, 3 * nf);
        let mut manifold = CsrBuilder::with_capacity(nf, 3 * nf);
        let (mut on_edge, mut row) = (Vec::new(), Vec::new());
        for (f, &degenerate) in degenerate.iter().enumerate() {
            if degenerate {
                neighbors.end_row();
                manifold.end_row();
                continue;
            }
            let w = welded_corners(mesh, weld, f);
            // (edge key, the face across | AGREE_BIT) of each manifold edge.
            let mut across: [Option<((u32, u32), u32)>; 3] = [None; 3];
            row.clear();
            for k in 0..3 {
                let (a, b) = (w[k], w[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                common_items(
                    vertex_faces.row(a as usize),
                    vertex_faces.row(b as usize),
                    &mut on_edge,
                );
                row.extend(on_edge.iter().copied().filter(|&g| g as usize != f));
                // Each edge is counted once, by the lowest face on it.
                let first = on_edge.first() == Some(&(f as u32));
                match on_edge.len() {
                    1 => edge_counts.boundary += usize::from(first),
                    2 => {
                        let g = on_edge[usize::from(first)];
                        // Two faces agreeing on orientation walk their shared edge in opposite
                        // directions.
                        let agree = !walks(welded_corners(mesh, weld, g as usize), a, b);
                        edge_counts.inconsistent += usize::from(first && !agree);
                        let bit = if agree { AGREE_BIT } else { 0 };
                        across[k] = Some((key, g | bit));
                    }
                    _ => edge_counts.nonmanifold += usize::from(first),
                }
            }
            row.sort_unstable();
            row.dedup();
            neighbors.push_row(&row);
            let mut across: Vec<_> = across.into_iter().flatten().collect();
            across.sort_unstable_by_key(|&(key, _)| key);
            manifold.push_row_iter(across.into_iter().map(|(_, g)| g));
        }
        EdgeAdjacency {
            face_neighbors: neighbors.finish(),
            manifold_neighbors: manifold.finish(),
            edge_counts,
        }
    }
}

/// Whether a face with welded corners `w` walks from `a` to `b` along one of its edges.
fn walks(w: [u32; 3], a: u32, b: u32) -> bool {
    (0..3).any(|k| w[k] == a && w[(k + 1) % 3] == b)
}

/// A `Csr` built row after row, in row order.
struct CsrBuilder {
    csr: Csr,
}

impl CsrBuilder {
    fn with_capacity(rows: usize, items: usize) -> CsrBuilder {
        let mut offsets = Vec::with_capacity(rows + 1);
        offsets.push(0);
        CsrBuilder {
            csr: Csr {
                offsets,
                items: Vec::with_capacity(items),
            },
        }
    }

    fn end_row(&mut self) {
        self.csr.offsets.push(self.csr.items.len() as u32);
    }

    fn push_row(&mut self, row: &[u32]) {
        self.csr.items.extend_from_slice(row);
        self.end_row();
    }

    fn push_row_iter(&mut self, row: impl Iterator<Item = u32>) {
        self.csr.items.extend(row);
        self.end_row();
    }

    /// The rows, their items' spare capacity given back.
    fn finish(mut self) -> Csr {
        self.csr.items.shrink_to_fit();
        self.csr
    }
}

/// Faces around each vertex (welded vertices list the same faces), ascending: counted then
/// filled per welded vertex, with no list of (vertex, face) pairs.
fn vertex_faces(mesh: &Mesh, weld: &[u32], degenerate: &[bool], duplicates: usize) -> Csr {
    let (nf, nv) = (mesh.faces.len(), mesh.positions.len());
    // Each face once around each of its distinct welded corners (a face's corners are distinct
    // unless it is degenerate, but a repeat must not list it twice).
    let corners = |f: usize| {
        let w = welded_corners(mesh, weld, f);
        (0..3)
            .filter(move |&k| !w[..k].contains(&w[k]))
            .map(move |k| w[k])
    };
    let mut offsets = vec![0u32; nv + 1];
    for f in (0..nf).filter(|&f| !degenerate[f]) {
        for w in corners(f) {
            offsets[w as usize + 1] += 1;
        }
    }
    for v in 0..nv {
        offsets[v + 1] += offsets[v];
    }
    let mut items = vec![0u32; offsets[nv] as usize];
    let mut fill: Vec<u32> = offsets[..nv].to_vec();
    for f in (0..nf).filter(|&f| !degenerate[f]) {
        for w in corners(f) {
            items[fill[w as usize] as usize] = f as u32;
            fill[w as usize] += 1;
        }
    }
    let welded = Csr { offsets, items };
    if duplicates == 0 {
        return welded; // every vertex is its own weld
    }
    // Every vertex lists its weld group's faces.
    let mut all = CsrBuilder::with_capacity(nv, welded.items.len() + duplicates * 6);
    for &w in weld {
        all.push_row(welded.row(w as usize));
    }
    all.finish()
}

impl MeshGeometry {
    pub fn new(mesh: &Mesh) -> MeshGeometry {
        let diagonal = mesh.diagonal();
        let (weld, duplicate_vertices) = weld(mesh);
        crate::profile::memory("geometry: weld");
        let faces = FaceGeometry::new(mesh, &weld, diagonal);
        crate::profile::memory("geometry: faces");
        let vertex_faces = vertex_faces(mesh, &weld, &faces.degenerate, duplicate_vertices);
        crate::profile::memory("geometry: vertex faces");
        let edges = EdgeAdjacency::new(mesh, &weld, &faces.degenerate, &vertex_faces);
        crate::profile::memory("geometry: edges");
        MeshGeometry {
            face_normals: faces.normals,
            face_areas: faces.areas,
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

    /// `corner_normals`, the geometry consumed: every array they are not made from is freed
    /// first, so they are allocated in its place rather than on top of it (the frame stage of a
    /// 1.1 M-face conversion held both), and flat or smooth normals are moved, not copied.
    pub fn into_corner_normals(mut self, mesh: &Mesh, rule: NormalRule) -> CornerNormals {
        self.face_areas = Vec::new();
        self.face_neighbors = Csr::default();
        self.vertex_faces = Csr::default();
        match rule.source {
            NormalSource::Flat => CornerNormals::flat(mesh, self.face_normals),
            NormalSource::Smooth => CornerNormals::smooth(mesh, self.vertex_normals),
            NormalSource::Crease => {
                self.vertex_normals = Vec::new();
                self.crease_normals(mesh, rule.crease_angle.to_radians().cos())
            }
        }
    }

    /// Per face, the unit normal at each of its corners under `rule` (zero for degenerate
    /// faces). `Crease`: each corner averages, weighted by corner angle as trimesh weights its
    /// vertex normals, the faces around its vertex that are reachable from its own face across
    /// manifold edges sharper by less than the crease angle; trimesh's `smooth_shade` splits the
    /// same edges. Union-find over the corners: linear in the faces (inverse Ackermann aside).
    pub fn corner_normals(&self, mesh: &Mesh, rule: NormalRule) -> CornerNormals {
        match rule.source {
            NormalSource::Flat => CornerNormals::flat(mesh, self.face_normals.clone()),
            NormalSource::Smooth => CornerNormals::smooth(mesh, self.vertex_normals.clone()),
            NormalSource::Crease => self.crease_normals(mesh, rule.crease_angle.to_radians().cos()),
        }
    }

    /// `corner_normals` for `Crease`: faces whose normals' dot product exceeds `min_cos` are
    /// smooth across their shared edge.
    fn crease_normals(&self, mesh: &Mesh, min_cos: f64) -> CornerNormals {
        let corner_vertex = |c: usize| self.weld[mesh.faces[c / 3][c % 3] as usize];
        // Corner 3 f + k is corner k of face f; each class is one smooth fan around a vertex.
        let mut fans = UnionFind::new(3 * mesh.faces.len());
        for f in 0..mesh.faces.len() {
            for &item in self.manifold_neighbors.row(f) {
                let g = (item & !AGREE_BIT) as usize;
                if g < f || self.face_normals[f].dot(self.face_normals[g]) <= min_cos {
                    continue;
                }
                // The two corners of each face on the shared edge meet their twins.
                for cf in 3 * f..3 * f + 3 {
                    for cg in 3 * g..3 * g + 3 {
                        if corner_vertex(cf) == corner_vertex(cg) {
                            fans.union(cf, cg);
                        }
                    }
                }
            }
        }
        // One normal per fan, summed then normalized, and each corner's fan: 24 bytes per face
        // and 8 per fan instead of 72 per face (corner normals were the largest allocation of a
        // 1.1 M-face conversion). Angles are recomputed here rather than kept per face.
        let (fan, fan_count) = fans.into_sets();
        let mut normals = vec![DVec3::ZERO; fan_count];
        for (f, t) in mesh.faces.iter().enumerate() {
            if self.degenerate[f] {
                continue;
            }
            let angles = corner_angles(t.map(|v| mesh.positions[v as usize]));
            for (k, angle) in angles.into_iter().enumerate() {
                normals[fan[3 * f + k] as usize] += self.face_normals[f] * angle;
            }
        }
        let normals = normals.into_iter().map(DVec3::normalize_or_zero).collect();
        CornerNormals { fan, normals }
    }
}

/// The unit normal at every face corner under a `NormalRule`, kept once per fan of corners that
/// share it (a face for flat normals, a vertex for smooth ones, a smooth fan for creases).
pub struct CornerNormals {
    /// Per corner (3 f + k is corner k of face f), its fan.
    fan: Vec<u32>,
    normals: Vec<DVec3>,
}

impl CornerNormals {
    /// Each corner takes its face's normal.
    fn flat(mesh: &Mesh, face_normals: Vec<DVec3>) -> CornerNormals {
        CornerNormals {
            fan: (0..3 * mesh.faces.len() as u32).map(|c| c / 3).collect(),
            normals: face_normals,
        }
    }

    /// Each corner takes its vertex's normal.
    fn smooth(mesh: &Mesh, vertex_normals: Vec<DVec3>) -> CornerNormals {
        CornerNormals {
            fan: mesh.faces.iter().flatten().copied().collect(),
            normals: vertex_normals,
        }
    }

    /// The normals at face `f`'s three corners.
    pub fn face(&self, f: usize) -> [DVec3; 3] {
        std::array::from_fn(|k| self.normals[self.fan[3 * f + k] as usize])
    }

    /// Every face's corner normals, in face order.
    pub fn faces(&self) -> impl Iterator<Item = [DVec3; 3]> + '_ {
        (0..self.fan.len() / 3).map(|f| self.face(f))
    }
}

/// Disjoint sets of 0..n with path halving. Corners are only ever joined around one vertex,
/// so a chain is at most one fan long and the whole pass stays linear without ranks.
struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    fn new(n: usize) -> UnionFind {
        UnionFind {
            parent: (0..n as u32).collect(),
        }
    }

    fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] as usize != x {
            let grand = self.parent[self.parent[x] as usize];
            self.parent[x] = grand;
            x = grand as usize;
        }
        x
    }

    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        self.parent[hi] = lo as u32;
    }

    /// Each element's set, numbered 0, 1, ... in the order of their lowest elements, written
    /// over the parents (no second array as large), and how many sets there are. A root is the lowest element of its set
    /// (`union`), so every parent is at most its child: in ascending order each element's
    /// parent already holds its root, then its root already holds the set's number.
    fn into_sets(mut self) -> (Vec<u32>, usize) {
        for x in 0..self.parent.len() {
            self.parent[x] = self.parent[self.parent[x] as usize];
        }
        let mut sets = 0;
        for x in 0..self.parent.len() {
            let root = self.parent[x] as usize;
            self.parent[x] = if root == x {
                sets += 1;
                sets - 1
            } else {
                self.parent[root]
            };
        }
        (self.parent, sets as usize)
    }
}

/// Two triangles per cell of an `nx` x `ny` grid of cells whose (nx + 1) x (ny + 1) vertices are
/// numbered row by row, wound counter-clockwise seen from +z when x and y grow with i and j:
/// the faces of the test meshes built on grids.
#[cfg(test)]
pub(crate) fn grid_faces(nx: usize, ny: usize) -> Vec<i64> {
    let v = |i: usize, j: usize| (j * (nx + 1) + i) as i64;
    let mut faces = Vec::with_capacity(6 * nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            faces.extend_from_slice(&[v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
            faces.extend_from_slice(&[v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    faces
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

    /// The adjacency by brute force over a map from each welded edge to the faces on it (in
    /// face order, with the direction each walks it): what `EdgeAdjacency` must equal.
    fn adjacency_by_edge_map(mesh: &Mesh, g: &MeshGeometry) -> (Vec<Vec<u32>>, Vec<Vec<u32>>) {
        let nf = mesh.faces.len();
        let mut on_edge: std::collections::HashMap<(u32, u32), Vec<(u32, bool)>> =
            Default::default();
        for f in (0..nf).filter(|&f| !g.degenerate[f]) {
            let w = mesh.faces[f].map(|v| g.weld[v as usize]);
            for k in 0..3 {
                let (a, b) = (w[k], w[(k + 1) % 3]);
                on_edge
                    .entry((a.min(b), a.max(b)))
                    .or_default()
                    .push((f as u32, a < b));
            }
        }
        let mut neighbors = vec![Vec::new(); nf];
        let mut manifold: Vec<Vec<((u32, u32), u32)>> = vec![Vec::new(); nf];
        for (&key, faces) in &on_edge {
            for &(f, _) in faces {
                neighbors[f as usize].extend(faces.iter().map(|p| p.0).filter(|&x| x != f));
            }
            if let [(f, df), (h, dh)] = faces[..] {
                let bit = if df != dh { AGREE_BIT } else { 0 };
                manifold[f as usize].push((key, h | bit));
                manifold[h as usize].push((key, f | bit));
            }
        }
        for n in &mut neighbors {
            n.sort_unstable();
            n.dedup();
        }
        let manifold = manifold
            .into_iter()
            .map(|mut m| {
                m.sort_unstable();
                m.into_iter().map(|(_, x)| x).collect()
            })
            .collect();
        (neighbors, manifold)
    }

    #[test]
    fn adjacency_matches_an_edge_map() {
        // Winding flips, a non-manifold fin, a duplicated face, a degenerate one and a soup.
        let mut mesh = grid();
        for f in [0, 7, 20] {
            mesh.faces[f].swap(1, 2);
        }
        mesh.positions.push(DVec3::new(1.5, 1.5, 1.0));
        mesh.faces.push([6, 12, 25]);
        mesh.faces.push(mesh.faces[9]);
        mesh.faces.push([3, 3, 4]);
        let soup = Mesh {
            positions: mesh
                .faces
                .iter()
                .flatten()
                .map(|&v| mesh.positions[v as usize])
                .collect(),
            faces: (0..mesh.faces.len() as u32)
                .map(|f| [3 * f, 3 * f + 1, 3 * f + 2])
                .collect(),
            colors: None,
            appearance: Appearance::default(),
        };
        for m in [&mesh, &soup, &cube()] {
            let g = MeshGeometry::new(m);
            let (neighbors, manifold) = adjacency_by_edge_map(m, &g);
            for f in 0..m.faces.len() {
                assert_eq!(g.face_neighbors.row(f), &neighbors[f][..], "face {f}");
                assert_eq!(g.manifold_neighbors.row(f), &manifold[f][..], "face {f}");
            }
        }
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

    /// The unit cube's 8 corners and 12 faces, wound outwards.
    fn cube() -> Mesh {
        let mut positions = Vec::new();
        for i in 0..8 {
            positions.extend([(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64]);
        }
        #[rustfmt::skip]
        let faces = [
            0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, // z = 0, z = 1
            0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, // y = 0, y = 1
            0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5, // x = 0, x = 1
        ];
        Mesh::from_flat(&positions, &faces, None).unwrap()
    }

    /// A UV sphere of radius 1 with `n` segments around and `n / 2` rings.
    fn sphere(n: usize) -> Mesh {
        let rings = n / 2;
        let mut positions = vec![0.0, 0.0, 1.0];
        for r in 1..rings {
            let theta = std::f64::consts::PI * r as f64 / rings as f64;
            for s in 0..n {
                let phi = std::f64::consts::TAU * s as f64 / n as f64;
                positions.extend([
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                ]);
            }
        }
        positions.extend([0.0, 0.0, -1.0]);
        let ring = |r: usize, s: usize| (1 + (r - 1) * n + s % n) as i64;
        let south = (positions.len() / 3 - 1) as i64;
        let mut faces = Vec::new();
        for s in 0..n {
            faces.extend([0, ring(1, s), ring(1, s + 1)]);
            for r in 1..rings - 1 {
                let (a, b) = (ring(r, s), ring(r, s + 1));
                let (c, d) = (ring(r + 1, s), ring(r + 1, s + 1));
                faces.extend([a, c, d, a, d, b]);
            }
            faces.extend([ring(rings - 1, s), south, ring(rings - 1, s + 1)]);
        }
        Mesh::from_flat(&positions, &faces, None).unwrap()
    }

    fn angle_deg(a: DVec3, b: DVec3) -> f64 {
        a.angle_between(b).to_degrees()
    }

    #[test]
    fn crease_normals_of_a_box_are_its_face_normals() {
        let m = cube();
        let g = MeshGeometry::new(&m);
        let crease = g.corner_normals(&m, NormalRule::default());
        for (f, corners) in crease.faces().enumerate() {
            for n in corners {
                assert!(angle_deg(n, g.face_normals[f]) < 1e-9, "face {f}: {n}");
            }
        }
        // Smooth: angle weights give each corner the exact diagonal, whatever the
        // triangulation (each square side contributes 90 degrees, split or not).
        let smooth = g.corner_normals(
            &m,
            NormalRule::from_keywords(Some(NormalSource::Smooth), None).unwrap(),
        );
        for (f, corners) in smooth.faces().enumerate() {
            for (k, n) in corners.into_iter().enumerate() {
                let p = m.positions[m.faces[f][k] as usize] - DVec3::splat(0.5);
                assert!(angle_deg(n, p) < 1e-9, "face {f} corner {k}: {n}");
            }
        }
        // Above the box's 90-degree dihedral every edge is smooth again.
        let wide = NormalRule::from_keywords(None, Some(91.0)).unwrap();
        for (a, b) in g.corner_normals(&m, wide).faces().zip(smooth.faces()) {
            for k in 0..3 {
                assert!(angle_deg(a[k], b[k]) < 1e-9);
            }
        }
    }

    #[test]
    fn crease_normals_of_a_fine_sphere_are_smooth() {
        let m = sphere(64); // 5.6 degrees between neighbouring faces
        let g = MeshGeometry::new(&m);
        let crease = g.corner_normals(&m, NormalRule::default());
        let smooth = g.corner_normals(
            &m,
            NormalRule::from_keywords(Some(NormalSource::Smooth), None).unwrap(),
        );
        for (f, (c, s)) in crease.faces().zip(smooth.faces()).enumerate() {
            for k in 0..3 {
                assert!(angle_deg(c[k], s[k]) < 1e-9, "face {f} corner {k}");
                let p = m.positions[m.faces[f][k] as usize];
                assert!(
                    angle_deg(c[k], p) < 0.5,
                    "face {f} corner {k}: {} vs {p}",
                    c[k]
                );
            }
        }
        // Below the dihedral between neighbouring quads (about 5 degrees near the equator; each
        // quad's two triangles are coplanar) every quad is shaded flat.
        let sharp = NormalRule::from_keywords(None, Some(3.0)).unwrap();
        for (f, c) in g.corner_normals(&m, sharp).faces().enumerate() {
            let equatorial = m.faces[f]
                .iter()
                .all(|&v| m.positions[v as usize].z.abs() < 0.5);
            if equatorial {
                assert!(
                    c.iter().all(|n| angle_deg(*n, g.face_normals[f]) < 1e-4),
                    "face {f}: {:?}",
                    c.map(|n| angle_deg(n, g.face_normals[f]))
                );
            }
        }
    }

    #[test]
    fn normal_keywords_parse_and_bad_values_say_why() {
        assert_eq!(
            "crease".parse::<NormalSource>().unwrap(),
            NormalSource::Crease
        );
        let bad = |s: Option<NormalSource>, a: f64| {
            NormalRule::from_keywords(s, Some(a))
                .unwrap_err()
                .to_string()
        };
        for a in [0.0, -5.0, 180.5, f64::NAN] {
            assert!(
                bad(None, a).contains("crease_angle must be in (0, 180]"),
                "{a}"
            );
        }
        assert!(bad(Some(NormalSource::Flat), 30.0).contains("normals='flat'"));
        let e = "bumpy".parse::<NormalSource>().unwrap_err().to_string();
        assert!(e.contains("'crease', 'smooth' or 'flat'"), "{e}");
        assert_eq!(
            NormalRule::from_keywords(None, Some(180.0))
                .unwrap()
                .crease_angle,
            180.0
        );
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

    fn triangle() -> Mesh {
        Mesh::from_flat(&[0., 0., 0., 1., 0., 0., 0., 1., 0.], &[0, 1, 2], None).unwrap()
    }

    /// A 4 x 2 image: left half black, right half white (row 0 at the top).
    fn halves() -> Vec<u8> {
        (0..8)
            .flat_map(|p| {
                let v = if p % 4 >= 2 { 255 } else { 0 };
                [v, v, v, 255]
            })
            .collect()
    }

    #[test]
    fn every_source_gives_the_color_at_a_point() {
        let plain = triangle();
        assert_eq!(
            plain.base_color(0, [1.0, 0.0, 0.0]),
            crate::gtex::NEUTRAL_COLOR
        );
        let faced = triangle()
            .with_appearance(Some(&[10, 20, 30, 255]), None)
            .unwrap();
        assert_eq!(faced.base_color(0, [0.2, 0.3, 0.5]), [10, 20, 30, 255]);
        let image = halves();
        let uv = [0.0, 0.5, 1.0, 0.5, 0.0, 0.5];
        let input = TextureInput {
            coords: &uv,
            per_corner: false,
            width: 4,
            height: 2,
            pixels: &image,
        };
        let textured = triangle().with_appearance(None, Some(input)).unwrap();
        // u = 0.25 lies at pixel centre 1 (black), u = 0.75 at pixel centre 3 (white), and
        // u = 0.5 halfway between pixels 1 and 2.
        assert_eq!(textured.base_color(0, [0.75, 0.25, 0.0])[0], 0);
        assert_eq!(textured.base_color(0, [0.25, 0.75, 0.0])[0], 255);
        assert_eq!(textured.base_color(0, [0.5, 0.5, 0.0])[0], 128);
        // Drawn on a grid one unit per face: each grid cell spans 4 pixels, so level 2 (one
        // pixel, the mean) is read.
        let grid = [DVec2::ZERO, DVec2::X, DVec2::Y];
        let coarse = textured.face_color(0, Some(grid));
        assert_eq!(coarse.at([0.75, 0.25, 0.0])[0], 128);
    }

    #[test]
    fn bad_appearance_is_named() {
        let e = |r: Result<Mesh>| r.unwrap_err().to_string();
        let msg = e(triangle().with_appearance(Some(&[0; 5]), None));
        assert!(msg.contains("face colors hold 5"), "{msg}");
        let image = halves();
        let mut uv = [0.0; 6];
        uv[3] = f64::NAN;
        let input = |coords: &'static [f64], per_corner, pixels: &'static [u8]| TextureInput {
            coords,
            per_corner,
            width: 4,
            height: 2,
            pixels,
        };
        let nan: &'static [f64] = Box::leak(Box::new(uv));
        let pixels: &'static [u8] = Box::leak(image.into_boxed_slice());
        let msg = e(triangle().with_appearance(None, Some(input(nan, false, pixels))));
        assert!(msg.contains("v of vertex 1"), "{msg}");
        let msg = e(triangle().with_appearance(None, Some(input(nan, true, pixels))));
        assert!(msg.contains("v of face 0 corner 1"), "{msg}");
        let msg = e(triangle().with_appearance(None, Some(input(&nan[..4], true, pixels))));
        assert!(msg.contains("expected 6"), "{msg}");
        let msg = e(triangle().with_appearance(None, Some(input(&[0.0; 6], false, &[]))));
        assert!(msg.contains("holds 0 values"), "{msg}");
        let empty = TextureInput {
            width: 0,
            ..input(&[0.0; 6], false, &[])
        };
        let msg = e(triangle().with_appearance(None, Some(empty)));
        assert!(msg.contains("empty"), "{msg}");
    }

    #[test]
    fn rewinding_swaps_corner_coordinates() {
        let uv = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
        let pixels = [0u8; 4];
        let input = TextureInput {
            coords: &uv,
            per_corner: true,
            width: 1,
            height: 1,
            pixels: &pixels,
        };
        let m = triangle().with_appearance(None, Some(input)).unwrap();
        let flipped = m.appearance.rewound(&[true]);
        let Some(Texture {
            coords: TextureCoords::PerCorner(c),
            ..
        }) = flipped.texture
        else {
            panic!("per-corner coordinates expected");
        };
        assert_eq!(c[0], [DVec2::ZERO, DVec2::Y, DVec2::X]);
    }
}
