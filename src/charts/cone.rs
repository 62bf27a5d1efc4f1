//! The cone partition for height fields: charts as large as the no-fold condition allows.
//!
//! A height field only needs every face of its chart to face up along the chart's z. Each chart
//! keeps a cone (axis, half-angle) that holds all its face normals; a face joins only while the
//! cone stays within `cone_angle` of its axis, so no face comes within 90° - `cone_angle` of
//! inverting when projected on the axis. Charts grow one at a time from a seed, cheapest face
//! first, the cost being the distance from the seed (round charts, small boxes) plus VSA's L2,1
//! error against the cone's axis (the secondary criterion, so a chart prefers faces that fit
//! its axis); a chart also stops at `chart_size` of the diagonal from its seed, because the
//! largest chart sets everyone's texel. Then small charts merge into a neighbour while the
//! merged cone and size still fit, so isolated noisy faces do not each keep a chart.
//!
//! Every step is linear in the faces (plus a heap's log): adjacency is the mesh's CSR, labels
//! and members are flat arrays.
//!
//! Space: face normals (unit vectors) and centroids in world space.

use std::collections::{BinaryHeap, HashMap};

use glam::{DVec2, DVec3};

use super::vsa::{Candidate, MeshPartition, NONE};
use crate::convert_options::ConvertOptions;
use crate::error::Result;
use crate::mesh::{Mesh, MeshGeometry};
use crate::progress::Progress;

/// A ball holding points (centroids), merged as the smallest ball holding both.
#[derive(Clone, Copy, Debug)]
struct Ball {
    centre: DVec3,
    radius: f64,
}

impl Ball {
    fn merged(&self, other: &Ball) -> Ball {
        let d = (other.centre - self.centre).length();
        if d + other.radius <= self.radius {
            return *self;
        }
        if d + self.radius <= other.radius {
            return *other;
        }
        let radius = 0.5 * (self.radius + d + other.radius);
        Ball {
            centre: self.centre + (other.centre - self.centre) * ((radius - self.radius) / d),
            radius,
        }
    }
}

/// The limits a chart must keep.
#[derive(Clone, Copy, Debug)]
pub struct ConeLimits {
    /// Largest half-angle of a chart's normal cone, radians (< pi/2).
    pub half_angle: f64,
    /// Largest distance from the seed's centroid to a face's centroid, world units.
    pub radius: f64,
}

impl ConeLimits {
    pub fn of(opts: &ConvertOptions, diagonal: f64) -> ConeLimits {
        ConeLimits {
            half_angle: opts.cone_angle.to_radians(),
            radius: (opts.chart_size * diagonal).max(f64::MIN_POSITIVE),
        }
    }
}

/// A growing chart's faces by where their centroids project on the plane across its axis, so a
/// face can be turned away where the chart already has a sheet of surface above or below it.
/// A chart whose normals stay within `cone_angle` of its axis is, where it is one sheet, a
/// height field of slope at most tan(cone_angle): two centroids whose heights differ by more
/// than that slope allows over their projected distance lie on different sheets, and one height
/// map cannot hold both (the chart wrapped round a handle or a tunnel).
struct Sheet {
    origin: DVec3,
    x: DVec3,
    y: DVec3,
    z: DVec3,
    cell: f64,
    /// Allowed height difference per unit of projected distance.
    slope: f64,
    cells: HashMap<(i64, i64), Vec<(DVec2, f64)>>,
}

impl Sheet {
    fn new(origin: DVec3, z: DVec3, cell: f64, slope: f64) -> Sheet {
        let x = super::frame::perpendicular(z);
        Sheet {
            origin,
            x,
            y: z.cross(x),
            z,
            cell,
            slope,
            cells: HashMap::new(),
        }
    }

    fn project(&self, c: DVec3) -> (DVec2, f64, (i64, i64)) {
        let d = c - self.origin;
        let p = DVec2::new(d.dot(self.x), d.dot(self.y));
        let key = (
            (p.x / self.cell).floor() as i64,
            (p.y / self.cell).floor() as i64,
        );
        (p, d.dot(self.z), key)
    }

