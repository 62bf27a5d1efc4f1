// Per-pixel rays, reversed-Z depth and headlight shading, shared by every pass that draws into the frame.
//
// Spaces: view (camera-relative, OpenGL-style; see camera_types.wgsl) and framebuffer pixels
// (centres at +0.5, row 0 at the top); `headlight` takes a world-space normal.

fn camera_ray(cam: Camera, pixel: vec2<f32>) -> Ray {
    let a = vec2<f32>(pixel.x * cam.ray.x + cam.ray.z, pixel.y * cam.ray.y + cam.ray.w);
    if (cam.params.x > 0.5) {
        return Ray(vec3<f32>(a, 0.0), vec3<f32>(0.0, 0.0, -1.0));
    }
    return Ray(vec3<f32>(0.0), vec3<f32>(a, -1.0));
}

// Reversed Z: perspective depth = near / z_distance (infinite far plane, 0 = nothing);
// orthographic depth = (far - z_distance) / (far - near).
fn depth_from_distance(cam: Camera, z_distance: f32) -> f32 {
    if (cam.params.x > 0.5) {
        return clamp((cam.params.z - z_distance) / (cam.params.z - cam.params.y), 0.0, 1.0);
    }
    return clamp(cam.params.y / max(z_distance, 1e-30), 0.0, 1.0);
}

// The inverse: the view distance of a depth value; a huge finite one for 0 (nothing drawn).
fn distance_from_depth(cam: Camera, depth: f32) -> f32 {
    if (depth <= 0.0) {
        return 3.0e38;
    }
    if (cam.params.x > 0.5) {
        return cam.params.z - depth * (cam.params.z - cam.params.y);
    }
    return cam.params.y / depth;
}

// Headlight: light comes from the eye, so shading needs no light setup.
fn headlight(cam: Camera, base: vec3<f32>, world_normal: vec3<f32>, view_dir: vec3<f32>) -> vec3<f32> {
    let n = (cam.view_from_world * vec4<f32>(world_normal, 0.0)).xyz;
    let lambert = abs(dot(normalize(n), normalize(view_dir)));
    return base * (0.25 + 0.75 * lambert);
}
