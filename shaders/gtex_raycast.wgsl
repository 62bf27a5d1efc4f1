// Entry points of the geometry-texture pass: each patch's box is drawn (back faces, so a camera
// inside a box still gets fragments) and the fragment shader casts the pixel's ray through the
// patch's height map.
//
// Spaces: view (camera-relative, see camera_types.wgsl) and patch-local, where the box is the
// unit cube, x/y are texture u/v and z is height. Ray parameters t are shared by both spaces
// (the map between them is affine). The height-field search lives in heightfield_functions.wgsl.

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

    // Search from the box entry: with the camera as origin, ray positions in texels would be
    // differences of large f32 numbers (the camera may be thousands of texels away).
    let entry = o + d * t_start;
    var t_local: f32;
    if (search.method.x == 1u) {
        t_local = maxmip_hit(p, search, entry, d, 0.0, t_end - t_start);
    } else {
        t_local = linear_binary_hit(p, search, entry, d, 0.0, t_end - t_start);
    }
    let t_hit = select(-1.0, t_start + t_local, t_local >= 0.0);
    if (COUNT_FETCHES) {
        atomicAdd(&counters[0], fetches);
        atomicAdd(&counters[1], 1u);
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
