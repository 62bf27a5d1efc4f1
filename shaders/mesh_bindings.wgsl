// Group 1 of the mesh pass: one mesh's record (its vertices come in vertex buffer 0) and its
// texture image with its mip chain (a 1 x 1 white image for meshes without one), read through a
// repeating trilinear sampler.
//
// Spaces: see mesh_types.wgsl (object → view, object → world normals).

@group(1) @binding(0) var<uniform> object: MeshObject;
@group(1) @binding(1) var image: texture_2d<f32>;
@group(1) @binding(2) var image_sampler: sampler;
