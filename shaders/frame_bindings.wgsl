// Group 0 of every pass that draws into the frame (raster passes and tracers): what one frame
// shares across all its objects.
//
// Spaces: see camera_types.wgsl (view space, camera-relative).

@group(0) @binding(0) var<uniform> camera: Camera;
// Storage, not a uniform: lavapipe compiles a compute shader again whenever a uniform that bounds
// its loops is bound anew (each ray query and shadow pass; render/shaders.rs,
// no_ray_tracer_reads_a_uniform).
@group(0) @binding(1) var<storage, read> search: Search;
// [0]: height fetches (counting build only), [1]: box searches started by the tracers,
// [2]: pieces whose slab a tiled walk tested (counting build only).
@group(0) @binding(2) var<storage, read_write> counters: array<atomic<u32>, 3>;
