//! A bounding-volume hierarchy over boxes (one leaf per box), for the tracer (trace_functions.wgsl).
//! Crate-level: the renderer's tracer and igt's ambient occlusion rays both use it.
//!
//! The tree's shape is built once per object from its boxes in the object's own space (binned
//! surface-area heuristic) and kept with the object's upload; each frame only refits the bounds
//! to the boxes as the view places them, so node bounds are camera-relative and stay precise far
//! from the world origin. Nodes are stored depth first: a node's left child is the next node.
//!
//! Spaces: `build` takes axis-aligned boxes in any one space; `refit` takes each leaf's box
//! already placed in view space and writes f32 bounds widened outward by rounding.

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// `BvhNode` in trace_types.wgsl: bounds, then (interior) the right child's index and 0, or
/// (leaf) the box's index and 1.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Debug, PartialEq)]
pub(crate) struct BvhNodeGpu {
    pub lo: [f32; 3],
    pub index: u32,
    pub hi: [f32; 3],
    pub leaf: u32,
}

/// An axis-aligned box [lo, hi]; empty when lo > hi on some axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Aabb {
    pub lo: DVec3,
    pub hi: DVec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        lo: DVec3::INFINITY,
        hi: DVec3::NEG_INFINITY,
    };

    /// Whether the ray o + t d meets the box for some t in [t0, t1].
    #[cfg(test)]
    pub fn meets(&self, o: DVec3, d: DVec3, range: (f64, f64)) -> bool {
        self.meets_inverse(o, d.recip(), range)
    }

    /// `meets` for a direction given by its inverse (slab test; a zero direction component is
    /// an infinite inverse, which the comparisons handle): rays that share a direction share it.
    pub fn meets_inverse(&self, o: DVec3, inverse: DVec3, range: (f64, f64)) -> bool {
        self.entry_inverse(o, inverse, range).is_some()
    }

    /// Where the ray enters the box within [t0, t1] (t0 if it starts inside; NaN where the
    /// ray lies in a slab's plane, kept: conservative), or None if it misses.
    pub fn entry_inverse(&self, o: DVec3, inverse: DVec3, (t0, t1): (f64, f64)) -> Option<f64> {
        if self.lo.cmpgt(self.hi).any() {
            return None;
        }
        let (a, b) = ((self.lo - o) * inverse, (self.hi - o) * inverse);
        // glam's min, max and *_element compare plainly; the stretch's ends do too, a NaN
        // giving way to t0 or t1 as f64::max/min would have it, at three instructions fewer
        // each (this test runs for every piece a frame's ray is listed against).
        let (near, far) = (a.min(b).max_element(), a.max(b).min_element());
        let near = if near > t0 { near } else { t0 };
        let far = if far < t1 { far } else { t1 };
        (near.partial_cmp(&far) != Some(std::cmp::Ordering::Greater)).then_some(near)
    }

    /// The box's corners; corner k takes hi on x, y, z where bit 0, 1, 2 of k is set.
    pub fn corners(&self) -> [DVec3; 8] {
        let (lo, hi) = (self.lo, self.hi);
        std::array::from_fn(|k| {
            DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            )
        })
    }

    pub fn of_points(points: impl IntoIterator<Item = DVec3>) -> Aabb {
        points.into_iter().fold(Aabb::EMPTY, |b, p| Aabb {
            lo: b.lo.min(p),
            hi: b.hi.max(p),
        })
    }

    pub fn union(self, other: Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
        }
    }

    fn centre(&self) -> DVec3 {
        0.5 * (self.lo + self.hi)
    }

    /// Half the surface area (what the heuristic compares); 0 for an empty box.
    fn half_area(&self) -> f64 {
        let e = (self.hi - self.lo).max(DVec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// The tree's shape: for each node (depth first) its right child, or the box it holds.
#[derive(Clone, Debug)]
pub(crate) struct Bvh {
    nodes: Vec<Shape>,
}

#[derive(Clone, Copy, Debug)]
enum Shape {
    Interior { right: u32 },
    Leaf { item: u32 },
}

/// Bins of the surface-area heuristic along the split axis.
const BINS: usize = 12;

/// Depth below which splits halve the items (at most 2^32 of them: at most 32 more levels).
const MEDIAN_DEPTH: u32 = 16;

/// Nodes a CPU walk keeps waiting at most: one per level of the deepest tree, and two more.
const WALK_STACK: usize = MEDIAN_DEPTH as usize + 32 + 2;

impl Bvh {
    /// The tree over `boxes` (at least one).
    pub fn build(boxes: &[Aabb]) -> Bvh {
        let mut items: Vec<u32> = (0..boxes.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * boxes.len());
        if !boxes.is_empty() {
            build_node(boxes, &mut items, &mut nodes, 0);
        }
        Bvh { nodes }
    }

    #[cfg(test)]
    fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Per node (depth first), the box around its subtree's items in `placed` (one box per
    /// item; an empty box is a leaf no ray enters).
    pub fn node_bounds(&self, placed: &[Aabb]) -> Vec<Aabb> {
        let mut bounds = vec![Aabb::EMPTY; self.nodes.len()];
        // Children follow their parent, so walking backwards meets them first.
        for i in (0..self.nodes.len()).rev() {
            bounds[i] = match self.nodes[i] {
                Shape::Leaf { item } => placed[item as usize],
                Shape::Interior { right } => bounds[i + 1].union(bounds[right as usize]),
            };
        }
        bounds
    }

    /// GPU nodes with the bounds of `placed` (in the frame's space, as `node_bounds`).
    pub fn refit(&self, placed: &[Aabb]) -> Vec<BvhNodeGpu> {
        let bounds = self.node_bounds(placed);
        self.nodes
            .iter()
            .zip(&bounds)
            .map(|(shape, b)| {
                let (index, leaf) = match *shape {
                    Shape::Interior { right } => (right, 0),
                    Shape::Leaf { item } => (item, 1),
                };
                let (lo, hi) = outward_f32(b);
                BvhNodeGpu {
                    lo,
                    index,
                    hi,
                    leaf,
                }
            })
            .collect()
    }

    /// Calls `found` for every item whose subtree's boxes all pass `keep` (a test that keeps a
    /// node's box whenever it keeps one of its items' boxes: a bundle of rays' frustum).
    pub fn select(
        &self,
        bounds: &[Aabb],
        keep: impl Fn(&Aabb) -> bool,
        mut found: impl FnMut(u32),
    ) {
        let mut stack = [0usize; WALK_STACK];
        let mut waiting = usize::from(!self.nodes.is_empty());
        while waiting > 0 {
            waiting -= 1;
            let i = stack[waiting];
            if !keep(&bounds[i]) {
                continue;
            }
            match self.nodes[i] {
                Shape::Leaf { item } => found(item),
                Shape::Interior { right } => {
                    stack[waiting] = right as usize;
                    stack[waiting + 1] = i + 1;
                    waiting += 2;
                }
            }
        }
    }

    /// This tree with the node bounds a CPU walk tests (`node_bounds`), for `ItemWalk`'s
    /// queries.
    pub fn with<'a>(&'a self, bounds: &'a [Aabb]) -> Bounded<'a> {
        Bounded { bvh: self, bounds }
    }

    /// Visits the items whose boxes the ray meets within the span, which `visit` may shorten
    /// (its second argument, the span's end) or end (returning true).
    fn walk(
        &self,
        bounds: &[Aabb],
        o: DVec3,
        d: DVec3,
        (t0, mut t1): (f64, f64),
        mut visit: impl FnMut(u32, &mut f64) -> bool,
    ) {
        let inverse = d.recip();
        // Nodes with where the ray enters them; the nearer child is popped first, so the
        // nearest hit is usually found early and shortens the span for the rest. A fixed
        // array: trees are at most MEDIAN_DEPTH + 32 deep, and each level leaves one child.
        let mut stack = [(0usize, 0.0f64); WALK_STACK];
        let mut waiting = 0;
        if let Some(t) = bounds
            .first()
            .and_then(|b| b.entry_inverse(o, inverse, (t0, t1)))
        {
            stack[0] = (0usize, t);
            waiting = 1;
        }
        while waiting > 0 {
            waiting -= 1;
            let (i, entry) = stack[waiting];
            if entry > t1 {
                continue;
            }
            match self.nodes[i] {
                Shape::Leaf { item } => {
                    if visit(item, &mut t1) {
                        return;
                    }
                }
                Shape::Interior { right } => {
                    let enter = |k: usize| {
                        bounds[k]
                            .entry_inverse(o, inverse, (t0, t1))
                            .map(|t| (k, t))
                    };
                    let (left, right) = (enter(i + 1), enter(right as usize));
                    let (near, far) = match (left, right) {
                        (Some(l), Some(r)) if r.1 < l.1 => (Some(r), Some(l)),
                        _ => (left, right),
                    };
                    for child in [far, near].into_iter().flatten() {
                        stack[waiting] = child;
                        waiting += 1;
                    }
                }
            }
        }
    }
}

/// A hierarchy a ray walks item by item, nearest subtree first (a `Bvh` with its bounds,
/// `wide_bvh::BoxBvh`), each item's own test the caller's: any-hit and nearest-hit queries.
pub(crate) trait ItemWalk {
    /// Visits the items whose boxes the ray o + t d meets within `span`: `visit(item, t1)` may
    /// shorten the span's end t1 (a nearer hit) or end the walk (returning true).
    fn walk(&self, o: DVec3, d: DVec3, span: (f64, f64), visit: impl FnMut(u32, &mut f64) -> bool);

    /// Whether `hit(item)` holds for some item whose box the ray meets within `span`. Stops at
    /// the first: an any-hit walk, as occlusion rays need.
    fn any(&self, o: DVec3, d: DVec3, span: (f64, f64), mut hit: impl FnMut(u32) -> bool) -> bool {
        let mut found = false;
        self.walk(o, d, span, |item, _| {
            found = hit(item);
            found
        });
        found
    }

    /// The nearest hit of the ray within `span`: `hit(item, t1)` gives the item's nearest hit
    /// before t1, if any, and each one found shortens the span. (t, item), or (span.1, None)
    /// without one.
    fn nearest(
        &self,
        o: DVec3,
        d: DVec3,
        span: (f64, f64),
        mut hit: impl FnMut(u32, f64) -> Option<f64>,
    ) -> (f64, Option<u32>) {
        let mut best = (span.1, None);
        self.walk(o, d, span, |item, t1| {
            if let Some(t) = hit(item, *t1).filter(|&t| t < *t1) {
                *t1 = t;
                best = (t, Some(item));
            }
            false
        });
        best
    }
}

/// A `Bvh` with the node bounds its CPU walk tests (`Bvh::with`).
pub(crate) struct Bounded<'a> {
    bvh: &'a Bvh,
    bounds: &'a [Aabb],
}

impl ItemWalk for Bounded<'_> {
    fn walk(&self, o: DVec3, d: DVec3, span: (f64, f64), visit: impl FnMut(u32, &mut f64) -> bool) {
        self.bvh.walk(self.bounds, o, d, span, visit);
    }
}

