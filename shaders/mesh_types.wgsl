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

// One triangle of a traced mesh (kinds/mesh.rs), its corners placed in the query's frame.
struct TraceTriangle {
    a: vec3<f32>,
    _pad0: u32,
    b: vec3<f32>,
    _pad1: u32,
    c: vec3<f32>,
    _pad2: u32,
}

// A traced mesh's settings.
struct MeshTrace {
    // x: the id its hits get (-2 - k for the scene's k-th mesh, as in frames).
    ids: vec4<i32>,
}
