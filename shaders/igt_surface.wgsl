// Entry point of the surface pass, drawn after the scene pass where the scene holds an inverse
// geometric texture: the simplified mesh again (igt_raster.wgsl's vertex stage, depth tested
// against the finished depth buffer without writing it, so only the visible fragments pass),
// writing the detailed face under each pixel (+1; 0 = none) and its barycentric coordinates
// (f32 bits) into the surface target.
//
// Spaces: see igt_types.wgsl.

@fragment
fn fs_surface(in: VsOut) -> @location(0) vec4<u32> {
    let hit = igt_fragment_hit(in);
    if (hit.entry < 0) {
        return vec4<u32>(0u);
    }
    return vec4<u32>(entries[hit.entry].face + 1u, bitcast<vec3<u32>>(hit.bary));
}
