// Entry point of ray queries through a displacement shell: one invocation per ray traces it
// through the shell's prisms (trace_functions.wgsl with gdm_trace_functions.wgsl's leaves), no
// further than the nearest hit earlier objects left in `hits`, and writes a nearer hit with the
// mesostructure's world normal there.
//
// Space: the query's frame (see query_types.wgsl).

@compute @workgroup_size(64)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let q = trace_query_ray(id);
    if (q.index < 0) {
        return;
    }
    // The walk keeps only the distance: the prism found is searched again for its normal (the
    // same march from the same start finds the same hit).
    let hit = gdm_local_hit(u32(q.found.item), q.ray.origin, q.ray.dir, q.ray.t_min, 3.0e38);
    hits[q.index] = QueryHit(hit.normal, q.found.t, shell.ids.x, 0u, 0u, 0u);
}
