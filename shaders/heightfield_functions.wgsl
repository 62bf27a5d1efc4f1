// Height-field intersection, shared by the ray-casting passes: the surface rule of
// src/heightfield.rs (bilinear in cells whose four texels all hold surface, where the bilinear
// blend of the texels' outline distances is not negative; that CPU code is the reference the
// tests hold this code to), the paper's linear + binary search, and an exact min-max-pyramid
// traversal. Reads `heights`, `outlines` and `pyramid` (gtex_bindings.wgsl). A crossing outside
// the outline is no hit: every search goes on past it.
//
// Space: patch-local (unit cube, heights h in [0, 1]) and, inside it, texel-centre coordinates
// x = u W - 1/2 (texel i at x = i) or cell-grid coordinates g = x + 1 (pyramid level-0 cell c spans
// g in [c, c + 1]). Heights are 8- or 16-bit codes: 0 = empty, else
// h = (code - 1) / (code_max - 1), code_max (255 or 65535) per patch.

// Counting build: this fragment's height, outline and pyramid reads (see COUNT_FETCHES).
var<private> fetches: u32 = 0u;

// Height code at a texel (0: empty). The atlas holds each map with a one-texel border that
// continues it linearly past its edge (src/render/atlas.rs, heightfield::padded_heights), so the
// cells at the map's sides, which reach one texel beyond it over the box's border half-texel,
// read the continued surface; indices are clamped to that border.
fn load_code(p: PatchMaps, texel: vec2<i32>) -> f32 {
    if (COUNT_FETCHES) {
        fetches += 1u;
    }
    let t = clamp(texel, vec2<i32>(-1), vec2<i32>(p.size));
    return f32(textureLoad(heights, vec2<i32>(p.atlas_origin) + t, p.ids.x, 0).x);
}

// Pyramid node `index` (src/render/atlas.rs, pack_node) as (smallest, largest) height code, each
// rounded outwards; smallest > largest for a node with no surface.
fn pyramid_node(p: PatchMaps, index: u32) -> vec2<f32> {
    let width = textureDimensions(pyramid).x;
    let packed = textureLoad(pyramid, vec2<u32>(index % width, index / width), 0).x;
    let lo = packed & 0xffu;
    let hi = packed >> 8u;
    if (lo > hi) {
        return vec2<f32>(1.0, 0.0);
    }
    // 16-bit patches keep the top byte of each code: widen it to every code it stands for.
    let shift = select(0u, 8u, p.pyramid_at.z > 255u);
    let fill = (1u << shift) - 1u;
    return vec2<f32>(f32(lo << shift), f32((hi << shift) | fill));
}

// Outline distance at a texel (in the atlas's continued border past the map's edge, as the
// heights), in units of OUTLINE_REACH texels.
fn load_outline(p: PatchMaps, texel: vec2<i32>) -> f32 {
    if (COUNT_FETCHES) {
        fetches += 1u;
    }
    let t = clamp(texel, vec2<i32>(-1), vec2<i32>(p.size));
    return textureLoad(outlines, vec2<i32>(p.atlas_origin) + t, p.ids.x, 0).x;
}

// Outline distances at the corners of the cell with lower-left texel ij, in corner_codes' order.
fn corner_outlines(p: PatchMaps, ij: vec2<i32>) -> vec4<f32> {
    return vec4<f32>(
        load_outline(p, ij),
        load_outline(p, ij + vec2<i32>(1, 0)),
        load_outline(p, ij + vec2<i32>(0, 1)),
        load_outline(p, ij + vec2<i32>(1, 1)),
    );
}

// Bilinear blend of a cell's corner values at fractions f in the cell.
fn blend(q: vec4<f32>, f: vec2<f32>) -> f32 {
    return mix(mix(q.x, q.y, f.x), mix(q.z, q.w, f.x), f.y);
}

fn decode(p: PatchMaps, code: f32) -> f32 {
    return (code - 1.0) / (f32(p.pyramid_at.z) - 1.0);
}

// The four corner codes of the cell with lower-left texel ij (indices clamped).
fn corner_codes(p: PatchMaps, ij: vec2<i32>) -> vec4<f32> {
    return vec4<f32>(
        load_code(p, ij),
        load_code(p, ij + vec2<i32>(1, 0)),
        load_code(p, ij + vec2<i32>(0, 1)),
        load_code(p, ij + vec2<i32>(1, 1)),
    );
}

