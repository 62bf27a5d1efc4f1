"""Numerical stability at the extremes: models far from the origin, micrometre and kilometre
scales, cameras inside the model, rays grazing a surface, and damaged meshes (triangle soup,
reversed faces, holes, fins, slivers), each rendered and checked against
trimesh ray casting of the same transformed mesh (geomtex.reference, which intersects on a
centred, normalized copy so that embree's float32 is not the limit).

The property tests draw their cases with hypothesis: a fixed, bounded set in CI (profile "ci",
derandomized), fresh random ones locally (profile "dev"); see conftest.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, example, given
from hypothesis import strategies as st

import geomtex as gt
from geomtex import reference
from geomtex.testing import (
    add_fins,
    add_slivers,
    flat_grid,
    flip_faces,
    height_field,
    look_from,
    punch_holes,
    similar,
    soup,
)

from bounds import RenderBounds
from conftest import Converted, converted

agreement = reference.agreement

# Bounds of the tests below. The property tests (hypothesis) range over scales, offsets, eyes
# and angles, so they hold the renderer issue's floor; the fixed cases are tighter.
FAR_TINY_HUGE = RenderBounds(iou=0.997, depth_median=9e-6, depth_p99=2e-4)  # 0.999, 3.0e-6, 6.8e-5
TERRAIN_GRAZING = RenderBounds(iou=0.991, depth_median=3.5e-6, depth_p99=2.8e-4)  # 0.997, 1.1e-6, 9.2e-5
# Worst of 200 draws (GEOMTEX_HYPOTHESIS=thorough) beside each bound.
ANY_SCALE = RenderBounds(iou=0.991, depth_median=6e-4, depth_p99=3.5e-3)  # 0.997, 2.1e-4, 1.2e-3
# Silhouette-dominated views: p99 with a one-pixel tolerance (see the tests).
EYE_INSIDE = RenderBounds(depth_median=1.3e-5, depth_p99_1px=4.4e-3)  # 4.4e-6, 1.5e-3
#: An eye closer to the surface than this (median depth, diagonals) sees a few texels of one
#: region, whose approximation error is that region's, not the set's typical one.
CLOSE_UP = 0.01
# IoU here is a floor, not a measured bound: 200 draws reach 0.90 (a 0.5° view of the sheet's
# rim) while no differing pixel lies more than one pixel from the other mask (mask_far_px = 0).
# IoU is a floor only: at 1° elevation over the open sheet a random example measured 0.948, every
# differing pixel within one of the reference's mask (mask_far_px 0), as before tiled frames.
GRAZING = RenderBounds(iou=0.93, mask_far_px=0, depth_median=4e-5, depth_p99_1px=2e-3)  # 1.4e-5, 6.6e-4
DAMAGED = RenderBounds(iou=0.997, depth_median=7.5e-6, depth_p99=2.9e-4)  # 0.999, 2.5e-6, 9.6e-5


@pytest.fixture(scope="module")
def r512() -> gt.Renderer:
    return gt.Renderer(512, 512)


@pytest.fixture(scope="module")
def r160() -> gt.Renderer:
    return gt.Renderer(160, 160)


# ----------------------------------------------------------------------------- the cases


@pytest.mark.parametrize("scale, offset", [(1.0, 1e6), (1e-4, 0.0), (1e4, 0.0)],
                         ids=["translated_1e6", "scaled_1e-4", "scaled_1e4"])
def test_bunny_far_away_tiny_and_huge(bunny: Converted, r512: gt.Renderer, scale: float, offset: float) -> None:
    """The issue asks for IoU >= 0.97, median <= 0.2% and p99 <= 2%; we hold the renderer issue's
    tighter bounds, and the figures must match the untransformed bunny's (offsets and scales cost
    nothing)."""
    mesh = similar(bunny.mesh, scale, [offset, -offset, 0.5 * offset])
    gts = gt.convert(mesh, max_resolution=256)
    for direction in [(1, 0.8, 1), (0.3, -1, 0.2)]:
        for quality in ["balanced", "exact"]:
            m = agreement(r512, gts, mesh, look_from(mesh, direction), quality=quality)
            base = agreement(r512, bunny.gts, bunny.mesh, look_from(bunny.mesh, direction), quality=quality)
            FAR_TINY_HUGE.check(m, direction, quality)
            assert m["depth_p99"] <= 1.5 * base["depth_p99"] + 1e-6, (direction, quality, m, base)
            assert abs(m["iou"] - base["iou"]) <= 2e-3, (direction, quality, m, base)


@pytest.mark.parametrize("azimuth_deg", [0.0, 35.0])
def test_terrain_seen_half_a_degree_above_its_plane(r512: gt.Renderer, azimuth_deg: float) -> None:
    terrain = converted("fractal_terrain")
    e, a = np.radians(0.5), np.radians(azimuth_deg)
    cam = look_from(terrain.mesh, (np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)))
    for quality in ["balanced", "exact"]:
        m = agreement(r512, terrain.gts, terrain.mesh, cam, quality=quality)
        TERRAIN_GRAZING.check(m, quality)


# ----------------------------------------------------------------------------- properties


@given(
    log_scale=st.floats(-6.0, 6.0),
    offset=st.tuples(*[st.floats(-1e7, 1e7)] * 3),
    direction=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
    quality=st.sampled_from(["balanced", "exact"]),
)
def test_any_scale_and_offset(r160: gt.Renderer, log_scale: float, offset, direction, quality: str) -> None:  # type: ignore[no-untyped-def]
    d = np.asarray(direction)
    assume(np.linalg.norm(d) > 0.1)
    torus = converted("torus").mesh
    mesh = similar(torus, 10.0 ** log_scale, offset)
    m = agreement(r160, gt.convert(mesh, max_resolution=256), mesh, look_from(mesh, d), quality=quality)
    ANY_SCALE.check(m, log_scale, offset, direction, quality)


@given(
    pick=st.integers(0, 10**6),
    uvh=st.tuples(*[st.floats(0.0, 1.0)] * 3),
    direction=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
    quality=st.sampled_from(["balanced", "exact"]),
)
# Close-ups random draws found: a median depth error past the set's typical one
# (eye_inside_bounds); coverage differing at the frame's edge, 3 pixels of it outside
# frame.coverage_uncertain until the pixels just past the edges were traced (render/coverage.rs).
@example(pick=929963, uvh=(0.1015625, 0.0, 0.125), direction=(-1.0, 0.0, -1.0), quality="exact")
@example(pick=161714, uvh=(0.75, 0.76171875, 0.625), direction=(0.75, 0.75, 0.625), quality="exact")
# A close-up whose outlines stand a pixel or more off: 21 differing pixels beside transition pixels,
# not transitions themselves.
@example(pick=300, uvh=(0.8125, 0.0, 0.0), direction=(1.0, 0.0, 0.0), quality="exact")
def test_camera_inside_a_patch_box(r160: gt.Renderer, pick: int, uvh, direction, quality: str) -> None:  # type: ignore[no-untyped-def]
    """The eye anywhere inside a patch's box (often inside the torus's tube, or just off a
    surface), looking anywhere. An eye a few texels from a surface sees that surface's silhouette
    as a whole line of pixels, where a sub-texel difference between the height map and the
    triangles decides hit or miss; so p99 is taken with a one-pixel tolerance there
    (reference.compare's depth_p99_1px). Where the search is exact, every pixel whose coverage
    differs from the mesh's lies in frame.coverage_uncertain (a close-up's silhouettes stand
    several pixels off); else hit masks may differ only within a pixel of each other when the
    view holds so few pixels that IoU is all edge."""
    d = np.asarray(direction)
    assume(np.linalg.norm(d) > 0.1)
    torus = converted("torus")
    eye = (torus.gts.world_from_patch[pick % len(torus.gts)] @ np.array([*uvh, 1.0]))[:3]
    up = (0.0, 0.0, 1.0) if abs(d[2]) < 0.9 * np.linalg.norm(d) else (0.0, 1.0, 0.0)
    cam = gt.Camera.look_at(eye, eye + d, up=up, yfov_deg=60)
    m = agreement(r160, torus.gts, torus.mesh, cam, quality=quality)
    if m["ref_px"] + m["covered_px"] > 200:
        frame = r160.render(torus.gts, cam, quality=quality, outputs=("depth", "error_bound", "coverage_uncertain"))
        if frame.stats["error_bound_search"] == "exact":
            ref = reference.raycast(torus.mesh, cam, r160.width, r160.height)
            differ = np.isfinite(ref["depth"]) != np.isfinite(frame.depth)
            outside = differ & ~frame.coverage_uncertain
            assert not outside.any(), (eye, d, quality, np.argwhere(outside), m)
        else:
            assert m["iou"] >= 0.97 or m["mask_far_px"] == 0, m
        eye_inside_bounds(torus, frame).check(m, eye, d, quality)
    else:
        RenderBounds().check(m, eye, d, quality, "too few pixels for more than no NaN")


def eye_inside_bounds(torus: Converted, frame: gt.Frame) -> RenderBounds:
    """EYE_INSIDE, but for a close-up (CLOSE_UP) a median depth error up to the frame's median
    `error_bound` (each drawn point's bound on its distance to the mesh): measured 1.9e-5 against
    a bound of 5.1e-5 on a random draw (pick 929963, uvh (0.102, 0, 0.125), direction (-1, 0, -1)),
    where the set's typical 1.3e-5 failed on both backends."""
    drawn = np.isfinite(frame.depth)
    diag = reference.diagonal(torus.mesh)
    if not drawn.any() or np.median(frame.depth[drawn]) > CLOSE_UP * diag:
        return EYE_INSIDE
    bound = float(np.median(frame.error_bound[drawn])) / diag
    return RenderBounds(depth_median=max(EYE_INSIDE.depth_median or 0.0, bound),
                        depth_p99_1px=EYE_INSIDE.depth_p99_1px)


@given(
    elevation_deg=st.floats(0.1, 10.0),
    azimuth_deg=st.floats(0.0, 360.0),
    eye_xy=st.tuples(st.floats(0.3, 0.7), st.floats(0.3, 0.7)),
    mesh_name=st.sampled_from(["flat", "open_sheet"]),
    quality=st.sampled_from(["balanced", "exact"]),
)
def test_grazing_rays(r160: gt.Renderer, elevation_deg: float, azimuth_deg: float, eye_xy, mesh_name: str,
                      quality: str) -> None:  # type: ignore[no-untyped-def]
    """Rays 0.1° to 10° above a chart's plane, from an eye over the middle of a flat chart (zero
    height range) or of the wavy sheet. The sheet's rim, seen edge-on, is a silhouette whose
    position the maps know to half a texel (conservative coverage), so p99 is taken with a
    one-pixel tolerance (reference.compare's depth_p99_1px), and hit masks may differ only within
    a pixel of each other."""
    if mesh_name == "flat":
        mesh = flat_grid()
        gts = gt.convert(mesh, max_resolution=256)
        assert len(gts) == 1
    else:
        c = converted("open_sheet")
        mesh, gts = c.mesh, c.gts
    lo, hi = mesh.bounds
    e, a = np.radians(elevation_deg), np.radians(azimuth_deg)
    forward = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), -np.sin(e)])
    eye = np.array([lo[0] + eye_xy[0] * (hi[0] - lo[0]), lo[1] + eye_xy[1] * (hi[1] - lo[1]),
                    hi[2] + 0.02 * mesh.diagonal])
    cam = gt.Camera.look_at(eye, eye + forward, up=(0, 0, 1), yfov_deg=30)
    m = agreement(r160, gts, mesh, cam, quality=quality)
    RenderBounds().check(m, "no NaN")
    assume(m["ref_px"] >= 1000)
    # A few thousand pixels of a surface seen edge-on are mostly silhouette (at 0.125° the sheet's
    # side rims give 3% of the pixels), so the bound is on where masks differ: never more than one
    # pixel from the reference's mask; IoU ≥ 0.95 is only a floor.
    GRAZING.check(m, mesh_name, elevation_deg, azimuth_deg, quality)


