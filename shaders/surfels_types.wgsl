// Surfel hierarchies (src/surfels/): tiles of surfels, level 0 finest, each level's surfels
// contiguous; one object's record; the frame's surfel tally.
//
// Spaces: object (positions relative to the hierarchy's centre, f32, placed by
// view_from_object), view (camera-relative, see camera_types.wgsl), world for output normals.

struct SurfelTile {
    // xyz: centre of a sphere holding every disc of every level (object space), w: its radius.
    sphere: vec4<f32>,
    // Perpendicular error of level l at [l / 4][l % 4] (object units), never decreasing with l.
    error: array<vec4<f32>, 2>,
    // First surfel of level l at [l / 4][l % 4]; entry [levels] is the tile's end.
    start: array<vec4<u32>, 2>,
    // x: levels, y: patch index within the set, z: the node above the tile (NO_NODE: none).
    info: vec4<u32>,
    // Normal cones of the tile's levels (object space): xyz the unit axis, shared by every
    // level; the half angle (radians) of level l at cone_angle[l / 4][l % 4].
    cone_axis: vec4<f32>,
    cone_angle: array<vec4<f32>, 2>,
}

// A node of a patch's quadtree above its tiles (src/surfels/nodes.rs): one surfel standing for
// its 2x2 children.
struct SurfelNode {
    // xyz: centre of a sphere holding every disc below (object space), w: its radius.
    sphere: vec4<f32>,
    // Normal cone of the tiles' top-level surfels below: unit axis, half angle (radians).
    cone: vec4<f32>,
    // Its error (object units), never smaller than a child's.
    error: f32,
    // Its surfel (index into `surfels`, after every tile's).
    surfel: u32,
    // The node one level up, NO_NODE at a root.
    parent: u32,
    level: u32,
}

struct Surfel {
    position: vec3<f32>,
    radius: f32,
    // Object-space unit normal.
    normal: vec3<f32>,
    // RGBA8 (unpack4x8unorm).
    color: u32,
}

// A patch's texel grid in object space: texel coordinate u = dot(u.xyz, p) + u.w of an
// object-space point p (texel i spans u in [i, i + 1]), v likewise.
struct PatchFrame {
    u: vec4<f32>,
    v: vec4<f32>,
}

struct SurfelObject {
    view_from_object: mat4x4<f32>,
    world_normal_from_object: mat4x4<f32>,
    // The frustum's four side planes in view space: inside where dot(xyz, p) + w >= 0.
    planes: array<vec4<f32>, 4>,
    // x: max_pixel_error, y: world size of a pixel at unit distance (perspective) or of any
    // pixel (orthographic), z: view units per object unit, w: the share of max_pixel_error a
    // tile or node that may show a silhouette is held to (it grows with the model's size on
    // screen, render/kinds/surfels.rs outline_share).
    params: vec4<f32>,
    // x, y: image size, z: the id of the set's patch 0, w: tiles.
    sizes: vec4<u32>,
    // The resolve pass's rectangle in normalized device coordinates (x0, y0, x1, y1): the
    // hierarchy's bounding box on screen, a few pixels wider.
    rect: vec4<f32>,
    // x: nodes above the tiles.
    counts: vec4<u32>,
}

// The tally's slots: surfels listed, tiles in view, finest surfels of those tiles, the surfels
// listed per tile level, then the node surfels listed (every level above the tile).
const TALLY_DRAWN: u32 = 0u;
const TALLY_TILES: u32 = 1u;
const TALLY_FINEST: u32 = 2u;
const TALLY_LEVEL0: u32 = 3u;
const TALLY_NODES: u32 = 10u;
const NO_NODE: u32 = 0xffffffffu;
const TALLY_SLOTS: u32 = 16u;
// Splatting threads per workgroup, and the most workgroups a dispatch row takes.
const SPLAT_GROUP: u32 = 64u;
const DISPATCH_ROW: u32 = 65535u;
// Largest splat radius in pixels a surfel is drawn with (the level choice keeps splats near a
// pixel; only a camera a few texels from the surface reaches this).
const MAX_SPLAT_RADIUS: f32 = 24.0;
