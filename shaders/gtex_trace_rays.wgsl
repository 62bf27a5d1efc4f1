// Entry point of ray queries through a geometry-texture set: one invocation per ray traces it
// through the set (trace_functions.wgsl with gtex_trace_functions.wgsl's leaves), no further than
// the nearest hit earlier objects left in `hits`, and writes the hit where it finds a nearer one.
//
// Space: the query's frame (see query_types.wgsl); the patch records and the hierarchy's bounds
// were placed in it.

@compute @workgroup_size(64)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let q = trace_query_ray(id);
    if (q.index < 0) {
        return;
    }
    let index = pieces[q.found.item].patch_index;
    var normal = vec3<f32>(0.0);
    if (query.counts.w == 0u) {
        normal = gtex_surface(index, q.ray.origin, q.ray.dir, q.found.t).normal;
    }
    hits[q.index] = QueryHit(normal, q.found.t, patches[index].maps.ids.y, 0u, 0u, 0u);
}
