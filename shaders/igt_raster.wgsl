// Entry points of the inverse-geometric-texture pass: the simplified mesh is rasterized into
// the shared targets and reversed-Z depth (two-sided, as meshes are), and each fragment is
// shaded with the attributes of the detailed triangle under it (igt_functions.wgsl): its
// normal, and its texture or corner colors. Where nothing is listed near a point, the
// simplified face's own normal and the neutral color.
//
// Spaces: see igt_types.wgsl.

struct VsIn {
    @location(0) position: vec3<f32>,
    @location(1) grid: u32,
}

struct VsOut {
    // Invariant: the surface pass (igt_surface.wgsl) draws the same depths again.
    @builtin(position) @invariant position: vec4<f32>,
    @location(0) object_pos: vec3<f32>,
    @location(1) view_pos: vec3<f32>,
    @location(2) @interpolate(flat) grid: u32,
}

@vertex
fn vs_main(v: VsIn) -> VsOut {
    let view = object.view_from_object * vec4<f32>(v.position, 1.0);
    return VsOut(camera.clip_from_view * view, v.position, view.xyz, v.grid);
}

struct FsOut {
    @location(0) color: vec4<f32>,
    @location(1) normal: vec4<f32>,
    @location(2) id: i32,
    @location(3) albedo: vec4<f32>,
}

@fragment
fn fs_main(in: VsOut) -> FsOut {
    // The simplified face's normal (derivatives taken before any branch).
    let flat_normal = cross(dpdx(in.object_pos), dpdy(in.object_pos));
    let hit = igt_lookup(in.grid, in.object_pos);
    var n = flat_normal;
    var base = vec4<f32>(200.0, 200.0, 200.0, 255.0) / 255.0;
    if (hit.entry >= 0) {
        let face = entries[hit.entry].face;
        n = igt_normal(face, hit.bary);
        base = igt_color(face, hit.bary);
    }
    let world_n = normalize((object.world_normal_from_object * vec4<f32>(n, 0.0)).xyz);
    var out: FsOut;
    out.color = vec4<f32>(headlight(camera, base.rgb, world_n, in.view_pos), base.a);
    out.normal = vec4<f32>(world_n, 0.0);
    out.id = object.ids.x;
    out.albedo = base;
    return out;
}
