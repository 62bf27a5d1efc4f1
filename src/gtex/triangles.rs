//! A set's triangles: the regions a hybrid conversion keeps as the source mesh's own faces, where
//! a height map would cost more bytes than those faces or could not meet the error bound.
//!
//! Space: world, as the patches (the source mesh's coordinates, f64 in memory; the file stores
//! f32 offsets from the vertices' bounding-box centre, so far-off meshes keep their detail).
//!
//! The faces of every cluster (one per chart kept as triangles) share one vertex list, so a
//! vertex on the border of two clusters is stored once, as in the mesh: all-triangles costs the
//! mesh's own bytes, never more. Cluster `c` is faces `starts[c]..starts[c + 1]`.

use std::fmt;
use std::sync::Arc;

use glam::DVec3;

use crate::mesh::{Mesh, NormalRule, ShadedMesh};

/// Why a chart was kept as triangles (one per cluster; the file stores the code).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum KeptBecause {
    /// No height map taking fewer bytes than its faces met the error bound.
    Bound = 0,
    /// Its height map met the bound in fewer bytes, but the set as a whole would have cost more
    /// than the mesh (a vertex on a patch/triangle border counts on both sides).
    Budget = 1,
}

impl KeptBecause {
    pub fn from_code(code: u8) -> Option<KeptBecause> {
        [Self::Bound, Self::Budget]
            .into_iter()
            .find(|k| *k as u8 == code)
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Bound => "bound",
            Self::Budget => "budget",
        }
    }
}

/// Bytes of `vertices` vertices and `faces` faces as a mesh stores them: float32 positions and
/// uint32 indices, and RGBA8 per vertex with colors. The one measure a hybrid set weighs its
/// height maps against, and stays within.
pub fn mesh_bytes(vertices: usize, faces: usize, colored: bool) -> usize {
    let per_vertex = if colored { 16 } else { 12 };
    per_vertex * vertices + 12 * faces
}

/// The triangles of a hybrid set; drawn and traced as a mesh (`shaded`) by every backend.
#[derive(Clone)]
pub struct SetTriangles {
    /// The kept faces over the vertices they use (the source's colors per vertex, if any).
    /// Shared with `shaded`, which the renderers' upload caches know by its address: one
    /// upload per set, not per frame.
    pub shaded: Arc<ShadedMesh>,
    /// Face ranges of the clusters: `starts[0] == 0`, the last is the face count.
    pub starts: Vec<u32>,
    /// Per cluster, why its chart stayed triangles.
    pub because: Vec<KeptBecause>,
    /// Per face, the source mesh's face it is (as a patch lists its chart's faces).
    pub source_faces: Vec<u32>,
    /// The point the file stores positions from (as f32 offsets); every position is exactly
    /// `centre` plus an f32 offset, so a set reads back equal to the one written.
    pub(crate) centre: DVec3,
}

/// The farthest a position `centre` + f32 offset may lie from the point it was rounded from:
/// half an f32 step of each offset coordinate (rounding to nearest), plus the f64 sum's rounding.
fn offset_rounding(positions: &[DVec3], centre: DVec3) -> f64 {
    let half_step = |x: f64| {
        let x = (x as f32).abs();
        0.5 * (f64::from(x.next_up()) - f64::from(x))
    };
    let (farthest, largest) = positions.iter().fold((0.0f64, 0.0f64), |(m, l), p| {
        let o = *p - centre;
        let step = DVec3::new(half_step(o.x), half_step(o.y), half_step(o.z)).length();
        (m.max(step), l.max(p.abs().max_element()))
    });
    farthest + 4.0 * f64::EPSILON * largest
}

impl SetTriangles {
    /// Positions are rounded to the bounding-box centre plus f32 offsets, as the file keeps
    /// them (`as_filed`).
    pub fn new(
        mut mesh: Mesh,
        rule: NormalRule,
        starts: Vec<u32>,
        because: Vec<KeptBecause>,
        source_faces: Vec<u32>,
    ) -> SetTriangles {
        let centre = centre_of(&mesh.positions);
        for p in &mut mesh.positions {
            *p = centre + (*p - centre).as_vec3().as_dvec3();
        }
        SetTriangles::filed(mesh, centre, rule, starts, because, source_faces)
    }

    /// As read from a file: positions already `centre` plus f32 offsets.
    pub(crate) fn filed(
        mesh: Mesh,
        centre: DVec3,
        rule: NormalRule,
        starts: Vec<u32>,
        because: Vec<KeptBecause>,
        source_faces: Vec<u32>,
    ) -> SetTriangles {
        let stored_rounding = offset_rounding(&mesh.positions, centre);
        SetTriangles {
            centre,
            shaded: Arc::new(ShadedMesh {
                mesh: Arc::new(mesh),
                rule,
                stored_rounding,
                diagonal: std::sync::OnceLock::new(),
            }),
            starts,
            because,
            source_faces,
        }
    }

