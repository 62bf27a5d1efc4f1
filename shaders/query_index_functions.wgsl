// Which ray an invocation of a ray-query dispatch traces: each object's dispatch runs over the
// rays its CPU-side test kept (query.rs, kinds::RayTest), listed in `traced_rays`.
//
// Space: none (indices).

// The index in `rays` and `hits` of the ray invocation `id` traces; -1 for none, and for an
// any-hit ray an earlier object already stopped (shadow rays: whatever hit it, the answer is
// known, and searching the next object up to that hit would only repeat it).
fn query_ray_index(id: vec3<u32>) -> i32 {
    let k = id.y * query.counts.z + id.x;
    if (k >= query.counts.x) {
        return -1;
    }
    let i = traced_rays[k];
    if (query.counts.y == 1u && hits[i].id != -1) {
        return -1;
    }
    return i32(i);
}
