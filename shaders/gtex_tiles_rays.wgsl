// Entry point of parallel ray queries through a geometry-texture set (shadow rays toward a
// directional light): the set's boxes are tiled as seen along the rays (tiles.rs, `parallel`),
// so each ray stays in one tile and walks its list (gtex_tiles_functions.wgsl) instead of the
// hierarchy, no further than the nearest hit earlier objects left in `hits`.
//
// Spaces: the query's frame (see query_types.wgsl), where the patch records were placed; the
// grid's frame (`tiles.grid_from_view`), whose -Z is the rays' direction.

// The entries of `range` (first, count) from the first that may reach `depth` on: the list is
// sorted by nearest depth, and no box is thicker than `tiles.thickness.x`, so an entry nearer than
// depth - thickness lies wholly behind a ray starting at `depth` (found by bisection, where the
// walk would test each: the bunny's shadow dispatch took 73-117 ms against 108-144, loaded).
fn entries_ahead(range: vec2<u32>, depth: f32) -> vec2<u32> {
    let behind = depth - tiles.thickness.x;
    var lo = range.x;
    var hi = range.x + range.y;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (bitcast<f32>(tile_entries[mid].y) < behind) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return vec2<u32>(lo, range.x + range.y - lo);
}

@compute @workgroup_size(64)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = query_ray_index(id);
    if (index < 0) {
        return;
    }
    let i = u32(index);
    let ray = rays[i];
    let p = (tiles.grid_from_view * vec4<f32>(ray.origin, 1.0)).xyz;
    let pixel = (p.xy - tiles.grid.zw) / tiles.grid.xy;
    let extent = vec2<f32>(tiles.size.xy * tiles.size.z);
    // Every box lies inside the grid: a ray starting outside it passes beside them all.
    if (any(pixel < vec2<f32>(0.0)) || any(pixel >= extent)) {
        return;
    }
    let at = vec2<u32>(pixel);
    let tile = at / tiles.size.z;
    let range = entries_ahead(tile_ranges[tile.y * tiles.size.x + tile.x], -p.z);
    let t_hi = hits[i].t;
    let found = tile_walk(range, at, ray.origin, ray.dir, -p.z, ray.t_min, t_hi,
                           select(select(ASK_NEAREST, ASK_ANY, query.counts.y == 1u), ASK_BLOCKED, query.counts.w == 1u));
    if (found.t >= t_hi) {
        return;
    }
    var normal = vec3<f32>(0.0);
    if (query.counts.w == 0u) {
        normal = gtex_surface(found.patch_index, ray.origin, ray.dir, found.t).normal;
    }
    hits[i] = QueryHit(normal, found.t, patches[found.patch_index].maps.ids.y, 0u, 0u, 0u);
}