# ----------------------------------------------------------------------------- damaged meshes


def check_renders(gts: gt.GeometryTextureSet, mesh: gt.Mesh, r: gt.Renderer) -> None:
    for direction in [(1, 0.8, 1), (-0.3, -1, -0.4)]:
        m = agreement(r, gts, mesh, look_from(mesh, direction), quality="balanced")
        DAMAGED.check(m, direction)


def test_triangle_soup_converts_like_its_welded_mesh(bunny: Converted, r160: gt.Renderer) -> None:
    """STL-style soup: vertices are welded by position, so the charts are the welded mesh's."""
    mesh = soup(bunny.mesh)
    gts = gt.convert(mesh, max_resolution=256)
    used = len(np.unique(np.asarray(bunny.mesh.faces)))
    assert gts.stats["duplicate_vertices"] == 3 * len(mesh.faces) - used
    for key in ["charts", "texels", "boundary_edges"]:
        assert gts.stats[key] == bunny.gts.stats[key], key
    check_renders(gts, mesh, r160)


def test_reversed_faces_are_rewound(bunny: Converted, r160: gt.Renderer) -> None:
    """10% of the faces wound the other way: each connected piece is rewound to its majority, so
    exactly the reversed faces are flipped back and the charts are the clean mesh's."""
    mesh, reversed_faces = flip_faces(bunny.mesh, 0.10, seed=1)
    gts = gt.convert(mesh, max_resolution=256)
    assert gts.stats["inconsistent_edges"] > len(reversed_faces)
    assert gts.stats["flipped_faces"] == len(reversed_faces)
    assert gts.stats["charts"] == bunny.gts.stats["charts"]
    check_renders(gts, mesh, r160)


