// Entry point of ray queries through a mesh: one invocation per ray traces it through the mesh's
// triangles (trace_functions.wgsl with mesh_trace_functions.wgsl's leaves), no further than the
// nearest hit earlier objects left in `hits`, and writes the hit where it finds a nearer one:
// the triangle's unit normal as its corners wind (as trimesh's face normals).
//
// Space: each ray is moved from the query's frame into the mesh's local space, where its
// triangles stay between queries; t keeps the query's unit (see mesh_types.wgsl), and normals
// go back to world space (the query's frame only translates it).

@compute @workgroup_size(64)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let q = trace_query_ray_in(id, traced.local_from_query);
    if (q.index < 0) {
        return;
    }
    hits[q.index] = mesh_query_hit(u32(q.found.item), q.found.t);
}
