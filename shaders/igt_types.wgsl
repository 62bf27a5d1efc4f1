// An inverse geometric texture and the simplified mesh shaded through it (kinds/igt.rs).
//
// Spaces: object space is the meshes' own (the detailed and the simplified mesh share it),
// stored relative to the detailed mesh's bounding-box centre (f32); view space is
// camera-relative (camera_types.wgsl); normals are output in world space. Primary space is per
// grid, in cell units (src/igt_data/primary.rs): charts project along their own z; spherical and
// cylindrical maps take longitude (and colatitude or height along the axis).

struct IgtObject {
    view_from_object: mat4x4<f32>,
    world_normal_from_object: mat4x4<f32>,
    // x: id written to the id target; y: 1 for the ray lookup, 0 for the projection; z: lookups
    // per pixel (1, or 5 averaged).
    ids: vec4<i32>,
    // x: primary (0 charts, 1 spherical, 2 cylindrical), y: attribute bits (1 corner colors,
    // 2 texture coordinates and image, 4 ambient occlusion), z, w: the image's width and height
    // in pixels.
    info: vec4<u32>,
    // Inverse of view_from_object (for the view ray's direction in object space).
    object_from_view: mat4x4<f32>,
    // Where the attribute buffer's parts start: corner colors, texture coordinates, image,
    // occlusion (the normals start at 0).
    segments: vec4<u32>,
    // y: the shader LoD (0 off, 1 where a cell covers less than a pixel, 2 beyond a distance);
    // z: that distance's f32 bits (view units); w: where the cells' heights start in
    // cell_start (igt_bindings.wgsl); x unused.
    lod: vec4<u32>,
}

// One grid of the primary space. Its y axis is cross(z, x) (the axes are right-handed).
struct IgtGrid {
    // xyz: origin (object space); w: cells per world unit along u (charts).
    origin: vec4<f32>,
    // xyz: axis x; w: cells per world unit along v (charts, cylindrical).
    x: vec4<f32>,
    // xyz: axis z (the chart's projection direction, or the pole / cylinder axis); w: the
    // lowest height (along z from the origin) of its listed faces.
    z: vec4<f32>,
    // width, height (cells), first cell (index into the cell offsets), the highest height's
    // f32 bits.
    size: vec4<u32>,
}

// A detailed triangle as one grid sees it: corners in that grid's primary space (cell units).
struct IgtEntry {
    a: vec2<f32>,
    b: vec2<f32>,
    c: vec2<f32>,
    face: u32,
    grid: u32,
}

// What a lookup found: the entry (-1 when nothing is listed near the point) and the point's
// barycentric coordinates in it.
struct IgtHit {
    entry: i32,
    bary: vec3<f32>,
}

// What a fragment shows: the detailed normal (object space; zero when no triangle was found)
// and base color (occlusion applied; alpha -1 from igt_baked when no baked cell was near).
struct IgtShade {
    normal: vec3<f32>,
    base: vec4<f32>,
}
