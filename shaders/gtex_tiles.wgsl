// Entry points of the tiled primary pass (the default for frames): one rectangle over the set's
// boxes on screen; each fragment walks its tile's list (gtex_tiles_functions.wgsl), searching the
// boxes its ray enters before its nearest hit so far. One fragment per pixel and set, so overdraw
// no longer multiplies the searches.
//
// Spaces: view (camera-relative; a camera ray's t is its view depth, the entries' unit) and
// framebuffer pixels (row 0 at the top); the rectangle arrives in normalized device coordinates.

struct VsOut {
    @builtin(position) position: vec4<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32) -> VsOut {
    return VsOut(rect_vertex(tiles.rect, vertex));
}

@fragment
fn fs_main(in: VsOut) -> FsOut {
    let pixel = vec2<u32>(in.position.xy);
    let tile = pixel / tiles.size.z;
    let range = tile_ranges[tile.y * tiles.size.x + tile.x];
    let ray = camera_ray(camera, in.position.xy);
    let found = tile_walk(range, pixel, ray.origin, ray.dir, 0.0, camera.params.y, 3.0e38, ASK_NEAREST);
    count_work();
    if (found.t >= 3.0e38) {
        discard;
    }
    return gtex_fragment(found.patch_index, ray, found.t);
}
