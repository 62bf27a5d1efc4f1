// A ray through one prism of a displacement shell: the prism's entry and exit (its top, bottom
// and fins, each fin as the two triangles the raster pass draws), the exact inverse of the
// prism's map (Newton), and the march through the tile for the first crossing of the occupancy's
// trilinear 0.5 level (the surface marching cubes extracts for Shell.to_mesh), skipping the
// empty boxes the radius grid vouches for.
//
// Spaces: see gdm_types.wgsl. The prism's map takes weights (w1, w2, h) to
//   X = sum_k w_k (p_k + h (q_k - p_k)),  w0 = 1 - w1 - w2,
// and texture space to weights affinely: T = (sum_k w_k uv_k, h * nz).

const GDM_NUDGE: f32 = 1e-4;
// A conservative table's bound (voxels) below which stepping by it hands over to the march: the
// bound stays about two voxels short of any surface (bound.rs), so steps shorter than this skip
// less than the march's own boxes would.
const GDM_HANDOVER: f32 = 1.0;
// Most lookups one piece steps by before handing over to the march.
const GDM_MAX_LOOKUPS: i32 = 64;

// Diagnostics (shell.params.w = 1): lookups, march steps and field samples of this invocation.
var<private> gdm_counts: vec3<u32>;
// Step of the fine search near solid voxels (voxels), refined by bisection.
const GDM_FINE_STEP: f32 = 0.25;

struct GdmHit {
    // The ray's parameter at the hit (the same in every affine frame of the ray), -1 for none.
    t: f32,
    // World-space unit normal.
    normal: vec3<f32>,
}

fn gdm_corners(pr: Prism) -> array<vec3<f32>, 6> {
    return array<vec3<f32>, 6>(pr.p0.xyz, pr.p1.xyz, pr.p2.xyz, pr.q0.xyz, pr.q1.xyz, pr.q2.xyz);
}

