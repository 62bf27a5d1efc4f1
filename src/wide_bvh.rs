//! An 8-wide bounding-volume hierarchy for single-ray walks on a CPU: each node holds its eight
//! children's boxes as two groups of four SIMD lanes (glam's `Vec4`: SSE on x86-64, NEON on
//! ARM), so one box test serves four children at once; children are visited nearest first, and
//! a subtree starting beyond the nearest hit so far is skipped. Two kinds of leaves: up to four
//! triangles laid out lane by lane and tested at once (`WideBvh`, the CPU backend's meshes), or
//! one item's box, whose test the caller makes (`BoxBvh`, the pieces of a set's patches).
//!
//! The tree's shape comes from obvhs (PLOC with reinsertion), collapsed here to eight children
//! per node. Why not obvhs's own traversal: its compressed
//! 8-wide BVH is walked in the GPU-friendly octant order with one face tested at a time, and on
//! the bunny's 1 M random rays (this machine, 2 cores) it took 1.7–1.8 times as long as this
//! walk; no maintained crate offers a distance-ordered wide traversal for incoherent rays.
//!
//! Spaces: `WideBvh` takes triangles and rays in one f32 space (the mesh tracer's, re-centred
//! on its box), t in the direction's units. `BoxBvh` takes f64 boxes and rays in any one space
//! and keeps f32 copies re-centred on the boxes' centre, widened so that f32 rounding never
//! drops a box a ray meets.

use glam::{DVec3, Vec3A, Vec4};
use obvhs::bvh2::builder::{build_bvh2, build_bvh2_from_tris};
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::Bvh2;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

/// A child code's tag for a leaf (else the code is a node index).
const LEAF: u32 = 1 << 31;
/// An empty child slot (its box is empty, so no ray enters it).
const EMPTY: u32 = u32::MAX;
/// Children per node: `GROUPS` groups of four lanes.
const GROUPS: usize = 2;
const WIDTH: usize = 4 * GROUPS;
/// Box far distances are widened by this factor, so f32 rounding never drops a box a ray
/// grazes (Ize, "Robust BVH ray traversal": 1 + 2 gamma(3) covers the slab test's rounding).
const FAR_WIDEN: f32 = 1.000_000_4;

#[derive(Clone, Copy)]
struct Node {
    lo: [[Vec4; GROUPS]; 3],
    hi: [[Vec4; GROUPS]; 3],
    child: [u32; WIDTH],
}

impl Node {
    fn empty() -> Node {
        Node {
            lo: [[Vec4::INFINITY; GROUPS]; 3],
            hi: [[Vec4::NEG_INFINITY; GROUPS]; 3],
            child: [EMPTY; WIDTH],
        }
    }
}

/// Up to four triangles, lane by lane: a corner and two edges (Möller–Trumbore in the form of
/// obvhs's `Triangle::intersect`); unused lanes are NaN, which no comparison passes.
#[derive(Clone, Copy)]
struct Leaf {
    v0: [Vec4; 3],
    e1: [Vec4; 3],
    e2: [Vec4; 3],
    /// The primitive (index into the triangles given to `build`) of each lane.
    primitive: [u32; 4],
}

/// A ray made ready for the walk: its parts splat across lanes, and per axis whether the
/// direction is negative (then a box's near side is its high side).
pub(crate) struct WideRay {
    o: [Vec4; 3],
    d: [Vec4; 3],
    inv: [Vec4; 3],
    negative: [bool; 3],
    tmin: f32,
    /// The least barycentric coordinate a face test accepts (0, or below 0 for a widened test).
    least_weight: Vec4,
}

impl WideRay {
    pub fn new(o: Vec3A, d: Vec3A, tmin: f32) -> WideRay {
        // A zero component becomes a huge finite inverse: (lo - o) * inv then stays finite or
        // 0 instead of 0 * inf = NaN.
        let inverse = |x: f32| {
            if x.abs() < f32::MIN_POSITIVE {
                (0.5 * f32::MAX).copysign(x)
            } else {
                1.0 / x
            }
        };
        WideRay {
            o: [o.x, o.y, o.z].map(Vec4::splat),
            d: [d.x, d.y, d.z].map(Vec4::splat),
            inv: [d.x, d.y, d.z].map(|c| Vec4::splat(inverse(c))),
            negative: [d.x < 0.0, d.y < 0.0, d.z < 0.0],
            tmin,
            least_weight: Vec4::ZERO,
        }
    }

