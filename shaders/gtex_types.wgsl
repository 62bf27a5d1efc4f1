// One geometry-texture patch as the ray caster sees it.
//
// Spaces: view (camera-relative, see camera_types.wgsl), patch-local (the box is the unit cube,
// x/y are texture u/v, z is height), world for normals, atlas texels for the maps.

// Where a patch's maps are: all a height-field search reads (kept apart from the matrices so a
// search loads 48 bytes, not the whole record).
struct PatchMaps {
    // Texel origin of the patch in its atlas layer, and its size in texels.
    atlas_origin: vec2<f32>,
    size: vec2<f32>,
    // x: atlas layer, y: patch id written to the id target, z: 1 if the patch has a color map.
    ids: vec4<i32>,
    // x: first pyramid value of this patch in `pyramid`, y: pyramid levels, z: the largest
    // height code (255 or 65535), w: level-of-detail stop level (0 = exact).
    pyramid_at: vec4<u32>,
}

struct Patch {
    view_from_patch: mat4x4<f32>,
    patch_from_view: mat4x4<f32>,
    // Patch-local normal → world normal.
    world_normal_from_patch: mat4x4<f32>,
    maps: PatchMaps,
}

// A piece of a patch's box (src/render/kinds/gtex/boxes.rs): the part over one node of the
// patch's min-max pyramid, only as tall as the heights under it. Patch-local space.
struct PatchBox {
    lo: vec3<f32>,
    patch_index: u32,
    hi: vec3<f32>,
    // The pyramid level of the node (where a search inside the piece starts).
    level: u32,
}