    /// The clusters of `mesh`'s faces `clusters` (source face ids, each cluster a chart), over
    /// only the vertices they use, renumbered in first-use order.
    pub fn from_charts(
        mesh: &Mesh,
        rule: NormalRule,
        clusters: Vec<(Vec<u32>, KeptBecause)>,
    ) -> SetTriangles {
        let mut new_index = vec![u32::MAX; mesh.positions.len()];
        let mut positions = Vec::new();
        let mut faces = Vec::new();
        let mut starts = vec![0u32];
        let mut used = Vec::new();
        for (chart, _) in &clusters {
            for &f in chart {
                let face = mesh.faces[f as usize].map(|v| {
                    if new_index[v as usize] == u32::MAX {
                        new_index[v as usize] = positions.len() as u32;
                        positions.push(mesh.positions[v as usize]);
                        used.push(v);
                    }
                    new_index[v as usize]
                });
                faces.push(face);
            }
            starts.push(faces.len() as u32);
        }
        let colors = (mesh.colors.as_ref()).map(|c| used.iter().map(|&v| c[v as usize]).collect());
        let sub = Mesh {
            positions,
            faces,
            colors,
            appearance: Default::default(),
        };
        let because = clusters.iter().map(|c| c.1).collect();
        let source_faces = clusters.into_iter().flat_map(|c| c.0).collect();
        SetTriangles::new(sub, rule, starts, because, source_faces)
    }

    pub fn mesh(&self) -> &Mesh {
        &self.shaded.mesh
    }

    pub fn clusters(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }

    /// Bytes as the mesh's own are counted (`mesh_bytes`).
    pub fn bytes(&self) -> usize {
        let m = self.mesh();
        mesh_bytes(m.positions.len(), m.faces.len(), m.colors.is_some())
    }

    /// Checks what a file or a hand-made set could get wrong.
    pub fn validate(&self) -> Result<(), String> {
        let m = self.mesh();
        let n = m.positions.len();
        if let Some(v) = m.positions.iter().position(|p| !p.is_finite()) {
            return Err(format!("triangles: vertex {v} is not finite"));
        }
        if let Some(f) = (m.faces.iter()).position(|f| f.iter().any(|&v| v as usize >= n)) {
            return Err(format!("triangles: face {f} indexes past the {n} vertices"));
        }
        if (m.colors.as_ref()).is_some_and(|c| c.len() != n) {
            return Err("triangles: one color per vertex expected".into());
        }
        let ordered = self.starts.windows(2).all(|w| w[0] <= w[1]);
        if self.starts.first() != Some(&0)
            || !ordered
            || self.starts.last() != Some(&(m.faces.len() as u32))
        {
            return Err("triangles: cluster starts must rise from 0 to the face count".into());
        }
        if self.because.len() != self.clusters() {
            return Err("triangles: one reason per cluster expected".into());
        }
        if self.source_faces.len() != m.faces.len() {
            return Err("triangles: one source face id per face expected".into());
        }
        Ok(())
    }

    /// Each face's vertices in world space.
    pub fn face_corners(&self) -> impl Iterator<Item = [DVec3; 3]> + '_ {
        let m = self.mesh();
        (m.faces.iter()).map(|f| f.map(|v| m.positions[v as usize]))
    }
}

impl PartialEq for SetTriangles {
    fn eq(&self, other: &Self) -> bool {
        let (a, b) = (self.mesh(), other.mesh());
        a.positions == b.positions
            && a.faces == b.faces
            && a.colors == b.colors
            && self.shaded.rule == other.shaded.rule
            && self.starts == other.starts
            && self.because == other.because
    }
}

impl fmt::Debug for SetTriangles {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "SetTriangles({} clusters, {} faces, {} vertices)",
            self.clusters(),
            self.mesh().faces.len(),
            self.mesh().positions.len()
        )
    }
}

/// The point positions are stored from: their bounding box's centre.
fn centre_of(positions: &[DVec3]) -> DVec3 {
    let lo = positions.iter().fold(DVec3::INFINITY, |a, &p| a.min(p));
    let hi = positions.iter().fold(DVec3::NEG_INFINITY, |a, &p| a.max(p));
    if positions.is_empty() {
        DVec3::ZERO
    } else {
        (lo + hi) * 0.5
    }
}

impl SetTriangles {
    /// Points about `spacing` apart over every face, each with its face's unit normal: a
    /// barycentric grid of n² sub-triangle centroids, n from the longest edge.
    pub fn points(&self, spacing: f64) -> impl Iterator<Item = (DVec3, DVec3)> + '_ {
        self.face_corners().flat_map(move |[a, b, c]| {
            let normal = (b - a).cross(c - a).normalize_or_zero();
            let longest = (b - a).length().max((c - b).length()).max((a - c).length());
            let n = ((longest / spacing).ceil() as usize).clamp(1, 1024);
            let step = 1.0 / n as f64;
            // Upward sub-triangles (i, j) with i + j < n, centred at (i + 1/3, j + 1/3) steps.
            (0..n).flat_map(move |i| {
                (0..n - i).map(move |j| {
                    let (u, v) = ((i as f64 + 1.0 / 3.0) * step, (j as f64 + 1.0 / 3.0) * step);
                    (a + (b - a) * u + (c - a) * v, normal)
                })
            })
        })
    }
}
