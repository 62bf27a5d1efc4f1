// Entry points of the inverse-geometric-texture scene pass and the shading both passes share:
// the simplified mesh is rasterized into the shared targets and reversed-Z depth (two-sided, as
// meshes are); the surface pass (igt_surface.wgsl) then shades each visible fragment with the
// attributes of the detailed triangle under it (igt_functions.wgsl): its normal, and its
// texture or corner colors (with 5 samples, averaged over the pixel's footprint), darkened by
// its ambient occlusion when the texture has it. Where nothing is listed near a point, the
// simplified face's own normal and the neutral color. Where the object's shader LoD says the
// point is far, the baked texture instead (igt_baked).
//
// Spaces: see igt_types.wgsl.

struct VsIn {
    @location(0) position: vec3<f32>,
    @location(1) grid: u32,
    // The face's ray-lookup windows (object units from its plane): outside (the side its
    // normal points to) and inside.
    @location(2) window: vec2<f32>,
    // The grids the ray lookup walks: first and count in search_grids.
    @location(3) search: vec2<u32>,
    // The face's unit normal by its winding (object space).
    @location(4) normal: vec3<f32>,
}

struct VsOut {
    // Invariant: the surface pass (igt_surface.wgsl) draws the same depths again.
    @builtin(position) @invariant position: vec4<f32>,
    @location(0) object_pos: vec3<f32>,
    @location(1) view_pos: vec3<f32>,
    @location(2) @interpolate(flat) grid: u32,
    @location(3) @interpolate(flat) window: vec2<f32>,
    @location(4) @interpolate(flat) search: vec2<u32>,
    @location(5) @interpolate(flat) normal: vec3<f32>,
}

@vertex
fn vs_main(v: VsIn) -> VsOut {
    let view = object.view_from_object * vec4<f32>(v.position, 1.0);
    return VsOut(camera.clip_from_view * view, v.position, view.xyz, v.grid, v.window, v.search, v.normal);
}

// Below this cosine between the view ray and the simplified face, the ray lookup's reach stops
// growing (IGT_MAX_WALK bounds it anyway).
const IGT_MIN_COSINE: f32 = 0.05;

// The detailed triangle this fragment shows: the first the view ray meets within the face's
// windows when the object asks for the ray lookup (its window on the camera's side behind the
// point, the other ahead), else (or when it meets none) the one under the point projected into
// its grid.
fn igt_fragment_hit(in: VsOut) -> IgtHit {
    if (object.ids.y == 1) {
        let ortho = camera.params.x > 0.5;
        let view_dir = select(normalize(in.view_pos), vec3<f32>(0.0, 0.0, -1.0), ortho);
        let along = (object.object_from_view * vec4<f32>(view_dir, 0.0)).xyz;
        // Object units per view unit (placements may scale).
        let units = length(along);
        let d = along / units;
        let facing = dot(d, in.normal);
        let cosine = select(abs(facing), 1.0, dot(in.normal, in.normal) == 0.0);
        let slant = 1.0 / max(cosine, IGT_MIN_COSINE);
        // The camera is on the outside when the ray runs against the normal.
        let toward = select(in.window.y, in.window.x, facing <= 0.0) * slant;
        let ahead = select(in.window.x, in.window.y, facing <= 0.0) * slant;
        // Never behind the camera.
        let eye = select(length(in.view_pos), -in.view_pos.z, ortho) * units;
        let hit = igt_ray_lookup(in.search, in.object_pos, d, min(toward, eye), ahead);
        if (hit.entry >= 0) {
            return hit;
        }
    }
    return igt_lookup(in.grid, in.object_pos);
}

// Where the four extra lookups of a 5-sample pixel lie, in pixels from its centre: a rotated
// grid, so that no two share a row or column of the footprint.
const IGT_OFFSETS = array<vec2<f32>, 4>(
    vec2<f32>(-0.125, -0.375),
    vec2<f32>(0.375, -0.125),
    vec2<f32>(0.125, 0.375),
    vec2<f32>(-0.375, 0.125),
);

// The normal (object space, unit; zero when nothing was found) and base color of the detailed
// surface at `hit`.
fn igt_shade(hit: IgtHit) -> IgtShade {
    if (hit.entry < 0) {
        return IgtShade(vec3<f32>(0.0), vec4<f32>(200.0, 200.0, 200.0, 255.0) / 255.0);
    }
    let face = entries[hit.entry].face;
    let base = igt_color(face, hit.bary);
    let open = igt_occlusion(face, hit.bary);
    return IgtShade(igt_normal(face, hit.bary), vec4<f32>(base.rgb * open, base.a));
}

// What `in` shows through the lookup: one sample (`hit`, its centre's), or with
// object.ids.z == 5 the pixel's five (moved along the simplified surface by the footprint's
// derivatives, and their view rays with them; the normals that were found and all colors
// averaged).
fn igt_shade_pixel(in: VsOut, hit: IgtHit, dx: vec3<f32>, dy: vec3<f32>, view_dx: vec3<f32>, view_dy: vec3<f32>) -> IgtShade {
    let shade = igt_shade(hit);
    if (object.ids.z != 5) {
        return shade;
    }
    var normal_sum = shade.normal;
    var base_sum = shade.base;
    for (var k = 0; k < 4; k++) {
        var s = in;
        let o = IGT_OFFSETS[k];
        s.object_pos += o.x * dx + o.y * dy;
        s.view_pos += o.x * view_dx + o.y * view_dy;
        let more = igt_shade(igt_fragment_hit(s));
        normal_sum += more.normal;
        base_sum += more.base;
    }
    return IgtShade(normal_sum, base_sum / 5.0);
}

// The scene pass: depth, the object's id and the simplified face's own normal only. The
// lookup and the shading wait for the surface pass (igt_surface.wgsl), which draws over the
// visible fragments alone: a lookup costs far more than rasterizing (on lavapipe about 10 us a
// pixel for the ray lookup), and hidden fragments of the simplified mesh (about one for each
// visible one, two-sided, in no particular order) would each have paid for one.
@fragment
fn fs_main(in: VsOut) -> RasterFsOut {
    let n = cross(dpdx(in.object_pos), dpdy(in.object_pos));
    let world_n = normalize((object.world_normal_from_object * vec4<f32>(n, 0.0)).xyz);
    var out: RasterFsOut;
    out.color = vec4<f32>(0.0);
    out.normal = vec4<f32>(world_n, 0.0);
    out.id = object.ids.x;
    out.albedo = vec4<f32>(0.0);
    return out;
}
