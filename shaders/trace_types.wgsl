// The tracer's bounding-volume hierarchy (src/bvh.rs): nodes depth first, a node's left
// child is the next node.
//
// Space: node bounds are in the space rays are traced in (view space for camera rays).

struct BvhNode {
    lo: vec3<f32>,
    // Interior: the right child's index. Leaf: the index of the box it holds.
    index: u32,
    hi: vec3<f32>,
    // 1 for a leaf.
    leaf: u32,
}
