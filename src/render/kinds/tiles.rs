//! Tile lists: a grid of tiles over an image, each listing the boxes (or triangles) that may
//! cover it, nearest first, so that a ray through one tile enters them front to back and stops
//! once the next starts behind its nearest hit.
//!
//! Primary frames of texture sets (kinds/gtex): the image's tiles list the pieces of the
//! patches' boxes (boxes.rs, tile_pieces); a pixel searches each patch once from the first of its
//! pieces it enters (gtex_tiles_functions.wgsl). Drawing every box and searching each fragment
//! started 4.8–6.1 searches per covered pixel on the bunny, since writing frag_depth switches
//! early depth testing off; listing whole boxes here started 2.4–2.7 (a ray entered about one
//! more thick box of a neighbouring chart, or an overlap ring's copy of the surface, before the
//! box it hit); the pieces start 1.15–1.18. Camera rays through the tracer's hierarchy cost more
//! per ray on lavapipe (bench/README.md). A camera's rays share one origin and sweep the image in
//! order, so sorting pieces once per tile replaces the per-ray walk.
//!
//! Parallel rays (`parallel`: shadow rays toward a directional light) through a set's pieces or
//! a mesh's triangles (kinds/mesh.rs): an orthographic grid seen along their direction, where
//! each ray stays in one tile (gtex_tiles_rays.wgsl, mesh_tiles_rays.wgsl, tiles_functions.wgsl).
//!
//! Spaces: view (camera-relative, OpenGL-style: depth along the view is -z, which is also the ray
//! parameter t of camera_ray's rays) and framebuffer pixels (row 0 at the top, centres at +0.5);
//! for parallel rays, the grid's frame (its -Z along the rays) and its pixels.

use glam::{DMat3, DMat4, DVec3};
use rayon::prelude::*;

use crate::render::camera::Lens;
use crate::render::gpu_types::gpu_matrix;

/// Pixels on a side of a tile. 8 keeps lists short at silhouettes and the lists' bytes small
/// (4,096 tiles at 512²).
pub(crate) const TILE: u32 = 8;

/// One entry of a tile's list: the index of a piece (boxes.rs; with `SPANS_COLUMN` set where
/// its surface spans its column), its nearest view depth (f32 bits; no hit in it can be nearer), and its pixel rectangle [x0, y0, x1, y1) as x0 | y0 << 16,
/// x1 | y1 << 16. A pixel outside the rectangle passes beside the piece: that test needs no
/// record of the piece, where the slab test reads its patch's matrix (on the bunny's headline
/// views a pixel slab-tested 56-78 pieces before this test, for 1.15-1.18 searches).
pub(crate) type Entry = [u32; 4];

/// The bit of an entry's piece index that says the piece's surface spans its whole column
/// (boxes.rs, `spans_column`): an any-hit walk that crosses its slab from face to face has a
/// hit without a search (gtex_tiles_functions.wgsl).
pub(crate) const SPANS_COLUMN: u32 = 1 << 31;

/// tiles_bindings.wgsl's `Tiles`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct TilesHeader {
    /// Tiles across and down, TILE, unused.
    pub size: [u32; 4],
    /// Frames: the draw's rectangle in normalized device coordinates: x0, y0, x1, y1.
    pub rect_ndc: [f32; 4],
    /// Parallel rays: the grid's frame from the query's, and pixel = (grid xy - zw) / xy.
    pub grid_from_view: [[f32; 4]; 4],
    pub grid: [f32; 4],
    /// Parallel rays: x = the largest depth extent of a box (gtex_tiles_rays.wgsl skips the
    /// entries wholly behind a ray's origin by it); 0 for frames.
    pub thickness: [f32; 4],
}

/// Pixels on a side of the grid parallel rays are tiled on (64 x 64 tiles).
const GRID_PIXELS: u32 = 512;

