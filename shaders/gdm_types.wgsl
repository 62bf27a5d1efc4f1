// One displacement shell (kinds/gdm.rs): prisms over a base mesh and the mesostructure tile they
// carry.
//
// Spaces: the shell's object space, stored relative to its bounding box's centre ("local", f32);
// view (camera-relative, see camera_types.wgsl); texture space in voxels of the tile (x, y repeat,
// z = 0 on the base surface, z = nz on the top).

struct GdmObject {
    view_from_object: mat4x4<f32>,
    object_from_view: mat4x4<f32>,
    world_normal_from_object: mat4x4<f32>,
    // x, y, z: the tile's voxels; w: march pieces per prism.
    size: vec4<u32>,
    color: vec4<f32>,
    // x: id written to the id target.
    ids: vec4<i32>,
    // The GDM lookup (SVD terms in gdm_bindings.wgsl): x, y: theta and phi counts, z: terms k,
    // w: 0 to march exactly, 1 for the paper's lookup, 2 to step by a conservative table and
    // finish with the march.
    lookup: vec4<u32>,
    // x: half-width (voxels) of the exact search around a looked-up distance; 0: none.
    // w: 1 to write (lookups, march steps) to the normal target (diagnostics).
    params: vec4<f32>,
}

// One prism: base corners p (local), top corners q = p + thickness * n (shared vertex normals),
// texture coordinates of the corners in voxels. p0.w holds the fin diagonals: bit e set when fin
// e (corner e to e + 1) is split along p_e - q_(e+1), else along p_(e+1) - q_e; both prisms
// sharing a fin split it alike (chosen by vertex id on the CPU). Only the raster pass draws
// those triangles; a ray's span in the prism is found through the exact bilinear fins.
struct Prism {
    p0: vec4<f32>,
    p1: vec4<f32>,
    p2: vec4<f32>,
    q0: vec4<f32>,
    q1: vec4<f32>,
    q2: vec4<f32>,
    // xy: corner 0, zw: corner 1.
    uv01: vec4<f32>,
    // xy: corner 2.
    uv2: vec4<f32>,
}
