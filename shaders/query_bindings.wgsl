// Group 2 of a ray query: the batch's settings, its rays and their hits, and which of the rays
// this object's dispatch traces (invocation k traces ray traced_rays[k]).
//
// Space: the query's frame (see query_types.wgsl).

// Storage, not a uniform, as frame_bindings.wgsl's search settings.
@group(2) @binding(0) var<storage, read> query: Query;
@group(2) @binding(1) var<storage, read> rays: array<QueryRay>;
@group(2) @binding(2) var<storage, read_write> hits: array<QueryHit>;
@group(2) @binding(3) var<storage, read> traced_rays: array<u32>;
