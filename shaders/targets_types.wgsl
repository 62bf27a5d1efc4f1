// What the scene pass's fragments write into the frame's targets (targets.rs): the shaded color,
// the world normal, the object's or patch's id and the unshaded base color. Kinds that find
// their surface by searching inside a proxy (geometry textures, shells, surfels' resolve) also
// write its depth (`FsOut`); rasterized surfaces keep the rasterizer's depth (`RasterFsOut`),
// since writing frag_depth switches early depth testing off.
//
// Spaces: world normals; colors in [0, 1].

struct FsOut {
    @location(0) color: vec4<f32>,
    @location(1) normal: vec4<f32>,
    @location(2) id: i32,
    // The unshaded base color.
    @location(3) albedo: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

struct RasterFsOut {
    @location(0) color: vec4<f32>,
    @location(1) normal: vec4<f32>,
    @location(2) id: i32,
    @location(3) albedo: vec4<f32>,
}
