// Entry points of the geometry-texture raster pass: each visible patch's box is drawn (back
// faces, so a camera inside a box still gets fragments) and the fragment shader searches the
// pixel's ray through the patch's height map, the whole box as one piece
// (gtex_piece_functions.wgsl, shared with the tracer). Rasterizing whole boxes measured faster
// on lavapipe than tracing camera rays through the hierarchy (see bench/README.md).
//
// Spaces: view (camera-relative, see camera_types.wgsl) and patch-local, where the patch's box is
// the unit cube, x/y are texture u/v and z is height.

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
    let view = patches[instance].view_from_patch * vec4<f32>(CUBE[vertex], 1.0);
    return VsOut(camera.clip_from_view * view, instance);
}

struct FsOut {
    @location(0) color: vec4<f32>,
    @location(1) normal: vec4<f32>,
    @location(2) id: i32,
    // The unshaded base color.
    @location(3) albedo: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_main(in: VsOut) -> FsOut {
    // The whole box, searched from the pyramid's top level.
    let piece = PatchBox(vec3<f32>(0.0), in.patch_index, vec3<f32>(1.0), 31u);
    let ray = camera_ray(camera, in.position.xy);
    let t_hit = piece_search(piece, ray.origin, ray.dir, camera.params.y, 3.0e38);
    if (COUNT_FETCHES) {
        atomicAdd(&counters[0], fetches);
    }
    if (searches > 0u) {
        atomicAdd(&counters[1], 1u);
    }
    if (t_hit < 0.0) {
        discard;
    }
    let surface = gtex_surface(piece.patch_index, ray.origin, ray.dir, t_hit);
    var out: FsOut;
    out.color = vec4<f32>(headlight(camera, surface.color.rgb, surface.normal, ray.dir), surface.color.a);
    out.normal = vec4<f32>(surface.normal, 0.0);
    out.id = patches[piece.patch_index].maps.ids.y;
    out.albedo = surface.color;
    // View distance along -Z equals t for both projections (camera_ray's directions have z = -1).
    out.depth = depth_from_distance(camera, t_hit);
    return out;
}
