// The mesh leaf of the tracer's walk (trace_functions.wgsl): a leaf is one triangle, hit by the
// watertight test of ray_triangle_functions.wgsl.
//
// Space: rays and triangles in the mesh's local space (mesh_trace_rays.wgsl moves the rays there).

// The hit of o + t d with triangle `item` for t in [t_lo, t_best), or -1.
fn leaf_search(item: u32, o: vec3<f32>, d: vec3<f32>, t_lo: f32, t_best: f32) -> f32 {
    let tri = triangles[item];
    return ray_triangle(tri.a, tri.b, tri.c, o, d, t_lo, t_best).x;
}

// The hit record of triangle `item` at t: its unit normal as its corners wind (as trimesh's face
// normals), placed in world space.
fn mesh_query_hit(item: u32, t: f32) -> QueryHit {
    let tri = triangles[item];
    let local = cross(tri.b - tri.a, tri.c - tri.a);
    let normal = normalize((traced.world_normal_from_local * vec4<f32>(local, 0.0)).xyz);
    return QueryHit(normal, t, traced.ids.x, 0u, 0u, 0u);
}
