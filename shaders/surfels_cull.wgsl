// Entry point of the surfel cull pass: one thread per tile. A tile wholly outside the frustum is
// skipped; otherwise its coarsest level whose perpendicular error, projected at the tile's
// nearest point, stays within max_pixel_error is chosen and that level's surfels are appended
// to `chosen`, counted in the tally.
//
// Spaces: object (tiles) → view (camera-relative); pixels at the tile's nearest view distance.

@compute @workgroup_size(64)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let t = id.x;
    if (t >= object.sizes.w) {
        return;
    }
    let sphere = tiles[t].sphere;
    let c = (object.view_from_object * vec4<f32>(sphere.xyz, 1.0)).xyz;
    let r = sphere.w * object.params.z;
    for (var k = 0u; k < 4u; k++) {
        if (dot(object.planes[k].xyz, c) + object.planes[k].w < -r) {
            return;
        }
    }
    if (-c.z + r < camera.params.y) {
        return;
    }
    let info = tiles[t].info;
    atomicAdd(&tally[TALLY_TILES], 1u);
    atomicAdd(&tally[TALLY_FINEST], tiles[t].start[0].y - tiles[t].start[0].x);
    let budget = object.params.x * pixel_size(max(-c.z - r, camera.params.y));
    var level = 0u;
    for (var l = info.x - 1u; l > 0u; l--) {
        if (tiles[t].error[l / 4u][l % 4u] * object.params.z <= budget) {
            level = l;
            break;
        }
    }
    let first = tiles[t].start[level / 4u][level % 4u];
    let end = tiles[t].start[(level + 1u) / 4u][(level + 1u) % 4u];
    let base = atomicAdd(&tally[TALLY_DRAWN], end - first);
    atomicAdd(&tally[TALLY_LEVEL0 + level], end - first);
    for (var i = 0u; i < end - first; i++) {
        chosen[base + i] = first + i;
    }
}
