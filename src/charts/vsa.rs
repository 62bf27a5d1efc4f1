//! Variational Shape Approximation (Cohen-Steiner, Alliez, Desbrun 2004) with the L2,1 metric:
//! faces are clustered by normal, each cluster (chart) has an area-weighted proxy normal, and the
//! error of face f against proxy N is area(f) * |n_f - N|^2.
//!
//! Written here because no maintained Rust crate implements VSA. The same solver serves the global
//! partition and the two-way splits that folding repair asks for: both run on a `FaceSet`, a set of
//! faces with adjacency restricted to the set and local indices 0..n.
//!
//! Space: face normals in world space (unit vectors); only directions matter here.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::DVec3;

use crate::cancel::{Cancel, NEVER};
use crate::convert_options::ConvertOptions;
use crate::error::Result;
use crate::mesh::{Csr, Mesh, MeshGeometry};
use crate::progress::Progress;

pub const NONE: u32 = u32::MAX;

/// Faces of the mesh (by global index) with adjacency restricted to them, indexed locally.
///
/// A coarse level (`coarsen`) has clusters of faces as its "faces": their area, area-weighted
/// mean normal (not unit) and centroid, and in `spread` what makes the L2,1 error and the
/// compactness term of a cluster exact sums over its faces (empty for a set of mesh faces).
pub struct FaceSet {
    pub global: Vec<u32>,
    pub normals: Vec<DVec3>,
    pub areas: Vec<f64>,
    pub centroids: Vec<DVec3>,
    pub neighbors: Csr,
    /// Per cluster: (sum a|n|², sum a|c|²) over its faces, less area × |mean|² of each.
    spread: Vec<[f64; 2]>,
}

impl FaceSet {
    /// `local_of` is scratch of one entry per mesh face, all NONE on entry and on return.
    pub fn new(mesh: &Mesh, geo: &MeshGeometry, faces: &[u32], local_of: &mut [u32]) -> FaceSet {
        for (l, &g) in faces.iter().enumerate() {
            local_of[g as usize] = l as u32;
        }
        let mut pairs = Vec::with_capacity(faces.len() * 3);
        for (l, &g) in faces.iter().enumerate() {
            for &nb in geo.face_neighbors.row(g as usize) {
                let ln = local_of[nb as usize];
                if ln != NONE {
                    pairs.push((l as u32, ln));
                }
            }
        }
        let neighbors = Csr::from_pairs(faces.len(), &pairs);
        for &g in faces {
            local_of[g as usize] = NONE;
        }
        FaceSet {
            global: faces.to_vec(),
            normals: faces
                .iter()
                .map(|&g| geo.face_normals[g as usize])
                .collect(),
            areas: faces.iter().map(|&g| geo.face_areas[g as usize]).collect(),
            centroids: faces.iter().map(|&g| mesh.centroid(g as usize)).collect(),
            neighbors,
            spread: Vec::new(),
        }
    }

    pub fn len(&self) -> usize {
        self.areas.len()
    }

    pub fn is_empty(&self) -> bool {
        self.areas.is_empty()
    }

    /// The L2,1 error alone: what the chart-count target and reports measure.
    #[inline]
    fn error(&self, f: usize, proxy: DVec3) -> f64 {
        self.areas[f] * (self.normals[f] - proxy).length_squared() + self.spread(f)[0]
    }

    /// The constant parts of a cluster's error and compactness sums (zero for a mesh face, so
    /// adding them changes nothing there).
    #[inline]
    fn spread(&self, f: usize) -> [f64; 2] {
        self.spread.get(f).copied().unwrap_or([0.0; 2])
    }

    /// The proxy normal a chart seeded at `f` starts with.
    fn seed_normal(&self, f: usize) -> DVec3 {
        if self.spread.is_empty() {
            self.normals[f]
        } else {
            self.normals[f].normalize_or(DVec3::Z)
        }
    }

    /// Connected components (by edge adjacency inside the set): a label per face and the count.
    fn components(&self) -> (Vec<u32>, usize) {
        let mut comp = vec![NONE; self.len()];
        let mut count = 0;
        let mut stack = Vec::new();
        for start in 0..self.len() {
            if comp[start] != NONE {
                continue;
            }
            comp[start] = count as u32;
            stack.push(start as u32);
            while let Some(f) = stack.pop() {
                for &nb in self.neighbors.row(f as usize) {
                    if comp[nb as usize] == NONE {
                        comp[nb as usize] = count as u32;
                        stack.push(nb);
                    }
                }
            }
            count += 1;
        }
        (comp, count)
    }
}

