"""Geometry textures straight from height grids (geological horizons): a stack of three synthetic
horizons with a hole, checked against trimesh ray casting of the triangulated grids. The full
1588 x 1188 stack is in bench/horizons.py (its trimesh reference needs ~11 GB and a minute)."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pytest

import geomtex as gt
from geomtex import reference
from geomtex.testing import grid_mesh, horizon_stack, look_from

from bounds import RenderBounds

EXTENT = (0.0, 4000.0, 0.0, 3000.0)
STACK = RenderBounds(iou=0.99, mask_far_px=2, depth_median=1.4e-5, depth_p99=9e-5)  # 0.994, 0, 4.7e-6, 3.1e-5


@pytest.fixture(scope="module")
def stack() -> tuple[list[np.ndarray], gt.GeometryTextureSet, gt.Mesh]:
    grids = horizon_stack(300, 400)
    assert np.isnan(grids[1][100:140, 150:230]).all() and np.isnan(grids[1]).sum() == 40 * 80
    gts = gt.GeometryTextureSet.from_heightmaps(grids, EXTENT, properties=grids, cmap="viridis")
    meshes = [grid_mesh(g, EXTENT) for g in grids]
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    mesh = gt.Mesh(np.vstack([np.asarray(m.vertices) for m in meshes]),
                   np.vstack([np.asarray(m.faces) + o for m, o in zip(meshes, offsets)]))
    return grids, gts, mesh


def test_tiles_and_stats(stack) -> None:  # type: ignore[no-untyped-def]
    grids, gts, _ = stack
    # 400 columns in tiles of 256 sharing a border: 2 x 2 tiles per horizon.
    assert len(gts) == 12
    assert list(gts.stats["patch_grid"]) == [0] * 4 + [1] * 4 + [2] * 4
    assert gts.stats["missing_samples"] == 40 * 80
    assert gts.stats["samples"] == 3 * 300 * 400
    assert gts.stats["texel_size"] == pytest.approx(max(4000 / 399, 3000 / 299))  # the coarser spacing


@pytest.mark.parametrize("direction", [(1, 0.8, 0.6), (0.2, -1, 0.3), (1, 0, 0.05)],
                         ids=["oblique", "from_below_side", "grazing_3deg"])
@pytest.mark.parametrize("quality", ["balanced", "exact"])
def test_depth_matches_the_triangulated_grids(stack, direction, quality: str) -> None:  # type: ignore[no-untyped-def]
    """The renderer issue's bounds; measured: IoU ≥ 0.992 (the map's half-texel rim beyond the
    outermost samples), median ≤ 5e-6 and p99 ≤ 3.4e-5 of the diagonal."""
    _, gts, mesh = stack
    m = reference.agreement(gt.Renderer(512, 512), gts, mesh, look_from(mesh, direction), quality=quality)
    STACK.check(m, direction, quality)


def test_colors_follow_the_colormap_and_holes_stay_empty(stack) -> None:  # type: ignore[no-untyped-def]
    grids, gts, _ = stack
    lo = min(np.nanmin(g) for g in grids)
    hi = max(np.nanmax(g) for g in grids)
    p = gts.patch(4)  # horizon 1, first tile: samples [0, 256) x [0, 256)
    assert p["height"].shape == (256, 256)
    want = matplotlib.colormaps["viridis"]((grids[1][:256, :256] - lo) / (hi - lo), bytes=True)
    filled = p["height"] > 0
    assert np.array_equal(p["color"][filled], want[filled])
    assert not filled[100:140, 150:230].any() and filled.sum() == 256 * 256 - 40 * 80


def test_round_trip_keeps_everything(stack, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    _, gts, _ = stack
    gts.save(tmp_path / "horizons.gtex")
    back = gt.load(tmp_path / "horizons.gtex")
    assert len(back) == len(gts)
    assert np.array_equal(back.stats["patch_grid"], gts.stats["patch_grid"])
    for i in range(len(gts)):
        assert np.array_equal(back.patch(i)["height"], gts.patch(i)["height"])


@pytest.mark.parametrize("args, kw, match", [
    (([[0.0, 1.0, 2.0]],), {}, "at least 2 x 2"),
    (([[0.0, np.inf], [0.0, 0.0]],), {}, "row 0, column 1 is infinite"),
    (([[np.nan, np.nan], [np.nan, np.nan]],), {}, "every height is NaN"),
    ((np.zeros(5),), {}, "must be 2-D"),
    (([np.zeros((3, 3)), np.zeros(4)],), {}, r"grids\[1\] must be 2-D"),
    ((np.zeros((3, 3)),), {"properties": np.zeros((3, 4))}, "match the grids"),
    ((np.zeros((3, 3)),), {"properties": np.zeros((3, 3)), "cmap": "no-such-map"}, "cmap must be a matplotlib"),
    ((np.zeros((3, 3)),), {"max_resolution": 1}, "max_resolution"),
    ((np.zeros((3, 3)),), {"height_bits": 12}, "height_bits"),
])
def test_bad_grids(args, kw, match: str) -> None:  # type: ignore[no-untyped-def]
    extent = kw.pop("extent", (0, 1, 0, 1))
    with pytest.raises(gt.ParameterError, match=match):
        gt.GeometryTextureSet.from_heightmaps(args[0], extent, **kw)


def test_bad_extent() -> None:
    with pytest.raises(gt.ParameterError, match="extent"):
        gt.GeometryTextureSet.from_heightmaps(np.zeros((3, 3)), (0, 1, 0))
    with pytest.raises(gt.ParameterError, match="x0 < x1"):
        gt.GeometryTextureSet.from_heightmaps(np.zeros((3, 3)), (1, 0, 0, 1))
