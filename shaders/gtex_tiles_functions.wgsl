// The walk of one tile's list (tiles.rs), shared by the tiled primary pass (camera rays) and
// parallel ray queries (shadow rays toward a directional light). The list holds pieces of the
// patches (boxes.rs, tile_pieces: a pyramid node's column with a thin slab along the surface's
// slope, over the texels the patch owns), sorted by each piece's nearest depth along the tiles'
// view, not by where this ray enters it, so the next BATCH pieces the ray enters are sorted by
// entry (insertion) and taken in that order; the walk stops at the first piece that starts
// behind the nearest hit. Entering a piece is a cheap test, not a search: the first piece of a
// patch the ray enters before the nearest hit starts one search of that patch's whole box, from
// the piece's entry on (the height-field search of gtex_piece_functions.wgsl, counted in
// `searches`; an exact one descends from SEARCH_START_LEVEL), and the patch's later pieces start
// none. An any-hit walk (shadow rays) that crosses a piece whose surface spans its column from
// one face of its slab to the other has its hit there: only that stretch is searched, for where
// (and not even that when only whether the ray is blocked is read).
//
// Spaces: the ray and the pieces' records in one space (view space for frames, the query's frame
// for queries); depths along the tiles' view direction, where the ray's origin lies at
// `origin_depth` and a unit of t moves one unit of depth (the ray runs along the view direction;
// camera rays' directions have z = -1).

// The bit of an entry's piece index set where the piece's surface spans its whole column
// (tiles.rs, SPANS_COLUMN).
const SPANS_COLUMN: u32 = 0x80000000u;
const NO_PIECE: u32 = 0xffffffffu;

// What a walk asks (tile_walk's `ask`): the nearest hit, any hit, or only whether a ray is blocked.
const ASK_NEAREST: u32 = 0u;
const ASK_ANY: u32 = 1u;
const ASK_BLOCKED: u32 = 2u;

// Pieces a walk orders by where its ray enters them, at most this many at a time.
const BATCH: u32 = 8u;
// Patches a walk remembers having searched (and from where), the last this many.
const SEARCHED: u32 = 8u;
// The pyramid level an exact search of a patch starts its descent at (maxmip_hit_from): the ray
// enters a piece a step or two from the surface, so starting at the cells and climbing over what
// is skipped reads fewer nodes than coming down from the box's root. Bunny, 512², top, oblique
// and below views: 12.3-13.8 fetches per search against 20.1-21.6 from the root and 16.1-17.6
// from the pieces' own level (16 texels).
const SEARCH_START_LEVEL: i32 = 0;

// A normal f16 (the low 16 bits of `h`) as f32, 0 for zero and subnormals (the CPU writes no
// others): decoded by hand, since unpack2x16float needs a capability not every adapter has.
fn normal_f16(h: u32) -> f32 {
    let e = (h >> 10u) & 0x1fu;
    if (e == 0u) {
        return 0.0;
    }
    // Rebias the exponent from 15 to 127 and widen the 10-bit mantissa to 23 bits.
    return bitcast<f32>(((h & 0x8000u) << 16u) | ((e + 112u) << 23u) | ((h & 0x3ffu) << 13u));
}

// Where ray o + t d is inside tile piece `piece` (src/render/kinds/gtex/boxes.rs, tile_pieces):
// its column of patch-local u/v, lo.xy to hi.xy, and across it the slab
// lo.z <= z - a u - b v <= hi.z along the plane of slopes (a, b) (two f16 in `level`). In the
// sheared coordinates (u, v, z - a u - b v) that is a box. (enter, exit, through), enter > exit on
// a miss; through = 1 where the ray enters and leaves by the slab's faces, not the column's sides.
fn tile_piece_span(piece: PatchBox, o: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    let patch_from_view = patches[piece.patch_index].patch_from_view;
    let o_p = (patch_from_view * vec4<f32>(o, 1.0)).xyz;
    let d_p = (patch_from_view * vec4<f32>(d, 0.0)).xyz;
    let slope = vec2<f32>(normal_f16(piece.level & 0xffffu), normal_f16(piece.level >> 16u));
    let o_s = vec3<f32>(o_p.xy, o_p.z - dot(slope, o_p.xy));
    let d_s = vec3<f32>(d_p.xy, d_p.z - dot(slope, d_p.xy));
    let inv = safe_inverse(d_s);
    let s = axis_spans(piece.lo, piece.hi, o_s, inv);
    let through = s.enter.z >= max(s.enter.x, s.enter.y) && s.exit.z <= min(s.exit.x, s.exit.y);
    return vec3<f32>(box_span(s), select(0.0, 1.0, through));
}

