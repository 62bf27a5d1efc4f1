// Height-field search settings: the per-frame uniform and the pipeline constant that switches
// on the counting build.
//
// Space: none (counts and step numbers); steps are counted in texels of patch-local space.

struct Search {
    // x: linear steps per texel crossed, y: least linear steps, z: most linear steps,
    // w: binary steps.
    steps: vec4<f32>,
    // x: 0 = linear + binary, 1 = max pyramid; y: most traversal steps (max pyramid).
    method: vec4<u32>,
}

// Counting build (COUNT_FETCHES = true): the shader counts its height and pyramid reads.
override COUNT_FETCHES: bool = false;
