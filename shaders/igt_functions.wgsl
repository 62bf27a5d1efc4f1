// The inverse-geometric-texture lookup, following the CPU reference (src/igt_data/lookup.rs) step by
// step: project an object-space point into its grid's primary space, test its cell's list with
// watertight edge functions (first listed triangle containing it), else take the listed
// triangle nearest to it (in its cell, or if that lists none in the ring of cells around it,
// IGT_MAX_RING = lookup.rs's MAX_RING); then the hit triangle's attributes, interpolated.
// The ray lookup (igt_ray_lookup) instead walks the cells the view ray crosses near the point
// and takes the first listed triangle the ray meets (no CPU twin: the reference for it is
// embree's ray casting of the detailed mesh, bench/igt.py).
//
// Spaces: object space in (see igt_types.wgsl); primary space in cell units; world normals out.

const IGT_TAU: f32 = 6.283185307179586;
const IGT_PI: f32 = 3.141592653589793;
// Rings of neighbouring cells searched when nothing listed contains the point (lookup.rs).
const IGT_MAX_RING: i32 = 1;

fn igt_wraps() -> bool {
    return object.info.x != 0u;
}

// `p` (object space) in grid `g`'s primary space; u in [0, width) when the primary wraps.
fn igt_project(g: IgtGrid, p: vec3<f32>) -> vec2<f32> {
    let d = p - g.origin.xyz;
    let y = cross(g.z.xyz, g.x.xyz);
    let l = vec3<f32>(dot(d, g.x.xyz), dot(d, y), dot(d, g.z.xyz));
    if (!igt_wraps()) {
        return vec2<f32>(l.x * g.origin.w, l.y * g.x.w);
    }
    let w = f32(g.size.x);
    let turn = fract(atan2(l.y, l.x) / IGT_TAU);
    let u = min(turn * w, w * 0.9999999);
    if (object.info.x == 1u) {
        // atan2 rather than the CPU's acos(z / r): the same angle, but f32's acos loses 3e-4
        // rad near the poles.
        let colatitude = atan2(length(l.xy), l.z);
        return vec2<f32>(u, colatitude / IGT_PI * f32(g.size.y));
    }
    return vec2<f32>(u, l.z * g.x.w);
}

// The cell offsets' index of cell (i, j) of grid `g`: i wrapped (or clamped), j clamped.
fn igt_cell(g: IgtGrid, i: i32, j: i32) -> u32 {
    let w = i32(g.size.x);
    var ii = clamp(i, 0, w - 1);
    if (igt_wraps()) {
        ii = ((i % w) + w) % w;
    }
    let jj = clamp(j, 0, i32(g.size.y) - 1);
    return g.size.z + u32(jj * w + ii);
}

// The edge function of (a, b) at p, its endpoints taken in one fixed order so that the two
// triangles sharing an edge get exactly opposite values: no point falls between them.
fn igt_edge(a: vec2<f32>, b: vec2<f32>, p: vec2<f32>) -> f32 {
    if (a.x < b.x || (a.x == b.x && a.y < b.y)) {
        let e = b - a;
        let q = p - a;
        return e.x * q.y - e.y * q.x;
    }
    let e = a - b;
    let q = p - b;
    return -(e.x * q.y - e.y * q.x);
}

