// Group 2 of the 32-bit splat passes (adapters without 64-bit atomics): the same visibility
// buffer as two u32 per pixel, [2p] = surfel index, [2p + 1] = reversed-Z depth bits; the depth
// pass takes the nearest depth, the id pass the largest index at exactly that depth (the
// 64-bit pass's tie-break).

@group(2) @binding(0) var<storage, read_write> visible: array<atomic<u32>>;
