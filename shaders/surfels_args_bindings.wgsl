// Group 2 of the surfel dispatch-arguments pass: the splat passes' indirect workgroup counts
// (x, y, z). Its own buffer: a pass cannot read arguments from a buffer it binds for writing.

@group(2) @binding(0) var<storage, read_write> dispatch: array<u32, 3>;