struct TileHit {
    t: f32,
    // Index of the patch hit, in `patches`; meaningless when t >= t_hi.
    patch_index: u32,
}

// The nearest hit in [t_lo, t_hi) among the pieces of list `range` (first, count) whose pixel
// rectangles hold `pixel`, or with `ask` ASK_ANY the first hit found, with ASK_BLOCKED the first
// found where only whether there is one is read (its t may be a piece's entry); t = t_hi for none.
fn tile_walk(range: vec2<u32>, pixel: vec2<u32>, o: vec3<f32>, d: vec3<f32>, origin_depth: f32, t_lo: f32,
             t_hi: f32, ask: u32) -> TileHit {
    let any_hit = ask != ASK_NEAREST;
    var best = TileHit(t_hi, 0u);
    var searched_patch: array<u32, SEARCHED>;
    var searched_from: array<f32, SEARCHED>;
    var n_searched = 0u;
    var k = range.x;
    let end = range.x + range.y;
    // A piece the ray surely hits (any hit), once one is met, and its stretch (enter, exit).
    var sure_piece = NO_PIECE;
    var sure = vec2<f32>(0.0);
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
            // The piece's footprint misses this pixel.
            if (!entry_holds(entry, pixel)) {
                continue;
            }
            if (COUNT_FETCHES) {
                piece_tests += 1u;
            }
            let piece = entry.x & ~SPANS_COLUMN;
            let span = tile_piece_span(pieces[piece], o, d);
            let t0 = max(span.x, t_lo);
            // From one face of the slab to the other across a whole sheet of surface: a hit
            // inside that stretch, the only one an any-hit walk still searches (for where).
            if (any_hit && (entry.x & SPANS_COLUMN) != 0u && span.z > 0.5 && span.x >= t_lo && span.y < best.t) {
                if (ask == ASK_BLOCKED) {
                    return TileHit(span.x, pieces[piece].patch_index);
                }
                enter[0] = span.x;
                piece_at[0] = piece;
                n = 1u;
                k = end;
                sure_piece = piece;
                sure = span.xy;
                break;
            }
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
            piece_at[j] = piece;
            n += 1u;
        }
        for (var i = 0u; i < n && enter[i] < best.t; i += 1u) {
            let owner = pieces[piece_at[i]].patch_index;
            // A patch is searched once, from the first of its pieces the ray enters to its box's
            // exit (or the nearest hit): its other pieces lie on that stretch. Only a piece met
            // later in the list that the ray enters earlier opens the stretch before it.
            var t_end = select(best.t, sure.y, sure_piece != NO_PIECE);
            var slot = SEARCHED;
            for (var s = 0u; s < min(n_searched, SEARCHED); s += 1u) {
                if (searched_patch[s] == owner) {
                    slot = s;
                    break;
                }
            }
            if (slot < SEARCHED) {
                if (searched_from[slot] <= enter[i]) {
                    continue;
                }
                t_end = min(t_end, searched_from[slot]);
            } else {
                slot = n_searched % SEARCHED;
                searched_patch[slot] = owner;
                n_searched += 1u;
            }
            searched_from[slot] = enter[i];
            let t = piece_search_from(PatchBox(vec3<f32>(0.0), owner, vec3<f32>(1.0), 31u), o, d, enter[i], t_end,
                                      SEARCH_START_LEVEL);
            if (t >= 0.0) {
                best = TileHit(t, owner);
                if (any_hit) {
                    return best;
                }
            }
        }
        if (k >= end) {
            break;
        }
    }
    // The sure hit's search lost it to rounding: its entry stands in.
    if (sure_piece != NO_PIECE && best.t >= t_hi) {
        return TileHit(sure.x, pieces[sure_piece].patch_index);
    }
    return best;
}
