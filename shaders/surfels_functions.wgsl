// Surfels as discs seen from the camera: placing one in view space, its pixel box, and the
// reversed-Z depth where a pixel's ray meets it.
//
// Spaces: object → view (camera-relative) by object.view_from_object; framebuffer pixels
// (centres at +0.5, row 0 at the top).

struct ViewDisc {
    centre: vec3<f32>,
    normal: vec3<f32>,
    radius: f32,
}

fn view_disc(s: Surfel) -> ViewDisc {
    let c = (object.view_from_object * vec4<f32>(s.position, 1.0)).xyz;
    let world_normal = object.world_normal_from_object * vec4<f32>(s.normal, 0.0);
    let n = normalize((camera.view_from_world * world_normal).xyz);
    return ViewDisc(c, n, s.radius * object.params.z);
}

// World size of a pixel at view distance z.
fn pixel_size(z: f32) -> f32 {
    if (camera.params.x > 0.5) {
        return object.params.y;
    }
    return z * object.params.y;
}

// The pixel (fractional, centres at +0.5) a view-space point projects to.
fn pixel_of(p: vec3<f32>) -> vec2<f32> {
    var a = p.xy;
    if (camera.params.x < 0.5) {
        a = p.xy / max(-p.z, 1e-30);
    }
    return (a - camera.ray.zw) / camera.ray.xy;
}

// The pixels (x0, y0, x1, y1 inclusive) a disc may cover; empty (x1 < x0) when behind the near
// plane or off the image.
fn splat_box(d: ViewDisc) -> vec4<i32> {
    let near = camera.params.y;
    if (-d.centre.z + d.radius < near) {
        return vec4<i32>(0, 0, -1, -1);
    }
    let nearest = max(-d.centre.z - d.radius, near);
    let reach = min(d.radius / pixel_size(nearest), MAX_SPLAT_RADIUS) + 0.5;
    let c = pixel_of(d.centre);
    let size = vec2<f32>(object.sizes.xy) - 1.0;
    let lo = clamp(floor(c - reach), vec2<f32>(0.0), size);
    let hi = clamp(floor(c + reach), vec2<f32>(-1.0), size);
    if (any(c + reach < vec2<f32>(0.0)) || any(c - reach > size + 1.0)) {
        return vec4<i32>(0, 0, -1, -1);
    }
    return vec4<i32>(vec2<i32>(lo), vec2<i32>(hi));
}

// The view distance along -Z where pixel `px`'s ray meets the disc's plane, within `reach`
// radii of its centre; negative on a miss.
fn disc_distance(d: ViewDisc, px: vec2<f32>, reach: f32) -> f32 {
    let ray = camera_ray(camera, px);
    let facing = dot(d.normal, ray.dir);
    if (abs(facing) < 1e-7) {
        return -1.0;
    }
    // camera_ray's directions have z = -1, so t is the view distance along -Z.
    let t = dot(d.normal, d.centre - ray.origin) / facing;
    let q = ray.origin + t * ray.dir;
    let r = d.radius * reach;
    if (t < camera.params.y || dot(q - d.centre, q - d.centre) > r * r) {
        return -1.0;
    }
    return t;
}

// The index of the chosen-list entry this splat thread draws (dispatches are rows of
// DISPATCH_ROW workgroups), or a value >= the drawn count past the end.
fn splat_thread(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.x + id.y * groups.x * SPLAT_GROUP;
}
