// A ray against one piece of a patch's box (gtex_types.wgsl's PatchBox: the part over one node
// of the patch's min-max pyramid, as tall as the heights under it): the height-field search
// (heightfield_functions.wgsl) over just the stretch of the ray inside the piece, and what a hit
// there shows. Shared by the raster pass (one piece per fragment) and the tracer (pieces in
// front-to-back order).
//
// Spaces: rays in the space `patch_from_view` maps from (camera-relative view space for frames,
// a translated world space for ray queries); patch-local inside a piece (the unit cube, x/y
// texture u/v, z height). A ray parameter t means the same point in both (the map between them
// is affine).

// Piece searches this invocation started: the measure of overdraw (frame.stats).
var<private> searches: u32 = 0u;
// Counting build: pieces whose slab this invocation's tiled walk tested (the walk's cost beside
// its searches; frame.stats).
var<private> piece_tests: u32 = 0u;

// The first hit inside piece `piece` for t in [t_lo, t_hi), or -1.
fn piece_search(piece: PatchBox, o: vec3<f32>, d: vec3<f32>, t_lo: f32, t_hi: f32) -> f32 {
    return piece_search_from(piece, o, d, t_lo, t_hi, i32(piece.level));
}

// piece_search whose exact (min-max) descent starts at pyramid level `start`.
fn piece_search_from(piece: PatchBox, o: vec3<f32>, d: vec3<f32>, t_lo: f32, t_hi: f32, start: i32) -> f32 {
    let patch_from_view = patches[piece.patch_index].patch_from_view;
    let o_p = (patch_from_view * vec4<f32>(o, 1.0)).xyz;
    let d_p = (patch_from_view * vec4<f32>(d, 0.0)).xyz;
    let span = slab(piece.lo, piece.hi, o_p, safe_inverse(d_p));
    let t_start = max(span.x, t_lo);
    let t_end = min(span.y, t_hi);
    if (!(t_end > t_start)) {
        return -1.0;
    }
    searches += 1u;
    let p = patches[piece.patch_index].maps;
    // Search from the box entry: with the ray origin far away, ray positions in texels would be
    // differences of large f32 numbers.
    let entry = o_p + d_p * t_start;
    var t_local: f32;
    if (search.method.x == 1u) {
        t_local = maxmip_hit_from(p, search, entry, d_p, 0.0, t_end - t_start, i32(piece.level), start);
    } else {
        t_local = linear_binary_hit(p, search, entry, d_p, 0.0, t_end - t_start);
    }
    return select(-1.0, t_start + t_local, t_local >= 0.0 && t_start + t_local < t_hi);
}

// What a hit shows: the world normal and base color at the hit of ray o + t d in patch `index`.
struct Surface {
    normal: vec3<f32>,
    color: vec4<f32>,
}

// The base color of texels without a color map (gtex::NEUTRAL_COLOR).
const NEUTRAL_COLOR: vec4<f32> = vec4<f32>(200.0 / 255.0, 200.0 / 255.0, 200.0 / 255.0, 1.0);

// An octahedral normal code (src/gtex/mod.rs, encode_normal) → unit vector; zero for "none".
fn decode_normal(code: vec2<i32>) -> vec3<f32> {
    if (code.x == -128) {
        return vec3<f32>(0.0);
    }
    let e = vec2<f32>(code) / 126.0;  // gtex::NORMAL_STEPS
    let z = 1.0 - abs(e.x) - abs(e.y);
    let t = max(-z, 0.0);
    let xy = e - select(vec2<f32>(-t), vec2<f32>(t), e >= vec2<f32>(0.0));
    return normalize(vec3<f32>(xy, z));
}

// cos 20°: texels whose normals differ by more are on two sides of a crease.
const CREASE_COS: f32 = 0.9397;

// The patch-local normal at `uv` (texels; not normalized): bilinear over the four texels around
// it, leaving out those whose normal differs from the nearest texel's by a crease (a crease
// inside a chart then stays a step, as in the mesh, instead of a texel-wide ramp). The normal
// maps do not record the crease angle a set was converted with; 20° (the default) is used.
fn crease_aware_normal(p: PatchMaps, uv: vec2<f32>) -> vec3<f32> {
    let f = uv - 0.5;
    let cell = floor(f);
    let w = f - cell;
    let last = vec2<i32>(p.size) - 1;
    let origin = vec2<i32>(p.atlas_origin);
    let c0 = vec2<i32>(cell);
    var texel: array<vec3<f32>, 4>;
    var weight: array<f32, 4>;
    for (var k = 0; k < 4; k += 1) {
        let offset = vec2<i32>(k & 1, k >> 1u);
        let at = origin + clamp(c0 + offset, vec2<i32>(0), last);
        texel[k] = decode_normal(textureLoad(normals, at, p.ids.x, 0).xy);
        let wx = select(1.0 - w.x, w.x, offset.x == 1);
        let wy = select(1.0 - w.y, w.y, offset.y == 1);
        weight[k] = wx * wy;
    }
    var nearest = 0;
    for (var k = 1; k < 4; k += 1) {
        if (weight[k] > weight[nearest]) {
            nearest = k;
        }
    }
    // Unit anchor, or zero if the nearest texel holds no normal (then every texel blends).
    let anchor = texel[nearest] * inverseSqrt(max(dot(texel[nearest], texel[nearest]), 1e-12));
    var all = vec3<f32>(0.0);
    var same_side = vec3<f32>(0.0);
    for (var k = 0; k < 4; k += 1) {
        all += weight[k] * texel[k];
        if (dot(texel[k], anchor) >= CREASE_COS * length(texel[k])) {
            same_side += weight[k] * texel[k];
        }
    }
    return select(all, same_side, dot(same_side, same_side) > 1e-12);
}

fn gtex_surface(index: u32, o: vec3<f32>, d: vec3<f32>, t: f32) -> Surface {
    let patch_from_view = patches[index].patch_from_view;
    let p = patches[index].maps;
    let o_p = (patch_from_view * vec4<f32>(o, 1.0)).xyz;
    let d_p = (patch_from_view * vec4<f32>(d, 0.0)).xyz;
    let hit = o_p + d_p * t;
    let uv = clamp(hit.xy * p.size, vec2<f32>(0.5), p.size - 0.5);
    let atlas_size = vec2<f32>(textureDimensions(colors));
    let coord = (p.atlas_origin + uv) / atlas_size;
    let n_local = crease_aware_normal(p, uv);
    var base = NEUTRAL_COLOR;
    if (p.ids.z != 0) {
        base = textureSampleLevel(colors, linear_clamp, coord, p.ids.x, 0.0);
    }
    let n_world = normalize((patches[index].world_normal_from_patch * vec4<f32>(n_local, 0.0)).xyz);
    return Surface(n_world, base);
}
