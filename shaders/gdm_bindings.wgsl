// Group 1 of the displacement-shell pass: one shell's record, its prisms and its tile's
// empty-space radii (one u32 per voxel, x-major: (i * ny + j) * nz + k; 0 = solid).
//
// Spaces: see gdm_types.wgsl.

@group(1) @binding(0) var<uniform> shell: GdmObject;
@group(1) @binding(1) var<storage, read> prisms: array<Prism>;
@group(1) @binding(2) var<storage, read> radii: array<u32>;
