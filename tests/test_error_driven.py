"""Error-driven conversion (convert(max_error=...)): the bound is met as measured, the bytes fall,
and independent references agree: trimesh closest points (geomtex.reference.points_to_mesh) from
the texel points to the original mesh, and trimesh ray casting of the original mesh against the
GPU render."""

from __future__ import annotations

import numpy as np
import pytest

import geomtex as gt
from geomtex import reference, testing

from bounds import RenderBounds
from conftest import Converted

# Issue 6: at the p99 of max_resolution=256, the error-driven bunny uses at most 60% of the bytes.
BYTES_RATIO_MAX = 0.6
# Render bounds (reference: trimesh ray casting of the original mesh).
BUNNY_DRIVEN = RenderBounds(iou=0.997, depth_median=3e-6, depth_p99=2.5e-4)  # 1.000, 9.5e-7, 8.5e-5
SHEET_DRIVEN = RenderBounds(iou=0.99, depth_p99=3e-5)  # 0.996, 1.0e-5


def bump_in_a_corner(n: int = 120) -> gt.Mesh:
    """A flat square with fine ripples in one corner only: detail that one texel size overpays."""
    x = np.linspace(0.0, 1.0, n + 1)

    def z(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        corner = np.exp(-((u - 0.85) ** 2 + (v - 0.85) ** 2) / 0.004)
        return 0.02 * corner * np.sin(60 * u) * np.cos(50 * v)

    return testing.height_field(x, x, z)


def texel_point_distance_p99(gts: gt.GeometryTextureSet, mesh: gt.Mesh, samples: int = 40_000) -> float:
    """99th percentile, by texel area, of trimesh's closest-point distance from the surface
    texels' world points (a fixed random subset) to the original mesh."""
    points, _ = gts.to_points()
    texel = np.asarray(gts.stats["patch_texel"])
    # to_points lists patches in order, each patch's filled texels in a run.
    filled = [int(np.count_nonzero(gts.patch(i)["height"])) for i in range(len(texel))]
    weight = np.repeat(texel**2, filled)
    pick = np.random.default_rng(0).choice(len(points), min(samples, len(points)), replace=False)
    points, weight = points[pick], weight[pick]
    distance = reference.points_to_mesh(points, mesh)
    order = np.argsort(distance)
    cumulative = np.cumsum(weight[order])
    return float(distance[order][np.searchsorted(cumulative, 0.99 * cumulative[-1])])


@pytest.fixture(scope="module")
def bunny_driven(bunny: Converted) -> gt.GeometryTextureSet:
    # Issue 6's figure is for VSA (three partitions tried); the cone partition that error-driven
    # conversion now uses by default takes 0.83 of the bytes here (bench/economy.py --default).
    return gt.convert(bunny.mesh, max_error=bunny.gts.stats["reconstruction_error_p99"], partition="vsa",
                      hybrid=False)


def test_bunny_at_the_fixed_sets_error_takes_at_most_60_percent_of_the_bytes(
        bunny: Converted, bunny_driven: gt.GeometryTextureSet) -> None:
    fixed = bunny.gts.stats
    driven = bunny_driven.stats
    assert driven["max_error"] == fixed["reconstruction_error_p99"]
    assert driven["reconstruction_error_p99"] <= driven["max_error"]
    ratio = driven["bytes"] / fixed["bytes"]
    assert ratio <= BYTES_RATIO_MAX, (ratio, driven["charts"], driven["chart_error"])
    # Each chart reports its own texel, resolution and error; the texels really differ.
    res, texel = np.asarray(driven["patch_resolution"]), np.asarray(driven["patch_texel"])
    assert len(res) == len(texel) == len(driven["patch_error"]) == driven["charts"]
    assert texel.max() > 1.5 * texel.min()
    assert driven["texel_size"] == pytest.approx(texel.min())
    assert res.max() <= 1024


def test_bunny_error_driven_agrees_with_trimesh(bunny: Converted, bunny_driven: gt.GeometryTextureSet) -> None:
    e = bunny_driven.stats["max_error"]
    # Texel points (lips included) lie on the scan to within the bound.
    assert texel_point_distance_p99(bunny_driven, bunny.mesh) <= e
    renderer = gt.Renderer(256, 256)
    for direction in [(1.0, 0.8, 1.0), (-0.3, 0.2, -1.0)]:
        cam = testing.look_from(bunny.mesh, direction)
        m = reference.agreement(renderer, bunny_driven, bunny.mesh, cam, quality="exact")
        BUNNY_DRIVEN.check(m, direction)


def test_local_detail_gets_the_texels() -> None:
    # Sixteen charts on one sheet (one would cover it all), the same partition for both.
    mesh = bump_in_a_corner()
    fixed = gt.convert(mesh, max_resolution=256, charts=16)
    e = fixed.stats["reconstruction_error_p99"]
    # Measured: 'set' 0.18 of the bytes; 'chart' 0.85 (every chart's own p99 within e leaves the
    # set's p99 far below e: the rippled charts pay alone).
    for scope, most in (("set", 0.3), ("chart", 0.95)):
        driven = gt.convert(mesh, max_error=e, error_scope=scope, charts=16, hybrid=False)
        st = driven.stats
        assert st["reconstruction_error_p99"] <= e, scope
        assert st["bytes"] <= most * fixed.stats["bytes"], (scope, st["bytes"] / fixed.stats["bytes"])
        if scope == "chart":
            # Every chart within the bound, unless the cap kept it over (and then it is counted).
            over = np.asarray(st["patch_error"]) > e
            assert over.sum() == st["charts_over_max_error"]
            assert np.all(np.asarray(st["patch_resolution"])[over] >= 1024)
        # The rippled corner's charts are finer than the flat ones'.
        texel = np.asarray(st["patch_texel"])
        assert texel.max() >= 4 * texel.min(), scope
        # Coarse charts stay within their outline: the render agrees with trimesh's ray cast.
        cam = testing.look_from(mesh, (0.3, -0.5, 1.0))
        m = reference.agreement(gt.Renderer(128, 128), driven, mesh, cam, quality="exact")
        SHEET_DRIVEN.check(m, scope)


def test_relative_bound_and_tighter_bounds_cost_more() -> None:
    mesh = testing.wavy_sheet(40)
    diag = mesh.diagonal
    loose = gt.convert(mesh, max_error_rel=1e-4)
    same = gt.convert(mesh, max_error=1e-4 * diag)
    assert loose.stats["max_error"] == pytest.approx(1e-4 * diag)
    assert loose.stats["bytes"] == same.stats["bytes"]
    tight = gt.convert(mesh, max_error_rel=1e-5)
    assert tight.stats["reconstruction_error_p99"] <= 1e-5 * diag
    assert tight.stats["bytes"] > loose.stats["bytes"]


def test_mixed_texels_survive_save_and_load(tmp_path) -> None:
    mesh = bump_in_a_corner(60)
    gts = gt.convert(mesh, max_error_rel=2e-4)
    path = tmp_path / "mixed.gtex"
    gts.save(path)
    back = gt.load(path)
    for i in range(gts.stats["charts"]):
        a, b = gts.patch(i), back.patch(i)
        assert np.array_equal(a["height"], b["height"])
        assert np.allclose(a["extent"], b["extent"])
    assert back.stats["patch_texel"] == pytest.approx(gts.stats["patch_texel"])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(max_error=-1.0), r"max_error must be a positive finite number, got -1"),
        (dict(max_error=float("nan")), r"max_error must be a positive finite number"),
        (dict(max_error_rel=0.0), r"max_error_rel must be a positive finite number"),
        (dict(max_error=1e-3, max_error_rel=1e-3), r"max_error or max_error_rel, not both"),
        (dict(max_error=1e-3, texel_size=0.01), r"texel_size fixes the texel"),
        (dict(max_error=1e-3, error_scope="patch"), r"error_scope must be 'set' or 'chart'"),
        (dict(max_error="1e-3"), r"max_error must be a number"),
    ],
)
def test_bad_error_options_are_parameter_errors(kwargs: dict, message: str) -> None:
    with pytest.raises(gt.ParameterError, match=message):
        gt.convert(testing.flat_grid(4), **kwargs)
