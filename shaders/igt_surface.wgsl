// Entry point of the surface pass, drawn after the scene pass where the scene holds an inverse
// geometric texture: the simplified mesh again (igt_raster.wgsl's vertex stage, depth tested
// against the finished depth buffer without writing it, so only the visible fragments pass),
// looking up the detailed triangle under each pixel once (igt_raster.wgsl, igt_shade_pixel)
// and writing its face (+1; 0 = none) and barycentric coordinates (f32 bits) into the surface
// target, and the pixel's shaded color, normal and base color over the scene pass's (which
// drew depth and ids only). Where the object's shader LoD says the point is far, the color and
// normal come from the baked texture (igt_baked); the face and barycentrics still from the
// lookup.
//
// Spaces: see igt_types.wgsl.

struct IgtSurfaceOut {
    @location(0) surface: vec4<u32>,
    @location(1) color: vec4<f32>,
    @location(2) normal: vec4<f32>,
    @location(3) albedo: vec4<f32>,
}

@fragment
fn fs_surface(in: VsOut) -> IgtSurfaceOut {
    // The simplified face's normal and the footprint's derivatives, taken before any branch.
    let dx = dpdx(in.object_pos);
    let dy = dpdy(in.object_pos);
    let view_dx = dpdx(in.view_pos);
    let view_dy = dpdy(in.view_pos);
    let flat_normal = cross(dx, dy);
    let hit = igt_fragment_hit(in);
    var out: IgtSurfaceOut;
    out.surface = vec4<u32>(0u);
    if (hit.entry >= 0) {
        out.surface = vec4<u32>(entries[hit.entry].face + 1u, bitcast<vec3<u32>>(hit.bary));
    }
    // Far away the baked texture (already one value per cell: no extra samples), unless no
    // cell near the point holds one.
    var shade = IgtShade(vec3<f32>(0.0), vec4<f32>(-1.0));
    if (igt_far(in.grid, in.object_pos, in.view_pos, dx, dy)) {
        shade = igt_baked(in.grid, in.object_pos);
    }
    if (shade.base.a < 0.0) {
        shade = igt_shade_pixel(in, hit, dx, dy, view_dx, view_dy);
    }
    var n = flat_normal;
    if (dot(shade.normal, shade.normal) > 0.0) {
        n = shade.normal;
    }
    let base = shade.base;
    let world_n = normalize((object.world_normal_from_object * vec4<f32>(n, 0.0)).xyz);
    out.color = vec4<f32>(headlight(camera, base.rgb, world_n, in.view_pos), base.a);
    out.normal = vec4<f32>(world_n, 0.0);
    out.albedo = base;
    return out;
}