/// How many charts the global partition should end with.
#[derive(Clone, Copy, Debug)]
pub enum ChartTarget {
    /// Exactly this many (or the number of connected components, if larger).
    Count(usize),
    /// Add charts until the area-weighted mean L2,1 error, sum(area |n - N|^2) / sum(area), is at
    /// most this value, but never more than `max_charts`.
    MeanError { tolerance: f64, max_charts: usize },
}

/// A partition of a `FaceSet`: a chart label per local face and a proxy normal per chart.
pub struct Partition {
    pub labels: Vec<u32>,
    pub proxies: Vec<DVec3>,
    /// Area-weighted mean L2,1 error, sum(area |n - N|^2) / sum(area).
    pub mean_error: f64,
}

impl Partition {
    /// Each chart's faces by mesh index (faces left unlabelled skipped), empty charts dropped.
    pub fn groups(&self, set: &FaceSet) -> Vec<Vec<u32>> {
        let mut groups: Vec<Vec<u32>> = vec![Vec::new(); self.proxies.len()];
        for (l, &c) in self.labels.iter().enumerate() {
            if c != NONE {
                groups[c as usize].push(set.global[l]);
            }
        }
        groups.retain(|g| !g.is_empty());
        groups
    }
}

/// The global partition: each chart's faces by mesh index, and VSA's mean L2,1 error.
pub struct MeshPartition {
    pub groups: Vec<Vec<u32>>,
    pub mean_error: f64,
    /// The chart cap (`max_charts`) stopped VSA before its error target.
    pub capped: bool,
}

/// Partitions the mesh's `active` (non-degenerate) faces as the options say.
pub fn partition_mesh(
    mesh: &Mesh,
    geo: &MeshGeometry,
    active: &[u32],
    opts: &ConvertOptions,
    progress: Progress,
) -> Result<MeshPartition> {
    let mut scratch = vec![NONE; geo.degenerate.len()];
    let set = FaceSet::new(mesh, geo, active, &mut scratch);
    drop(scratch);
    let target = match opts.charts {
        Some(n) => ChartTarget::Count(n),
        None => ChartTarget::MeanError {
            tolerance: opts.chart_error_target(),
            max_charts: opts.max_charts,
        },
    };
    let part = partition(
        &set,
        target,
        opts.lloyd_iterations,
        opts.compactness,
        progress,
    )?;
    let capped = match target {
        ChartTarget::MeanError {
            tolerance,
            max_charts,
        } => part.proxies.len() >= max_charts && part.mean_error > tolerance,
        ChartTarget::Count(_) => false,
    };
    let (groups, mean_error) = (part.groups(&set), part.mean_error);
    if set.len() > COARSEN_ABOVE {
        drop((set, part));
        release_freed_memory();
    }
    Ok(MeshPartition {
        groups,
        mean_error,
        capped,
    })
}

/// Hands the pages of freed heap memory back to the system. glibc keeps them, and the raster
/// stage allocates from its worker threads' own arenas, so on the 1.1M-face bunny the
/// partition's freed set, levels and queue (~110 bytes per face) stayed resident under the
/// maps (peak 401 bytes per face above the mesh, against 279 with the cone partition).
fn release_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        extern "C" {
            fn malloc_trim(pad: usize) -> std::os::raw::c_int;
        }
        // SAFETY: glibc's malloc_trim only returns free pages to the system; no live
        // allocation is touched.
        unsafe {
            malloc_trim(0);
        }
    }
}

/// A face offered to a growing chart: popped cheapest first from a `BinaryHeap` (a max-heap),
/// ties broken by face index so growth is deterministic; `chart` is what the face would join.
/// Shared by VSA's flooding and the cone partition (cone.rs).
#[derive(PartialEq)]
pub(super) struct Candidate<T> {
    pub cost: f64,
    pub face: u32,
    pub chart: T,
}
impl<T: PartialEq> Eq for Candidate<T> {}
impl<T: PartialEq> Ord for Candidate<T> {
    fn cmp(&self, other: &Self) -> Ordering {
        // Reversed: BinaryHeap is a max-heap and we pop the cheapest first.
        other
            .cost
            .total_cmp(&self.cost)
            .then_with(|| other.face.cmp(&self.face))
    }
}
impl<T: PartialEq> PartialOrd for Candidate<T> {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

struct Solver<'a> {
    set: &'a FaceSet,
    /// Weight of the compactness term, already divided by the squared typical chart radius.
    compactness: f64,
    proxies: Vec<DVec3>,
    /// Area-weighted centroid of each chart (for the compactness term).
    centres: Vec<DVec3>,
    seeds: Vec<u32>,
    labels: Vec<u32>,
    heap: BinaryHeap<Candidate<u32>>,
    /// Polled before every Lloyd iteration (one flood of the mesh, ~0.2 s on 330k faces).
    cancel: &'a Cancel,
}

