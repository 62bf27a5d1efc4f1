// Entry point of the 64-bit surfel splat pass: one thread per chosen surfel; every pixel whose
// ray meets the surfel's disc (clipped to its texels) takes atomicMax of (reversed-Z depth bits << 32 | surfel index),
// so the nearest disc wins (depth bits of non-negative floats order as the floats do).
//
// Spaces: view (camera-relative) and framebuffer pixels (row 0 at the top).

@compute @workgroup_size(64)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = splat_thread(id, groups);
    if (k >= atomicLoad(&tally[TALLY_DRAWN])) {
        return;
    }
    let index = chosen[k];
    let disc = view_disc(surfels[index]);
    let clip = disc_clip(index);
    let b = splat_box(disc);
    for (var y = b.y; y <= b.w; y++) {
        for (var x = b.x; x <= b.z; x++) {
            let depth = clipped_depth(disc, clip, x, y);
            if (depth > 0.0) {
                let key = (u64(bitcast<u32>(depth)) << 32u) | u64(index);
                atomicMax(&visible[u32(y) * object.sizes.x + u32(x)], key);
            }
        }
    }
}