    /// The ray with each face test widened by `slack` (barycentric units) past the face's
    /// edges: it then never slips between two faces sharing an edge, and a caller that checks
    /// the faces found exactly (as the CPU backend's meshes do in f64) gets every hit.
    pub fn with_edge_slack(mut self, slack: f32) -> WideRay {
        self.least_weight = Vec4::splat(-slack);
        self
    }
}

/// What a leaf visitor tells the walk.
pub(crate) enum Visit {
    Continue,
    Stop,
}

pub(crate) struct WideBvh {
    nodes: Vec<Node>,
    leaves: Vec<Leaf>,
}

impl WideBvh {
    /// The hierarchy over `triangles` (every core for the build).
    pub fn build(triangles: &[Triangle]) -> WideBvh {
        let mut bvh = WideBvh {
            nodes: Vec::new(),
            leaves: Vec::new(),
        };
        if triangles.is_empty() {
            return bvh;
        }
        let params = BvhBuildParams {
            max_prims_per_leaf: 4,
            ..BvhBuildParams::fast_build()
        };
        let binary = build_bvh2_from_tris(triangles, params, &mut std::time::Duration::default());
        bvh.node(&binary, 0, &mut |bvh, node| {
            bvh.leaf(&binary, node, triangles)
        });
        bvh
    }

    /// Node `k` of the binary tree as a wide node (appended); `leaf` gives a binary leaf's
    /// child code.
    fn node(
        &mut self,
        binary: &Bvh2,
        k: usize,
        leaf: &mut impl FnMut(&mut WideBvh, &Bvh2Node) -> u32,
    ) {
        let me = self.nodes.len();
        self.nodes.push(Node::empty());
        if binary.nodes[k].is_leaf() {
            // A tree of a single leaf: the root holds it.
            let code = leaf(self, &binary.nodes[k]);
            self.set_child(me, 0, &binary.nodes[k], code);
            return;
        }
        // Open the largest interior child until there are WIDTH children (or only leaves).
        let first = binary.nodes[k].first_index as usize;
        let mut children = vec![first, first + 1];
        while children.len() < WIDTH {
            let area = |i: &usize| half_area(&binary.nodes[children[*i]]);
            let interior = (0..children.len()).filter(|&i| !binary.nodes[children[i]].is_leaf());
            let Some(widest) = interior.max_by(|a, b| area(a).total_cmp(&area(b))) else {
                break;
            };
            let grand = binary.nodes[children[widest]].first_index as usize;
            children[widest] = grand;
            children.push(grand + 1);
        }
        for (lane, &c) in children.iter().enumerate() {
            let node = &binary.nodes[c];
            let code = if node.is_leaf() {
                leaf(self, node)
            } else {
                let code = self.nodes.len() as u32;
                self.node(binary, c, leaf);
                code
            };
            self.set_child(me, lane, node, code);
        }
    }

    fn leaf(&mut self, binary: &Bvh2, node: &Bvh2Node, triangles: &[Triangle]) -> u32 {
        let nan = [Vec4::NAN; 3];
        let mut leaf = Leaf {
            v0: nan,
            e1: nan,
            e2: nan,
            primitive: [EMPTY; 4],
        };
        let first = node.first_index as usize;
        let primitives = &binary.primitive_indices[first..first + node.prim_count as usize];
        assert!(
            primitives.len() <= 4,
            "a leaf of {} faces",
            primitives.len()
        );
        for (lane, &p) in primitives.iter().enumerate() {
            let t = &triangles[p as usize];
            let (e1, e2) = (t.v0 - t.v1, t.v2 - t.v0);
            for axis in 0..3 {
                leaf.v0[axis][lane] = t.v0[axis];
                leaf.e1[axis][lane] = e1[axis];
                leaf.e2[axis][lane] = e2[axis];
            }
            leaf.primitive[lane] = p;
        }
        self.leaves.push(leaf);
        LEAF | (self.leaves.len() as u32 - 1)
    }