/// The tiles of one set in one frame, or of a set's pieces or a mesh's triangles along one
/// direction, as tiles_bindings.wgsl reads them.
pub(crate) struct TileLists {
    pub header: TilesHeader,
    /// Per tile (row-major): first entry, entry count.
    pub ranges: Vec<[u32; 2]>,
    pub entries: Vec<Entry>,
    /// Parallel rays: the grid's frame from the frame the boxes were given in (a rotation, kept
    /// in f64 so that the lists can serve a query frame translated from it: `moved`).
    pub grid_from_view: DMat4,
}

/// Where a box lies on screen: its pixel rectangle [x0, y0, x1, y1) and nearest view depth.
#[derive(Clone, Copy, Debug)]
struct Footprint {
    rect: [u32; 4],
    near: f64,
}

/// The footprint of the box with view-space `corners`, or `None` when it covers no pixel.
/// Conservative: a box reaching behind the near plane covers the whole image.
fn footprint(corners: &[DVec3], lens: &Lens, size: [u32; 2]) -> Option<Footprint> {
    let near = corners.iter().map(|c| -c.z).fold(f64::INFINITY, f64::min);
    let whole = [0, 0, size[0], size[1]];
    if !lens.orthographic && near <= lens.near * 0.5 {
        return Some(Footprint {
            rect: whole,
            near: near.max(0.0),
        });
    }
    // View point → pixel: invert camera_ray's a = pixel * ray.xy + ray.zw.
    let [sx, sy, ox, oy] = lens.ray;
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for c in corners {
        let a = if lens.orthographic {
            [c.x, c.y]
        } else {
            [c.x / -c.z, c.y / -c.z]
        };
        let p = [(a[0] - ox) / sx, (a[1] - oy) / sy];
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    // One pixel of slack each way: a pixel whose centre is inside the box's outline is covered,
    // and rounding must never drop one.
    let clamp = |v: f64, k: usize| v.clamp(0.0, size[k] as f64) as u32;
    let rect = [
        clamp(lo[0].floor() - 1.0, 0),
        clamp(lo[1].floor() - 1.0, 1),
        clamp(hi[0].ceil() + 1.0, 0),
        clamp(hi[1].ceil() + 1.0, 1),
    ];
    (rect[2] > rect[0] && rect[3] > rect[1]).then_some(Footprint { rect, near })
}

impl TileLists {
    /// The lists for `boxes` (each an index and its corners in view space: a box's eight, a
    /// triangle's three) seen through `lens` on an image of `size` pixels; `None` when no box
    /// covers a pixel. Footprints and the sort run in parallel, and each tile's list is counted
    /// before it is filled (with these and three corners a triangle, a 1000-ray query that built
    /// a 1.1M-triangle mesh's footprint and lists took 0.38 s on 2 cores, not 0.56 s).
    pub fn build<const N: usize>(
        boxes: impl Iterator<Item = (u32, [DVec3; N])>,
        lens: &Lens,
        size: [u32; 2],
    ) -> Option<TileLists> {
        // Rectangles pack into u16 (images are at most the adapter's texture size, 16,384 or
        // less; the parallel grid is GRID_PIXELS).
        assert!(size[0] < 1 << 16 && size[1] < 1 << 16, "{size:?} pixels");
        let boxes: Vec<(u32, [DVec3; N])> = boxes.collect();
        let mut boxes: Vec<(u32, Footprint)> = (boxes.par_iter())
            .filter_map(|(i, corners)| Some((*i, footprint(corners, lens, size)?)))
            .collect();
        if boxes.is_empty() {
            return None;
        }
        // Nearest first, so each tile's list comes out sorted.
        boxes.par_sort_by(|a, b| a.1.near.total_cmp(&b.1.near));
        let across = size[0].div_ceil(TILE);
        let down = size[1].div_ceil(TILE);
        let tiles_under = |r: [u32; 4]| {
            (r[1] / TILE..r[3].div_ceil(TILE)).flat_map(move |ty| {
                (r[0] / TILE..r[2].div_ceil(TILE)).map(move |tx| ty * across + tx)
            })
        };
        let mut ranges = vec![[0u32; 2]; (across * down) as usize];
        let mut rect = [u32::MAX, u32::MAX, 0, 0];
        for (_, f) in &boxes {
            for t in tiles_under(f.rect) {
                ranges[t as usize][1] += 1;
            }
            for k in 0..2 {
                rect[k] = rect[k].min(f.rect[k]);
                rect[k + 2] = rect[k + 2].max(f.rect[k + 2]);
            }
        }
        let mut first = 0;
        for range in &mut ranges {
            range[0] = first;
            first += range[1];
        }
        let mut entries = vec![[0u32; 4]; first as usize];
        let mut filled: Vec<u32> = ranges.iter().map(|r| r[0]).collect();
        for (index, f) in &boxes {
            let r = f.rect;
            let entry = [
                *index,
                (f.near as f32).to_bits(),
                r[0] | (r[1] << 16),
                r[2] | (r[3] << 16),
            ];
            for t in tiles_under(r) {
                entries[filled[t as usize] as usize] = entry;
                filled[t as usize] += 1;
            }
        }
        let ndc = |v: u32, k: usize| 2.0 * v as f32 / size[k] as f32 - 1.0;
        let header = TilesHeader {
            size: [across, down, TILE, 0],
            // Pixel rows run down, NDC y up.
            rect_ndc: [
                ndc(rect[0], 0),
                -ndc(rect[1], 1),
                ndc(rect[2], 0),
                -ndc(rect[3], 1),
            ],
            grid_from_view: [[0.0; 4]; 4],
            grid: [0.0; 4],
            thickness: [0.0; 4],
        };
        Some(TileLists {
            header,
            ranges,
            entries,
            grid_from_view: DMat4::IDENTITY,
        })
    }
}

impl TileLists {
    /// The header of parallel rays' lists for a query frame that is `view_from_query` of the
    /// frame they were built in (lists built for one frame's rays serve the next frame's).
    pub fn header_for(&self, view_from_query: DMat4) -> TilesHeader {
        TilesHeader {
            grid_from_view: gpu_matrix(self.grid_from_view * view_from_query),
            ..self.header
        }
    }

    /// Parallel rays' test (kinds::RayTest) under `header` (this one's, or `header_for`'s):
    /// whether a ray starts in a tile whose list is not empty, found as gtex_tiles_rays.wgsl
    /// finds it (from the header's f32 values; a box's footprint has a pixel of slack, so
    /// rounding cannot drop a ray that enters it).
    pub fn reaches(&self, header: &TilesHeader) -> crate::render::kinds::RayTest {
        let m = header.grid_from_view;
        let grid_from_view = DMat4::from_cols_array_2d(&m.map(|c| c.map(f64::from)));
        let [sx, sy, ox, oy] = header.grid.map(f64::from);
        let [across, down, tile, _] = header.size;
        let listed: Vec<bool> = self.ranges.iter().map(|r| r[1] > 0).collect();
        let (w, h) = (f64::from(across * tile), f64::from(down * tile));
        Box::new(move |ray| {
            let p = grid_from_view.transform_point3(ray.origin);
            let (x, y) = ((p.x - ox) / sx, (p.y - oy) / sy);
            if !(x >= 0.0 && y >= 0.0 && x < w && y < h) {
                return false;
            }
            let (tx, ty) = (x as u32 / tile, y as u32 / tile);
            listed[(ty * across + tx) as usize]
        })
    }
}

/// The lists for `boxes` (index and corners in the query's frame) tiled as seen along
/// `direction` (unit): an orthographic grid whose -Z is the direction, over the boxes' extent,
/// so that each ray along `direction` stays in one tile (gtex_tiles_rays.wgsl,
/// mesh_tiles_rays.wgsl).
pub(crate) fn parallel<const N: usize>(
    boxes: impl Iterator<Item = (u32, [DVec3; N])>,
    direction: DVec3,
) -> Option<TileLists> {
    let up = if direction.y.abs() < 0.9 {
        DVec3::Y
    } else {
        DVec3::X
    };
    // A rotation whose rows are the grid's axes: -Z along the rays.
    let z = -direction;
    let x = up.cross(z).normalize();
    let grid_from_view = DMat4::from_mat3(DMat3::from_cols(x, z.cross(x), z).transpose());
    let mut boxes: Vec<(u32, [DVec3; N])> = boxes.collect();
    boxes.par_iter_mut().for_each(|(_, corners)| {
        *corners = corners.map(|c| grid_from_view.transform_point3(c));
    });
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let mut thickness = 0.0f64;
    for (_, corners) in &boxes {
        let (near, far) = (corners.iter()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), c| {
            (a.min(c.z), b.max(c.z))
        });
        thickness = thickness.max(far - near);
        for c in corners {
            lo = lo.min(*c);
            hi = hi.max(*c);
        }
    }
    let side = f64::from(GRID_PIXELS);
    // A pixel never narrower than f32 can tell apart at the boxes' extent, and a margin so that
    // no box touches the grid's edge.
    let extent = (hi - lo).max(DVec3::splat(
        1e-6 * (hi - lo).abs().max_element().max(1e-30),
    ));
    let lo = lo - 0.01 * extent;
    let extent = 1.02 * extent;
    let (sx, sy) = (extent.x / side, extent.y / side);
    let lens = Lens {
        orthographic: true,
        ray: [sx, sy, lo.x, lo.y],
        clip_from_view: DMat4::IDENTITY,
        near: 0.0,
        far: 0.0,
    };
    let mut lists = TileLists::build(boxes.into_iter(), &lens, [GRID_PIXELS; 2])?;
    lists.header.grid_from_view = gpu_matrix(grid_from_view);
    lists.header.grid = [sx, sy, lo.x, lo.y].map(|v| v as f32);
    // Depths reach the shader as f32 (entries, and the ray's origin moved into the grid): a
    // margin far above their rounding at the boxes' extent, far below a box's thickness.
    let margin = 1e-5 * extent.max_element();
    lists.header.thickness = [(1.01 * thickness + margin) as f32, 0.0, 0.0, 0.0];
    lists.grid_from_view = grid_from_view;
    Some(lists)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::camera::Camera;
    use crate::render::cull::placed_unit_cube;
    use crate::render::kinds::TestRay;
    use glam::DMat4;

    /// The view-space corners of the unit cube under each of `view_from_box`, numbered in order.
    fn corners(view_from_box: &[DMat4]) -> impl Iterator<Item = (u32, [DVec3; 8])> + '_ {
        (0..).zip(view_from_box.iter().map(placed_unit_cube))
    }

    fn lens_and_view(size: [u32; 2]) -> (Lens, DMat4) {
        let camera =
            Camera::look_at(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, DVec3::Y, 40.0).unwrap();
        let lens = camera.lens(size[0], size[1], 3.0, 7.0).unwrap();
        (lens, camera.view_from_world())
    }

    #[test]
    fn every_covered_pixel_lists_its_boxes_nearest_first() {
        let size = [64, 48];
        let (lens, view_from_world) = lens_and_view(size);
        // Three boxes one behind another, and one off to the side.
        let boxes: Vec<DMat4> = [(0.0, 1.0), (0.0, -1.0), (0.0, 0.0), (1.5, 0.0)]
            .iter()
            .map(|&(x, z)| {
                view_from_world
                    * DMat4::from_translation(DVec3::new(x - 0.25, -0.25, z))
                    * DMat4::from_scale(DVec3::splat(0.5))
            })
            .collect();
        let tiles = TileLists::build(corners(&boxes), &lens, size).unwrap();
        let centre = ((size[1] / 2 / TILE) * tiles.header.size[0] + size[0] / 2 / TILE) as usize;
        let [first, count] = tiles.ranges[centre];
        let listed: Vec<u32> = (first..first + count)
            .map(|k| tiles.entries[k as usize][0])
            .collect();
        assert_eq!(
            listed,
            vec![0, 2, 1],
            "the centre tile lists the row, nearest first"
        );
        let corner = tiles.ranges[0];
        assert_eq!(corner[1], 0, "the top-left tile lists nothing");
        let [x0, y0, x1, y1] = tiles.header.rect_ndc;
        assert!(x0 > -1.0 && x1 < 1.0 && y0 < 1.0 && y1 > -1.0 && x0 < x1 && y1 < y0);
    }

    #[test]
    fn entry_rectangles_hold_every_pixel_whose_ray_meets_the_box() {
        let size = [64, 48];
        let (lens, view_from_world) = lens_and_view(size);
        // The camera looks down -Z from (0, 0, 5) with +Y up: view space is world moved by -5 z,
        // so the boxes stay axis-aligned there.
        let boxes: Vec<DMat4> = [(-0.9, 0.3, 0.2), (0.55, -0.45, -0.7)]
            .iter()
            .map(|&(x, y, z)| {
                view_from_world
                    * DMat4::from_translation(DVec3::new(x, y, z))
                    * DMat4::from_scale(DVec3::new(0.4, 0.3, 0.5))
            })
            .collect();
        let tiles = TileLists::build(corners(&boxes), &lens, size).unwrap();
        let [sx, sy, ox, oy] = lens.ray;
        for (index, m) in (0..).zip(&boxes) {
            let (a, b) = (
                m.transform_point3(DVec3::ZERO),
                m.transform_point3(DVec3::ONE),
            );
            let (lo, hi) = (a.min(b), a.max(b));
            let mut met = 0;
            for (x, y) in (0..size[1]).flat_map(|y| (0..size[0]).map(move |x| (x, y))) {
                // The pixel centre's camera ray (camera_ray: a = pixel * ray.xy + ray.zw).
                let d = DVec3::new(
                    (f64::from(x) + 0.5) * sx + ox,
                    (f64::from(y) + 0.5) * sy + oy,
                    -1.0,
                );
                let (t0, t1) = (lo / d, hi / d);
                if t0.min(t1).max_element() > t0.max(t1).min_element() {
                    continue;
                }
                met += 1;
                let tile = (y / TILE * tiles.header.size[0] + x / TILE) as usize;
                let [first, count] = tiles.ranges[tile];
                let entry = tiles.entries[first as usize..(first + count) as usize]
                    .iter()
                    .find(|e| e[0] == index)
                    .expect("the pixel's tile lists the box");
                let (x0, y0) = (entry[2] & 0xffff, entry[2] >> 16);
                let (x1, y1) = (entry[3] & 0xffff, entry[3] >> 16);
                assert!(
                    (x0..x1).contains(&x) && (y0..y1).contains(&y),
                    "box {index}: pixel ({x}, {y}) outside [{x0}, {y0}, {x1}, {y1})"
                );
            }
            // Measured: the boxes meet 23 and more pixel rays.
            assert!(met > 15, "box {index} meets {met} pixel rays");
        }
    }

    #[test]
    fn a_box_around_the_camera_covers_the_whole_image_from_depth_zero() {
        let size = [32, 32];
        let (lens, view_from_world) = lens_and_view(size);
        let around = view_from_world
            * DMat4::from_translation(DVec3::new(-1.0, -1.0, 4.0))
            * DMat4::from_scale(DVec3::splat(2.0));
        let tiles = TileLists::build(corners(&[around]), &lens, size).unwrap();
        assert_eq!(tiles.header.rect_ndc, [-1.0, 1.0, 1.0, -1.0]);
        assert!(tiles.ranges.iter().all(|r| r[1] == 1));
        assert_eq!(f32::from_bits(tiles.entries[0][1]), 0.0);
    }

    /// The tile a ray along the grid's direction from `origin` falls in (as gtex_tiles_rays.wgsl
    /// finds it), or `None` outside the grid.
    fn tile_of(tiles: &TileLists, origin: DVec3) -> Option<usize> {
        let m = glam::Mat4::from_cols_array_2d(&tiles.header.grid_from_view).as_dmat4();
        let p = m.transform_point3(origin);
        let [sx, sy, ox, oy] = tiles.header.grid.map(f64::from);
        let pixel = [(p.x - ox) / sx, (p.y - oy) / sy];
        let extent = f64::from(tiles.header.size[0] * TILE);
        if pixel.iter().any(|&v| !(0.0..extent).contains(&v)) {
            return None;
        }
        let [tx, ty] = pixel.map(|v| (v as u32 / TILE) as usize);
        Some(ty * tiles.header.size[0] as usize + tx)
    }

    #[test]
    fn parallel_lists_serve_a_translated_frame_and_bound_every_box() {
        let direction = DVec3::new(0.3, -1.0, 0.2).normalize();
        // A tilted, stretched box, so that its depth extent along the rays is not its side.
        let tilted = DMat4::from_rotation_z(0.7) * DMat4::from_scale(DVec3::new(2.0, 0.2, 0.5));
        let boxes = [tilted, DMat4::from_translation(DVec3::new(3.0, 0.0, 0.0))];
        let tiles = parallel(corners(&boxes), direction).unwrap();
        // Every box's depth extent along the rays lies within the bound the shader skips by.
        let m = tiles.grid_from_view;
        for (_, c) in corners(&boxes) {
            let z = c.map(|p| m.transform_point3(p).z);
            let extent = z.iter().copied().fold(f64::NEG_INFINITY, f64::max)
                - z.iter().copied().fold(f64::INFINITY, f64::min);
            assert!(extent <= f64::from(tiles.header.thickness[0]), "{extent}");
        }
        // The same lists for a query frame translated by `shift`: a point there falls in the
        // tile its world position fell in before, through header_for's matrix.
        let shift = DVec3::new(10.0, -4.0, 2.5);
        let moved = TileLists {
            header: tiles.header_for(DMat4::from_translation(shift)),
            ranges: tiles.ranges.clone(),
            entries: tiles.entries.clone(),
            grid_from_view: tiles.grid_from_view,
        };
        for p in [
            DVec3::splat(0.5) - 4.0 * direction,
            DVec3::new(3.5, 0.5, 0.5),
        ] {
            assert_eq!(tile_of(&moved, p - shift), tile_of(&tiles, p));
            assert!(tile_of(&tiles, p).is_some());
        }
        let test = tiles.reaches(&moved.header);
        let from = |o| TestRay::new(o, direction, (0.0, 1.0));
        assert!(test(&from(DVec3::splat(0.5) - shift)));
        assert!(!test(&from(DVec3::new(0.5, 0.5, 40.0) - shift)));
    }

    #[test]
    fn parallel_rays_find_the_boxes_they_pass_through() {
        let direction = DVec3::new(0.3, -1.0, 0.2).normalize();
        let boxes = [
            DMat4::IDENTITY,
            DMat4::from_translation(DVec3::new(3.0, 0.0, 0.0)),
        ];
        let tiles = parallel(corners(&boxes), direction).unwrap();
        let listed = |origin: DVec3| -> Vec<u32> {
            let Some(tile) = tile_of(&tiles, origin) else {
                return vec![];
            };
            let [first, count] = tiles.ranges[tile];
            (first..first + count)
                .map(|k| tiles.entries[k as usize][0])
                .collect()
        };
        // From above each box's centre, back along the direction: that box is listed.
        for (index, centre) in [(0, DVec3::splat(0.5)), (1, DVec3::new(3.5, 0.5, 0.5))] {
            assert!(listed(centre - 4.0 * direction).contains(&index));
        }
        // Between the boxes, and far off to the side: neither.
        assert!(listed(DVec3::new(2.0, 0.5, 0.5) - 4.0 * direction).is_empty());
        assert!(listed(DVec3::new(0.5, 0.5, 40.0)).is_empty());
    }
}
