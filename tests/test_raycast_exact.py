"""The exact (max-pyramid) ray caster against the CPU reference of the same height-map surface
(f64, closed-form per cell: GeometryTextureSet.first_hits), on thin features and on the bunny."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

import geomtex as gt

from conftest import Converted


def write_gtex(path, heights: np.ndarray, origin, axes, extent, bits: int = 16) -> None:
    """A one-patch .gtex written from the documented layout (src/format.rs), not by geomtex:
    version 1 for 16-bit heights (no height-bits field), version 2 for 8-bit ones."""
    h, w = heights.shape
    payload = struct.pack("<d", 1.0) + struct.pack("<I", 0) + struct.pack("<I", 0) + struct.pack("<I", 1)
    payload += struct.pack("<3d", *origin) + b"".join(struct.pack("<3d", *a) for a in axes)
    payload += struct.pack("<3d", *extent) + struct.pack("<2I", w, h)
    if bits == 16:
        payload += struct.pack("<2I", 0, 0) + heights.astype("<u2").tobytes()
    else:
        payload += struct.pack("<3I", 8, 0, 0) + heights.astype(np.uint8).tobytes()
    payload += np.tile(np.array([0, 0, 127, 0], np.int8), h * w).tobytes()
    payload += np.full(h * w * 4, 200, np.uint8).tobytes()
    version = 1 if bits == 16 else 2
    header = b"GTEX\r\n\x1a\n" + struct.pack("<IIQII", version, 0, len(payload), zlib.crc32(payload), 0)
    path.write_bytes(header + payload)


@pytest.fixture(scope="module", params=[16, 8], ids=["16bit", "8bit"])
def thin(tmp_path_factory, request) -> gt.GeometryTextureSet:
    """A 64 x 64 map: a low floor, one-texel walls every 8 columns and single-texel spikes."""
    top = 2 ** request.param - 1
    codes = np.full((64, 64), round(0.03 * top), np.uint16)
    codes[:, 4::8] = round(0.76 * top)  # walls, one texel thick, across the view
    codes[2::9, 2::11] = top  # spikes
    path = tmp_path_factory.mktemp("thin") / "thin.gtex"
    write_gtex(path, codes, origin=(0, 0, 0), axes=[(1, 0, 0), (0, 1, 0), (0, 0, 1)], extent=(1.0, 1.0, 0.2),
               bits=request.param)
    gts = gt.load(path)
    assert gts.patch(0)["height_bits"] == request.param
    assert np.array_equal(gts.patch(0)["height"], codes)
    return gts


def reference_depth(gts, cam, size):
    o, d = cam.rays(size, size)
    t, k = gts.first_hits(o.reshape(-1, 3), d.reshape(-1, 3))
    depth = t * (d.reshape(-1, 3) @ np.asarray(cam.forward))
    return depth.reshape(size, size), k.reshape(size, size)


@pytest.mark.parametrize("elevation_deg", [4.0, 12.0])
def test_maxmip_is_exact_on_thin_features(thin, elevation_deg) -> None:
    size = 192
    r = gt.Renderer(size, size, device="gpu")
    el = np.radians(elevation_deg)
    # Looking across the walls (along +x) from low above the floor.
    eye = np.array([-0.6, 0.5, 0.05 + 1.2 * np.tan(el)])
    cam = gt.Camera.look_at(eye, [1.0, 0.5, 0.05], up=(0, 0, 1), yfov_deg=30)
    ref, _ = reference_depth(thin, cam, size)
    hit = np.isfinite(ref)
    assert hit.sum() > 2000
    exact = r.render(thin, cam, method="maxmip")
    # Every pixel the reference hits is hit, and nothing else; depth to 1e-4 of the patch height.
    assert np.array_equal(np.isfinite(exact.depth), hit)
    assert np.abs(exact.depth[hit] - ref[hit]).max() <= 1e-4 * 0.2
    # The paper's search with 16 linear steps steps over walls and spikes.
    coarse = r.render(thin, cam, method="linear_binary", steps_per_texel=1e-6,
                      min_linear_steps=16, max_linear_steps=16, binary_steps=8)
    wrong = ~np.isfinite(coarse.depth[hit]) | (np.abs(coarse.depth[hit] - ref[hit]) > 1e-3)
    assert wrong.mean() > 0.01, wrong.mean()


def test_maxmip_matches_the_cpu_reference_on_the_bunny(bunny: Converted) -> None:
    size = 160
    r = gt.Renderer(size, size, device="gpu")
    lo, hi = bunny.mesh.bounds
    centre, diag = (lo + hi) / 2, bunny.mesh.diagonal
    for direction in [(1, 0.8, 1), (0.05, 1, 0.02), (-1, -0.3, 0.2)]:
        d = np.asarray(direction, float) / np.linalg.norm(direction)
        cam = gt.Camera.look_at(centre + d * 1.2 * diag, centre, yfov_deg=40)
        ref, patch = reference_depth(bunny.gts, cam, size)
        hit = np.isfinite(ref)
        # Drawing every box searches every patch over a pixel, as the reference does, so the
        # nearest of two copies of a surface (the overlap rings) shows: the search itself.
        f = r.render(bunny.gts, cam, quality="exact", count_fetches=True, primary="boxes")
        assert (np.isfinite(f.depth) != hit).sum() <= 0.001 * hit.sum()
        both = hit & np.isfinite(f.depth)
        err = np.abs(f.depth[both] - ref[both]) / diag
        assert np.percentile(err, 99.9) < 1e-5 and err.max() < 1e-3, (direction, err.max())
        assert f.stats["method"] == "maxmip" and f.stats["fetches_per_pixel"] > 0
        # Tiles show the owning patch's copy near chart borders (their pieces leave the other
        # out). Measured: p99 4.5-5.7e-6, p99.9 2.4-4.7e-5 of the diagonal; a grazing ray at a
        # fold can pass beside the owner's copy (at most one pixel a view, up to 7.3e-2).
        f = r.render(bunny.gts, cam, quality="exact")
        assert (np.isfinite(f.depth) != hit).sum() <= 0.001 * hit.sum()
        both = hit & np.isfinite(f.depth)
        err = np.abs(f.depth[both] - ref[both]) / diag
        assert np.percentile(err, 99) < 1.7e-5 and np.percentile(err, 99.9) < 1.4e-4, direction


def test_fetch_counts_follow_the_work(bunny: Converted) -> None:
    """More linear steps per texel cost proportionally more fetches; the exact method fewer.
    Every box drawn: each search starts at its box's entry, where a tiled frame's starts at a
    thin piece's, a step or two from the surface, so there the linear steps hardly count."""
    r = gt.Renderer(128, 128, device="gpu")
    lo, hi = bunny.mesh.bounds
    centre = (lo + hi) / 2
    cam = gt.Camera.look_at(centre + np.array([1, 0.8, 1.0]) * bunny.mesh.diagonal, centre, yfov_deg=40)
    fetches = {}
    settings = {"s1": dict(quality="balanced", steps_per_texel=1.0),
                "s4": dict(quality="balanced", steps_per_texel=4.0), "exact": dict(quality="exact")}
    for name, kw in settings.items():
        kw = {**kw, "primary": "boxes"}
        f = r.render(bunny.gts, cam, count_fetches=True, **kw)
        fetches[name] = f.stats["fetches_per_pixel"]
        stats = f.stats
        assert stats["searches"] > 0 and stats["covered_pixels"] > 0
        assert stats["searches_per_pixel"] == stats["searches"] / stats["covered_pixels"]
        plain = r.render(bunny.gts, cam, **kw)
        assert np.array_equal(plain.depth, f.depth)  # counting does not change the image
    assert 2.5 < fetches["s4"] / fetches["s1"] < 4.5, fetches
    assert fetches["exact"] < fetches["s1"], fetches


