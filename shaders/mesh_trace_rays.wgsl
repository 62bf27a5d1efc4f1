// Entry point of ray queries through a mesh: one invocation per ray traces it through the mesh's
// triangles (trace_functions.wgsl with mesh_trace_functions.wgsl's leaves), no further than the
// nearest hit earlier objects left in `hits`, and writes the hit where it finds a nearer one:
// the triangle's unit normal as its corners wind (as trimesh's face normals).
//
// Space: the query's frame (see query_types.wgsl), a translation of world space, so its normals
// are world normals.

@compute @workgroup_size(64)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let q = trace_query_ray(id);
    if (q.index < 0) {
        return;
    }
    let tri = triangles[q.found.item];
    let normal = normalize(cross(tri.b - tri.a, tri.c - tri.a));
    hits[q.index] = QueryHit(normal, q.found.t, traced.ids.x, 0u, 0u, 0u);
}
