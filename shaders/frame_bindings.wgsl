// Group 0 of every pass that draws into the frame (raster passes and tracers): what one frame
// shares across all its objects.
//
// Spaces: see camera_types.wgsl (view space, camera-relative).

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var<uniform> search: Search;
// [0]: height fetches (counting build only), [1]: box searches started by the tracers,
// [2]: pieces whose slab a tiled walk tested (counting build only).
@group(0) @binding(2) var<storage, read_write> counters: array<atomic<u32>, 3>;
