// Entry points of the geometry-texture raster pass: each visible patch's box is drawn (back
// faces, so a camera inside a box still gets fragments) and the fragment shader searches the
// pixel's ray through the patch's height map, the whole box as one piece
// (gtex_piece_functions.wgsl, shared with the tracer). Every box over a pixel starts a search;
// the tiled pass (gtex_tiles.wgsl, the default) searches them front to back instead.
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

@fragment
fn fs_main(in: VsOut) -> FsOut {
    // The whole box, searched from the pyramid's top level.
    let piece = PatchBox(vec3<f32>(0.0), in.patch_index, vec3<f32>(1.0), 31u);
    let ray = camera_ray(camera, in.position.xy);
    let t_hit = piece_search(piece, ray.origin, ray.dir, camera.params.y, 3.0e38);
    count_work();
    if (t_hit < 0.0) {
        discard;
    }
    return gtex_fragment(piece.patch_index, ray, t_hit);
}