// Barycentric coordinates of p in (a, b, c) and, in w, 1 if p lies inside (edges included),
// 0 if outside, -1 for a triangle of zero area.
fn igt_barycentric(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, p: vec2<f32>) -> vec4<f32> {
    let w = vec3<f32>(igt_edge(b, c, p), igt_edge(c, a, p), igt_edge(a, b, p));
    let sum = w.x + w.y + w.z;
    if (sum == 0.0) {
        return vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    let s = sign(sum);
    let inside = w.x * s >= 0.0 && w.y * s >= 0.0 && w.z * s >= 0.0;
    return vec4<f32>(w / sum, select(0.0, 1.0, inside));
}

// Squared distance from p to segment (a, b), and where its nearest point lies (0 at a, 1 at b).
fn igt_segment(a: vec2<f32>, b: vec2<f32>, p: vec2<f32>) -> vec2<f32> {
    let e = b - a;
    let len2 = dot(e, e);
    var s = 0.0;
    if (len2 > 0.0) {
        s = clamp(dot(p - a, e) / len2, 0.0, 1.0);
    }
    let q = a + e * s - p;
    return vec2<f32>(dot(q, q), s);
}

// Squared distance from p to its nearest point of (a, b, c) in w, that point's barycentrics in
// xyz (the edges tried in lookup.rs's order, a nearer one replacing a farther).
fn igt_nearest(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, p: vec2<f32>) -> vec4<f32> {
    let inside = igt_barycentric(a, b, c, p);
    if (inside.w > 0.5) {
        return vec4<f32>(inside.xyz, 0.0);
    }
    let ab = igt_segment(a, b, p);
    let bc = igt_segment(b, c, p);
    let ca = igt_segment(c, a, p);
    var best = vec4<f32>(1.0 - ab.y, ab.y, 0.0, ab.x);
    if (bc.x < best.w) {
        best = vec4<f32>(0.0, 1.0 - bc.y, bc.y, bc.x);
    }
    if (ca.x < best.w) {
        best = vec4<f32>(ca.y, 0.0, 1.0 - ca.y, ca.x);
    }
    return best;
}

// The point as entry `e`'s triangle may see it one turn on: when the primary wraps and the
// (unwrapped) triangle reaches past the grid's width; else the point itself.
fn igt_turned(e: IgtEntry, width: u32, uv: vec2<f32>) -> vec2<f32> {
    let w = f32(width);
    if (igt_wraps() && max(e.a.x, max(e.b.x, e.c.x)) > w) {
        return uv + vec2<f32>(w, 0.0);
    }
    return uv;
}

// The nearest listed triangle to `uv` in the ring `ring` of cells around (i, j); w of the
// result: its squared distance (3e38 when nothing is listed), entry index in `entry`.
fn igt_nearest_in_ring(g: IgtGrid, uv: vec2<f32>, i: i32, j: i32, ring: i32, entry: ptr<function, i32>) -> vec4<f32> {
    var best = vec4<f32>(0.0, 0.0, 0.0, 3.0e38);
    // The ring's 8 * ring cells (one for ring 0), 2 * ring a side: bottom (t, -ring), right
    // (ring, t), top (-t, ring), left (-ring, -t) for t in -ring .. ring - 1.
    let per_side = max(2 * ring, 1);
    let cells = select(8 * ring, 1, ring == 0);
    for (var q = 0; q < cells; q++) {
        let t = q % per_side - ring;
        let side = q / per_side;
        let di = select(select(-ring, -t, side == 2), select(t, ring, side == 1), side < 2);
        let dj = select(select(-t, ring, side == 2), select(-ring, t, side == 1), side < 2);
        let c = igt_cell(g, i + di, j + dj);
        for (var k = cell_start[c]; k < cell_start[c + 1u]; k++) {
            let e = entries[cell_entries[k]];
            var near = igt_nearest(e.a, e.b, e.c, uv);
            let turned = igt_turned(e, g.size.x, uv);
            if (turned.x != uv.x) {
                let other = igt_nearest(e.a, e.b, e.c, turned);
                if (other.w < near.w) {
                    near = other;
                }
            }
            if (near.w < best.w) {
                best = near;
                *entry = i32(cell_entries[k]);
            }
        }
    }
    return best;
}

// The detailed triangle under object-space point `p` in grid `grid`.
fn igt_lookup(grid: u32, p: vec3<f32>) -> IgtHit {
    let g = grids[grid];
    let uv = igt_project(g, p);
    let i = i32(floor(uv.x));
    let j = i32(floor(uv.y));
    let c = igt_cell(g, i, j);
    for (var k = cell_start[c]; k < cell_start[c + 1u]; k++) {
        let e = entries[cell_entries[k]];
        var b = igt_barycentric(e.a, e.b, e.c, uv);
        let turned = igt_turned(e, g.size.x, uv);
        if (b.w <= 0.5 && turned.x != uv.x) {
            b = igt_barycentric(e.a, e.b, e.c, turned);
        }
        if (b.w > 0.5) {
            return IgtHit(i32(cell_entries[k]), b.xyz);
        }
    }
    for (var ring = 0; ring <= IGT_MAX_RING; ring++) {
        var entry = -1;
        let near = igt_nearest_in_ring(g, uv, i, j, ring, &entry);
        if (entry >= 0) {
            return IgtHit(entry, near.xyz);
        }
    }
    return IgtHit(-1, vec3<f32>(0.0));
}

// Cells the ray lookup walks at most: bounds its cost where a grazing ray's window is long.
const IGT_MAX_WALK: i32 = 64;

// Corner k of detailed face `face` (object space).
fn igt_corner(face: u32, k: u32) -> vec3<f32> {
    let i = 9u * face + 3u * k;
    return vec3<f32>(face_corners[i], face_corners[i + 1u], face_corners[i + 2u]);
}

// The first triangle listed in grid `grid` that the ray p + t d (object space, d unit) meets
// for t in [-back, *best), if any: then *best becomes its t and *hit the hit. The grid's cells
// that the ray's projection crosses are walked in order along it (a 2D DDA, from where it
// enters the grid), each listed triangle ray-tested (watertight, ray_triangle_functions.wgsl),
// until the best hit lies before the next cell (a triangle is listed in every cell it
// overlaps). A wrapping primary's cells are not straight along a ray: nothing is walked there
// (the projection serves it).
fn igt_ray_walk(grid: u32, p: vec3<f32>, d: vec3<f32>, back: f32, best: ptr<function, f32>, hit: ptr<function, IgtHit>) {
    if (igt_wraps()) {
        return;
    }
    let g = grids[grid];
    let size = vec2<i32>(g.size.xy);
    // The ray in cell units: where it is at t = 0, and cells per unit t.
    let at = igt_project(g, p);
    let duv = vec2<f32>(dot(d, g.x.xyz) * g.origin.w, dot(d, cross(g.z.xyz, g.x.xyz)) * g.x.w);
    let moves = abs(duv) > vec2<f32>(1e-30);
    let safe = select(vec2<f32>(1.0), duv, moves);
    // Clipped to the grid's rectangle (slabs; a still axis keeps the whole range if inside).
    let t0 = (vec2<f32>(0.0) - at) / safe;
    let t1 = (vec2<f32>(size) - at) / safe;
    let inside = (at >= vec2<f32>(0.0)) & (at <= vec2<f32>(size));
    let lo = select(select(vec2<f32>(3.0e38), vec2<f32>(-3.0e38), inside), min(t0, t1), moves);
    let hi = select(select(vec2<f32>(-3.0e38), vec2<f32>(3.0e38), inside), max(t0, t1), moves);
    // And to the slab of heights its listed faces span.
    let height = dot(p - g.origin.xyz, g.z.xyz);
    let rise = dot(d, g.z.xyz);
    let top = bitcast<f32>(g.size.w);
    let rises = abs(rise) > 1e-30;
    let within = height >= g.z.w && height <= top;
    let safe_rise = select(1.0, rise, rises);
    let h0 = (g.z.w - height) / safe_rise;
    let h1 = (top - height) / safe_rise;
    let h_lo = select(select(3.0e38, -3.0e38, within), min(h0, h1), rises);
    let h_hi = select(select(-3.0e38, 3.0e38, within), max(h0, h1), rises);
    let first = max(max(-back, h_lo), max(lo.x, lo.y));
    if (first >= min(min(*best, h_hi), min(hi.x, hi.y))) {
        return;
    }
    let start = at + first * duv;
    var cell = clamp(vec2<i32>(floor(start)), vec2<i32>(0), size - 1);
    let up = duv > vec2<f32>(0.0);
    let step = select(vec2<i32>(-1), vec2<i32>(1), up);
    // t at which the ray leaves the current cell along u and v, and t per cell.
    let edge = vec2<f32>(cell) + select(vec2<f32>(0.0), vec2<f32>(1.0), up);
    var exits = select(vec2<f32>(3.0e38), (edge - at) / safe, moves);
    let per = select(vec2<f32>(3.0e38), abs(1.0 / safe), moves);
    // The cells' heights (cell_heights in kinds/igt.rs): unorm16 of the slab, rounded outward;
    // a step of slack for the f32 arithmetic here.
    let span = top - g.z.w;
    let slack = span * (2.0 / 65535.0);
    var enter = first;
    for (var k = 0; k < IGT_MAX_WALK; k++) {
        if (any(cell < vec2<i32>(0)) || any(cell >= size)) {
            break;
        }
        let c = g.size.z + u32(cell.y * size.x + cell.x);
        // The heights the ray has over this cell (up to the best hit so far), against those of
        // the cell's listed triangles: where they miss, no listed triangle can be met here (a
        // triangle met elsewhere is listed, and tested, in the cell it is met over).
        let leave = min(min(exits.x, exits.y), *best);
        let h_enter = height + rise * enter;
        let h_leave = height + rise * leave;
        let listed = unpack2x16unorm(cell_start[object.lod.w + c]);
        let meets = max(h_enter, h_leave) >= g.z.w + listed.x * span - slack
            && min(h_enter, h_leave) <= g.z.w + listed.y * span + slack;
        let end = select(cell_start[c], cell_start[c + 1u], meets);
        for (var q = cell_start[c]; q < end; q++) {
            let e = cell_entries[q];
            let f = entries[e].face;
            let r = ray_triangle(igt_corner(f, 0u), igt_corner(f, 1u), igt_corner(f, 2u), p, d, -back, *best);
            if (r.y >= 0.0) {
                *best = r.x;
                *hit = IgtHit(i32(e), r.yzw);
            }
        }
        if (min(exits.x, exits.y) >= min(*best, h_hi)) {
            break;
        }
        enter = min(exits.x, exits.y);
        if (exits.x < exits.y) {
            cell.x += step.x;
            exits.x += per.x;
        } else {
            cell.y += step.y;
            exits.y += per.y;
        }
    }
}

// The first detailed triangle that the ray p + t d meets for t in [-back, ahead), in the lists
// of the grids search_grids[search.x ..][.. search.y]; entry -1 when none.
fn igt_ray_lookup(search: vec2<u32>, p: vec3<f32>, d: vec3<f32>, back: f32, ahead: f32) -> IgtHit {
    var hit = IgtHit(-1, vec3<f32>(0.0));
    var best = ahead;
    for (var k = 0u; k < search.y; k++) {
        igt_ray_walk(search_grids[search.x + k], p, d, back, &best, &hit);
    }
    return hit;
}

// A unit normal from its octahedral encoding (two values in [-1, 1]).
fn igt_octahedral(e: vec2<f32>) -> vec3<f32> {
    var n = vec3<f32>(e.x, e.y, 1.0 - abs(e.x) - abs(e.y));
    let t = max(-n.z, 0.0);
    n.x += select(t, -t, n.x >= 0.0);
    n.y += select(t, -t, n.y >= 0.0);
    return normalize(n);
}

// The detailed face's normal at barycentric point `bary` (object space, unit).
fn igt_normal(face: u32, bary: vec3<f32>) -> vec3<f32> {
    var n = vec3<f32>(0.0);
    for (var k = 0u; k < 3u; k++) {
        n += bary[k] * igt_octahedral(unpack2x16snorm(attributes[3u * face + k]));
    }
    return normalize(n);
}

// The unoccluded fraction at `bary` of the detailed face (1 without the occlusion attribute).
fn igt_occlusion(face: u32, bary: vec3<f32>) -> f32 {
    if ((object.info.y & 4u) == 0u) {
        return 1.0;
    }
    return dot(bary, unpack4x8unorm(attributes[object.segments.w + face]).xyz);
}

// Texel (i, j) of the image, repeating.
fn igt_texel(i: i32, j: i32) -> vec4<f32> {
    let w = i32(object.info.z);
    let h = i32(object.info.w);
    let ii = ((i % w) + w) % w;
    let jj = ((j % h) + h) % h;
    return unpack4x8unorm(attributes[object.segments.z + u32(jj * w + ii)]);
}

// The image sampled bilinearly at full size at texture coordinates `uv` ((0, 0) at the bottom
// left), repeating: as the CPU samples it (src/appearance.rs).
fn igt_sample(uv: vec2<f32>) -> vec4<f32> {
    let x = uv.x * f32(object.info.z) - 0.5;
    let y = (1.0 - uv.y) * f32(object.info.w) - 0.5;
    let i = floor(x);
    let j = floor(y);
    let f = vec2<f32>(x - i, y - j);
    let a = igt_texel(i32(i), i32(j));
    let b = igt_texel(i32(i) + 1, i32(j));
    let c = igt_texel(i32(i), i32(j) + 1);
    let d = igt_texel(i32(i) + 1, i32(j) + 1);
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}

// The detailed face's base color at `bary`: its texture, else its corner colors, else neutral.
fn igt_color(face: u32, bary: vec3<f32>) -> vec4<f32> {
    if ((object.info.y & 2u) != 0u) {
        var uv = vec2<f32>(0.0);
        for (var k = 0u; k < 3u; k++) {
            let at = object.segments.y + 6u * face + 2u * k;
            uv += bary[k] * bitcast<vec2<f32>>(vec2<u32>(attributes[at], attributes[at + 1u]));
        }
        return igt_sample(uv);
    }
    if ((object.info.y & 1u) != 0u) {
        var c = vec4<f32>(0.0);
        for (var k = 0u; k < 3u; k++) {
            c += bary[k] * unpack4x8unorm(attributes[object.segments.x + 3u * face + k]);
        }
        return c;
    }
    return vec4<f32>(200.0, 200.0, 200.0, 255.0) / 255.0;
}

// A baked cell with nothing listed near it (kinds/igt.rs, EMPTY_CELL).
const IGT_EMPTY_CELL: u32 = 0x80008000u;

// The shader LoD: the baked texture (one normal and color per cell, bake.rs) read bilinearly
// between the four cell centres around object-space point `p` of grid `grid`, empty cells
// left out. Alpha -1 when all four are empty (the caller then looks up).
fn igt_baked(grid: u32, p: vec3<f32>) -> IgtShade {
    let g = grids[grid];
    let at = igt_project(g, p) - vec2<f32>(0.5);
    let corner = floor(at);
    let f = at - corner;
    var normal = vec3<f32>(0.0);
    var base = vec4<f32>(0.0);
    var weight = 0.0;
    for (var k = 0; k < 4; k++) {
        let di = k & 1;
        let dj = k >> 1u;
        let c = igt_cell(g, i32(corner.x) + di, i32(corner.y) + dj);
        let record = baked[c];
        if (record.x == IGT_EMPTY_CELL) {
            continue;
        }
        let w = select(1.0 - f.x, f.x, di == 1) * select(1.0 - f.y, f.y, dj == 1);
        normal += w * igt_octahedral(unpack2x16snorm(record.x));
        base += w * unpack4x8unorm(record.y);
        weight += w;
    }
    if (weight <= 0.0) {
        return IgtShade(vec3<f32>(0.0), vec4<f32>(-1.0));
    }
    return IgtShade(normalize(normal), base / weight);
}

// How many cells of grid `grid` one pixel spans at `p`, from the simplified surface's
// object-space derivatives per pixel (the larger of the two screen axes; a wrapping primary's
// u difference taken the short way round).
fn igt_cells_per_pixel(grid: u32, p: vec3<f32>, dx: vec3<f32>, dy: vec3<f32>) -> f32 {
    let g = grids[grid];
    let at = igt_project(g, p);
    let w = f32(g.size.x);
    var du = igt_project(g, p + dx) - at;
    var dv = igt_project(g, p + dy) - at;
    if (igt_wraps()) {
        du.x -= w * round(du.x / w);
        dv.x -= w * round(dv.x / w);
    }
    return max(length(du), length(dv));
}

// Whether the shader LoD shades this point from the baked texture (object.lod: off, where a
// cell covers less than a pixel, or beyond a distance).
fn igt_far(grid: u32, p: vec3<f32>, view_pos: vec3<f32>, dx: vec3<f32>, dy: vec3<f32>) -> bool {
    if (object.lod.y == 1u) {
        return igt_cells_per_pixel(grid, p, dx, dy) >= 1.0;
    }
    if (object.lod.y == 2u) {
        let ortho = camera.params.x > 0.5;
        let distance = select(length(view_pos), -view_pos.z, ortho);
        return distance >= bitcast<f32>(object.lod.z);
    }
    return false;
}
