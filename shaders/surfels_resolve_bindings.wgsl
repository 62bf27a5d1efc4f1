// Group 1 of the surfel resolve pass (a fragment pass in the scene pass): the object, its
// surfels and the visibility buffer the splat passes filled (read as (index, depth bits)).
//
// Spaces: see surfels_types.wgsl.

@group(1) @binding(0) var<uniform> object: SurfelObject;
@group(1) @binding(1) var<storage, read> surfels: array<Surfel>;
@group(1) @binding(2) var<storage, read> surfel_patch: array<u32>;
@group(1) @binding(3) var<storage, read> visible: array<vec2<u32>>;
