// The geometry-texture leaf of the tracer's walk (trace_functions.wgsl): a leaf is one piece of a
// patch's box (bvh.rs builds the hierarchy over the pieces), searched by the height-field search
// over the stretch of the ray inside it (gtex_piece_functions.wgsl).
//
// Spaces: rays and the hierarchy's bounds in the space the patch records map from (see
// gtex_piece_functions.wgsl).

fn leaf_search(item: u32, o: vec3<f32>, d: vec3<f32>, t_lo: f32, t_best: f32) -> f32 {
    return piece_search(pieces[item], o, d, t_lo, t_best);
}
