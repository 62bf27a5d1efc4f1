// One rasterized mesh: its placement and id.
//
// Spaces: object space (vertices relative to the mesh's own centre, f32), view space
// (camera-relative, see camera_types.wgsl), world for normals.

struct MeshObject {
    view_from_object: mat4x4<f32>,
    world_normal_from_object: mat4x4<f32>,
    // x: id written to the id target.
    ids: vec4<i32>,
}
