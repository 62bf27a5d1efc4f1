// Entry points of the mesh pass: ordinary triangle meshes, rasterized into the same
// color/normal/id/albedo/depth targets as the geometry-texture patches so the nearer surface wins
// at every pixel. Vertices come three per face, each with its corner's normal (flat, smooth or
// crease-split, chosen on the CPU), base color and texture coordinates: the base color is the
// vertex color times the mesh's image there (white without one), so a texture is filtered per
// pixel by the sampler's mip chain, as a rasterizer's users expect.
//
// Spaces: object space (vertices relative to the mesh's own centre, f32), view space
// (camera-relative, see camera_types.wgsl), world for output normals.

struct VsIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
    @location(3) uv: vec2<f32>,
}

struct VsOut {
    @builtin(position) position: vec4<f32>,
    @location(0) view_pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
    @location(3) uv: vec2<f32>,
}

@vertex
fn vs_main(v: VsIn) -> VsOut {
    let view = object.view_from_object * vec4<f32>(v.position, 1.0);
    let n = (object.world_normal_from_object * vec4<f32>(v.normal, 0.0)).xyz;
    return VsOut(camera.clip_from_view * view, view.xyz, n, v.color, v.uv);
}

@fragment
fn fs_main(in: VsOut) -> RasterFsOut {
    let n = normalize(in.normal);
    // Texture coordinates have v up; the image's rows run down.
    let base = in.color * textureSample(image, image_sampler, vec2<f32>(in.uv.x, 1.0 - in.uv.y));
    var out: RasterFsOut;
    out.color = vec4<f32>(headlight(camera, base.rgb, n, in.view_pos), base.a);
    out.normal = vec4<f32>(n, 0.0);
    out.id = object.ids.x;
    out.albedo = base;
    return out;
}