impl<'a> Solver<'a> {
    fn new(set: &'a FaceSet, seeds: Vec<u32>, compactness: f64) -> Self {
        let proxies = seeds.iter().map(|&s| set.seed_normal(s as usize)).collect();
        let centres = seeds.iter().map(|&s| set.centroids[s as usize]).collect();
        Solver {
            set,
            compactness,
            proxies,
            centres,
            seeds,
            labels: vec![NONE; set.len()],
            heap: BinaryHeap::new(),
            cancel: &NEVER,
        }
    }

    fn add_proxy(&mut self, seed: u32) {
        self.seeds.push(seed);
        self.proxies.push(self.set.seed_normal(seed as usize));
        self.centres.push(self.set.centroids[seed as usize]);
    }

    /// Flooding cost: L2,1 error plus an area-weighted squared distance to the chart's centre,
    /// which keeps charts round so their boxes waste fewer texels.
    #[inline]
    fn cost(&self, f: usize, proxy: usize) -> f64 {
        self.set.error(f, self.proxies[proxy])
            + self.compactness
                * self.set.areas[f]
                * (self.set.centroids[f] - self.centres[proxy]).length_squared()
            + self.compactness * self.set.spread(f)[1]
    }

    fn push_neighbors(&mut self, f: u32, proxy: u32) {
        for &nb in self.set.neighbors.row(f as usize) {
            if self.labels[nb as usize] == NONE {
                self.heap.push(Candidate {
                    cost: self.cost(nb as usize, proxy as usize),
                    face: nb,
                    chart: proxy,
                });
            }
        }
    }

    /// Grows every chart from its seed, always taking the globally cheapest (face, proxy) pair.
    fn flood(&mut self) {
        self.labels.fill(NONE);
        self.heap.clear();
        for (i, &s) in self.seeds.iter().enumerate() {
            if self.labels[s as usize] == NONE {
                self.labels[s as usize] = i as u32;
            }
        }
        for i in 0..self.seeds.len() {
            if self.labels[self.seeds[i] as usize] == i as u32 {
                self.push_neighbors(self.seeds[i], i as u32);
            }
        }
        while let Some(c) = self.heap.pop() {
            if self.labels[c.face as usize] != NONE {
                continue;
            }
            self.labels[c.face as usize] = c.chart;
            self.push_neighbors(c.face, c.chart);
        }
    }

    /// Proxy = normalized area-weighted mean normal; new seed = the region's best-fitting face.
    /// Charts left empty (two seeds on one face) are dropped.
    fn fit_and_reseed(&mut self) {
        let k = self.proxies.len();
        let mut sums = vec![DVec3::ZERO; k];
        let mut centres = vec![(DVec3::ZERO, 0.0); k];
        for (f, &l) in self.labels.iter().enumerate() {
            if l != NONE {
                let a = self.set.areas[f];
                sums[l as usize] += self.set.normals[f] * a;
                centres[l as usize].0 += self.set.centroids[f] * a;
                centres[l as usize].1 += a;
            }
        }
        for i in 0..k {
            // A region whose normals cancel (a thin closed sliver) keeps its previous proxy.
            if let Some(n) = sums[i].try_normalize() {
                self.proxies[i] = n;
            }
            if centres[i].1 > 0.0 {
                self.centres[i] = centres[i].0 / centres[i].1;
            }
        }
        let mut best = vec![(f64::INFINITY, NONE); k];
        for (f, &l) in self.labels.iter().enumerate() {
            if l != NONE {
                let e = self.cost(f, l as usize);
                if e < best[l as usize].0 {
                    best[l as usize] = (e, f as u32);
                }
            }
        }
        let keep: Vec<usize> = (0..k).filter(|&i| best[i].1 != NONE).collect();
        if keep.len() != k {
            let mut remap = vec![NONE; k];
            for (new, &old) in keep.iter().enumerate() {
                remap[old] = new as u32;
            }
            for l in self.labels.iter_mut() {
                if *l != NONE {
                    *l = remap[*l as usize];
                }
            }
            self.proxies = keep.iter().map(|&i| self.proxies[i]).collect();
            self.centres = keep.iter().map(|&i| self.centres[i]).collect();
        }
        self.seeds = keep.iter().map(|&i| best[i].1).collect();
    }

