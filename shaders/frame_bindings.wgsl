// Group 0 of every raster pass: what one frame shares across all its objects.
//
// Spaces: see camera_types.wgsl (view space, camera-relative).

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var<uniform> search: Search;
// Counting build: x = fetches, y = ray-cast fragments.
@group(0) @binding(2) var<storage, read_write> counters: array<atomic<u32>, 2>;