    /// Whether a face with centroid `c` lies on the chart's sheet where the chart has one.
    fn fits(&self, c: DVec3) -> bool {
        let (p, h, (i, j)) = self.project(c);
        (i - 1..=i + 1).all(|a| {
            (j - 1..=j + 1).all(|b| {
                self.cells.get(&(a, b)).is_none_or(|v| {
                    v.iter().all(|&(q, hq)| {
                        (h - hq).abs() <= 2.0 * self.slope * ((p - q).length() + self.cell)
                    })
                })
            })
        })
    }

    fn insert(&mut self, c: DVec3) {
        let (p, h, key) = self.project(c);
        self.cells.entry(key).or_default().push((p, h));
    }
}

/// Charts as they grow: a label per mesh face and each chart's axis and ball.
struct Grower<'a> {
    mesh: &'a Mesh,
    geo: &'a MeshGeometry,
    limits: ConeLimits,
    /// cos of `limits.half_angle`: a face fits an axis if normal·axis is at least this.
    min_cos: f64,
    labels: Vec<u32>,
    axes: Vec<DVec3>,
    balls: Vec<Ball>,
    heap: BinaryHeap<Candidate<()>>,
    /// Faces a chart turned away: the next seeds, so charts tile outwards from the first.
    rejected: Vec<u32>,
    /// Scratch for `seed_axis`.
    near: Vec<u32>,
    /// Side of a `Sheet` cell: about two typical edge lengths.
    cell: f64,
}

impl Grower<'_> {
    fn cost(&self, f: usize, origin: DVec3, axis: DVec3) -> f64 {
        let d2 = (self.mesh.centroid(f) - origin).length_squared() / self.limits.radius.powi(2);
        d2 + (self.geo.face_normals[f] - axis).length_squared()
    }

    /// A chart's axis: the area-weighted mean normal of the unplaced faces within `SEED_RINGS`
    /// edge-rings of the seed, so one noisy face does not tilt a whole chart.
    fn seed_axis(&mut self, seed: u32) -> DVec3 {
        const SEED_RINGS: usize = 3;
        let geo = self.geo;
        self.near.clear();
        self.near.push(seed);
        let (mut start, mut sum) = (0, DVec3::ZERO);
        for _ in 0..SEED_RINGS {
            let end = self.near.len();
            for i in start..end {
                for &nb in geo.face_neighbors.row(self.near[i] as usize) {
                    if self.labels[nb as usize] == NONE && !self.near[..].contains(&nb) {
                        self.near.push(nb);
                    }
                }
            }
            start = end;
        }
        for &f in &self.near {
            sum += geo.face_normals[f as usize] * geo.face_areas[f as usize];
        }
        let own = geo.face_normals[seed as usize];
        // The seed itself must fit its chart's axis.
        match sum.try_normalize() {
            Some(a) if a.dot(own) >= self.min_cos => a,
            _ => own,
        }
    }

    /// Grows chart `id` from `seed` until no neighbouring face fits; returns its face count.
    fn grow(&mut self, seed: u32, id: u32) -> usize {
        let geo = self.geo;
        let origin = self.mesh.centroid(seed as usize);
        let axis = self.seed_axis(seed);
        let mut ball = Ball {
            centre: origin,
            radius: 0.0,
        };
        let slope = self.min_cos.acos().tan();
        let mut sheet = Sheet::new(origin, axis, self.cell, slope);
        sheet.insert(origin);
        self.labels[seed as usize] = id;
        self.heap.clear();
        self.push_neighbors(seed, origin, axis);
        let mut count = 1;
        while let Some(Candidate { face, .. }) = self.heap.pop() {
            let f = face as usize;
            if self.labels[f] != NONE {
                continue;
            }
            let c = self.mesh.centroid(f);
            if geo.face_normals[f].dot(axis) < self.min_cos
                || (c - origin).length() > self.limits.radius
                || !sheet.fits(c)
            {
                self.rejected.push(face);
                continue;
            }
            sheet.insert(c);
            ball = ball.merged(&Ball {
                centre: c,
                radius: 0.0,
            });
            self.labels[f] = id;
            count += 1;
            self.push_neighbors(face, origin, axis);
        }
        self.axes.push(axis);
        self.balls.push(ball);
        count
    }

    fn push_neighbors(&mut self, f: u32, origin: DVec3, axis: DVec3) {
        for &nb in self.geo.face_neighbors.row(f as usize) {
            if self.labels[nb as usize] == NONE {
                let cost = self.cost(nb as usize, origin, axis);
                self.heap.push(Candidate {
                    cost,
                    face: nb,
                    chart: (),
                });
            }
        }
    }
}

