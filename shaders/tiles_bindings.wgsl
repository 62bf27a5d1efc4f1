// Group 1's tile lists (src/render/kinds/tiles.rs), after the kind's own bindings: a texture
// set's pieces in its tiled frames and parallel ray queries (after gtex_bindings.wgsl's and
// gtex_pieces_bindings.wgsl's), a mesh's triangles in parallel ray queries (after
// mesh_trace_bindings.wgsl's).
//
// Spaces: the tiles' pixels (framebuffer pixels, row 0 at the top, for frames; the grid's for
// parallel rays), normalized device coordinates for the rectangle; entry depths are depths along
// the tiles' view direction.

struct Tiles {
    // x, y: tiles across and down; z: pixels on a tile's side.
    size: vec4<u32>,
    // Frames: the rectangle the lists cover in normalized device coordinates: x0, y0, x1, y1.
    rect: vec4<f32>,
    // Parallel rays: the grid's frame (its -Z along the rays) from the query's frame, and its
    // pixels: pixel = (grid xy - zw) / xy.
    grid_from_view: mat4x4<f32>,
    grid: vec4<f32>,
    // Parallel rays: x = the largest depth extent of a listed box along the rays (with a margin
    // for rounding), so that a ray skips the entries that lie wholly behind its origin; 0 for
    // frames (camera rays start at depth 0, behind every box).
    thickness: vec4<f32>,
}

@group(1) @binding(9) var<storage, read> tiles: Tiles;
// Per tile (row-major): first entry, entry count.
@group(1) @binding(10) var<storage, read> tile_ranges: array<vec2<u32>>;
// Per entry: index of a piece in `pieces` (or of a triangle in `triangles`), the nearest view
// depth of its box (f32 bits), its pixel rectangle [x0, y0, x1, y1) as x0 | y0 << 16,
// x1 | y1 << 16; nearest first.
@group(1) @binding(11) var<storage, read> tile_entries: array<vec4<u32>>;
