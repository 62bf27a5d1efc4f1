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
@group(1) @binding(5) var<storage, read> nodes: array<SurfelNode>;
// Per surfel (tiles' then nodes'): its clip box in its patch's texel grid (u0, v0, u1, v1) and
// its patch; per patch, the texel grid's frame.
@group(1) @binding(6) var<storage, read> clips: array<vec4<f32>>;
@group(1) @binding(7) var<storage, read> surfel_patch: array<u32>;
@group(1) @binding(8) var<storage, read> patch_frames: array<PatchFrame>;