/// f32 bounds that still contain the f64 box (an empty box stays empty).
fn outward_f32(b: &Aabb) -> ([f32; 3], [f32; 3]) {
    if (0..3).any(|k| b.lo[k] > b.hi[k]) {
        return ([1.0; 3], [-1.0; 3]);
    }
    let pad = |v: f64| v.abs() * 1e-6 + 1e-30;
    let lo = b.lo.to_array().map(|v| (v - pad(v)) as f32);
    let hi = b.hi.to_array().map(|v| (v + pad(v)) as f32);
    (lo, hi)
}

/// Appends the subtree over `items`, depth first (its root is the first node pushed).
fn build_node(boxes: &[Aabb], items: &mut [u32], nodes: &mut Vec<Shape>, depth: u32) {
    let at = nodes.len();
    if items.len() == 1 {
        nodes.push(Shape::Leaf { item: items[0] });
        return;
    }
    nodes.push(Shape::Interior { right: 0 });
    // Past MEDIAN_DEPTH only halving: a tree stays shallower than the walk's stack
    // (STACK_DEPTH = 48 in trace_functions.wgsl) however the boxes lie.
    let mid = if depth < MEDIAN_DEPTH {
        split(boxes, items)
    } else {
        median_split(boxes, items)
    };
    let (left, right) = items.split_at_mut(mid);
    build_node(boxes, left, nodes, depth + 1);
    let right_at = nodes.len() as u32;
    build_node(boxes, right, nodes, depth + 1);
    nodes[at] = Shape::Interior { right: right_at };
}

