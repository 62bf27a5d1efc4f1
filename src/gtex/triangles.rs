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

use crate::mesh::{Mesh, NormalRule, NormalSource};
use crate::render::ShadedMesh;

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
    centre: DVec3,
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
    fn filed(
        mesh: Mesh,
        centre: DVec3,
        rule: NormalRule,
        starts: Vec<u32>,
        because: Vec<KeptBecause>,
        source_faces: Vec<u32>,
    ) -> SetTriangles {
        SetTriangles {
            centre,
            shaded: Arc::new(ShadedMesh {
                mesh: Arc::new(mesh),
                rule,
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

    /// Bytes as the mesh's own are counted: float32 positions and uint32 indices (and RGBA8 per
    /// vertex with colors).
    pub fn bytes(&self) -> usize {
        let m = self.mesh();
        let per_vertex = if m.colors.is_some() { 16 } else { 12 };
        per_vertex * m.positions.len() + 12 * m.faces.len()
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

fn rule_code(rule: NormalRule) -> u32 {
    match rule.source {
        NormalSource::Crease => 0,
        NormalSource::Smooth => 1,
        NormalSource::Flat => 2,
    }
}

/// The triangle section of a version 7 file (layout in file.rs).
pub(crate) fn encode(t: &SetTriangles, out: &mut Vec<u8>) {
    let (m, centre) = (t.mesh(), t.centre);
    super::file::put_f64s(out, &centre.to_array());
    out.extend_from_slice(&rule_code(t.shaded.rule).to_le_bytes());
    super::file::put_f64s(out, &[t.shaded.rule.crease_angle]);
    for n in [
        m.positions.len(),
        m.faces.len(),
        t.clusters(),
        m.colors.is_some() as usize,
    ] {
        out.extend_from_slice(&(n as u32).to_le_bytes());
    }
    for p in &m.positions {
        for x in (*p - centre).as_vec3().to_array() {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    out.extend_from_slice(bytemuck::cast_slice(&m.faces));
    out.extend_from_slice(bytemuck::cast_slice(&t.starts));
    out.extend_from_slice(bytemuck::cast_slice(&t.source_faces));
    out.extend(t.because.iter().map(|&b| b as u8));
    if let Some(colors) = &m.colors {
        out.extend_from_slice(bytemuck::cast_slice(colors));
    }
}

/// Reads what `encode` wrote; sizes are checked before anything is allocated.
pub(crate) fn decode(r: &mut super::file::Reader) -> Result<SetTriangles, String> {
    let centre = r.vec3("triangles: centre")?;
    let source = match r.u32("triangles: normal rule")? {
        0 => NormalSource::Crease,
        1 => NormalSource::Smooth,
        2 => NormalSource::Flat,
        other => return Err(format!("triangles: normal rule {other} is not 0, 1 or 2")),
    };
    let crease_angle = r.f64("triangles: crease angle")?;
    let rule = NormalRule::from_keywords(Some(source), Some(crease_angle))
        .map_err(|e| format!("triangles: {e}"))?;
    let mut counts = [0usize; 4];
    for (k, what) in ["vertices", "faces", "clusters", "color flag"]
        .iter()
        .enumerate()
    {
        counts[k] = r.u32(&format!("triangles: {what}"))? as usize;
    }
    let [vertices, faces, clusters, colored] = counts;
    if colored > 1 {
        return Err(format!(
            "triangles: the color flag must be 0 or 1, found {colored}"
        ));
    }
    let words = |r: &mut super::file::Reader, n: usize, what: &str| -> Result<Vec<u32>, String> {
        let bytes = r.take(n.saturating_mul(4), what)?;
        Ok(bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
            .collect())
    };
    let floats = words(r, vertices.saturating_mul(3), "triangles: positions")?;
    let positions = floats
        .chunks_exact(3)
        .map(|c| {
            centre
                + glam::Vec3::new(
                    f32::from_bits(c[0]),
                    f32::from_bits(c[1]),
                    f32::from_bits(c[2]),
                )
                .as_dvec3()
        })
        .collect();
    let indices = words(r, faces.saturating_mul(3), "triangles: faces")?;
    let faces: Vec<[u32; 3]> = indices
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let starts = words(r, clusters.saturating_add(1), "triangles: cluster starts")?;
    let source_faces = words(r, indices.len() / 3, "triangles: source face ids")?;
    let because = (r.take(clusters, "triangles: reasons")?.iter())
        .map(|&c| KeptBecause::from_code(c).ok_or(format!("triangles: reason code {c}")))
        .collect::<Result<_, _>>()?;
    let colors = match colored {
        1 => Some(
            (r.take(vertices.saturating_mul(4), "triangles: colors")?
                .chunks_exact(4))
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect(),
        ),
        _ => None,
    };
    let mesh = Mesh {
        positions,
        faces,
        colors,
        appearance: Default::default(),
    };
    let t = SetTriangles::filed(mesh, centre, rule, starts, because, source_faces);
    t.validate()?;
    Ok(t)
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
