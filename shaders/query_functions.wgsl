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
    return trace_query_ray_in(id, mat4x4<f32>(
        vec4<f32>(1.0, 0.0, 0.0, 0.0), vec4<f32>(0.0, 1.0, 0.0, 0.0),
        vec4<f32>(0.0, 0.0, 1.0, 0.0), vec4<f32>(0.0, 0.0, 0.0, 1.0)));
}

// The same with the object's hierarchy in another space: `space_from_query` moves each ray there
// (its direction unnormalized, so t keeps the query's unit; `ray` stays in the query's frame).
fn trace_query_ray_in(id: vec3<u32>, space_from_query: mat4x4<f32>) -> QueryTrace {
    var out = QueryTrace(-1, QueryRay(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0u), TraceHit(0.0, -1));
    let index = query_ray_index(id);
    if (index < 0) {
        return out;
    }
    let i = u32(index);
    out.ray = rays[i];
    let any_hit = query.counts.y == 1u;
    let o = (space_from_query * vec4<f32>(out.ray.origin, 1.0)).xyz;
    let d = (space_from_query * vec4<f32>(out.ray.dir, 0.0)).xyz;
    out.found = trace_nearest(o, d, out.ray.t_min, hits[i].t, any_hit);
    if (out.found.item >= 0) {
        out.index = i32(i);
    }
    return out;
}
