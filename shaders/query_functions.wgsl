// What every ray-query entry point does first: find its ray, trace it through the object's
// hierarchy (trace_functions.wgsl) no further than the nearest hit earlier objects left in `hits`.
//
// Space: the query's frame (see query_types.wgsl).

struct QueryTrace {
    // The ray's index in `rays` and `hits`; -1 when the invocation has no ray or found no nearer
    // hit.
    index: i32,
    ray: QueryRay,
    found: TraceHit,
}

fn trace_query_ray(id: vec3<u32>) -> QueryTrace {
    var out = QueryTrace(-1, QueryRay(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0u), TraceHit(0.0, -1));
    let index = query_ray_index(id);
    if (index < 0) {
        return out;
    }
    let i = u32(index);
    out.ray = rays[i];
    let any_hit = query.counts.y == 1u;
    out.found = trace_nearest(out.ray.origin, out.ray.dir, out.ray.t_min, hits[i].t, any_hit);
    if (out.found.item >= 0) {
        out.index = i32(i);
    }
    return out;
}