/// Reorders `items` and returns the split point: the binned surface-area heuristic over the
/// centres' longest axis, or the median where the centres coincide or no split is better.
fn split(boxes: &[Aabb], items: &mut [u32]) -> usize {
    let centres = Aabb::of_points(items.iter().map(|&i| boxes[i as usize].centre()));
    let extent = centres.hi - centres.lo;
    let axis = extent.max_position();
    if extent[axis] <= 0.0 {
        return median_split(boxes, items);
    }
    let bin_of = |i: u32| {
        let c = boxes[i as usize].centre()[axis];
        (((c - centres.lo[axis]) / extent[axis] * BINS as f64) as usize).min(BINS - 1)
    };
    let mut bins = [(Aabb::EMPTY, 0usize); BINS];
    for &i in items.iter() {
        let b = &mut bins[bin_of(i)];
        *b = (b.0.union(boxes[i as usize]), b.1 + 1);
    }
    // Cost of splitting after bin k: left area x count + right area x count.
    let mut best = (f64::INFINITY, 0);
    for k in 0..BINS - 1 {
        let side = |range: &[(Aabb, usize)]| {
            range
                .iter()
                .fold((Aabb::EMPTY, 0), |(a, n), (b, m)| (a.union(*b), n + m))
        };
        let (la, ln) = side(&bins[..=k]);
        let (ra, rn) = side(&bins[k + 1..]);
        if ln == 0 || rn == 0 {
            continue;
        }
        let cost = la.half_area() * ln as f64 + ra.half_area() * rn as f64;
        if cost < best.0 {
            best = (cost, k);
        }
    }
    if !best.0.is_finite() {
        return median_split(boxes, items);
    }
    let mut left = 0;
    for j in 0..items.len() {
        if bin_of(items[j]) <= best.1 {
            items.swap(left, j);
            left += 1;
        }
    }
    left
}