    fn lloyd(&mut self, iterations: usize) {
        for _ in 0..iterations.max(1) {
            if self.cancel.is_cancelled() {
                return; // the caller's check reports it
            }
            self.flood();
            self.fit_and_reseed();
        }
        self.flood();
    }

    /// The partition carried to the finer level `fine`, whose face `f` lies in this level's
    /// cluster `parent[f]`, with proxies, centres and seeds fitted there.
    fn refined<'b>(self, fine: &'b FaceSet, parent: &[u32], cancel: &'b Cancel) -> Solver<'b> {
        let labels = parent.iter().map(|&p| self.labels[p as usize]).collect();
        let mut s = Solver {
            set: fine,
            compactness: self.compactness,
            proxies: self.proxies,
            centres: self.centres,
            seeds: Vec::new(),
            labels,
            heap: BinaryHeap::new(),
            cancel,
        };
        s.fit_and_reseed();
        s
    }

    /// Per chart: total error and the worst face.
    fn region_errors(&self) -> Vec<(f64, u32, u32)> {
        let mut out = vec![(0.0, NONE, 0u32); self.proxies.len()];
        // Worst by error, then (on flat regions, where every face ties) by distance from the
        // chart's centre, so a new seed never lands on the chart's own seed.
        let mut worst = vec![(-1.0f64, -1.0f64); self.proxies.len()];
        for (f, &l) in self.labels.iter().enumerate() {
            let e = self.set.error(f, self.proxies[l as usize]);
            let d = (self.set.centroids[f] - self.centres[l as usize]).length_squared();
            let r = &mut out[l as usize];
            r.0 += e;
            r.2 += 1;
            let w = &mut worst[l as usize];
            let tie = (e - w.0).abs() <= 1e-12 * self.set.areas[f];
            if (e > w.0 && !tie) || (tie && d > w.1) {
                *w = (e, d);
                r.1 = f as u32;
            }
        }
        out
    }

    fn into_partition(self) -> Partition {
        let total_area = self.set.areas.iter().sum::<f64>().max(f64::MIN_POSITIVE);
        let mean_error = self.region_errors().iter().map(|r| r.0).sum::<f64>() / total_area;
        Partition {
            labels: self.labels,
            proxies: self.proxies,
            mean_error,
        }
    }
}

/// Meshes with more faces than this are partitioned on coarser levels first (multilevel VSA):
/// charts are added where a flood costs a fraction of the mesh's, and the mesh's own faces
/// see only the last Lloyd iterations.
pub const COARSEN_ABOVE: usize = 20_000;
/// Coarsening stops at about this many clusters.
const COARSEST: usize = 4_096;
/// A level serves while it has at least this many clusters per chart: finer levels take over
/// as charts are added, so a chart is never made of a handful of clusters.
const CLUSTERS_PER_CHART: usize = 24;
/// Lloyd iterations on the mesh's own faces after a partition found on coarser levels (at
/// most `lloyd_iterations`): the partition is already converged on the level above.
const FINE_LLOYD: usize = 2;

