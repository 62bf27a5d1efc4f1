// What a geometry-texture fragment writes, shared by the two primary-frame passes (gtex_raycast.wgsl:
// one fragment per box; gtex_tiles.wgsl: one per pixel, boxes front to back).
//
// Spaces: view (camera-relative; a camera ray's t is its view depth) and world normals out.

// The fragment of camera ray `ray` hitting patch `index` at t.
fn gtex_fragment(index: u32, ray: Ray, t: f32) -> FsOut {
    let surface = gtex_surface(index, ray.origin, ray.dir, t);
    var out: FsOut;
    out.color = vec4<f32>(headlight(camera, surface.color.rgb, surface.normal, ray.dir), surface.color.a);
    out.normal = vec4<f32>(surface.normal, 0.0);
    out.id = patches[index].maps.ids.y;
    out.albedo = surface.color;
    // View distance along -Z equals t for both projections (camera_ray's directions have z = -1).
    out.depth = depth_from_distance(camera, t);
    return out;
}

// Adds this invocation's height fetches and piece tests (counting build) and box searches to the
// frame's counters.
fn count_work() {
    if (COUNT_FETCHES) {
        atomicAdd(&counters[0], fetches);
        atomicAdd(&counters[2], piece_tests);
    }
    if (searches > 0u) {
        atomicAdd(&counters[1], searches);
    }
}