// Two-sided ray-triangle distance, -1 on a miss.
fn gdm_ray_triangle(o: vec3<f32>, d: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> f32 {
    let e1 = b - a;
    let e2 = c - a;
    let pv = cross(d, e2);
    let det = dot(e1, pv);
    if (abs(det) < 1e-20) {
        return -1.0;
    }
    let s = o - a;
    let u = dot(s, pv) / det;
    let qv = cross(s, e1);
    let v = dot(d, qv) / det;
    // A hair of slack so a ray through a shared edge meets both triangles.
    if (u < -1e-5 || v < -1e-5 || u + v > 1.0 + 1e-5) {
        return -1.0;
    }
    return dot(e2, qv) / det;
}

// Distances (up to two, -1 for none) where the ray o + t d meets the bilinear patch
//   P(u, v) = (1 - v) ((1 - u) p00 + u p10) + v ((1 - u) p01 + u p11),  u, v in [0, 1]:
// the patch's distances to two planes through the ray, each bilinear in (u, v), both zero;
// eliminating v leaves a quadratic in u.
fn gdm_ray_bilinear(o: vec3<f32>, d: vec3<f32>, p00: vec3<f32>, p10: vec3<f32>, p01: vec3<f32>,
                    p11: vec3<f32>) -> vec2<f32> {
    let ad = abs(d);
    var helper = vec3<f32>(1.0, 0.0, 0.0);
    if (ad.y <= ad.x && ad.y <= ad.z) {
        helper = vec3<f32>(0.0, 1.0, 0.0);
    } else if (ad.z <= ad.x && ad.z <= ad.y) {
        helper = vec3<f32>(0.0, 0.0, 1.0);
    }
    let n1 = normalize(cross(d, helper));
    let n2 = normalize(cross(d, n1));
    let e00 = p00 - o;
    let eu = p10 - p00;
    let ev = p01 - p00;
    let euv = p11 - p10 - p01 + p00;
    // f_i(u, v) = a_i + b_i u + c_i v + e_i u v.
    let a = vec2<f32>(dot(n1, e00), dot(n2, e00));
    let b = vec2<f32>(dot(n1, eu), dot(n2, eu));
    let c = vec2<f32>(dot(n1, ev), dot(n2, ev));
    let e = vec2<f32>(dot(n1, euv), dot(n2, euv));
    let qa = b.y * e.x - e.y * b.x;
    let qb = a.y * e.x + b.y * c.x - c.y * b.x - e.y * a.x;
    let qc = a.y * c.x - c.y * a.x;
    var roots = vec2<f32>(-1.0, -1.0);
    var us = vec2<f32>(2.0, 2.0);
    if (abs(qa) <= 1e-6 * abs(qb)) {
        if (abs(qb) > 0.0) {
            us.x = -qc / qb;
        }
    } else {
        let disc = qb * qb - 4.0 * qa * qc;
        if (disc >= 0.0) {
            let q = -0.5 * (qb + select(-1.0, 1.0, qb >= 0.0) * sqrt(disc));
            us = vec2<f32>(q / qa, select(2.0, qc / q, q != 0.0));
        }
    }
    for (var k = 0; k < 2; k++) {
        let u = us[k];
        if (u < -1e-5 || u > 1.0 + 1e-5) {
            continue;
        }
        let den = c + e * u;
        let num = a + b * u;
        let v = select(-num.y / den.y, -num.x / den.x, abs(den.x) >= abs(den.y));
        if (v < -1e-5 || v > 1.0 + 1e-5) {
            continue;
        }
        let p = p00 + eu * u + ev * v + euv * (u * v);
        roots[k] = dot(p - o, d) / dot(d, d);
    }
    return roots;
}

// (t_in, t_out) of the ray in the prism: its top and bottom triangles and its three bilinear
// fins (the prism map's own sides, so the segment's ends map onto the face's texture
// triangle, which matters where a texture seam runs along the fin); t_out < t_in on a miss.
fn gdm_prism_interval(pr: Prism, o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    var c = gdm_corners(pr);
    var lo = 3.0e38;
    var hi = -3.0e38;
    var caps = array<f32, 2>(gdm_ray_triangle(o, d, c[3], c[4], c[5]), gdm_ray_triangle(o, d, c[0], c[2], c[1]));
    for (var k = 0; k < 2; k++) {
        if (caps[k] > -0.5) {
            lo = min(lo, caps[k]);
            hi = max(hi, caps[k]);
        }
    }
    for (var e = 0u; e < 3u; e++) {
        let n = (e + 1u) % 3u;
        let t = gdm_ray_bilinear(o, d, c[e], c[n], c[e + 3u], c[n + 3u]);
        for (var k = 0; k < 2; k++) {
            if (t[k] > -0.5) {
                lo = min(lo, t[k]);
                hi = max(hi, t[k]);
            }
        }
    }
    return vec2<f32>(lo, hi);
}

fn gdm_forward(pr: Prism, w: vec3<f32>) -> vec3<f32> {
    let w0 = 1.0 - w.x - w.y;
    let a = mix(pr.p0.xyz, pr.q0.xyz, w.z);
    let b = mix(pr.p1.xyz, pr.q1.xyz, w.z);
    let c = mix(pr.p2.xyz, pr.q2.xyz, w.z);
    return w0 * a + w.x * b + w.y * c;
}

// Columns of d X / d (w1, w2, h) at w.
fn gdm_jacobian(pr: Prism, w: vec3<f32>) -> mat3x3<f32> {
    let a = mix(pr.p0.xyz, pr.q0.xyz, w.z);
    let b = mix(pr.p1.xyz, pr.q1.xyz, w.z);
    let c = mix(pr.p2.xyz, pr.q2.xyz, w.z);
    let e0 = pr.q0.xyz - pr.p0.xyz;
    let e1 = pr.q1.xyz - pr.p1.xyz;
    let e2 = pr.q2.xyz - pr.p2.xyz;
    return mat3x3<f32>(b - a, c - a, e0 + w.x * (e1 - e0) + w.y * (e2 - e0));
}

// Solves J x = r by Cramer's rule.
fn gdm_solve(j: mat3x3<f32>, r: vec3<f32>) -> vec3<f32> {
    let det = dot(j[0], cross(j[1], j[2]));
    if (abs(det) < 1e-30) {
        return vec3<f32>(0.0);
    }
    return vec3<f32>(dot(r, cross(j[1], j[2])), dot(j[0], cross(r, j[2])), dot(j[0], cross(j[1], r))) / det;
}

// The weights of local point x, by Newton's method from `guess`.
fn gdm_inverse(pr: Prism, x: vec3<f32>, guess: vec3<f32>) -> vec3<f32> {
    var w = guess;
    for (var k = 0; k < 6; k++) {
        w = w + gdm_solve(gdm_jacobian(pr, w), x - gdm_forward(pr, w));
    }
    return w;
}

fn gdm_uv(pr: Prism, k: u32) -> vec2<f32> {
    if (k == 0u) {
        return pr.uv01.xy;
    } else if (k == 1u) {
        return pr.uv01.zw;
    }
    return pr.uv2.xy;
}

fn gdm_texture_point(pr: Prism, w: vec3<f32>) -> vec3<f32> {
    let uv = pr.uv01.xy + w.x * (pr.uv01.zw - pr.uv01.xy) + w.y * (pr.uv2.xy - pr.uv01.xy);
    return vec3<f32>(uv, w.z * f32(shell.size.z));
}

// d (uv) / d (w1, w2) as columns; its inverse maps texture steps to weight steps.
fn gdm_uv_matrix(pr: Prism) -> mat2x2<f32> {
    return mat2x2<f32>(pr.uv01.zw - pr.uv01.xy, pr.uv2.xy - pr.uv01.xy);
}

fn gdm_inverse2(m: mat2x2<f32>) -> mat2x2<f32> {
    let det = m[0].x * m[1].y - m[1].x * m[0].y;
    return mat2x2<f32>(vec2<f32>(m[1].y, -m[0].y), vec2<f32>(-m[1].x, m[0].x)) * (1.0 / det);
}

fn gdm_weights_at(pr: Prism, t: vec3<f32>) -> vec3<f32> {
    let w = gdm_inverse2(gdm_uv_matrix(pr)) * (t.xy - pr.uv01.xy);
    return vec3<f32>(w, t.z / f32(shell.size.z));
}

// Empty-space radius of voxel v, the tile repeated in x and y; 1 (empty, no skip) outside z.
fn gdm_radius(v: vec3<i32>) -> u32 {
    let n = vec3<i32>(shell.size.xyz);
    if (v.z < 0 || v.z >= n.z) {
        return 1u;
    }
    let i = ((v.x % n.x) + n.x) % n.x;
    let j = ((v.y % n.y) + n.y) % n.y;
    return radii[u32((i * n.y + j) * n.z + v.z)];
}

fn gdm_solid(v: vec3<i32>) -> f32 {
    if (v.z < 0 || v.z >= i32(shell.size.z)) {
        return 0.0;
    }
    return select(0.0, 1.0, gdm_radius(v) == 0u);
}

// The occupancy sampled at voxel centres, interpolated trilinearly at texture point t.
fn gdm_field(t: vec3<f32>) -> f32 {
    gdm_counts.z += 1u;
    let s = t - 0.5;
    let b = floor(s);
    let f = s - b;
    let v = vec3<i32>(b);
    var acc = 0.0;
    for (var k = 0; k < 8; k++) {
        let o = vec3<i32>(k & 1, (k >> 1) & 1, (k >> 2) & 1);
        let wt = mix(1.0 - f, f, vec3<f32>(o));
        acc += wt.x * wt.y * wt.z * gdm_solid(v + o);
    }
    return acc;
}

// First s in [s0, s1] where the field along a + dir * s reaches 0.5, or -1.
fn gdm_fine_search(a: vec3<f32>, dir: vec3<f32>, s0: f32, s1: f32) -> f32 {
    if (gdm_field(a + dir * s0) >= 0.5) {
        return s0;
    }
    var prev = s0;
    loop {
        if (prev >= s1) {
            return -1.0;
        }
        let next = min(prev + GDM_FINE_STEP, s1);
        if (gdm_field(a + dir * next) >= 0.5) {
            var lo = prev;
            var hi = next;
            for (var k = 0; k < 8; k++) {
                let mid = 0.5 * (lo + hi);
                if (gdm_field(a + dir * mid) >= 0.5) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return hi;
        }
        prev = next;
    }
    return -1.0;
}

// Distance along the unit texture direction `dir` from `a` to the first surface, within `len`;
// -1 for none. Voxels within one of solid are searched finely; farther ones are skipped in
// boxes the radius grid guarantees free of the field's 0.5 level (radius - 2 around them).
fn gdm_march(a: vec3<f32>, dir: vec3<f32>, len: f32) -> f32 {
    var s = 0.0;
    for (var step = 0; step < 4096; step++) {
        if (s >= len) {
            break;
        }
        gdm_counts.y += 1u;
        let v = floor(a + dir * (s + GDM_NUDGE));
        let r = gdm_radius(vec3<i32>(v));
        let reach = f32(max(i32(r) - 2, 0));
        var exit = 3.0e38;
        for (var axis = 0; axis < 3; axis++) {
            let d = dir[axis];
            if (d != 0.0) {
                let face = select(v[axis] - reach, v[axis] + 1.0 + reach, d > 0.0);
                exit = min(exit, (face - a[axis]) / d);
            }
        }
        exit = max(exit, s + GDM_NUDGE);
        if (r <= 1u) {
            let hit = gdm_fine_search(a, dir, s, min(exit, len));
            if (hit >= 0.0) {
                return hit;
            }
        }
        s = exit;
    }
    return -1.0;
}

// The SVD-compressed distance d(x, y, z, theta, phi) at texture point t for the unit direction
// dir, interpolated in all five (x, y wrapped; z, theta clamped; phi wrapped), as the paper's
// texture fetches do: each term's weight map W_k(x, y, phi) trilinearly and its eigen map
// E_k(theta, z) bilinearly, whose products sum to the table's own 5D interpolation. (The nearest
// sampled direction instead, up to 6 degrees off at 16 x 32, landed on other links.)
fn gdm_lookup(t: vec3<f32>, dir: vec3<f32>) -> f32 {
    // Counted here, so the paper's one lookup per piece and the bounded march's steps count alike.
    gdm_counts.x += 1u;
    let n = vec3<i32>(shell.size.xyz);
    let counts = shell.lookup;
    let pi = 3.14159265;
    var phi = atan2(dir.y, dir.x);
    if (phi < 0.0) {
        phi += 2.0 * pi;
    }
    // Polar samples sit at the centres of equal steps, azimuths at their starts (gdm.py).
    let ta = clamp(acos(clamp(dir.z, -1.0, 1.0)) * f32(counts.x) / pi - 0.5, 0.0, f32(counts.x - 1u));
    let a0 = u32(floor(ta));
    let a1 = min(a0 + 1u, counts.x - 1u);
    let fa = ta - f32(a0);
    let tb = phi * f32(counts.y) / (2.0 * pi);
    let fb = fract(tb);
    let b0 = u32(floor(tb)) % counts.y;
    let b1 = (b0 + 1u) % counts.y;
    let s = t - 0.5;
    let base = vec3<i32>(floor(s));
    let f = s - floor(s);
    let z0 = u32(clamp(base.z, 0, n.z - 1));
    let z1 = u32(clamp(base.z + 1, 0, n.z - 1));
    var d = 0.0;
    for (var k = 0u; k < counts.z; k++) {
        var w = 0.0;
        for (var c = 0; c < 4; c++) {
            let o = vec2<i32>(c & 1, (c >> 1) & 1);
            let i = (((base.x + o.x) % n.x) + n.x) % n.x;
            let j = (((base.y + o.y) % n.y) + n.y) % n.y;
            let wt = mix(1.0 - f.xy, f.xy, vec2<f32>(o));
            let row = u32(i * n.y + j) * counts.y;
            let wp = mix(gdm_terms_w[(row + b0) * counts.z + k], gdm_terms_w[(row + b1) * counts.z + k], fb);
            w += wt.x * wt.y * wp;
        }
        let e0 = mix(gdm_terms_e[(k * counts.x + a0) * u32(n.z) + z0], gdm_terms_e[(k * counts.x + a1) * u32(n.z) + z0], fa);
        let e1 = mix(gdm_terms_e[(k * counts.x + a0) * u32(n.z) + z1], gdm_terms_e[(k * counts.x + a1) * u32(n.z) + z1], fa);
        d += w * mix(e0, e1, f.z);
    }
    return d;
}

// The paper's lookup along one straight piece: the distance the table gives from its start; a
// miss when it lies beyond the piece (a miss in the table holds the distance to the slab's
// boundary). With shell.params.x = 0 the distance is kept where the field confirms solid within
// a voxel past it, as the paper takes it. With a half-width r > 0 the first surface within r of
// it is searched exactly instead: the table's value, interpolated between samples a voxel and a
// direction step apart and off by the SVD's error (4.7 voxels rms at k = 8), stopped short of or
// beyond links two or three voxels thick.
fn gdm_lookup_piece(a: vec3<f32>, dir: vec3<f32>, len: f32) -> f32 {
    let r = shell.params.x;
    let d = max(gdm_lookup(a, dir), 0.0);
    if (d > len + r) {
        return -1.0;
    }
    if (r > 0.0) {
        return gdm_fine_search(a, dir, max(d - r, 0.0), min(d + r, len));
    }
    for (var k = 0; k < 3; k++) {
        if (gdm_field(a + dir * (d + 0.5 * f32(k))) >= 0.5) {
            return d;
        }
    }
    return -1.0;
}

// A conservative table (shell.lookup.w = 2) drives the march: from the piece's start, step by
// the looked-up lower bound of the distance to the first surface (sphere tracing with a
// directional distance; it never passes a surface, bound.rs), and once the bound falls below
// GDM_HANDOVER march exactly from there. The hit is the march's; the table only decides how much
// empty space is skipped.
fn gdm_bound_piece(a: vec3<f32>, dir: vec3<f32>, len: f32) -> f32 {
    let nz = f32(shell.size.z);
    var s = 0.0;
    for (var n = 0; n < GDM_MAX_LOOKUPS; n++) {
        if (s >= len) {
            return -1.0;
        }
        let p = a + dir * s;
        let b = gdm_lookup(vec3<f32>(p.xy, clamp(p.z, 0.0, nz)), dir);
        if (b < GDM_HANDOVER) {
            break;
        }
        s += b;
    }
    if (s >= len) {
        return -1.0;
    }
    let h = gdm_march(a + dir * s, dir, len - s);
    return select(-1.0, s + h, h >= 0.0);
}

// The field's gradient at texture point t: the trilinear interpolation's own derivative within
// t's cell, so the normal is that of the level set the march hits. (Central differences half a
// voxel wide reached into the neighbouring cells and tilted the flat tops beside every terrace
// step of a thin layer; see README.) `dir` where the field is flat there (a saddle).
fn gdm_gradient(t: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    let s = t - 0.5;
    let f = s - floor(s);
    let v = vec3<i32>(floor(s));
    var g = vec3<f32>(0.0);
    for (var k = 0; k < 8; k++) {
        let o = vec3<f32>(vec3<i32>(k & 1, (k >> 1) & 1, (k >> 2) & 1));
        let wt = mix(1.0 - f, f, o);
        let sign_o = 2.0 * o - 1.0;
        g += gdm_solid(v + vec3<i32>(o)) * sign_o * vec3<f32>(wt.y * wt.z, wt.x * wt.z, wt.x * wt.y);
    }
    return select(g, dir, dot(g, g) < 1e-12);
}

// Columns of d X / d T at weights w: local steps per texture voxel along x, y and z.
fn gdm_local_from_texture(pr: Prism, w: vec3<f32>) -> mat3x3<f32> {
    let jw = gdm_jacobian(pr, w);
    let m = gdm_inverse2(gdm_uv_matrix(pr));
    let a = jw[0] * m[0].x + jw[1] * m[0].y;
    let b = jw[0] * m[1].x + jw[1] * m[1].y;
    return mat3x3<f32>(a, b, jw[2] / f32(shell.size.z));
}

// World normal for the field's gradient g at weights w: the gradient taken through the prism's
// map (inverse transpose of d X / d T), pointing out of the solid.
fn gdm_normal(pr: Prism, g: vec3<f32>, w: vec3<f32>) -> vec3<f32> {
    let j = gdm_local_from_texture(pr, w);
    let det = dot(j[0], cross(j[1], j[2]));
    let n_object = -(cross(j[1], j[2]) * g.x + cross(j[2], j[0]) * g.y + cross(j[0], j[1]) * g.z) * sign(det);
    return normalize((shell.world_normal_from_object * vec4<f32>(n_object, 0.0)).xyz);
}

// The first surface the ray o + t d (local space) meets inside prism `pr` from t_lo on, if it
// comes before t_hi. The pieces follow the prism's whole span from t_lo, whatever t_hi, so a
// search again with another t_hi finds the same hit.
fn gdm_trace_prism(pr: Prism, o: vec3<f32>, d: vec3<f32>, t_lo: f32, t_hi: f32) -> GdmHit {
    let span = gdm_prism_interval(pr, o, d);
    let t0 = max(span.x, t_lo);
    let t1 = span.y;
    if (t1 < t0 || t0 >= t_hi) {
        return GdmHit(-1.0, vec3<f32>(0.0));
    }
    let pieces = shell.size.w;
    var w_prev = gdm_inverse(pr, o + d * t0, vec3<f32>(1.0 / 3.0, 1.0 / 3.0, 0.5));
    var t_prev = gdm_texture_point(pr, w_prev);
    for (var k = 1u; k <= pieces; k++) {
        if (mix(t0, t1, f32(k - 1u) / f32(pieces)) >= t_hi) {
            break;
        }
        let x = o + d * mix(t0, t1, f32(k) / f32(pieces));
        let w = gdm_inverse(pr, x, w_prev);
        let t_next = gdm_texture_point(pr, w);
        let len = length(t_next - t_prev);
        if (len > 1e-6) {
            let dir_t = (t_next - t_prev) / len;
            var s: f32;
            if (shell.lookup.w == 1u) {
                s = gdm_lookup_piece(t_prev, dir_t, len);
            } else if (shell.lookup.w == 2u) {
                s = gdm_bound_piece(t_prev, dir_t, len);
            } else {
                s = gdm_march(t_prev, dir_t, len);
            }
            if (s >= 0.0) {
                let th = t_prev + dir_t * s;
                let wh = gdm_weights_at(pr, th);
                let t = dot(gdm_forward(pr, wh) - o, d) / dot(d, d);
                if (t >= t_hi) {
                    break;
                }
                return GdmHit(t, gdm_normal(pr, gdm_gradient(th, dir_t), wh));
            }
        }
        w_prev = w;
        t_prev = t_next;
    }
    return GdmHit(-1.0, vec3<f32>(0.0));
}