    fn set_child(&mut self, me: usize, lane: usize, child: &Bvh2Node, code: u32) {
        let (node, aabb) = (&mut self.nodes[me], child.aabb());
        for axis in 0..3 {
            node.lo[axis][lane / 4][lane % 4] = aabb.min[axis];
            node.hi[axis][lane / 4][lane % 4] = aabb.max[axis];
        }
        node.child[lane] = code;
    }

    /// The distance of each lane's triangle along the ray within [tmin, tmax], else infinity.
    #[inline]
    fn leaf_hits(leaf: &Leaf, ray: &WideRay, tmax: f32) -> Vec4 {
        let (o, d) = (&ray.o, &ray.d);
        let (e1, e2) = (&leaf.e1, &leaf.e2);
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let c = [leaf.v0[0] - o[0], leaf.v0[1] - o[1], leaf.v0[2] - o[2]];
        let r = [
            d[1] * c[2] - d[2] * c[1],
            d[2] * c[0] - d[0] * c[2],
            d[0] * c[1] - d[1] * c[0],
        ];
        let inv_det = Vec4::ONE / (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]);
        let u = (r[0] * e2[0] + r[1] * e2[1] + r[2] * e2[2]) * inv_det;
        let v = (r[0] * e1[0] + r[1] * e1[1] + r[2] * e1[2]) * inv_det;
        let t = (n[0] * c[0] + n[1] * c[1] + n[2] * c[2]) * inv_det;
        // A face seen edge on (det 0) gives t NaN, and NaN passes no comparison.
        let w = Vec4::ONE - u - v;
        let least = ray.least_weight;
        let inside = u.cmpge(least) & v.cmpge(least) & w.cmpge(least);
        let within = t.cmpge(Vec4::splat(ray.tmin)) & t.cmple(Vec4::splat(tmax));
        Vec4::select(inside & within, t, Vec4::INFINITY)
    }

    /// The children of `node` the ray enters before `tmax`: a lane mask and each entry distance.
    #[inline]
    fn node_hits(node: &Node, ray: &WideRay, tmax: f32) -> (u32, [f32; WIDTH]) {
        let mut entry = [0.0; WIDTH];
        let mut mask = 0;
        for g in 0..GROUPS {
            let slab = |axis: usize, near: bool| {
                let side = if ray.negative[axis] == near {
                    node.hi[axis][g]
                } else {
                    node.lo[axis][g]
                };
                (side - ray.o[axis]) * ray.inv[axis]
            };
            let near = slab(0, true)
                .max(slab(1, true))
                .max(slab(2, true).max(Vec4::splat(ray.tmin)));
            let far = slab(0, false)
                .min(slab(1, false))
                .min(slab(2, false).min(Vec4::splat(tmax)));
            mask |= near.cmple(far * FAR_WIDEN).bitmask() << (4 * g);
            entry[4 * g..4 * g + 4].copy_from_slice(&near.to_array());
        }
        (mask, entry)
    }

    /// Walks the leaves the ray enters before `tmax`, nearest subtree first. `visit` gets each
    /// leaf's code (without its tag), may lower `tmax` (a nearer hit), and may stop the walk.
    fn walk(&self, ray: &WideRay, mut tmax: f32, mut visit: impl FnMut(u32, &mut f32) -> Visit) {
        if self.nodes.is_empty() {
            return;
        }
        // Entries waiting: (child code, entry distance). Inline for every tree up to ~9 wide
        // levels, on the heap past that; never zero-filled (a 2 KB array was, per ray).
        let mut stack: smallvec::SmallVec<[(u32, f32); 64]> = smallvec::SmallVec::new();
        let mut code = 0u32;
        loop {
            if code & LEAF != 0 {
                if let Visit::Stop = visit(code & !LEAF, &mut tmax) {
                    return;
                }
            } else {
                let node = &self.nodes[code as usize];
                let (mut mask, entry) = Self::node_hits(node, ray, tmax);
                if mask != 0 {
                    // Entered children nearest last: the nearest is walked now, the rest wait.
                    let mut order = [0usize; WIDTH];
                    let mut count = 0;
                    while mask != 0 {
                        let i = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let mut j = count;
                        while j > 0 && entry[order[j - 1]] < entry[i] {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                        order[j] = i;
                        count += 1;
                    }
                    for &i in &order[..count - 1] {
                        stack.push((node.child[i], entry[i]));
                    }
                    code = node.child[order[count - 1]];
                    continue;
                }
            }
            // The next waiting subtree the ray enters before the nearest hit so far.
            loop {
                match stack.pop() {
                    None => return,
                    Some((next, entry)) if entry <= tmax => {
                        code = next;
                        break;
                    }
                    Some(_) => {}
                }
            }
        }
    }

    /// Walks the triangle leaves the ray enters before `tmax`: `visit` gets each leaf's lane
    /// distances (infinity where its triangle is missed or beyond `tmax`) and primitives.
    fn walk_triangles(
        &self,
        ray: &WideRay,
        tmax: f32,
        mut visit: impl FnMut(Vec4, &[u32; 4], &mut f32) -> Visit,
    ) {
        self.walk(ray, tmax, |k, tmax| {
            let leaf = &self.leaves[k as usize];
            let t = Self::leaf_hits(leaf, ray, *tmax);
            match t.cmplt(Vec4::INFINITY).any() {
                true => visit(t, &leaf.primitive, tmax),
                false => Visit::Continue,
            }
        });
    }

    /// Hands every primitive of the leaves the ray enters before `tmax` to `visit`, which may
    /// lower `tmax` (a nearer hit): for a caller's own face test, such as an exact one in f64.
    pub fn visit_primitives(&self, ray: &WideRay, tmax: f32, mut visit: impl FnMut(u32, &mut f32)) {
        self.walk(ray, tmax, |k, tmax| {
            for &p in &self.leaves[k as usize].primitive {
                if p != EMPTY {
                    visit(p, tmax);
                }
            }
            Visit::Continue
        });
    }

    /// The nearest hit within [ray.tmin, tmax]: (t, primitive), or None.
    pub fn nearest(&self, ray: &WideRay, tmax: f32) -> Option<(f32, u32)> {
        let mut best = None;
        self.walk_triangles(ray, tmax, |t, primitive, tmax| {
            let m = t.min_element();
            if m < *tmax {
                *tmax = m;
                let lane = t.cmpeq(Vec4::splat(m)).bitmask().trailing_zeros() as usize;
                best = Some((m, primitive[lane]));
            }
            Visit::Continue
        });
        best
    }

    /// Whether the ray meets any triangle within [ray.tmin, tmax] (stops at the first found).
    pub fn any(&self, ray: &WideRay, tmax: f32) -> bool {
        let mut found = false;
        self.walk_triangles(ray, tmax, |_, _, _| {
            found = true;
            Visit::Stop
        });
        found
    }

    /// Every primitive the ray meets within [ray.tmin, tmax], in no particular order.
    pub fn all(&self, ray: &WideRay, tmax: f32) -> Vec<u32> {
        let mut found = Vec::new();
        self.walk_triangles(ray, tmax, |t, primitive, _| {
            let mut mask = t.cmplt(Vec4::INFINITY).bitmask();
            while mask != 0 {
                found.push(primitive[mask.trailing_zeros() as usize]);
                mask &= mask - 1;
            }
            Visit::Continue
        });
        found
    }
}