/// One coarsening step: each face in turn, if still alone, is paired with its lone neighbour
/// of the most similar normal (heavy-edge matching on the dual graph); the pairs and the faces
/// left alone are the clusters of the returned level, with each face's cluster. Cluster errors
/// stay exact sums over their faces (`FaceSet::spread`, by the parallel-axis rule).
fn coarsen(set: &FaceSet) -> (FaceSet, Vec<u32>) {
    let n = set.len();
    let dir = |f: usize| set.normals[f].normalize_or_zero();
    let mut parent = vec![NONE; n];
    let mut k = 0u32;
    for f in 0..n {
        if parent[f] != NONE {
            continue;
        }
        let here = dir(f);
        let similarity = |g: u32| dir(g as usize).dot(here);
        let mate = set
            .neighbors
            .row(f)
            .iter()
            .copied()
            .filter(|&g| parent[g as usize] == NONE && g as usize != f)
            .max_by(|&a, &b| similarity(a).total_cmp(&similarity(b)).then(b.cmp(&a)));
        parent[f] = k;
        if let Some(g) = mate {
            parent[g as usize] = k;
        }
        k += 1;
    }
    let k = k as usize;
    let (mut areas, mut normals, mut centroids) =
        (vec![0.0; k], vec![DVec3::ZERO; k], vec![DVec3::ZERO; k]);
    for (f, &p) in parent.iter().enumerate() {
        let (p, a) = (p as usize, set.areas[f]);
        areas[p] += a;
        normals[p] += set.normals[f] * a;
        centroids[p] += set.centroids[f] * a;
    }
    for ((n, c), a) in normals.iter_mut().zip(centroids.iter_mut()).zip(&areas) {
        let inv = 1.0 / a.max(f64::MIN_POSITIVE);
        *n *= inv;
        *c *= inv;
    }
    let mut spread = vec![[0.0; 2]; k];
    let mut pairs = Vec::with_capacity(set.neighbors.items.len());
    for (f, &p) in parent.iter().enumerate() {
        let (p, a, [sn, sc]) = (p as usize, set.areas[f], set.spread(f));
        spread[p][0] += sn + a * (set.normals[f] - normals[p]).length_squared();
        spread[p][1] += sc + a * (set.centroids[f] - centroids[p]).length_squared();
        for &g in set.neighbors.row(f) {
            if parent[g as usize] as usize != p {
                pairs.push((p as u32, parent[g as usize]));
            }
        }
    }
    let coarse = FaceSet {
        global: Vec::new(),
        normals,
        areas,
        centroids,
        neighbors: Csr::from_pairs(k, &pairs).deduplicated(),
        spread,
    };
    (coarse, parent)
}

/// The coarser levels of a set (none for a small one): each with the cluster of every face of
/// the level below. A level is kept only where charts may be added on it: one whose next
/// coarser level has `CLUSTERS_PER_CHART` clusters for each of `most_charts` is never chosen,
/// and is left empty (its clusters counted in `sizes`), so the levels take linear memory of a
/// fraction of the mesh's faces.
fn coarse_levels(set: &FaceSet, most_charts: usize, coarsen_above: usize) -> Levels {
    let mut levels = Levels {
        sets: Vec::new(),
        sizes: Vec::new(),
    };
    if set.len() <= coarsen_above {
        return levels;
    }
    let mut finer: Option<FaceSet> = None;
    loop {
        let n = finer.as_ref().map_or(set.len(), FaceSet::len);
        if n <= COARSEST {
            break;
        }
        let (coarse, parent) = coarsen(finer.as_ref().unwrap_or(set));
        if coarse.len() * 10 > n * 9 {
            break; // matching stalls (many lone faces): not worth a level
        }
        if let Some(f) = finer.take() {
            // Never chosen if this coarser level serves every chart count.
            let keep = coarse.len() < most_charts.saturating_mul(CLUSTERS_PER_CHART);
            levels.sets.last_mut().unwrap().0 = keep.then_some(f);
        }
        levels.sizes.push(coarse.len());
        levels.sets.push((None, parent));
        finer = Some(coarse);
    }
    if let Some(f) = finer {
        levels.sets.last_mut().unwrap().0 = Some(f);
    }
    levels
}

/// The coarser levels of a set: per level (1, 2, ...) its clusters (None where never chosen),
/// the cluster of each face of the level below, and its size.
struct Levels {
    sets: Vec<(Option<FaceSet>, Vec<u32>)>,
    sizes: Vec<usize>,
}

impl Levels {
    /// Clusters at level `k` of `set` (level 0).
    fn size(&self, k: usize, set: &FaceSet) -> usize {
        if k == 0 {
            set.len()
        } else {
            self.sizes[k - 1]
        }
    }

    /// The coarsest level below `level` with `CLUSTERS_PER_CHART` clusters for each of `charts`
    /// (those are kept), or the faces themselves.
    fn serving(&self, level: usize, charts: usize) -> usize {
        (1..level)
            .rev()
            .find(|&k| self.sizes[k - 1] >= charts * CLUSTERS_PER_CHART)
            .unwrap_or(0)
    }
}

/// Each face of level `fine`'s cluster at level `coarse` (> fine).
fn parents_across(levels: &Levels, fine: usize, coarse: usize) -> Vec<u32> {
    let mut parent = levels.sets[fine].1.clone();
    for (_, up) in &levels.sets[fine + 1..coarse] {
        for p in parent.iter_mut() {
            *p = up[*p as usize];
        }
    }
    parent
}

