// Copies the depth buffer into a storage buffer for readback. Depth textures cannot be copied to
// buffers on every backend (GL cannot), but every backend can load them in a compute shader
// when bound as an unfilterable float texture.
//
// Space: framebuffer pixels, row 0 at the top; values are reversed-Z depth (0 = nothing).

@compute @workgroup_size(8, 8)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if (id.x >= size.x || id.y >= size.y) {
        return;
    }
    out[id.y * size.x + id.x] = textureLoad(depth, vec2<i32>(id.xy), 0).x;
}
