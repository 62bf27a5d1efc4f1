// The displacement-shell leaf of the tracer's walk (trace_functions.wgsl): a leaf is one prism,
// searched by the march the raster pass uses (gdm_trace_prism) on the ray taken into the shell's
// local space, where the ray's parameter is the same.
//
// Spaces: rays in the query's frame (query_types.wgsl); prisms in the shell's local space.

fn gdm_local_hit(item: u32, o: vec3<f32>, d: vec3<f32>, t_lo: f32, t_best: f32) -> GdmHit {
    let o_local = (shell.object_from_view * vec4<f32>(o, 1.0)).xyz;
    let d_local = (shell.object_from_view * vec4<f32>(d, 0.0)).xyz;
    return gdm_trace_prism(prisms[item], o_local, d_local, t_lo, t_best);
}

// The hit of o + t d with prism `item` for t in [t_lo, t_best), or -1.
fn leaf_search(item: u32, o: vec3<f32>, d: vec3<f32>, t_lo: f32, t_best: f32) -> f32 {
    let t = gdm_local_hit(item, o, d, t_lo, t_best).t;
    return select(-1.0, t, t >= t_lo && t < t_best);
}
