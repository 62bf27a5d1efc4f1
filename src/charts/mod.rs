//! Cutting a mesh into charts, each with a frame whose projection along z is fold-free for its
//! faces: the geometry (winding, degenerate faces), partition (cone or VSA), folding repair,
//! overlap-ring and frame stages. Shared by `convert`, which draws the charts into height maps,
//! and `igt`, whose charts primary projects the detailed mesh through them.
//!
//! Space: world (the mesh's coordinates, f64).

pub mod cone;
pub mod frame;
pub mod overlap;
pub mod repair;
pub mod sheets;
pub mod vsa;

use std::borrow::Cow;

use rayon::prelude::*;

use crate::convert_options::{ConvertOptions, PartitionMethod};
use crate::error::{GeomtexError, Result};
use crate::mesh::{Mesh, MeshGeometry};
use crate::progress::{Progress, Stages};
use frame::ChartFrame;
use overlap::Ring;
use repair::Folding;

/// The mesh as the stages see it: every face wound like its neighbours, its geometry, and its
/// non-degenerate faces.
pub struct Prepared<'m> {
    pub mesh: Cow<'m, Mesh>,
    pub geo: MeshGeometry,
    pub active: Vec<u32>,
    pub inconsistent_edges: usize,
    pub flipped_faces: usize,
}

/// The geometry stage. Charts are grown from face normals, so reversed triangles would split
/// them into thousands of slivers: every face is wound like its neighbours first.
pub fn prepare<'m>(mesh: &'m Mesh, progress: Progress) -> Result<Prepared<'m>> {
    let geo = MeshGeometry::new(mesh);
    progress.check("geometry")?;
    let inconsistent_edges = geo.edge_counts.inconsistent;
    let flips = geo.winding_flips();
    let flipped_faces = flips.iter().filter(|&&f| f).count();
    let (mesh, geo) = if flipped_faces > 0 {
        let rewound = mesh.rewound(&flips);
        let geo = MeshGeometry::new(&rewound);
        (Cow::Owned(rewound), geo)
    } else {
        (Cow::Borrowed(mesh), geo)
    };
    let active: Vec<u32> = (0..mesh.faces.len() as u32)
        .filter(|&f| !geo.degenerate[f as usize])
        .collect();
    if active.is_empty() {
        return Err(GeomtexError::Mesh(format!(
            "all {} faces are degenerate (zero area or a repeated vertex): nothing to convert",
            mesh.faces.len()
        )));
    }
    Ok(Prepared {
        mesh,
        geo,
        active,
        inconsistent_edges,
        flipped_faces,
    })
}

/// The charts after partition, repair and overlap rings, with what those stages counted.
pub struct Charted {
    pub charts: Vec<repair::Chart>,
    pub rings: Vec<Ring>,
    pub vsa_charts: usize,
    pub vsa_mean_error: f64,
    pub charts_capped: bool,
    pub repair_splits: usize,
    pub sheet_splits: usize,
    pub folding_before: Folding,
}

/// The partition, repair and overlap stages.
pub fn chart_stages(
    prepared: &Prepared,
    opts: &ConvertOptions,
    stages: &mut Stages,
) -> Result<Charted> {
    let (mesh, geo) = (prepared.mesh.as_ref(), &prepared.geo);
    stages.begin("partition")?;
    let partition = match opts.partition_method() {
        PartitionMethod::Cone => {
            cone::partition_mesh(mesh, geo, &prepared.active, opts, stages.progress)?
        }
        PartitionMethod::Vsa => {
            vsa::partition_mesh(mesh, geo, &prepared.active, opts, stages.progress)?
        }
    };
    stages.end("partition");

    stages.begin("repair")?;
    let vsa_charts = partition.groups.len();
    let folding_before = Folding::before_repair(geo, &partition.groups);
    let repaired = repair::repair(mesh, geo, partition.groups);
    stages.end("repair");

    stages.begin("overlap")?;
    let rings: Vec<Ring> = repaired
        .charts
        .par_iter()
        .map(|c| overlap::ring_faces(mesh, geo, &c.faces, c.z, opts.overlap_rings))
        .collect();
    stages.end("overlap");
    Ok(Charted {
        charts: repaired.charts,
        rings,
        vsa_charts,
        vsa_mean_error: partition.mean_error,
        charts_capped: partition.capped,
        repair_splits: repaired.splits,
        sheet_splits: repaired.sheet_splits,
        folding_before,
    })
}

/// A chart as inverse geometric textures use it (igt/): its faces, its overlap ring and its
/// frame, whose orthographic projection along z is fold-free for the faces by construction.
pub struct ChartPlane {
    pub faces: Vec<u32>,
    pub ring: Vec<u32>,
    pub frame: ChartFrame,
}

/// The geometry, partition, repair, overlap and frame stages of a conversion alone (one
/// partition, no rasterizing): the charts and their frames, timed into `stages`.
pub fn chart_planes(
    mesh: &Mesh,
    opts: &ConvertOptions,
    stages: &mut Stages,
) -> Result<Vec<ChartPlane>> {
    opts.validate()?;
    // VSA unless the cone is asked for: the charts are planes for a simplified mesh, whatever
    // `convert`'s default bound would choose.
    let opts = &ConvertOptions {
        partition: Some(opts.partition.unwrap_or(PartitionMethod::Vsa)),
        ..opts.clone()
    };
    stages.begin("geometry")?;
    let prepared = prepare(mesh, stages.progress)?;
    stages.end("geometry");
    let charted = chart_stages(&prepared, opts, stages)?;
    stages.begin("frame")?;
    let planes = charted
        .charts
        .into_par_iter()
        .zip(charted.rings)
        .map(|(c, ring)| {
            let frame = ChartFrame::new(&prepared.mesh, &c.faces, &ring.faces, c.z, opts.in_plane);
            ChartPlane {
                faces: c.faces,
                ring: ring.faces,
                frame,
            }
        })
        .collect();
    stages.end("frame");
    Ok(planes)
}