/// The cone partition of the mesh's `active` faces (see the module's comment), reporting the
/// faces placed as progress of stage "partition".
pub fn partition_mesh(
    mesh: &Mesh,
    geo: &MeshGeometry,
    active: &[u32],
    opts: &ConvertOptions,
    progress: Progress,
) -> Result<MeshPartition> {
    let n = geo.degenerate.len();
    let limits = ConeLimits::of(opts, geo.diagonal);
    let mut g = Grower {
        mesh,
        geo,
        limits,
        min_cos: limits.half_angle.cos(),
        labels: vec![NONE; n],
        axes: Vec::new(),
        balls: Vec::new(),
        heap: BinaryHeap::new(),
        rejected: Vec::new(),
        near: Vec::new(),
        cell: 2.0 * typical_edge(geo, active),
    };
    // Degenerate faces have no normal: they belong to no chart (marked so no chart takes them).
    const SKIP: u32 = NONE - 1;
    for (f, &d) in geo.degenerate.iter().enumerate() {
        if d {
            g.labels[f] = SKIP;
        }
    }
    let step = (active.len() / 64).max(1);
    let (mut placed, mut next_report) = (0usize, step);
    let mut scan = active.iter();
    loop {
        // The next seed: a face an earlier chart turned away, else the next unplaced face (a new
        // connected component).
        let seed = match g.rejected.pop() {
            Some(f) if g.labels[f as usize] == NONE => f,
            Some(_) => continue,
            None => match scan.find(|&&f| g.labels[f as usize] == NONE) {
                Some(&f) => f,
                None => break,
            },
        };
        let id = g.axes.len() as u32;
        placed += g.grow(seed, id);
        if placed >= next_report {
            progress.report("partition", 0.9 * placed as f64 / active.len() as f64)?;
            next_report = placed + step;
        }
    }
    for l in g.labels.iter_mut() {
        if *l == SKIP {
            *l = NONE;
        }
    }
    let groups = merge(geo, &g.labels, &g.axes, &g.balls, g.min_cos, limits.radius);
    progress.report("partition", 1.0)?;
    let mean_error = mean_l21(geo, &groups);
    Ok(MeshPartition {
        groups,
        mean_error,
        capped: false,
    })
}

/// sqrt(2 x the mean face area): the edge of a right isosceles triangle of that area.
fn typical_edge(geo: &MeshGeometry, active: &[u32]) -> f64 {
    let area: f64 = active.iter().map(|&f| geo.face_areas[f as usize]).sum();
    (2.0 * area / active.len().max(1) as f64)
        .sqrt()
        .max(f64::MIN_POSITIVE)
}

/// VSA's area-weighted mean L2,1 error of charts against their mean normals, for the report.
pub fn mean_l21(geo: &MeshGeometry, groups: &[Vec<u32>]) -> f64 {
    let (mut error, mut area) = (0.0, 0.0);
    for g in groups {
        let proxy = super::frame::mean_normal(geo, g)
            .try_normalize()
            .unwrap_or(DVec3::Z);
        for &f in g {
            let a = geo.face_areas[f as usize];
            error += a * (geo.face_normals[f as usize] - proxy).length_squared();
            area += a;
        }
    }
    error / area.max(f64::MIN_POSITIVE)
}

/// Union-find root with path halving.
fn root(parent: &mut [u32], mut c: u32) -> u32 {
    while parent[c as usize] != c {
        parent[c as usize] = parent[parent[c as usize] as usize];
        c = parent[c as usize];
    }
    c
}