/// Initial seeds: one per connected component (every face must be reachable by some flood),
/// then farthest-point sampling on face centroids up to `k` seeds.
fn initial_seeds(set: &FaceSet, k: usize) -> Vec<u32> {
    let (comp, n_comp) = set.components();
    let mut seeds = vec![NONE; n_comp];
    for (f, &c) in comp.iter().enumerate() {
        let s = &mut seeds[c as usize];
        if *s == NONE || set.areas[f] > set.areas[*s as usize] {
            *s = f as u32;
        }
    }
    // Farthest points by normal and position together (positions over the extent), so that
    // seeds spread over orientations first: L2,1 charts are about normals, and seeds on one
    // flat side of a box would stay there.
    let (lo, hi) = set.centroids.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), c| (lo.min(*c), hi.max(*c)),
    );
    let inv_extent2 = 1.0 / (hi - lo).length_squared().max(f64::MIN_POSITIVE);
    let mut dist: Vec<f64> = vec![f64::INFINITY; set.len()];
    let update = |dist: &mut Vec<f64>, s: u32| {
        let (c, n) = (set.centroids[s as usize], set.normals[s as usize]);
        for (f, d) in dist.iter_mut().enumerate() {
            let far = (set.normals[f] - n).length_squared()
                + (set.centroids[f] - c).length_squared() * inv_extent2;
            *d = d.min(far);
        }
    };
    for &s in &seeds {
        update(&mut dist, s);
    }
    while seeds.len() < k {
        let (far, d) = dist
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(i, d)| (i as u32, *d))
            .unwrap();
        if d <= 0.0 {
            break;
        }
        seeds.push(far);
        update(&mut dist, far);
    }
    seeds
}

/// Partitions a face set. Charts are added in rounds at the worst face of the worst charts
/// (hierarchical insertion), with a few Lloyd iterations after each round.
///
/// `compactness` weighs the squared distance to a chart's centre against the L2,1 error, in units
/// of the typical chart radius (sqrt(area / charts)); 0 gives plain VSA.
///
/// A large set is partitioned on its coarser levels (`coarse_levels`) first: charts are added
/// on the coarsest level that has `CLUSTERS_PER_CHART` clusters for each, and the partition is
/// carried down to the mesh's faces for the last `FINE_LLOYD` Lloyd iterations.
///
/// Progress of stage "partition": the charts against the target count, or the error's way down
/// to its target on a log scale, never moving back.
pub fn partition(
    set: &FaceSet,
    target: ChartTarget,
    lloyd_iterations: usize,
    compactness: f64,
    progress: Progress,
) -> Result<Partition> {
    let method = (lloyd_iterations, compactness, COARSEN_ABOVE);
    partition_coarsened(set, target, method, progress)
}

