// The camera uniform and a pixel's ray.
//
// Spaces: view space is OpenGL-style (camera at the origin, looking down -Z, +Y up). It is
// camera-relative: every matrix reaching the GPU was composed in f64 on the CPU with the camera
// position subtracted, so models far from the world origin keep their precision.
// Pixel (column x, row y) has its centre at (x + 0.5, y + 0.5), row 0 at the top.

struct Camera {
    clip_from_view: mat4x4<f32>,
    // Rotation part of view_from_world (for headlight shading of world normals).
    view_from_world: mat4x4<f32>,
    // Pixel centre → view ray: a = (px * ray.x + ray.z, py * ray.y + ray.w).
    // Perspective: direction (a, -1) from the origin. Orthographic: origin (a, 0), direction -Z.
    ray: vec4<f32>,
    // x: 1 if orthographic, y: near, z: far (orthographic only), w: unused.
    params: vec4<f32>,
}

// In view space.
struct Ray {
    origin: vec3<f32>,
    dir: vec3<f32>,
}
