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

// The rectangle as two triangles: corner (x from bit 0, y from bit 1) of each vertex.
const CORNERS = array<u32, 6>(0u, 1u, 3u, 0u, 3u, 2u);

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32) -> VsOut {
    let c = CORNERS[vertex];
    let r = tiles.rect;
    let xy = vec2<f32>(select(r.x, r.z, (c & 1u) != 0u), select(r.y, r.w, (c & 2u) != 0u));
    return VsOut(vec4<f32>(xy, 0.5, 1.0));
}

@fragment
fn fs_main(in: VsOut) -> FsOut {
    let tile = vec2<u32>(in.position.xy) / tiles.size.z;
    let range = tile_ranges[tile.y * tiles.size.x + tile.x];
    let ray = camera_ray(camera, in.position.xy);
    let found = tile_walk(range, ray.origin, ray.dir, 0.0, camera.params.y, 3.0e38, false);
    count_work();
    if (found.t >= 3.0e38) {
        discard;
    }
    return gtex_fragment(found.patch_index, ray, found.t);
}
