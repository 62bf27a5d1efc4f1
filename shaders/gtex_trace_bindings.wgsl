// Group 1 of the geometry-texture tracer, beyond gtex_bindings.wgsl and
// gtex_pieces_bindings.wgsl: the hierarchy over the pieces (trace_types.wgsl), its bounds placed
// in the space rays are traced in.
//
// Space: that of the rays (see gtex_piece_functions.wgsl).

@group(1) @binding(6) var<storage, read> bvh: array<BvhNode>;
