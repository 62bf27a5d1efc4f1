// Group 1 of the inverse-geometric-texture passes: the object's record, the texture's tables
// (grids; cell offsets, cell c listing cell_entries[cell_start[c] .. cell_start[c + 1]], then
// from object.lod.w on per cell the heights its listed triangles span (kinds/igt.rs,
// cell_heights); entries), its attributes in one buffer of u32 (parts where object.segments says;
// kinds/igt.rs, pack_attributes): per detailed face and corner a normal as two snorm16 of its
// octahedral encoding (first, from 0), a color as RGBA8, texture coordinates as two f32 bits;
// the texture image (RGBA8 per u32, row 0 at the top); per face the corners' ambient occlusion
// as three unorm8. Then the detailed faces' corners (object space, 9 f32 per face) for the ray
// lookup; per cell of the primary space the shader LoD's baked normal code and color
// (bake.rs); and the simplified mesh's own: the grids its faces' ray lookups walk (a face's
// first and count arrive with its vertices). Eight storage buffers: within the 8 any adapter
// allows a fragment stage. Absent parts are bound as one dummy element.
//
// Spaces: see igt_types.wgsl.

@group(1) @binding(0) var<uniform> object: IgtObject;
@group(1) @binding(1) var<storage, read> grids: array<IgtGrid>;
@group(1) @binding(2) var<storage, read> cell_start: array<u32>;
@group(1) @binding(3) var<storage, read> cell_entries: array<u32>;
@group(1) @binding(4) var<storage, read> entries: array<IgtEntry>;
@group(1) @binding(5) var<storage, read> attributes: array<u32>;
@group(1) @binding(6) var<storage, read> face_corners: array<f32>;
@group(1) @binding(7) var<storage, read> baked: array<vec2<u32>>;
@group(1) @binding(8) var<storage, read> search_grids: array<u32>;