/// A wide tree over f64 boxes (items), for walks whose item test the caller makes in f64.
pub(crate) struct BoxBvh {
    wide: WideBvh,
    centre: DVec3,
    /// The box around every item (a ray that misses it meets none).
    root: crate::bvh::Aabb,
}

impl BoxBvh {
    /// The tree over `boxes` (empty ones left out: no ray enters them).
    pub fn build(boxes: &[crate::bvh::Aabb]) -> BoxBvh {
        let root = (boxes.iter()).fold(crate::bvh::Aabb::EMPTY, |a, &b| a.union(b));
        let centre = 0.5 * (root.lo + root.hi);
        // Each box widened by 1e-6 of the largest distance from the centre: more than the f32
        // rounding of the boxes, of a ray's origin moved into the root box and of its
        // direction over the root box's span (each under 1e-7 of it).
        let reach = (root.lo - centre)
            .abs()
            .max((root.hi - centre).abs())
            .max_element();
        let margin = 1e-6 * reach + f64::from(f32::MIN_POSITIVE);
        let (mut items, mut wide_boxes) = (Vec::new(), Vec::new());
        for (i, b) in boxes.iter().enumerate() {
            if b.lo.cmple(b.hi).all() {
                items.push(i as u32);
                wide_boxes.push(obvhs::aabb::Aabb {
                    min: Vec3A::from((b.lo - centre - margin).as_vec3()),
                    max: Vec3A::from((b.hi - centre + margin).as_vec3()),
                });
            }
        }
        let mut wide = WideBvh {
            nodes: Vec::new(),
            leaves: Vec::new(),
        };
        if !items.is_empty() {
            let params = BvhBuildParams {
                max_prims_per_leaf: 1,
                ..BvhBuildParams::fast_build()
            };
            let binary = build_bvh2(&wide_boxes, params, &mut std::time::Duration::default());
            wide.node(&binary, 0, &mut |_, node| {
                assert_eq!(node.prim_count, 1, "a leaf of several boxes");
                LEAF | items[binary.primitive_indices[node.first_index as usize] as usize]
            });
        }
        BoxBvh { wide, centre, root }
    }
}

