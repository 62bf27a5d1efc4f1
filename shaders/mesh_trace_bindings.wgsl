// Group 1 of ray queries through a mesh: its settings, the hierarchy over its triangles
// (trace_types.wgsl) and the triangles (mesh_types.wgsl).
//
// Space: the hierarchy and triangles in the mesh's local space, kept between queries; `traced`
// says where the mesh is in this query's frame (see query_types.wgsl).

// Storage, not uniform: Mesa's lavapipe (22.3) crashed dispatching this pipeline with a uniform
// buffer here.
@group(1) @binding(0) var<storage, read> traced: MeshTrace;
@group(1) @binding(1) var<storage, read> bvh: array<BvhNode>;
@group(1) @binding(2) var<storage, read> triangles: array<TraceTriangle>;
