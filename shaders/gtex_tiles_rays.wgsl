// Entry point of parallel ray queries through a geometry-texture set (shadow rays toward a
// directional light): the set's boxes are tiled as seen along the rays (tiles.rs, `parallel`),
// so each ray stays in one tile and walks its list (gtex_tiles_functions.wgsl) instead of the
// hierarchy, no further than the nearest hit earlier objects left in `hits`.
//
// Spaces: the query's frame (see query_types.wgsl), where the patch records were placed; the
// grid's frame (`tiles.grid_from_view`), whose -Z is the rays' direction.

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
    let range = tile_ranges[tile.y * tiles.size.x + tile.x];
    let t_hi = hits[i].t;
    let found = tile_walk(range, at, ray.origin, ray.dir, -p.z, ray.t_min, t_hi, query.counts.y == 1u);
    if (found.t >= t_hi) {
        return;
    }
    let surface = gtex_surface(found.patch_index, ray.origin, ray.dir, found.t);
    hits[i] = QueryHit(surface.normal, found.t, patches[found.patch_index].maps.ids.y, 0u, 0u, 0u);
}
