// Group 0 of the depth copy pass (a compute pass of its own, not a raster pass).
//
// Space: framebuffer pixels, row 0 at the top; values are reversed-Z depth (0 = nothing).

@group(0) @binding(0) var depth: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> out: array<f32>;
