// Entry point of parallel ray queries through a geometry-texture set (shadow rays toward a
// directional light): the set's boxes are tiled as seen along the rays (tiles.rs, `parallel`),
// so each ray stays in one tile and walks its list (gtex_tiles_functions.wgsl) instead of the
// hierarchy, no further than the nearest hit earlier objects left in `hits`.
//
// Spaces: the query's frame (see query_types.wgsl), where the patch records were placed; the
// grid's frame (`tiles.grid_from_view`), whose -Z is the rays' direction.

@compute @workgroup_size(64)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let q = tiled_query_ray(id);
    if (q.index < 0) {
        return;
    }
    let i = u32(q.index);
    let ray = q.ray;
    let at = q.at;
    let t_hi = hits[i].t;
    let found = tile_walk(at.range, at.pixel, ray.origin, ray.dir, at.depth, ray.t_min, t_hi,
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