impl crate::bvh::ItemWalk for BoxBvh {
    fn walk(
        &self,
        o: DVec3,
        d: DVec3,
        (t0, mut t1): (f64, f64),
        mut visit: impl FnMut(u32, &mut f64) -> bool,
    ) {
        // The walk starts where the ray enters the root box, so its f32 origin is near the
        // boxes however far away the ray starts.
        let Some(base) = self.root.entry_inverse(o, d.recip(), (t0, t1)) else {
            return;
        };
        let start = (o + base * d - self.centre).as_vec3();
        let ray = WideRay::new(Vec3A::from(start), Vec3A::from(d.as_vec3()), 0.0);
        // A span end in the walk's t, rounded up (never prunes a box before it).
        let local = |t1: f64| ((t1 - base) * (1.0 + 1e-6)) as f32;
        self.wide.walk(&ray, local(t1), |item, tmax| {
            let stop = visit(item, &mut t1);
            *tmax = local(t1);
            if stop {
                Visit::Stop
            } else {
                Visit::Continue
            }
        });
    }
}

fn half_area(node: &Bvh2Node) -> f32 {
    let e = node.aabb().max - node.aabb().min;
    e.x * e.y + e.y * e.z + e.z * e.x
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bvh::ItemWalk;

    /// A reproducible stream of uniform numbers in [0, 1) (xorshift64), for the tests here and
    /// the CPU backend's mesh tests.
    pub(crate) fn uniform(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// A bumpy closed sphere of `n` x 2n quads (two faces each), f32.
    fn sphere(n: usize) -> Vec<Triangle> {
        let at = |i: usize, j: usize| {
            let (th, ph) = (
                std::f32::consts::PI * i as f32 / n as f32,
                std::f32::consts::PI * j as f32 / n as f32,
            );
            let r = 1.0 + 0.1 * (5.0 * ph).sin() * (3.0 * th).cos();
            Vec3A::new(
                r * th.sin() * ph.cos(),
                r * th.sin() * ph.sin(),
                r * th.cos(),
            )
        };
        let mut out = Vec::new();
        for i in 0..n {
            for j in 0..2 * n {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                out.push(Triangle {
                    v0: a,
                    v1: b,
                    v2: c,
                });
                out.push(Triangle {
                    v0: a,
                    v1: c,
                    v2: d,
                });
            }
        }
        out
    }

    /// Random rays from around and inside the sphere: the walk finds what testing every face
    /// finds (nearest distance and face, any-hit, every crossing), with obvhs's own face test
    /// as the independent reference.
    #[test]
    fn the_walk_finds_what_testing_every_face_finds() {
        let triangles = sphere(40);
        let bvh = WideBvh::build(&triangles);
        let mut random = uniform(0x9e37_79b9_7f4a_7c15);
        let mut unit = || (random() * 2.0 - 1.0) as f32;
        let (mut hits, mut crossings) = (0, 0);
        for k in 0..3000 {
            let reach = if k % 3 == 0 { 0.5 } else { 3.0 };
            let o = Vec3A::new(unit(), unit(), unit()) * reach;
            let d = Vec3A::new(unit(), unit(), unit()).normalize();
            let ray = obvhs::ray::Ray::new(o, d, 0.0, f32::INFINITY);
            let reference: Vec<(f32, u32)> = (triangles.iter().enumerate())
                .map(|(i, t)| (t.intersect(&ray), i as u32))
                .filter(|h| h.0.is_finite())
                .collect();
            let wide = WideRay::new(o, d, 0.0);
            let nearest = bvh.nearest(&wide, f32::INFINITY);
            let closest = reference.iter().min_by(|a, b| a.0.total_cmp(&b.0));
            match (nearest, closest) {
                (Some(a), Some(b)) => assert!((a.0 - b.0).abs() <= 1e-5, "{a:?} {b:?}"),
                (a, b) => assert_eq!(a.is_some(), b.is_some(), "{o} {d}: {a:?} {b:?}"),
            }
            assert_eq!(bvh.any(&wide, f32::INFINITY), closest.is_some());
            let mut all = bvh.all(&wide, f32::INFINITY);
            let mut expected: Vec<u32> = reference.iter().map(|h| h.1).collect();
            all.sort_unstable();
            expected.sort_unstable();
            assert_eq!(all, expected);
            hits += usize::from(closest.is_some());
            crossings += expected.len();
        }
        // Measured: 1,135 of 3,000 rays hit, 1,248 crossings (rays from inside cross once).
        assert!(hits > 600 && crossings > 700, "{hits} {crossings}");
    }

    /// Boxes of every size scattered far from the origin, rays from near and from a million
    /// times their spread away: the walk visits every box the ray meets in f64 (it may visit a
    /// few more, within its margin), and the nearest item is the brute-force one.
    #[test]
    fn a_box_walk_misses_no_box_the_ray_meets() {
        use crate::bvh::Aabb;
        let mut random = uniform(0x2545_f491_4f6c_dd1d);
        let mut unit = || random() * 2.0 - 1.0;
        let offset = DVec3::new(1e4, -3e4, 2e4);
        let boxes: Vec<Aabb> = (0..5000)
            .map(|k| {
                let c = offset + DVec3::new(unit(), unit(), unit()) * 10.0;
                // Some flat (zero thickness), as a flat patch's pieces are.
                let h = DVec3::new(
                    unit().abs(),
                    unit().abs(),
                    if k % 4 == 0 { 0.0 } else { unit().abs() },
                ) * 0.3;
                Aabb {
                    lo: c - h,
                    hi: c + h,
                }
            })
            .collect();
        let bvh = BoxBvh::build(&boxes);
        let (mut met, mut extra) = (0, 0);
        for k in 0..2000 {
            let far = if k % 2 == 0 { 30.0 } else { 3e7 };
            let d = DVec3::new(unit(), unit(), unit()).normalize();
            let target = offset + DVec3::new(unit(), unit(), unit()) * 8.0;
            let o = target - d * far;
            let meets: Vec<u32> = (0..boxes.len() as u32)
                .filter(|&i| boxes[i as usize].meets(o, d, (0.0, f64::INFINITY)))
                .collect();
            let mut visited = Vec::new();
            bvh.walk(o, d, (0.0, f64::INFINITY), |i, _| {
                visited.push(i);
                false
            });
            visited.sort_unstable();
            assert!(
                meets.iter().all(|i| visited.binary_search(i).is_ok()),
                "ray {k} missed a box"
            );
            met += meets.len();
            extra += visited.len() - meets.len();
            // Nearest by each box's entry: the walk's pruning keeps the nearest.
            let entry =
                |i: u32| boxes[i as usize].entry_inverse(o, d.recip(), (0.0, f64::INFINITY));
            let nearest = bvh.nearest(o, d, (0.0, f64::INFINITY), |i, _| entry(i));
            let brute = meets
                .iter()
                .filter_map(|&i| entry(i))
                .fold(f64::INFINITY, f64::min);
            assert_eq!(nearest.0, brute, "ray {k}");
        }
        // Measured: 3,044 boxes met, none visited beyond them.
        assert!(met > 1500 && extra * 100 < met, "{met} {extra}");
    }
}