/// `partition`, coarsening a set of more than `coarsen_above` faces.
fn partition_coarsened(
    set: &FaceSet,
    target: ChartTarget,
    (lloyd_iterations, compactness, coarsen_above): (usize, f64, usize),
    progress: Progress,
) -> Result<Partition> {
    let cancel = progress.cancel;
    if set.is_empty() {
        return Ok(Partition {
            labels: vec![],
            proxies: vec![],
            mean_error: 0.0,
        });
    }
    let total_area: f64 = set.areas.iter().sum::<f64>().max(f64::MIN_POSITIVE);
    let (want, tolerance, cap) = match target {
        ChartTarget::Count(n) => (n.max(1), -1.0, n.max(1)),
        ChartTarget::MeanError {
            tolerance,
            max_charts,
        } => (max_charts, tolerance, max_charts),
    };
    let want = want.min(set.len());
    let scaled = |k: usize| compactness * k as f64 / total_area;
    // An exact count starts from a few spread seeds; an error target from one chart per
    // connected component, so a flat part stays a single chart.
    let first = match target {
        ChartTarget::Count(_) => want.min(8),
        ChartTarget::MeanError { .. } => 1,
    };
    let levels = coarse_levels(set, want.min(cap), coarsen_above);
    let level_set = |k: usize| match k {
        0 => Some(set),
        _ => levels.sets[k - 1].0.as_ref(),
    };
    let level_size = |k: usize| levels.size(k, set);
    let mut level = levels.sets.len();
    let coarsest = level_set(level).expect("the coarsest level is kept");
    let mut solver = Solver::new(coarsest, initial_seeds(coarsest, first), 0.0);
    solver.cancel = cancel;
    solver.compactness = scaled(solver.proxies.len());
    solver.lloyd(3);
    let mut reported = 0.0f64;
    let mut first_mean = None;
    loop {
        cancel.check("partitioning the mesh")?;
        // The charts of the next round need a finer level: the coarsest with enough clusters.
        let c = solver.proxies.len();
        let next = if c < 8 { 2 * c } else { c + c / 4 }.min(want);
        if level > 0 && next * CLUSTERS_PER_CHART > level_size(level) {
            let to = levels.serving(level, next);
            let finer = level_set(to).expect("a level charts can outgrow is kept");
            solver = solver.refined(finer, &parents_across(&levels, to, level), cancel);
            solver.lloyd(1);
            level = to;
        }
        let regions = solver.region_errors();
        let mean = regions.iter().map(|r| r.0).sum::<f64>() / total_area;
        let count = solver.proxies.len();
        let start = *first_mean.get_or_insert(mean);
        let by_count = count as f64 / want.min(cap) as f64;
        let by_error = if tolerance > 0.0 && start > tolerance {
            (start / mean.max(tolerance)).ln() / (start / tolerance).ln()
        } else {
            0.0
        };
        // The last Lloyd iterations take the final tenth.
        reported = reported.max(0.9 * by_count.max(by_error).min(1.0));
        progress.report("partition", reported)?;
        if count >= want.min(cap) || mean <= tolerance {
            break;
        }
        // Grow by about a quarter per round: few rounds, little overshoot of an error target.
        // (doubling while there are few charts).
        let grow = if count < 8 { count } else { count / 4 };
        let add = (want.min(cap) - count).min(grow.max(1));
        let mut order: Vec<usize> = (0..count).filter(|&i| regions[i].2 > 1).collect();
        if order.is_empty() {
            break;
        }
        order.sort_by(|&a, &b| regions[b].0.total_cmp(&regions[a].0));
        for &i in order.iter().take(add) {
            solver.add_proxy(regions[i].1);
        }
        solver.compactness = scaled(solver.proxies.len());
        solver.lloyd(2);
        if solver.proxies.len() <= count {
            break; // every new chart was absorbed; the next round would do the same
        }
    }
    solver.lloyd(lloyd_iterations);
    if level > 0 {
        let parent = parents_across(&levels, 0, level);
        let mut fine = solver.refined(set, &parent, cancel);
        drop((parent, levels));
        fine_lloyd(&mut fine, lloyd_iterations.min(FINE_LLOYD), progress)?;
        cancel.check("partitioning the mesh")?;
        return Ok(fine.into_partition());
    }
    cancel.check("partitioning the mesh")?;
    Ok(solver.into_partition())
}

/// Lloyd iterations on the mesh's faces after a coarse partition (`Solver::refined` has fitted
/// proxies and seeds), each reported: on a million faces a flood takes most of a second.
fn fine_lloyd(solver: &mut Solver, iterations: usize, progress: Progress) -> Result<()> {
    for i in 0..iterations {
        solver.flood();
        solver.fit_and_reseed();
        progress.report(
            "partition",
            0.9 + 0.1 * (i + 1) as f64 / (iterations + 1) as f64,
        )?;
    }
    solver.flood();
    Ok(())
}

