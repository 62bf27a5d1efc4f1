// Group 1 of the surfel compute passes (cull, dispatch arguments, splat): one object's
// hierarchy, the surfels chosen this frame and their tally.
//
// Spaces: see surfels_types.wgsl.

@group(1) @binding(0) var<uniform> object: SurfelObject;
@group(1) @binding(1) var<storage, read> tiles: array<SurfelTile>;
@group(1) @binding(2) var<storage, read> surfels: array<Surfel>;
// Indices into `surfels` of the surfels to splat, appended by the cull pass.
@group(1) @binding(3) var<storage, read_write> chosen: array<u32>;
@group(1) @binding(4) var<storage, read_write> tally: array<atomic<u32>, TALLY_SLOTS>;
