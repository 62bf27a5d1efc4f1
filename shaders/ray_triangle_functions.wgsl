// The watertight ray/triangle test of Woop, Benthin and Wald (JCGT 2013), shared by the mesh
// tracer's leaves (mesh_trace_functions.wgsl) and the inverse-geometric-texture ray lookup
// (igt_functions.wgsl): the triangle is sheared into a frame where the ray runs along +z from
// the origin, and the signs of three edge functions decide, so a ray through a shared edge or
// vertex hits one of the triangles that meet there, never neither.
//
// Space: the caller's (ray and triangle in one frame).

// `v`'s components reordered so that the axis `kz` comes last, and the other two swapped when
// `swap` (constant swizzles: Mesa's lavapipe crashed on a runtime vector index here).
fn ray_axes(v: vec3<f32>, kz: u32, swap: bool) -> vec3<f32> {
    var p = v.xyz;
    if (kz == 0u) {
        p = v.yzx;
    } else if (kz == 1u) {
        p = v.zxy;
    }
    return select(p, p.yxz, swap);
}

// The hit of o + t d with triangle (a, b, c) for t in [t_lo, t_best): x is t, yzw the hit's
// barycentric coordinates (a, b, c); all four -1 for none (a caller with t_lo < 0 tests y).
fn ray_triangle(a_in: vec3<f32>, b_in: vec3<f32>, c_in: vec3<f32>, o: vec3<f32>, d: vec3<f32>, t_lo: f32, t_best: f32) -> vec4<f32> {
    let none = vec4<f32>(-1.0);
    // The axis the ray runs most along becomes z; swapping x and y when the ray runs down it
    // keeps the winding.
    let ad = abs(d);
    var kz = 2u;
    if (ad.x >= ad.y && ad.x >= ad.z) {
        kz = 0u;
    } else if (ad.y >= ad.z) {
        kz = 1u;
    }
    let swap = select(d.z, select(d.y, d.x, kz == 0u), kz < 2u) < 0.0;
    let dir = ray_axes(d, kz, swap);
    let shear = vec3<f32>(dir.x / dir.z, dir.y / dir.z, 1.0 / dir.z);
    let a = ray_axes(a_in - o, kz, swap);
    let b = ray_axes(b_in - o, kz, swap);
    let c = ray_axes(c_in - o, kz, swap);
    let ax = a.x - shear.x * a.z;
    let ay = a.y - shear.y * a.z;
    let bx = b.x - shear.x * b.z;
    let by = b.y - shear.y * b.z;
    let cx = c.x - shear.x * c.z;
    let cy = c.y - shear.y * c.z;
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    // Both faces count (a mesh is two-sided to a ray, as to the raster pass).
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return none;
    }
    let det = u + v + w;
    if (det == 0.0) {
        return none;
    }
    let t = (u * a.z + v * b.z + w * c.z) * shear.z / det;
    if (!(t >= t_lo && t < t_best)) {
        return none;
    }
    return vec4<f32>(t, vec3<f32>(u, v, w) / det);
}