// Height of the bilinear field at patch-local (u, v), where all four texels around hold a
// height (< 0 elsewhere), before the outline cuts it: the linear search looks for the field's
// crossings and then keeps those inside the outline, so a ray meeting the surface next to the
// outline still has a sample on either side of it.
fn height_at(p: PatchMaps, uv: vec2<f32>) -> f32 {
    let x = uv * p.size - 0.5;
    let base = floor(x);
    let f = x - base;
    let q = corner_codes(p, vec2<i32>(base));
    if (any(q == vec4<f32>(0.0))) {
        return -1.0;
    }
    return decode(p, blend(q, f));
}

// Whether patch-local (u, v) lies inside the outline (bilinear in its cell).
fn inside_outline(p: PatchMaps, uv: vec2<f32>) -> bool {
    let x = uv * p.size - 0.5;
    let base = floor(x);
    return blend(corner_outlines(p, vec2<i32>(base)), x - base) >= 0.0;
}

// +1 above the field, -1 on or below it, 0 where it has no height.
fn side(p: PatchMaps, point: vec3<f32>) -> f32 {
    let h = height_at(p, point.xy);
    if (h < 0.0) {
        return 0.0;
    }
    return select(-1.0, 1.0, point.z > h);
}

// The crossing between t = a0 (on side s_a of the field) and t = b0 (on the other) by
// bisection: t, or -1 where it lies outside the outline.
fn bisect_crossing(p: PatchMaps, search: Search, o: vec3<f32>, d: vec3<f32>, a0: f32, b0: f32, s_a: f32) -> f32 {
    var a = a0;
    var b = b0;
    for (var k = 0u; k < u32(search.steps.w); k += 1u) {
        let m = 0.5 * (a + b);
        if (side(p, o + d * m) == s_a) {
            a = m;
        } else {
            b = m;
        }
    }
    let hit = 0.5 * (a + b);
    return select(-1.0, hit, inside_outline(p, (o + d * hit).xy));
}

// Where the field's domain (the cells with four heights) begins or ends between t = a0 (side
// s_a) and t = b0 (one of the two outside it), by bisection: the parameter just inside it.
fn domain_edge(p: PatchMaps, search: Search, o: vec3<f32>, d: vec3<f32>, a0: f32, b0: f32, s_a: f32) -> f32 {
    var a = a0;
    var b = b0;
    for (var k = 0u; k < u32(search.steps.w); k += 1u) {
        let m = 0.5 * (a + b);
        if ((side(p, o + d * m) != 0.0) == (s_a != 0.0)) {
            a = m;
        } else {
            b = m;
        }
    }
    return select(b, a, s_a != 0.0);
}

// The paper's search: linear steps balanced by slant, then bisection; a crossing it finds
// outside the outline (the steps straddled a notch of it) is passed over. Where a step enters
// or leaves the field's domain (the rim, a texel or so past the outline), the stretch between
// the domain's edge and the sample inside it is checked for a crossing too: with steps of two
// texels, the surface next to the outline would otherwise be missed. Returns t or -1.
fn linear_binary_hit(p: PatchMaps, search: Search, o: vec3<f32>, d: vec3<f32>, t_start: f32, t_end: f32) -> f32 {
    let span = abs(d.xy * (t_end - t_start)) * p.size;
    let n = u32(clamp(ceil(max(span.x, span.y) * search.steps.x), search.steps.y, search.steps.z));
    var t_prev = t_start;
    var s_prev = side(p, o + d * t_start);
    for (var i = 1u; i <= n; i += 1u) {
        let t = mix(t_start, t_end, f32(i) / f32(n));
        let s = side(p, o + d * t);
        var hit = -1.0;
        if (s != 0.0 && s_prev != 0.0 && s != s_prev) {
            hit = bisect_crossing(p, search, o, d, t_prev, t, s_prev);
        } else if (s != s_prev) {
            let edge = domain_edge(p, search, o, d, t_prev, t, s_prev);
            let s_edge = side(p, o + d * edge);
            if (s_prev == 0.0 && s_edge != 0.0 && s_edge != s) {
                hit = bisect_crossing(p, search, o, d, edge, t, s_edge);
            }
            if (s == 0.0 && s_edge != 0.0 && s_edge != s_prev) {
                hit = bisect_crossing(p, search, o, d, t_prev, edge, s_prev);
            }
        }
        if (hit >= 0.0) {
            return hit;
        }
        t_prev = t;
        s_prev = s;
    }
    return -1.0;
}