/// Splits a (connected) chart in two: seeds at the face that fits `z` worst and the one that fits
/// it best, then Lloyd iterations. Used by folding repair.
pub fn split_in_two(set: &FaceSet, z: DVec3) -> Partition {
    let score = |f: usize| set.normals[f].dot(z);
    let worst = (0..set.len())
        .min_by(|&a, &b| score(a).total_cmp(&score(b)))
        .unwrap();
    let best = (0..set.len())
        .max_by(|&a, &b| score(a).total_cmp(&score(b)))
        .unwrap();
    let mut solver = Solver::new(set, vec![best as u32, worst as u32], 0.0);
    solver.lloyd(4);
    solver.into_partition()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;

    /// A closed axis-aligned box made of a grid per side: VSA with 6 charts must find the sides.
    fn cube(n: usize) -> Mesh {
        let mut pos = Vec::new();
        let mut faces = Vec::new();
        for axis in 0..3 {
            for side in [0.0, 1.0] {
                let base = (pos.len() / 3) as i64;
                for j in 0..=n {
                    for i in 0..=n {
                        let (a, b) = (i as f64 / n as f64, j as f64 / n as f64);
                        let mut p = [0.0; 3];
                        p[axis] = side;
                        p[(axis + 1) % 3] = a;
                        p[(axis + 2) % 3] = b;
                        pos.extend_from_slice(&p);
                    }
                }
                for j in 0..n as i64 {
                    for i in 0..n as i64 {
                        let v = |i: i64, j: i64| base + j * (n as i64 + 1) + i;
                        let (q0, q1, q2, q3) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
                        if side > 0.5 {
                            faces.extend_from_slice(&[q0, q1, q2, q0, q2, q3]);
                        } else {
                            faces.extend_from_slice(&[q0, q2, q1, q0, q3, q2]);
                        }
                    }
                }
            }
        }
        Mesh::from_flat(&pos, &faces, None).unwrap()
    }

    #[test]
    fn six_charts_on_a_cube_are_its_sides() {
        let m = cube(6);
        let geo = MeshGeometry::new(&m);
        let all: Vec<u32> = (0..m.faces.len() as u32).collect();
        let mut scratch = vec![NONE; m.faces.len()];
        let set = FaceSet::new(&m, &geo, &all, &mut scratch);
        let p = partition(&set, ChartTarget::Count(6), 10, 0.0, Progress::silent()).unwrap();
        assert_eq!(p.proxies.len(), 6);
        for (f, &l) in p.labels.iter().enumerate() {
            assert!(
                set.normals[f].dot(p.proxies[l as usize]) > 0.999,
                "face {f}"
            );
        }
    }

    #[test]
    fn coarse_levels_find_the_partition_of_the_faces() {
        // A bumpy sphere of ~61k faces: partitioned through coarse levels and on its faces
        // alone, to the same error target.
        let mut m = crate::test_shapes::uv_sphere(128, 240);
        for p in m.positions.iter_mut() {
            *p *= 1.0 + 0.05 * (5.0 * p.x).sin() * (4.0 * p.y).cos();
        }
        let geo = MeshGeometry::new(&m);
        let all: Vec<u32> = (0..m.faces.len() as u32).collect();
        let set = FaceSet::new(&m, &geo, &all, &mut vec![NONE; m.faces.len()]);
        let target = ChartTarget::MeanError {
            tolerance: 0.05,
            max_charts: 4096,
        };
        let levels = coarse_levels(&set, 4096, COARSEN_ABOVE);
        assert!(levels.sizes.len() >= 3, "{:?}", levels.sizes);
        assert!(*levels.sizes.last().unwrap() <= COARSEST);
        // Cluster errors are exact sums over their faces: any labelling scores the same on a
        // level as on the faces it covers.
        let (coarse, parent) = coarsen(&set);
        let proxy = DVec3::new(0.3, -0.2, 0.9).normalize();
        let sum = |s: &FaceSet| (0..s.len()).map(|f| s.error(f, proxy)).sum::<f64>();
        assert!((sum(&coarse) - sum(&set)).abs() <= 1e-9 * sum(&set));
        assert!(parent.iter().all(|&p| (p as usize) < coarse.len()));

        let reports_cell = std::sync::Mutex::new(Vec::new());
        let cb = |_: &str, f: f64| {
            reports_cell.lock().unwrap().push(f);
            true
        };
        let progress = Progress::new(&cb, &NEVER);
        let multi = partition_coarsened(&set, target, (6, 1.0, COARSEN_ABOVE), progress).unwrap();
        let flat =
            partition_coarsened(&set, target, (6, 1.0, usize::MAX), Progress::silent()).unwrap();
        let reports = reports_cell.into_inner().unwrap();
        assert!(reports.windows(2).all(|w| w[1] >= w[0]), "{reports:?}");
        assert!(reports.iter().any(|&f| f > 0.9 && f < 1.0), "{reports:?}");
        let (km, kf) = (multi.proxies.len() as f64, flat.proxies.len() as f64);
        // Measured: 51 charts at mean error 0.0448 through the levels, 51 at 0.0446 on the faces.
        assert!(km <= 1.3 * kf && km >= kf / 1.3, "{km} charts against {kf}");
        assert!(multi.mean_error <= 1.3 * flat.mean_error.max(0.05));
        assert!(multi
            .labels
            .iter()
            .all(|&l| (l as usize) < multi.proxies.len()));
    }

    #[test]
    fn error_target_stops_at_zero_error() {
        let m = cube(4);
        let geo = MeshGeometry::new(&m);
        let all: Vec<u32> = (0..m.faces.len() as u32).collect();
        let mut scratch = vec![NONE; m.faces.len()];
        let set = FaceSet::new(&m, &geo, &all, &mut scratch);
        let p = partition(
            &set,
            ChartTarget::MeanError {
                tolerance: 1e-9,
                max_charts: 100,
            },
            5,
            0.0,
            Progress::silent(),
        )
        .unwrap();
        assert!(
            p.proxies.len() >= 6 && p.proxies.len() <= 12,
            "{}",
            p.proxies.len()
        );
    }
}