/// Merges charts, smallest first, into the neighbour whose axis fits its faces best, while
/// every face stays within the cone of that axis and the merged ball within `radius`. Returns
/// each chart's faces by mesh index.
fn merge(
    geo: &MeshGeometry,
    labels: &[u32],
    axes: &[DVec3],
    balls: &[Ball],
    min_cos: f64,
    radius: f64,
) -> Vec<Vec<u32>> {
    let k = axes.len();
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); k];
    for (f, &l) in labels.iter().enumerate() {
        if l != NONE {
            members[l as usize].push(f as u32);
        }
    }
    let mut balls = balls.to_vec();
    let mut parent: Vec<u32> = (0..k as u32).collect();
    let mut order: Vec<u32> = (0..k as u32).collect();
    order.sort_by_key(|&c| (members[c as usize].len(), c));
    let mut near = Vec::new();
    for &c in &order {
        // Neighbouring charts, through the faces' edges.
        near.clear();
        for &f in &members[c as usize] {
            for &nb in geo.face_neighbors.row(f as usize) {
                let l = labels[nb as usize];
                if l != NONE {
                    let r = root(&mut parent, l);
                    if r != c {
                        near.push(r);
                    }
                }
            }
        }
        near.sort_unstable();
        near.dedup();
        let faces = &members[c as usize];
        let worst_fit = |axis: DVec3| {
            faces
                .iter()
                .map(|&f| geo.face_normals[f as usize].dot(axis))
                .fold(f64::INFINITY, f64::min)
        };
        let best = near
            .iter()
            .filter(|&&r| balls[r as usize].merged(&balls[c as usize]).radius <= radius)
            .map(|&r| (r, worst_fit(axes[r as usize])))
            .filter(|&(_, fit)| fit >= min_cos)
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((r, _)) = best {
            parent[c as usize] = r;
            balls[r as usize] = balls[r as usize].merged(&balls[c as usize]);
            let moved = std::mem::take(&mut members[c as usize]);
            members[r as usize].extend(moved);
        }
    }
    members.retain(|m| !m.is_empty());
    members
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square of n x n quads whose heights are a fixed pseudo-random pattern of up to
    /// `amplitude` (a rough height field: slopes up to about 2 * amplitude * n).
    fn rough_square(n: usize, amplitude: f64) -> Mesh {
        let mut pos = Vec::new();
        let mut state = 12345u64;
        for j in 0..=n {
            for i in 0..=n {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let r = (state >> 11) as f64 / (1u64 << 53) as f64;
                pos.extend_from_slice(&[i as f64 / n as f64, j as f64 / n as f64, amplitude * r]);
            }
        }
        Mesh::from_flat(&pos, &crate::mesh::grid_faces(n, n), None).unwrap()
    }

    #[test]
    fn a_rough_height_field_stays_one_chart_and_steeper_charts_never_fold() {
        // Slopes up to ~45 degrees: one chart holds them all within the 60-degree cone.
        let opts = ConvertOptions {
            chart_size: 2.0,
            ..Default::default()
        };
        let mesh = rough_square(40, 0.0125);
        let geo = MeshGeometry::new(&mesh);
        let active: Vec<u32> = (0..mesh.faces.len() as u32).collect();
        let p = partition_mesh(&mesh, &geo, &active, &opts, Progress::silent()).unwrap();
        assert_eq!(p.groups.len(), 1);
        // Up to ~80 degrees: more charts, every face in one, none folding.
        let mesh = rough_square(40, 0.08);
        let geo = MeshGeometry::new(&mesh);
        let p = partition_mesh(&mesh, &geo, &active, &opts, Progress::silent()).unwrap();
        assert!(p.groups.len() > 1);
        let placed: usize = p.groups.iter().map(Vec::len).sum();
        assert_eq!(placed, mesh.faces.len());
        for g in &p.groups {
            let (_, worst) = super::super::frame::choose_z(&geo, g);
            assert!(worst > 0.0, "a chart folds");
        }
    }
}