def test_tiled_exact_searches_start_beside_the_surface(bunny: Converted) -> None:
    """A tiled frame starts each exact search where its ray enters a thin piece, a step or two
    from the surface, so the min-max descent starts at the pyramid's finest level there and
    climbs only over what it skips, instead of coming down from the root of the patch's whole
    box: fewer pyramid reads per search, the same first hits (the tests above)."""
    r = gt.Renderer(256, 256, device="gpu")
    lo, hi = bunny.mesh.bounds
    centre, diag = (lo + hi) / 2, bunny.mesh.diagonal
    for direction in [(1, 0.8, 1), (0.3, -1, 0.2)]:
        d = np.asarray(direction, float) / np.linalg.norm(direction)
        cam = gt.Camera.look_at(centre + d * 1.7 * diag, centre, yfov_deg=40)
        stats = r.render(bunny.gts, cam, quality="exact", count_fetches=True).stats
        assert stats["primary"] == "tiles"
        # Measured (Stanford bunny, 256²): 12.9 / 12.3 fetches per search; descending from the
        # root of the box 20.7 / 20.1, from the piece's level (16 texels) 16.8 / 16.1.
        assert stats["fetches_per_search"] <= 15.0, (direction, stats["fetches_per_search"])


def test_bad_search_keywords(bunny: Converted) -> None:
    r = gt.Renderer(16, 16, device="gpu")
    cam = gt.Camera.look_at([0, 0, 1], [0, 0, 0])
    with pytest.raises(gt.ParameterError, match="quality must be"):
        r.render(bunny.gts, cam, quality="ultra")
    with pytest.raises(gt.ParameterError, match="method must be"):
        r.render(bunny.gts, cam, method="sphere_tracing")
    with pytest.raises(gt.ParameterError, match="max_traversal_steps"):
        r.render(bunny.gts, cam, max_traversal_steps=0)
    with pytest.raises(gt.ParameterError, match="origins and directions"):
        bunny.gts.first_hits(np.zeros((3, 3)), np.zeros((2, 3)))
