// Entry points of the surfel resolve pass, drawn in the scene pass: a rectangle over the
// hierarchy's bounding box on screen, whose fragments read the visibility buffer the splat passes filled and write the winning surfel's
// depth (frag_depth, so the shared reversed-Z test composites surfels with every other kind),
// normal, color and patch id. A pixel no disc reached is filled from its nearest neighbour, on
// that neighbour's disc plane, when covered neighbours lie on two opposite sides of it (a hole
// inside the surface) and that disc, grown to twice its radius, reaches the pixel.
//
// Spaces: view (camera-relative) and framebuffer pixels (row 0 at the top); world normals out.

struct VsOut {
    @builtin(position) position: vec4<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32) -> VsOut {
    return VsOut(rect_vertex(object.rect, vertex));
}

// The 8 neighbours in turn around the pixel: entry k + 4 is opposite entry k.
const RING = array<vec2<i32>, 8>(
    vec2(-1, -1), vec2(0, -1), vec2(1, -1), vec2(1, 0),
    vec2(1, 1), vec2(0, 1), vec2(-1, 1), vec2(-1, 0),
);

fn visible_at(x: i32, y: i32) -> vec2<u32> {
    let size = vec2<i32>(object.sizes.xy);
    if (x < 0 || y < 0 || x >= size.x || y >= size.y) {
        return vec2<u32>(0u);
    }
    return visible[u32(y) * object.sizes.x + u32(x)];
}

// (surfel index, depth bits) for an empty pixel inside the surface, from its nearest covered
// neighbour with the depth of that neighbour's disc plane here; depth bits 0 if none.
fn fill_hole(x: i32, y: i32) -> vec2<u32> {
    var near = vec2<u32>(0u);
    var opposite = false;
    for (var k = 0; k < 8; k++) {
        let v = visible_at(x + RING[k].x, y + RING[k].y);
        if (v.y == 0u) {
            continue;
        }
        if (k < 4 && visible_at(x + RING[k + 4].x, y + RING[k + 4].y).y != 0u) {
            opposite = true;
        }
        if (bitcast<f32>(v.y) > bitcast<f32>(near.y)) {
            near = v;
        }
    }
    if (!opposite) {
        return vec2<u32>(0u);
    }
    // Only where that disc, grown to twice its radius, reaches: a gap between discs of about a
    // pixel or more is filled, a notch in a silhouette that sub-pixel discs outline is not.
    let disc = view_disc(surfels[near.x]);
    let t = disc_distance(disc, vec2<f32>(f32(x), f32(y)) + 0.5, 2.0);
    if (t <= 0.0) {
        return vec2<u32>(0u);
    }
    near.y = bitcast<u32>(depth_from_distance(camera, t));
    return near;
}

@fragment
fn fs_main(in: VsOut) -> FsOut {
    let x = i32(in.position.x);
    let y = i32(in.position.y);
    var v = visible_at(x, y);
    if (v.y == 0u) {
        v = fill_hole(x, y);
        if (v.y == 0u) {
            discard;
        }
    }
    let s = surfels[v.x];
    let base = unpack4x8unorm(s.color);
    let n = normalize((object.world_normal_from_object * vec4<f32>(s.normal, 0.0)).xyz);
    let ray = camera_ray(camera, in.position.xy);
    var out: FsOut;
    out.color = vec4<f32>(headlight(camera, base.rgb, n, ray.dir), base.a);
    out.normal = vec4<f32>(n, 0.0);
    out.id = i32(object.sizes.z + surfel_patch[v.x]);
    out.albedo = base;
    out.depth = bitcast<f32>(v.y);
    return out;
}
