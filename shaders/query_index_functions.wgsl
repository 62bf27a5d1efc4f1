// Which ray an invocation of a ray-query dispatch traces: each object's dispatch runs over the
// rays its CPU-side test kept (query.rs, kinds::RayTest), listed in `traced_rays`.
//
// Space: none (indices).

// The index in `rays` and `hits` of the ray invocation `id` traces; -1 for none.
fn query_ray_index(id: vec3<u32>) -> i32 {
    let k = id.y * query.counts.z + id.x;
    if (k >= query.counts.x) {
        return -1;
    }
    return i32(traced_rays[k]);
}
