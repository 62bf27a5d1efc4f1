// Ray queries: one ray and its nearest hit so far, and the batch's settings.
//
// Space: the query's frame, world space translated to near the rays (src/render/query.rs), where
// t is the distance along the ray's unit direction in world units.

struct QueryRay {
    origin: vec3<f32>,
    // Only hits with t >= t_min count (shadow rays start off their surface).
    t_min: f32,
    dir: vec3<f32>,
    _pad: u32,
}

struct QueryHit {
    // World-space unit normal at the hit.
    normal: vec3<f32>,
    // Distance to the nearest hit so far (the far bound for the next object traced).
    t: f32,
    // Patch id across the query's texture sets; -1 for none.
    id: i32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct Query {
    // x: rays this dispatch traces (the length of `traced_rays`), y: 1 to stop at any hit (shadow
    // rays), z: invocations per row of the dispatch, w: 1 where only whether a ray is blocked is
    // read (shadow rays: a hit's normal is not worked out).
    counts: vec4<u32>,
}
