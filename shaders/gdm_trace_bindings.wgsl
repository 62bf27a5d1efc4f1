// Group 1 of ray queries through a displacement shell: its record (object_from_view there is
// local_from_query), its prisms, tile radii and SVD terms as in gdm_bindings.wgsl, and the
// hierarchy over its prisms (trace_types.wgsl) in the query's frame.
//
// Spaces: see gdm_types.wgsl; the query's frame (query_types.wgsl) for rays and the hierarchy.

// Storage, not uniform: Mesa's lavapipe (22.3) crashed dispatching the mesh tracer with a uniform
// buffer in this group.
@group(1) @binding(0) var<storage, read> shell: GdmObject;
@group(1) @binding(1) var<storage, read> prisms: array<Prism>;
@group(1) @binding(2) var<storage, read> radii: array<u32>;
@group(1) @binding(3) var<storage, read> gdm_terms_w: array<f32>;
@group(1) @binding(4) var<storage, read> gdm_terms_e: array<f32>;
@group(1) @binding(5) var<storage, read> bvh: array<BvhNode>;
