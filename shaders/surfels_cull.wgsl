// Entry point of the surfel cull pass: one thread per tile, then one per node above the tiles.
// It draws a cut of each patch's quadtree: a node when it is in view, within the error budget
// and its parent is not; a tile when its parent node is not within the budget, at its coarsest
// level within it. Errors never fall going up and spheres nest, so a node within the budget
// has every descendant within it and each thread decides alone, without traversal.
// The budget: max_pixel_error pixels at the sphere's nearest view distance, a share of that
// where the sphere may show a silhouette (object.params.w, larger for a model larger on screen). Tiles in view and their finest
// surfels are tallied whether or not a node above stands for them.
//
// Spaces: object (tiles, nodes) → view (camera-relative); pixels at a sphere's nearest view
// distance.

// A sphere (object space) in view space, its radius in view units.
fn view_sphere(sphere: vec4<f32>) -> vec4<f32> {
    let c = (object.view_from_object * vec4<f32>(sphere.xyz, 1.0)).xyz;
    return vec4<f32>(c, sphere.w * object.params.z);
}

fn in_view(s: vec4<f32>) -> bool {
    for (var k = 0u; k < 4u; k++) {
        if (dot(object.planes[k].xyz, s.xyz) + object.planes[k].w < -s.w) {
            return false;
        }
    }
    return -s.z + s.w >= camera.params.y;
}

// The smallest |cos| of the angle between a view ray through the sphere and a normal of the
// cone (object space): 0 where some ray may graze the surface. The axis makes angle a with the
// ray to the centre; rays through the sphere and normals in the cone stray from those by the
// sphere's angular radius and the cone's half angle.
fn facing(s: vec4<f32>, cone: vec4<f32>) -> f32 {
    var ray = vec3<f32>(0.0, 0.0, -1.0);
    var spread = cone.w;
    if (camera.params.x < 0.5) {
        let d = length(s.xyz);
        if (d <= s.w) {
            return 0.0;
        }
        ray = s.xyz / d;
        spread += asin(s.w / d);
    }
    let world = object.world_normal_from_object * vec4<f32>(cone.xyz, 0.0);
    let axis = normalize((camera.view_from_world * world).xyz);
    let a = acos(clamp(abs(dot(axis, ray)), 0.0, 1.0));
    return cos(min(a + spread, 1.5707963));
}

// Whether an error (object units), perpendicular to the surfels of a sphere, is within the
// budget. Seen at angle θ to its normal, a perpendicular error e moves depth by e / cos θ, so
// the budget shrinks with the cone's most oblique cos θ; near grazing, where the error moves
// the outline sideways instead, to the object's outline share of it (object.params.w: coverage
// lost to a moved outline falls with the model's size on screen, so a near model's rim may
// move further than a far one's). The cone is that of the discs
// drawn (a tile level's own normals; for a node, its tiles' top-level normals): a scan's noisy
// finest normals, averaged away at the level drawn, widened cones until most of a far scan
// counted as grazing and stayed fine.
fn within(s: vec4<f32>, cone: vec4<f32>, error: f32) -> bool {
    let budget = object.params.x * pixel_size(max(-s.z - s.w, camera.params.y));
    return error * object.params.z <= budget * max(facing(s, cone), object.params.w);
}

fn node_within(n: u32) -> bool {
    return within(view_sphere(nodes[n].sphere), nodes[n].cone, nodes[n].error);
}

// Appends surfels first..end to the chosen list, tallied in `slot`.
fn append(first: u32, end: u32, slot: u32) {
    let base = atomicAdd(&tally[TALLY_DRAWN], end - first);
    atomicAdd(&tally[slot], end - first);
    for (var i = 0u; i < end - first; i++) {
        chosen[base + i] = first + i;
    }
}

fn cull_tile(t: u32) {
    let s = view_sphere(tiles[t].sphere);
    if (!in_view(s)) {
        return;
    }
    let info = tiles[t].info;
    atomicAdd(&tally[TALLY_TILES], 1u);
    atomicAdd(&tally[TALLY_FINEST], tiles[t].start[0].y - tiles[t].start[0].x);
    if (info.z != NO_NODE && node_within(info.z)) {
        return;
    }
    var level = 0u;
    for (var l = info.x - 1u; l > 0u; l--) {
        let cone = vec4<f32>(tiles[t].cone_axis.xyz, tiles[t].cone_angle[l / 4u][l % 4u]);
        if (within(s, cone, tiles[t].error[l / 4u][l % 4u])) {
            level = l;
            break;
        }
    }
    let first = tiles[t].start[level / 4u][level % 4u];
    let end = tiles[t].start[(level + 1u) / 4u][(level + 1u) % 4u];
    append(first, end, TALLY_LEVEL0 + level);
}

fn cull_node(n: u32) {
    let node = nodes[n];
    let s = view_sphere(node.sphere);
    if (!in_view(s) || !within(s, node.cone, node.error)) {
        return;
    }
    if (node.parent != NO_NODE && node_within(node.parent)) {
        return;
    }
    append(node.surfel, node.surfel + 1u, TALLY_NODES);
}

@compute @workgroup_size(64)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let t = id.x;
    let tile_count = object.sizes.w;
    if (t < tile_count) {
        cull_tile(t);
    } else if (t < tile_count + object.counts.x) {
        cull_node(t - tile_count);
    }
}
