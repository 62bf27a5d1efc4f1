// Group 2 of the 64-bit splat pass: the visibility buffer, one (reversed-Z depth bits << 32 |
// surfel index) per pixel, row 0 at the top; 0 = nothing. atomicMax keeps the nearest.

@group(2) @binding(0) var<storage, read_write> visible: array<atomic<u64>>;
