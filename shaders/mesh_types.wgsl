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

// One triangle of a traced mesh (kinds/mesh.rs), its corners in the mesh's local space (object
// space relative to its bounding box centre), uploaded once per mesh.
struct TraceTriangle {
    a: vec3<f32>,
    _pad0: u32,
    b: vec3<f32>,
    _pad1: u32,
    c: vec3<f32>,
    _pad2: u32,
}

// A traced mesh's settings: where it is placed in this query.
struct MeshTrace {
    // Moves the query's rays into the mesh's local space (directions unnormalized: t stays the
    // query's distance).
    local_from_query: mat4x4<f32>,
    // Cofactor of the placement's linear part: a local face normal to the placed one (world).
    world_normal_from_local: mat4x4<f32>,
    // x: the id its hits get (-2 - k for the scene's k-th mesh, as in frames).
    ids: vec4<i32>,
}
