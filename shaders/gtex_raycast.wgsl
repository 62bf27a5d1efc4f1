// Geometry-texture patches: each patch's box is drawn (back faces, so a camera inside a box still
// gets fragments) and the fragment shader casts the pixel's ray through the patch's height map.
//
// Spaces: view (camera-relative, see camera_functions.wgsl) and patch-local, where the box is the
// unit cube, x/y are texture u/v and z is height. Ray parameters t are shared by both spaces
// (the map between them is affine). Heights are 16-bit integer codes: 0 = empty, else
// h = (code - 1) / 65534. They are loaded exactly and interpolated here, so no filtering
// feature is needed.

struct Patch {
    view_from_patch: mat4x4<f32>,
    patch_from_view: mat4x4<f32>,
    // Patch-local normal → world normal (inverse transpose of the linear part of world_from_patch
    // without the box extents).
    world_normal_from_patch: mat4x4<f32>,
    // Texel origin of the patch in its atlas layer, and its size in texels.
    atlas_origin: vec2<f32>,
    size: vec2<f32>,
    // x: atlas layer, y: patch id written to the id target.
    ids: vec4<i32>,
}

struct Search {
    // x: linear steps per texel crossed, y: least linear steps, z: most linear steps,
    // w: binary steps.
    steps: vec4<f32>,
}

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var<uniform> search: Search;
@group(1) @binding(0) var<storage, read> patches: array<Patch>;
@group(1) @binding(1) var heights: texture_2d_array<u32>;
@group(1) @binding(2) var normals: texture_2d_array<f32>;
@group(1) @binding(3) var colors: texture_2d_array<f32>;
@group(1) @binding(4) var linear_clamp: sampler;

struct VsOut {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) patch_index: u32,
}

// The unit cube as 12 triangles, counter-clockwise seen from outside.
const CUBE = array<vec3<f32>, 36>(
    vec3(0., 0., 0.), vec3(0., 1., 0.), vec3(1., 1., 0.), vec3(0., 0., 0.), vec3(1., 1., 0.), vec3(1., 0., 0.),
    vec3(0., 0., 1.), vec3(1., 0., 1.), vec3(1., 1., 1.), vec3(0., 0., 1.), vec3(1., 1., 1.), vec3(0., 1., 1.),
    vec3(0., 0., 0.), vec3(1., 0., 0.), vec3(1., 0., 1.), vec3(0., 0., 0.), vec3(1., 0., 1.), vec3(0., 0., 1.),
    vec3(0., 1., 0.), vec3(0., 1., 1.), vec3(1., 1., 1.), vec3(0., 1., 0.), vec3(1., 1., 1.), vec3(1., 1., 0.),
    vec3(0., 0., 0.), vec3(0., 0., 1.), vec3(0., 1., 1.), vec3(0., 0., 0.), vec3(0., 1., 1.), vec3(0., 1., 0.),
    vec3(1., 0., 0.), vec3(1., 1., 0.), vec3(1., 1., 1.), vec3(1., 0., 0.), vec3(1., 1., 1.), vec3(1., 0., 1.),
);

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) instance: u32) -> VsOut {
    let local = CUBE[vertex];
    let view = patches[instance].view_from_patch * vec4<f32>(local, 1.0);
    return VsOut(camera.clip_from_view * view, instance);
}

