// Tracing a ray through a geometry-texture set: the hierarchy over the pieces of its patches'
// boxes (bvh.rs) is walked front to back, each piece the ray enters before the nearest hit so
// far is searched (gtex_piece_functions.wgsl), and the walk stops when the next node starts
// behind the nearest hit.
//
// Spaces: rays and the hierarchy's bounds in the space the patch records map from (see
// gtex_piece_functions.wgsl).

// The deepest hierarchy a walk can hold (bvh.rs keeps trees shallower than this).
const STACK_DEPTH: u32 = 48u;

struct GtexHit {
    t: f32,
    // The patch hit (its index in `patches`), -1 for none.
    patch_index: i32,
}

// Whether a child's box is worth entering: it overlaps [t_lo, t_best).
fn worth(span: vec2<f32>, t_lo: f32, t_best: f32) -> bool {
    let enter = max(span.x, t_lo);
    return span.y >= enter && enter < t_best;
}

// The nearest hit for t in [t_lo, t_hi), or with `any_hit` the first one found (shadow rays).
fn trace_gtex(o: vec3<f32>, d: vec3<f32>, t_lo: f32, t_hi: f32, any_hit: bool) -> GtexHit {
    var best = GtexHit(t_hi, -1);
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
            let piece = pieces[n.index];
            let t = piece_search(piece, o, d, t_lo, best.t);
            if (t >= 0.0) {
                best = GtexHit(t, i32(piece.patch_index));
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

