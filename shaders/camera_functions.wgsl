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

// The two triangles of a screen rectangle: corner (x from bit 0, y from bit 1) of each vertex.
const RECT_CORNERS = array<u32, 6>(0u, 1u, 3u, 0u, 3u, 2u);

// Vertex `vertex` (0..6) of the rectangle `rect` (x0, y0, x1, y1 in normalized device
// coordinates), as a clip-space position: passes that draw one rectangle over what they cover.
fn rect_vertex(rect: vec4<f32>, vertex: u32) -> vec4<f32> {
    let c = RECT_CORNERS[vertex];
    let xy = vec2<f32>(select(rect.x, rect.z, (c & 1u) != 0u), select(rect.y, rect.w, (c & 2u) != 0u));
    return vec4<f32>(xy, 0.5, 1.0);
}
