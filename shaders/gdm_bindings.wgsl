// Group 1 of the displacement-shell pass: one shell's record, its prisms and its tile's
// empty-space radii (one u32 per voxel, x-major: (i * ny + j) * nz + k; 0 = solid), and the SVD
// terms of its distance function: weights W[((x * ny + y) * n_phi + phi) * k + i] and eigen-maps
// E[(i * n_theta + theta) * nz + z] (one float each when the shell has no lookup).
//
// Spaces: see gdm_types.wgsl.

@group(1) @binding(0) var<uniform> shell: GdmObject;
@group(1) @binding(1) var<storage, read> prisms: array<Prism>;
@group(1) @binding(2) var<storage, read> radii: array<u32>;
@group(1) @binding(3) var<storage, read> gdm_terms_w: array<f32>;
@group(1) @binding(4) var<storage, read> gdm_terms_e: array<f32>;