/// Halves `items` by their centres along the centres' longest axis.
fn median_split(boxes: &[Aabb], items: &mut [u32]) -> usize {
    let centres = Aabb::of_points(items.iter().map(|&i| boxes[i as usize].centre()));
    let axis = (centres.hi - centres.lo).max_position();
    let median = items.len() / 2;
    items.select_nth_unstable_by(median, |a, b| {
        let ca = boxes[*a as usize].centre()[axis];
        ca.total_cmp(&boxes[*b as usize].centre()[axis])
    });
    median
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_at(x: f64, y: f64, z: f64) -> Aabb {
        let lo = DVec3::new(x, y, z);
        Aabb { lo, hi: lo + 1.0 }
    }

    #[test]
    fn rays_meet_a_box_only_within_their_stretch() {
        let b = unit_at(0.0, 0.0, 0.0);
        let x = DVec3::X;
        let o = DVec3::new(-2.0, 0.5, 0.5);
        assert!(b.meets(o, x, (0.0, f64::MAX)));
        // Entered at t = 2, left at t = 3.
        assert!(!b.meets(o, x, (0.0, 1.9)));
        assert!(!b.meets(o, x, (3.1, 9.0)));
        assert!(b.meets(o, x, (2.5, 2.6)));
        // Beside the box, and along a face's plane (0 × inf): kept, conservatively.
        assert!(!b.meets(DVec3::new(-2.0, 1.5, 0.5), x, (0.0, f64::MAX)));
        assert!(b.meets(DVec3::new(-2.0, 1.0, 0.5), x, (0.0, f64::MAX)));
        assert!(!Aabb::EMPTY.meets(o, x, (0.0, f64::MAX)));
    }

    /// Every box is in exactly one leaf, and every node's bounds hold its children's.
    #[test]
    fn refit_bounds_hold_every_leaf_once() {
        let boxes: Vec<Aabb> = (0..37)
            .map(|i| unit_at((i % 5) as f64 * 1.5, (i / 5) as f64, ((i * 7) % 3) as f64))
            .collect();
        let bvh = Bvh::build(&boxes);
        assert_eq!(bvh.len(), 2 * boxes.len() - 1);
        let nodes = bvh.refit(&boxes);
        let mut seen = vec![0; boxes.len()];
        for (i, n) in nodes.iter().enumerate() {
            if n.leaf == 1 {
                seen[n.index as usize] += 1;
                let b = boxes[n.index as usize];
                for k in 0..3 {
                    assert!(n.lo[k] as f64 <= b.lo[k] && n.hi[k] as f64 >= b.hi[k]);
                }
                continue;
            }
            for child in [&nodes[i + 1], &nodes[n.index as usize]] {
                for k in 0..3 {
                    assert!(n.lo[k] <= child.lo[k] && n.hi[k] >= child.hi[k]);
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1), "{seen:?}");
    }

    /// Coincident centres (no axis to split on) still give a balanced, valid tree; an empty
    /// placed box stays empty after rounding.
    #[test]
    fn coincident_boxes_and_empty_leaves() {
        let boxes = vec![unit_at(0.0, 0.0, 0.0); 8];
        let bvh = Bvh::build(&boxes);
        let mut placed = boxes.clone();
        placed[3] = Aabb::EMPTY;
        let nodes = bvh.refit(&placed);
        let leaf3 = nodes.iter().find(|n| n.leaf == 1 && n.index == 3).unwrap();
        assert!(leaf3.lo[0] > leaf3.hi[0]);
        assert!(nodes[0].lo.iter().all(|&v| v <= 0.0) && nodes[0].hi.iter().all(|&v| v >= 1.0));
    }
}