// The roots of a s^2 + b s + c in [0, len], smaller first, -1 for none; a dip shallower than
// `graze` between two roots is no crossing.
fn crossings(a: f32, b: f32, c: f32, len: f32, graze: f32) -> vec2<f32> {
    let none = vec2<f32>(-1.0);
    let scale = max(max(abs(a), abs(b)), abs(c));
    if (scale == 0.0) {
        return vec2<f32>(0.0, -1.0);
    }
    var r0 = -1.0;
    var r1 = -1.0;
    if (abs(a) <= 1e-7 * scale) {
        if (b != 0.0) {
            r0 = -c / b;
        }
    } else {
        let disc = b * b - 4.0 * a * c;
        if (disc < 0.0) {
            return none;
        }
        let q = -0.5 * (b + select(-1.0, 1.0, b >= 0.0) * sqrt(disc));
        r0 = q / a;
        if (q != 0.0) {
            r1 = c / q;
        }
        // Both roots inside and a dip shallower than half a height code: the ray only grazes
        // the surface (heights are known to half a code), as in src/heightfield.rs.
        let both = r0 >= 0.0 && r0 <= len && r1 >= 0.0 && r1 <= len;
        if (both && abs(c - b * b / (4.0 * a)) < graze) {
            return none;
        }
    }
    let k0 = select(-1.0, r0, r0 >= 0.0 && r0 <= len);
    let k1 = select(-1.0, r1, r1 >= 0.0 && r1 <= len);
    if (k0 < 0.0 || (k1 >= 0.0 && k1 < k0)) {
        return vec2<f32>(k1, k0);
    }
    return vec2<f32>(k0, k1);
}

// First crossing inside one pyramid node for t in [ta, tb], on the bilinear surface through the
// texels at the node's corners: at scale 1 (a level-0 cell) that is the exact surface; at scale
// 2^L (level of detail) the map subsampled to every 2^L-th texel. The height along the ray is a
// quadratic in t there. The first crossing inside the outline counts (blended from the cell's
// corners at scale 1; at a coarser scale every corner must be well inside it). -2 when a corner
// texel is empty or, at a coarser scale, near the outline (no surface known at this scale).
fn node_hit(p: PatchMaps, o: vec3<f32>, d: vec3<f32>, node: vec2<f32>, scale: f32, ta: f32, tb: f32) -> f32 {
    let g0 = vec2<f32>(o.x * p.size.x + 0.5, o.y * p.size.y + 0.5);
    let dg = d.xy * p.size / scale;
    let lo = vec2<i32>(node * scale) - 1;
    let hi = vec2<i32>((node + 1.0) * scale) - 1;
    let q = vec4<f32>(
        load_code(p, lo),
        load_code(p, vec2<i32>(hi.x, lo.y)),
        load_code(p, vec2<i32>(lo.x, hi.y)),
        load_code(p, hi),
    );
    if (any(q == vec4<f32>(0.0))) {
        return -2.0;
    }
    let rim = vec4<f32>(
        load_outline(p, lo),
        load_outline(p, vec2<i32>(hi.x, lo.y)),
        load_outline(p, vec2<i32>(lo.x, hi.y)),
        load_outline(p, hi),
    );
    if (scale > 1.0 && any(rim < vec4<f32>(1.0))) {
        return -2.0;
    }
    let c00 = decode(p, q.x);
    let e = decode(p, q.y) - c00;
    let f = decode(p, q.z) - c00;
    let g = decode(p, q.x) - decode(p, q.y) - decode(p, q.z) + decode(p, q.w);
    // Fractions inside the node at ta, as functions of s = t - ta.
    let fa = (g0 / scale + dg * ta) - node;
    let h2 = g * dg.x * dg.y;
    let h1 = e * dg.x + f * dg.y + g * (fa.x * dg.y + fa.y * dg.x);
    let h0 = c00 + e * fa.x + f * fa.y + g * fa.x * fa.y;
    let graze = 0.5 / (f32(p.pyramid_at.z) - 1.0);
    let s = crossings(-h2, d.z - h1, o.z + d.z * ta - h0, tb - ta, graze);
    for (var k = 0; k < 2; k += 1) {
        if (s[k] >= 0.0 && blend(rim, fa + dg * s[k]) >= 0.0) {
            return ta + s[k];
        }
    }
    return -1.0;
}

// Nodes across and down at pyramid level `l` of a pyramid whose level 0 is `size` nodes: each
// level halves the one below, rounding up, which is size / 2^l rounded up.
fn level_dims(size: vec2<u32>, l: i32) -> vec2<u32> {
    let s = u32(l);
    return (size + (1u << s) - 1u) >> vec2<u32>(s);
}

