// What the entry points of parallel ray queries through tile lists do first: find the
// invocation's ray (query_index_functions.wgsl) and its tile (tiles_functions.wgsl).
//
// Space: the query's frame (see query_types.wgsl).

struct TiledRay {
    // The ray's index in `rays` and `hits`; -1 when the invocation has no ray to trace or the ray
    // starts outside the grid (every listed box lies inside it, so it passes beside them all).
    index: i32,
    ray: QueryRay,
    at: RayTile,
}

fn tiled_query_ray(id: vec3<u32>) -> TiledRay {
    var out = TiledRay(query_ray_index(id), QueryRay(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0u),
                       RayTile(vec2<u32>(0u), vec2<u32>(0u), 0.0));
    if (out.index < 0) {
        return out;
    }
    out.ray = rays[u32(out.index)];
    out.at = ray_tile(out.ray.origin);
    if (out.at.range.x == 0xffffffffu) {
        out.index = -1;
    }
    return out;
}
