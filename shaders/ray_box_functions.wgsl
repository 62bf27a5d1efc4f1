// A ray against an axis-aligned box: shared by every search that enters boxes (geometry-texture
// pieces, the tracer's hierarchy).
//
// Space: whatever space the ray and the box are both given in.

// 1 / d with rays parallel to an axis sent to a huge finite slope instead of dividing by zero.
fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    let tiny = 1e-30;
    let s = select(vec3<f32>(-1.0), vec3<f32>(1.0), d >= vec3<f32>(0.0));
    return 1.0 / select(d, s * tiny, abs(d) < vec3<f32>(tiny));
}

// Where the ray o + t d is inside the box [lo, hi]: (enter, exit), enter > exit on a miss.
fn slab(lo: vec3<f32>, hi: vec3<f32>, o: vec3<f32>, inv: vec3<f32>) -> vec2<f32> {
    let ta = (lo - o) * inv;
    let tb = (hi - o) * inv;
    let t0 = min(ta, tb);
    let t1 = max(ta, tb);
    return vec2<f32>(max(max(t0.x, t0.y), t0.z), min(min(t1.x, t1.y), t1.z));
}
