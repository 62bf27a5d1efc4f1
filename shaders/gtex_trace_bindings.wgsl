// Group 1 of the geometry-texture tracer, beyond gtex_bindings.wgsl: the pieces of the patches'
// boxes (gtex_types.wgsl) and the hierarchy over them (trace_types.wgsl), its bounds placed in the
// space rays are traced in.
//
// Space: that of the rays (see gtex_piece_functions.wgsl).

@group(1) @binding(6) var<storage, read> bvh: array<BvhNode>;
@group(1) @binding(7) var<storage, read> pieces: array<PatchBox>;
