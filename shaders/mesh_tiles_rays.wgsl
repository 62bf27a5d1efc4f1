// Entry point of parallel ray queries through a mesh (shadow rays toward a directional light):
// its triangles are tiled as seen along the rays (tiles.rs, `parallel`, built in the mesh's local
// space and kept per direction), so each ray walks the one tile it stays in, nearest triangle
// first, instead of the hierarchy, no further than the nearest hit earlier objects left in `hits`.
//
// Spaces: the query's frame (rays); the mesh's local space (triangles; each ray is moved there
// with its direction unnormalized, so t keeps the query's unit); the grid's frame, built in local
// space (`tiles.grid_from_view` takes query-frame points there), whose -Z is the rays' direction.

@compute @workgroup_size(64)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let q = tiled_query_ray(id);
    if (q.index < 0) {
        return;
    }
    let i = u32(q.index);
    let ray = q.ray;
    let at = q.at;
    let o = (traced.local_from_query * vec4<f32>(ray.origin, 1.0)).xyz;
    let d = (traced.local_from_query * vec4<f32>(ray.dir, 0.0)).xyz;
    // Grid depth per unit of t: the placement's scale along the rays.
    let speed = length(d);
    let any_hit = query.counts.y == 1u;
    var best_t = hits[i].t;
    var best = -1;
    let end = at.range.x + at.range.y;
    for (var k = at.range.x; k < end; k += 1u) {
        let entry = tile_entries[k];
        // This entry and every later one start behind the nearest hit.
        if (bitcast<f32>(entry.y) - at.depth >= best_t * speed) {
            break;
        }
        if (!entry_holds(entry, at.pixel)) {
            continue;
        }
        let tri = triangles[entry.x];
        let t = ray_triangle(tri.a, tri.b, tri.c, o, d, ray.t_min, best_t).x;
        if (t >= 0.0) {
            best_t = t;
            best = i32(entry.x);
            if (any_hit) {
                break;
            }
        }
    }
    if (best >= 0) {
        hits[i] = mesh_query_hit(u32(best), best_t);
    }
}
