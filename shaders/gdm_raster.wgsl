// Entry points of the displacement-shell pass: each prism's back faces are drawn (so a camera
// inside a prism still gets fragments), and the fragment finds where the pixel's ray enters and
// leaves that prism, maps the segment into texture space piece by piece through the prism's
// exact inverse map, and marches the tile for its first surface (gdm_functions.wgsl). The hit's
// true depth is written, so prisms, meshes and patches composite in one depth buffer and the
// silhouette is the mesostructure's, not the prism's.
//
// Spaces: see gdm_types.wgsl.

struct VsIn {
    @location(0) position: vec3<f32>,
    @location(1) prism: u32,
}

struct VsOut {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) prism: u32,
}

@vertex
fn vs_main(v: VsIn) -> VsOut {
    let view = shell.view_from_object * vec4<f32>(v.position, 1.0);
    return VsOut(camera.clip_from_view * view, v.prism);
}

@fragment
fn fs_main(in: VsOut) -> FsOut {
    let ray = camera_ray(camera, in.position.xy);
    // The ray's parameter is its view distance along -Z (camera_ray's directions have z = -1),
    // in local space too (an affine map keeps it).
    let o = (shell.object_from_view * vec4<f32>(ray.origin, 1.0)).xyz;
    let d = (shell.object_from_view * vec4<f32>(ray.dir, 0.0)).xyz;
    let hit = gdm_trace_prism(prisms[in.prism], o, d, camera.params.y, 3.0e38);
    if (hit.t < 0.0) {
        discard;
    }
    var out: FsOut;
    out.color = vec4<f32>(headlight(camera, shell.color.rgb, hit.normal, ray.dir), shell.color.a);
    out.normal = vec4<f32>(hit.normal, 0.0);
    if (shell.params.w > 0.5) {
        out.normal = vec4<f32>(vec3<f32>(gdm_counts), 0.0);
    }
    out.id = shell.ids.x;
    out.albedo = shell.color;
    out.depth = depth_from_distance(camera, hit.t);
    return out;
}
