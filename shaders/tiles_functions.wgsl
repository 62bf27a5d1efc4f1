// What every walk of parallel rays through tile lists (tiles.rs, `parallel`) does first: find a
// ray's tile and skip the entries that lie wholly behind its start.
//
// Spaces: the query's frame (the rays); the grid's frame (`tiles.grid_from_view`), whose -Z is
// the rays' direction, and its pixels.

// The tile's list for a ray from `origin` (query frame) and the depth of that origin along the
// rays: list (first, count) of the entries that may reach it, x = 0xffffffff for a ray that
// starts outside the grid (every listed box lies inside it, so such a ray passes beside them all).
struct RayTile {
    range: vec2<u32>,
    pixel: vec2<u32>,
    depth: f32,
}

fn ray_tile(origin: vec3<f32>) -> RayTile {
    let p = (tiles.grid_from_view * vec4<f32>(origin, 1.0)).xyz;
    let pixel = (p.xy - tiles.grid.zw) / tiles.grid.xy;
    let extent = vec2<f32>(tiles.size.xy * tiles.size.z);
    if (any(pixel < vec2<f32>(0.0)) || any(pixel >= extent)) {
        return RayTile(vec2<u32>(0xffffffffu, 0u), vec2<u32>(0u), 0.0);
    }
    let at = vec2<u32>(pixel);
    let tile = at / tiles.size.z;
    return RayTile(entries_ahead(tile_ranges[tile.y * tiles.size.x + tile.x], -p.z), at, -p.z);
}

// The entries of `range` (first, count) from the first that may reach `depth` on: the list is
// sorted by nearest depth, and no box is thicker than `tiles.thickness.x`, so an entry nearer than
// depth - thickness lies wholly behind a ray starting at `depth` (found by bisection, where the
// walk would test each: the bunny's shadow dispatch took 73-117 ms against 108-144, loaded).
fn entries_ahead(range: vec2<u32>, depth: f32) -> vec2<u32> {
    let behind = depth - tiles.thickness.x;
    var lo = range.x;
    var hi = range.x + range.y;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (bitcast<f32>(tile_entries[mid].y) < behind) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return vec2<u32>(lo, range.x + range.y - lo);
}

// Whether `pixel` lies in an entry's pixel rectangle (the cheap test: no record read).
fn entry_holds(entry: vec4<u32>, pixel: vec2<u32>) -> bool {
    let lo = vec2<u32>(entry.z & 0xffffu, entry.z >> 16u);
    let hi = vec2<u32>(entry.w & 0xffffu, entry.w >> 16u);
    return all(pixel >= lo) && all(pixel < hi);
}
