// The tracer's walk, shared by every kind that can be traced: the hierarchy over a kind's leaves
// (bvh.rs; `bvh`, declared in the kind's *_trace_bindings.wgsl) is walked front to back, each leaf
// the ray reaches before the nearest hit so far is searched by the kind's own
// `leaf_search(item, o, d, t_lo, t_best) -> f32` (the first hit in [t_lo, t_best), or -1), and the
// walk stops when the next node starts behind the nearest hit.
//
// Spaces: rays and the hierarchy's bounds in one space (the query's frame for ray queries).

// The deepest hierarchy a walk can hold (bvh.rs keeps trees shallower than this).
const STACK_DEPTH: u32 = 48u;

struct TraceHit {
    t: f32,
    // The leaf's item hit (its index in the kind's leaf list), -1 for none.
    item: i32,
}

// Whether a child's box is worth entering: it overlaps [t_lo, t_best).
fn worth(span: vec2<f32>, t_lo: f32, t_best: f32) -> bool {
    let enter = max(span.x, t_lo);
    return span.y >= enter && enter < t_best;
}

// The nearest hit for t in [t_lo, t_hi), or with `any_hit` the first one found (shadow rays).
fn trace_nearest(o: vec3<f32>, d: vec3<f32>, t_lo: f32, t_hi: f32, any_hit: bool) -> TraceHit {
    var best = TraceHit(t_hi, -1);
    let inv = safe_inverse(d);
    if (!worth(slab(bvh[0].lo, bvh[0].hi, o, inv), t_lo, best.t)) {
        return best;
    }
    var stack_node: array<u32, STACK_DEPTH>;
    var stack_enter: array<f32, STACK_DEPTH>;
    var sp = 0u;
    var node = 0u;
    loop {
        let n = bvh[node];
        if (n.leaf == 1u) {
            let t = leaf_search(n.index, o, d, t_lo, best.t);
            if (t >= 0.0) {
                best = TraceHit(t, i32(n.index));
                if (any_hit) {
                    return best;
                }
            }
        } else {
            let left = node + 1u;
            let span_l = slab(bvh[left].lo, bvh[left].hi, o, inv);
            let span_r = slab(bvh[n.index].lo, bvh[n.index].hi, o, inv);
            let go_l = worth(span_l, t_lo, best.t);
            let go_r = worth(span_r, t_lo, best.t);
            if (go_l && go_r) {
                // Nearer child first; the other waits with its entry, to be dropped if a hit
                // comes before it.
                let l_first = span_l.x <= span_r.x;
                stack_node[sp] = select(left, n.index, l_first);
                stack_enter[sp] = select(span_l.x, span_r.x, l_first);
                sp += 1u;
                node = select(n.index, left, l_first);
                continue;
            }
            if (go_l || go_r) {
                node = select(n.index, left, go_l);
                continue;
            }
        }
        var next = false;
        while (sp > 0u && !next) {
            sp -= 1u;
            node = stack_node[sp];
            next = stack_enter[sp] < best.t;
        }
        if (!next) {
            break;
        }
    }
    return best;
}