fn node_count(size: vec2<u32>, l: i32) -> u32 {
    let n = level_dims(size, l);
    return n.x * n.y;
}

// Exact first hit by descending the min-max pyramid from level `top` (the ray's stretch lies in
// one node of it): a node is skipped whole when the ray over it stays above its highest surface
// or below its lowest (no crossing is possible); a level-0 cell is solved in closed form. Node
// values pack the max code (high 16 bits) and min code (low).
fn maxmip_hit(p: PatchMaps, search: Search, o: vec3<f32>, d: vec3<f32>, t_start: f32, t_end: f32, top: i32) -> f32 {
    return maxmip_hit_from(p, search, o, d, t_start, t_end, top, top);
}

// maxmip_hit starting at level `start` instead of `top` (never below the level-of-detail stop,
// whose nodes are solved whole): the descent is exact from any level (a skipped node climbs one
// level, so the walk still widens over empty stretches), and a ray that starts next to the
// surface (the tiles' pieces) skips the visits down from the top.
fn maxmip_hit_from(p: PatchMaps, search: Search, o: vec3<f32>, d: vec3<f32>, t_start: f32, t_end: f32, top: i32,
                   start: i32) -> f32 {
    let levels = i32(p.pyramid_at.y);
    // Level-of-detail stop level (0: exact, down to the bilinear cells), never above `top`: a
    // coarser node's surface could leave the piece being searched.
    var stop = min(i32(p.pyramid_at.w), top);
    // Level 0 is (W + 1) x (H + 1) nodes; `offset` is where level `level` begins, kept as the
    // walk moves a level up or down (no per-search table of every level's offset).
    let size = vec2<u32>(p.size) + 1u;
    var level = clamp(max(start, stop), 0, levels - 1);
    var offset = p.pyramid_at.x;
    for (var l = 0; l < level; l += 1) {
        offset += node_count(size, l);
    }
    let g0 = vec2<f32>(o.x * p.size.x + 0.5, o.y * p.size.y + 0.5);
    let dg = d.xy * p.size;
    let along = select(vec2<f32>(0.0), normalize(dg), dot(dg, dg) > 0.0);
    var t = t_start;
    for (var step = 0u; step < search.method.y; step += 1u) {
        if (t >= t_end) {
            break;
        }
        let scale = f32(1 << u32(level));
        // Probe a hair along the ray so a node boundary belongs to the node being entered.
        let g = g0 + dg * t + along * 1e-3;
        let dims = level_dims(size, level);
        let node = clamp(floor(g / scale), vec2<f32>(0.0), vec2<f32>(dims - 1u));
        let lo = node * scale;
        let hi = lo + scale;
        var t_exit = t_end;
        if (dg.x > 0.0) { t_exit = min(t_exit, (hi.x - g0.x) / dg.x); }
        if (dg.x < 0.0) { t_exit = min(t_exit, (lo.x - g0.x) / dg.x); }
        if (dg.y > 0.0) { t_exit = min(t_exit, (hi.y - g0.y) / dg.y); }
        if (dg.y < 0.0) { t_exit = min(t_exit, (lo.y - g0.y) / dg.y); }
        // Always make progress, even when rounding puts t on the node's far boundary.
        t_exit = max(t_exit, t + 1e-6 * max(t_end, 1e-20));
        if (COUNT_FETCHES) {
            fetches += 1u;
        }
        let index = offset + u32(node.y) * dims.x + u32(node.x);
        let bounds = pyramid_node(p, index);
        let za = o.z + d.z * t;
        let zb = o.z + d.z * t_exit;
        if (bounds.x > bounds.y || min(za, zb) > decode(p, bounds.y)
            || max(za, zb) < decode(p, bounds.x)) {
            t = t_exit;
            if (level < levels - 1) {
                offset += dims.x * dims.y;
                level += 1;
            }
            continue;
        }
        if (level > stop) {
            level -= 1;
            offset -= node_count(size, level);
            continue;
        }
        // At the level-of-detail stop (a node about a pixel wide) the map subsampled to the
        // node's corners stands in for the texels inside it; where a corner is empty (the
        // chart's rim) the descent goes on to the exact cells.
        let hit = node_hit(p, o, d, node, scale, t, t_exit);
        if (hit >= 0.0) {
            return hit;
        }
        if (hit < -1.5 && level > 0) {
            level -= 1;
            offset -= node_count(size, level);
            stop = 0;
            continue;
        }
        t = t_exit;
        if (level < levels - 1) {
            offset += dims.x * dims.y;
            level += 1;
        }
    }
    return -1.0;
}
