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
    // The face's ray-lookup window (object units from its plane).
    @location(2) window: f32,
    // The grids the ray lookup walks: first and count in search_grids.
    @location(3) search: vec2<u32>,
}

struct VsOut {
    // Invariant: the surface pass (igt_surface.wgsl) draws the same depths again.
    @builtin(position) @invariant position: vec4<f32>,
    @location(0) object_pos: vec3<f32>,
    @location(1) view_pos: vec3<f32>,
    @location(2) @interpolate(flat) grid: u32,
    @location(3) @interpolate(flat) window: f32,
    @location(4) @interpolate(flat) search: vec2<u32>,
}

@vertex
fn vs_main(v: VsIn) -> VsOut {
    let view = object.view_from_object * vec4<f32>(v.position, 1.0);
    return VsOut(camera.clip_from_view * view, v.position, view.xyz, v.grid, v.window, v.search);
}

// Below this cosine between the view ray and the simplified face, the ray lookup's reach stops
// growing (IGT_MAX_WALK bounds it anyway).
const IGT_MIN_COSINE: f32 = 0.05;

// The detailed triangle this fragment shows: the first the view ray meets within the face's
// window when the object asks for the ray lookup, else (or when it meets none) the one under
// the point projected into its grid. `flat_normal`: the simplified face's (object space, any
// length).
fn igt_fragment_hit(in: VsOut, flat_normal: vec3<f32>) -> IgtHit {
    if (object.ids.y == 1) {
        let ortho = camera.params.x > 0.5;
        let view_dir = select(normalize(in.view_pos), vec3<f32>(0.0, 0.0, -1.0), ortho);
        let along = (object.object_from_view * vec4<f32>(view_dir, 0.0)).xyz;
        // Object units per view unit (placements may scale).
        let units = length(along);
        let d = along / units;
        let len = length(flat_normal);
        let cosine = select(abs(dot(d, flat_normal)) / len, 1.0, len == 0.0);
        let reach = in.window / max(cosine, IGT_MIN_COSINE);
        // Never behind the camera.
        let eye = select(length(in.view_pos), -in.view_pos.z, ortho) * units;
        let hit = igt_ray_lookup(in.search, in.object_pos, d, min(reach, eye), reach);
        if (hit.entry >= 0) {
            return hit;
        }
    }
    return igt_lookup(in.grid, in.object_pos);
}

@fragment
fn fs_main(in: VsOut) -> RasterFsOut {
    // The simplified face's normal (derivatives taken before any branch).
    let flat_normal = cross(dpdx(in.object_pos), dpdy(in.object_pos));
    let hit = igt_fragment_hit(in, flat_normal);
    var n = flat_normal;
    var base = vec4<f32>(200.0, 200.0, 200.0, 255.0) / 255.0;
    if (hit.entry >= 0) {
        let face = entries[hit.entry].face;
        n = igt_normal(face, hit.bary);
        base = igt_color(face, hit.bary);
    }
    let world_n = normalize((object.world_normal_from_object * vec4<f32>(n, 0.0)).xyz);
    var out: RasterFsOut;
    out.color = vec4<f32>(headlight(camera, base.rgb, world_n, in.view_pos), base.a);
    out.normal = vec4<f32>(world_n, 0.0);
    out.id = object.ids.x;
    out.albedo = base;
    return out;
}
