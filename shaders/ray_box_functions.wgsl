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

// Per axis, where the ray o + t d is between the box [lo, hi]'s two faces across that axis.
struct AxisSpans {
    enter: vec3<f32>,
    exit: vec3<f32>,
}

fn axis_spans(lo: vec3<f32>, hi: vec3<f32>, o: vec3<f32>, inv: vec3<f32>) -> AxisSpans {
    let ta = (lo - o) * inv;
    let tb = (hi - o) * inv;
    return AxisSpans(min(ta, tb), max(ta, tb));
}

// Where the ray is inside the box whose axis spans are `s`: (enter, exit), enter > exit on a miss.
fn box_span(s: AxisSpans) -> vec2<f32> {
    return vec2<f32>(max(max(s.enter.x, s.enter.y), s.enter.z), min(min(s.exit.x, s.exit.y), s.exit.z));
}

// Where the ray o + t d is inside the box [lo, hi]: (enter, exit), enter > exit on a miss.
fn slab(lo: vec3<f32>, hi: vec3<f32>, o: vec3<f32>, inv: vec3<f32>) -> vec2<f32> {
    return box_span(axis_spans(lo, hi, o, inv));
}