// Height at patch-local (u, v): bilinear over the non-empty texels of the 2x2 footprint,
// or < 0 when the nearest texel is empty (no surface there).
fn height_at(p: Patch, uv: vec2<f32>) -> f32 {
    let x = uv * p.size - 0.5;
    let base = floor(x);
    let f = x - base;
    let hi = vec2<i32>(p.size) - 1;
    let i0 = clamp(vec2<i32>(base), vec2<i32>(0), hi);
    let i1 = clamp(vec2<i32>(base) + 1, vec2<i32>(0), hi);
    let o = vec2<i32>(p.atlas_origin);
    let layer = p.ids.x;
    let q = vec4<f32>(vec4<u32>(
        textureLoad(heights, o + vec2<i32>(i0.x, i0.y), layer, 0).x,
        textureLoad(heights, o + vec2<i32>(i1.x, i0.y), layer, 0).x,
        textureLoad(heights, o + vec2<i32>(i0.x, i1.y), layer, 0).x,
        textureLoad(heights, o + vec2<i32>(i1.x, i1.y), layer, 0).x,
    ));
    let nearest = select(select(q.x, q.y, f.x >= 0.5), select(q.z, q.w, f.x >= 0.5), f.y >= 0.5);
    if (nearest == 0.0) {
        return -1.0;
    }
    let w = vec4<f32>((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y)
        * vec4<f32>(q > vec4<f32>(0.0));
    let code = dot(w, q) / max(w.x + w.y + w.z + w.w, 1e-12);
    return (code - 1.0) / 65534.0;
}

// +1 above the surface, -1 on or below it, 0 where there is no surface.
fn side(p: Patch, point: vec3<f32>) -> f32 {
    let h = height_at(p, point.xy);
    if (h < 0.0) {
        return 0.0;
    }
    return select(-1.0, 1.0, point.z > h);
}

// 1 / d with rays parallel to an axis sent to a huge finite slope instead of dividing by zero.
fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    let tiny = 1e-30;
    let s = select(vec3<f32>(-1.0), vec3<f32>(1.0), d >= vec3<f32>(0.0));
    return 1.0 / select(d, s * tiny, abs(d) < vec3<f32>(tiny));
}

struct FsOut {
    @location(0) color: vec4<f32>,
    @location(1) normal: vec4<f32>,
    @location(2) id: i32,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_main(in: VsOut) -> FsOut {
    let p = patches[in.patch_index];
    let ray = camera_ray(camera, in.position.xy);
    let o = (p.patch_from_view * vec4<f32>(ray.origin, 1.0)).xyz;
    let d = (p.patch_from_view * vec4<f32>(ray.dir, 0.0)).xyz;

    // Where the ray is inside the unit cube (and in front of the near plane).
    let inv = safe_inverse(d);
    let ta = (vec3<f32>(0.0) - o) * inv;
    let tb = (vec3<f32>(1.0) - o) * inv;
    let tmin3 = min(ta, tb);
    let tmax3 = max(ta, tb);
    let t_start = max(max(tmin3.x, tmin3.y), max(tmin3.z, camera.params.y));
    let t_end = min(min(tmax3.x, tmax3.y), tmax3.z);
    if (!(t_end > t_start)) {
        discard;
    }

    // Linear search balanced by slant: about `steps.x` samples per texel the ray crosses.
    let span = abs(d.xy * (t_end - t_start)) * p.size;
    let n = u32(clamp(ceil(max(span.x, span.y) * search.steps.x), search.steps.y, search.steps.z));
    var t_prev = t_start;
    var s_prev = side(p, o + d * t_start);
    var t_hit = -1.0;
    var s_first = 0.0;
    for (var i = 1u; i <= n; i += 1u) {
        let t = mix(t_start, t_end, f32(i) / f32(n));
        let s = side(p, o + d * t);
        if (s != 0.0 && s_prev != 0.0 && s != s_prev) {
            // Binary search between the last sample on the first side and this one.
            var a = t_prev;
            var b = t;
            for (var k = 0u; k < u32(search.steps.w); k += 1u) {
                let m = 0.5 * (a + b);
                let sm = side(p, o + d * m);
                if (sm == s_prev) {
                    a = m;
                } else {
                    b = m;
                }
            }
            t_hit = 0.5 * (a + b);
            break;
        }
        t_prev = t;
        s_prev = s;
    }
    if (t_hit < 0.0) {
        discard;
    }

    let hit = o + d * t_hit;
    let uv = clamp(hit.xy * p.size, vec2<f32>(0.5), p.size - 0.5);
    let atlas_size = vec2<f32>(textureDimensions(normals));
    let coord = (p.atlas_origin + uv) / atlas_size;
    let n_local = textureSampleLevel(normals, linear_clamp, coord, p.ids.x, 0.0).xyz;
    let base = textureSampleLevel(colors, linear_clamp, coord, p.ids.x, 0.0);
    let n_world = normalize((p.world_normal_from_patch * vec4<f32>(n_local, 0.0)).xyz);

    let hit_view = ray.origin + ray.dir * t_hit;
    var out: FsOut;
    out.color = vec4<f32>(headlight(camera, base.rgb, n_world, ray.dir), base.a);
    out.normal = vec4<f32>(n_world, 0.0);
    out.id = p.ids.y;
    out.depth = depth_from_distance(camera, -hit_view.z);
    return out;
}