def test_holes_in_a_scan(bunny: Converted, r160: gt.Renderer) -> None:
    mesh = punch_holes(bunny.mesh, 0.05, holes=40, seed=2)
    gts = gt.convert(mesh, max_resolution=256)
    assert gts.stats["boundary_edges"] > bunny.gts.stats["boundary_edges"] + 40 * 6
    check_renders(gts, mesh, r160)


def test_non_manifold_fins(bunny: Converted, r160: gt.Renderer) -> None:
    """200 triangles standing on existing edges, so three faces share each of those edges."""
    mesh = add_fins(bunny.mesh, 200, height=0.01, seed=3)
    gts = gt.convert(mesh, max_resolution=256)
    assert 0.9 * 200 <= gts.stats["nonmanifold_edges"] <= 200
    check_renders(gts, mesh, r160)


def test_slivers_and_zero_area_faces(bunny: Converted, r160: gt.Renderer) -> None:
    """20% of the faces split into a 1e-9 needle and a near-copy (T-junctions on their
    neighbours), plus 100 faces with a repeated vertex, reported and left out of every patch."""
    mesh = add_slivers(bunny.mesh, 0.20, zero_area=100, seed=4)
    gts = gt.convert(mesh, max_resolution=256)
    assert gts.stats["degenerate_faces"] == 100
    assert np.all(gts.face_patch()[-100:] == -1) and np.all(gts.face_patch()[:-100] >= 0)
    check_renders(gts, mesh, r160)


# ----------------------------------------------------------------------------- height precision


@pytest.mark.parametrize("amplitude, kept_at_16", [(0.15, 0), (0.6, 0), (1.5, 1)])
def test_8_bit_heights_round_within_half_a_texel(amplitude: float, kept_at_16: int) -> None:
    """One chart over z = a sin 3x cos 2y on [-1, 1]^2 (256 texels across): at a = 1.5 the chart
    stands ~1.7 of its width tall, where 8-bit codes would step 1.6 texels, so it keeps 16 bits."""
    x = np.linspace(-1, 1, 61)
    sheet = height_field(x, x, lambda u, v: amplitude * np.sin(3 * u) * np.cos(2 * v))
    gts = gt.convert(sheet, charts=1, height_bits=8, max_resolution=256)
    assert gts.stats["patches_kept_at_16_bits"] == kept_at_16
    assert gts.stats["max_quantization_error"] <= 0.5 * gts.stats["texel_size"]
    assert gts.patch(0)["height"].dtype == (np.uint16 if kept_at_16 else np.uint8)

