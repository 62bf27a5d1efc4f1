// Group 1 of the geometry-texture passes (raster and tracer): one texture set's patches, atlases
// and max pyramids; gtex_trace_bindings.wgsl adds what only the tracer needs.
//
// Spaces: patch records map view ↔ patch-local (see gtex_types.wgsl); the texture arrays are
// addressed in atlas texels (layer, x, y).

@group(1) @binding(0) var<storage, read> patches: array<Patch>;
// Height codes: 0 = empty, else 1..code_max (8- or 16-bit per patch).
@group(1) @binding(1) var heights: texture_2d_array<u32>;
// Octahedral normal codes (src/gtex/mod.rs, encode_normal): two signed bytes, /126; -128 = none.
@group(1) @binding(2) var normals: texture_2d_array<i32>;
// One neutral texel when the set has no color map (PatchMaps.ids.z says whether a patch has one).
@group(1) @binding(3) var colors: texture_2d_array<f32>;
@group(1) @binding(4) var linear_clamp: sampler;
// Every patch's min-max pyramid (src/heightfield.rs), from node PatchMaps.pyramid_at.x on, node k
// at texel (k mod width, k div width); each node 16 bits (src/render/atlas.rs, pack_node).
@group(1) @binding(5) var pyramid: texture_2d<u32>;
// Outline maps (src/gtex/mod.rs, encode_outline): signed distance from each texel centre to the
// outline of the patch's faces, as snorm (1 = OUTLINE_REACH texels inside), read with textureLoad.
// (Bindings 6 and 7 are the tracer's, gtex_trace_bindings.wgsl.)
@group(1) @binding(8) var outlines: texture_2d_array<f32>;
