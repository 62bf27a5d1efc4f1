// The walk of one tile's list (tiles.rs), shared by the tiled primary pass (camera rays) and
// parallel ray queries (shadow rays toward a directional light): the list is sorted by each
// piece's nearest depth along the tiles' view, not by where this ray enters it, so the next BATCH
// pieces the ray enters are sorted by entry (insertion) and searched in that order (the piece
// holding the nearest hit tends to come first, and the rest are skipped); the walk stops at the
// first piece that starts behind the nearest hit.
//
// Spaces: the ray and the pieces' records in one space (view space for frames, the query's frame
// for queries); depths along the tiles' view direction, where the ray's origin lies at
// `origin_depth` and a unit of t moves one unit of depth (the ray runs along the view direction;
// camera rays' directions have z = -1).

// Pieces a walk orders by where its ray enters them, at most this many at a time.
const BATCH: u32 = 8u;

struct TileHit {
    t: f32,
    // Index of the patch hit, in `patches`; meaningless when t >= t_hi.
    patch_index: u32,
}

// The nearest hit in [t_lo, t_hi) among the pieces of list `range` (first, count), or with
// `any_hit` the first hit found; t = t_hi for none.
fn tile_walk(range: vec2<u32>, o: vec3<f32>, d: vec3<f32>, origin_depth: f32, t_lo: f32, t_hi: f32,
             any_hit: bool) -> TileHit {
    var best = TileHit(t_hi, 0u);
    var k = range.x;
    let end = range.x + range.y;
    loop {
        var enter: array<f32, BATCH>;
        var piece_at: array<u32, BATCH>;
        var n = 0u;
        while (k < end && n < BATCH) {
            let entry = tile_entries[k];
            if (bitcast<f32>(entry.y) - origin_depth >= best.t) {
                k = end;
                break;
            }
            k += 1u;
            let span = piece_span(pieces[entry.x], o, d);
            let t0 = max(span.x, t_lo);
            if (!(min(span.y, best.t) > t0)) {
                continue;
            }
            var j = n;
            while (j > 0u && enter[j - 1u] > t0) {
                enter[j] = enter[j - 1u];
                piece_at[j] = piece_at[j - 1u];
                j -= 1u;
            }
            enter[j] = t0;
            piece_at[j] = entry.x;
            n += 1u;
        }
        for (var i = 0u; i < n && enter[i] < best.t; i += 1u) {
            let piece = pieces[piece_at[i]];
            let t = piece_search(piece, o, d, t_lo, best.t);
            if (t >= 0.0) {
                best = TileHit(t, piece.patch_index);
                if (any_hit) {
                    return best;
                }
            }
        }
        if (k >= end) {
            break;
        }
    }
    return best;
}
