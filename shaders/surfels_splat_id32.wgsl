// Entry point of the second 32-bit splat pass: a surfel whose depth at a pixel equals the
// nearest depth the first pass kept writes its index there (the largest index on a tie, as the
// 64-bit pass keeps).
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
            let p = 2u * (u32(y) * object.sizes.x + u32(x));
            if (depth > 0.0 && bitcast<u32>(depth) == atomicLoad(&visible[p + 1u])) {
                atomicMax(&visible[p], index);
            }
        }
    }
}
