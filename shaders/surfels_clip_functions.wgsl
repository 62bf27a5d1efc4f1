// Clipping a surfel's disc to the box of texels it stands for (Surfel::texels, plus a margin of
// half a texel): the disc is sized to cover its children's discs, so
// unclipped its rim reaches past the surface they cover and grows the silhouette. The box is
// tested in the patch's texel grid (u along its first axis, v along its second, in texels).
//
// Spaces: object → view (camera-relative); the patch's texel grid.

struct DiscClip {
    // View-space gradients of the texel coordinates u and v (covectors).
    u: vec3<f32>,
    v: vec3<f32>,
    // (u, v) at the disc's centre.
    at: vec2<f32>,
    // The box: (u0, v0, u1, v1).
    lo: vec2<f32>,
    hi: vec2<f32>,
}

fn disc_clip(index: u32) -> DiscClip {
    let s = surfels[index];
    let frame = patch_frames[surfel_patch[index]];
    // Covectors map by the inverse transpose, as normals do.
    let u = (camera.view_from_world * (object.world_normal_from_object * vec4<f32>(frame.u.xyz, 0.0))).xyz;
    let v = (camera.view_from_world * (object.world_normal_from_object * vec4<f32>(frame.v.xyz, 0.0))).xyz;
    let at = vec2<f32>(dot(frame.u.xyz, s.position) + frame.u.w, dot(frame.v.xyz, s.position) + frame.v.w);
    let b = clips[index];
    return DiscClip(u, v, at, b.xy, b.zw);
}

// Reversed-Z depth where pixel (x, y) sees the disc inside its clip box, 0 on a miss.
fn clipped_depth(d: ViewDisc, c: DiscClip, x: i32, y: i32) -> f32 {
    let px = vec2<f32>(f32(x), f32(y)) + 0.5;
    let t = disc_distance(d, px, 1.0);
    if (t < 0.0) {
        return 0.0;
    }
    let ray = camera_ray(camera, px);
    let q = ray.origin + t * ray.dir - d.centre;
    let uv = c.at + vec2<f32>(dot(c.u, q), dot(c.v, q));
    if (any(uv < c.lo) || any(uv > c.hi)) {
        return 0.0;
    }
    return depth_from_distance(camera, t);
}
