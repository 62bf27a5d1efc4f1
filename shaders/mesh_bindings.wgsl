// Group 1 of the mesh pass: one mesh's record (its vertices come in vertex buffer 0).
//
// Spaces: see mesh_types.wgsl (object → view, object → world normals).

@group(1) @binding(0) var<uniform> object: MeshObject;
