// Group 1 of the inverse-geometric-texture passes: the object's record, the texture's tables
// (grids; cell offsets, cell c listing cell_entries[cell_start[c] .. cell_start[c + 1]];
// entries) and its attributes per detailed face and corner (3 u32 each: a normal as two snorm16
// of its octahedral encoding, a color as RGBA8; 3 vec2 texture coordinates) and the texture
// image (RGBA8 per u32, row 0 at the top); the detailed faces' corners (object space, 9 f32 per
// face) for the ray lookup; then the simplified mesh's own: the grids its faces' ray lookups
// walk (a face's first and count arrive with its vertices). Absent parts are bound as one
// dummy element.
//
// Spaces: see igt_types.wgsl.

@group(1) @binding(0) var<uniform> object: IgtObject;
@group(1) @binding(1) var<storage, read> grids: array<IgtGrid>;
@group(1) @binding(2) var<storage, read> cell_start: array<u32>;
@group(1) @binding(3) var<storage, read> cell_entries: array<u32>;
@group(1) @binding(4) var<storage, read> entries: array<IgtEntry>;
@group(1) @binding(5) var<storage, read> corner_normals: array<u32>;
@group(1) @binding(6) var<storage, read> corner_colors: array<u32>;
@group(1) @binding(7) var<storage, read> corner_uvs: array<vec2<f32>>;
@group(1) @binding(8) var<storage, read> image: array<u32>;
@group(1) @binding(9) var<storage, read> face_corners: array<f32>;
@group(1) @binding(10) var<storage, read> search_grids: array<u32>;
