// Group 1 of the passes that search pieces of the patches' boxes (the tracer and the tiled
// primary pass), beyond gtex_bindings.wgsl: the pieces (gtex_types.wgsl's PatchBox, made by
// src/render/kinds/gtex/boxes.rs).
//
// Space: patch-local (each piece's own patch).

@group(1) @binding(7) var<storage, read> pieces: array<PatchBox>;
