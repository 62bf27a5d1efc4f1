"""The partitions (convert(partition="cone" | "vsa")): the cone partition keeps noise from
multiplying charts and never folds, its sets agree with trimesh's ray casting of the original
mesh, progress only moves forward, and a hit chart cap is a warning and a stat."""

from __future__ import annotations

import pytest

import geomtex as gt
from geomtex import reference, testing

from bounds import RenderBounds
from conftest import converted

# Cone partition of the shared bunny, reference: trimesh ray casting of the original mesh.
BUNNY_CONE = RenderBounds(iou=0.997, depth_median=1e-5, depth_p99=3.5e-4, depth_p99_1px=3.5e-4,
                          normal_deg_median=7.0)  # 0.9993, 3.7e-6, 1.2e-4, 1.2e-4, 2.4


@pytest.fixture(scope="module")
def noisy() -> gt.Mesh:
    """pymeshlab's noisy isosurface at resolution 64 (57,838 faces)."""
    pytest.importorskip("pymeshlab")
    return testing.noisy_isosurface(resolution=64)


def test_noise_does_not_multiply_cone_charts_and_none_fold(noisy: gt.Mesh) -> None:
    st = gt.convert(noisy, partition="cone", max_resolution=256).stats
    # Measured: 1,789 charts (VSA at its default chart_error: 4,096, its cap, and 635 MB of maps).
    assert st["charts"] <= 2_500
    assert st["folding_charts"] == 0 and st["inverted_triangles"] == 0
    assert st["repair_splits"] == 0  # the cone leaves repair nothing to split
    assert st["charts_capped"] == 0
    # Measured 62.6 MB of maps at the default max_resolution.
    assert st["bytes"] <= 1.0e8


def test_cone_bunny_agrees_with_trimesh() -> None:
    bunny = converted("stanford-bunny").mesh
    gts = gt.convert(bunny, partition="cone", max_resolution=256)
    assert gts.stats["folding_charts"] == 0
    m = reference.agreement(gt.Renderer(256, 256), gts, bunny, testing.look_from(bunny, (1, 0.4, 0.3)))
    BUNNY_CONE.check(m, "stanford-bunny", "cone")


def _positions(calls: list[tuple[str, float]]) -> list[float]:
    """Where the tqdm bar of geomtex.convert(progress=True) stands after each report."""
    from geomtex import _STAGE_SPAN

    out = []
    for stage, fraction in calls:
        start, end = _STAGE_SPAN[stage]
        out.append(start + (end - start) * fraction)
    return out


@pytest.mark.parametrize("options", [dict(partition="vsa"), dict(partition="cone"),
                                     dict(partition="vsa", max_error_rel=1e-3)], ids=str)
def test_progress_moves_within_partitioning_and_never_back(options: dict) -> None:
    calls: list[tuple[str, float]] = []
    gt.convert(converted("sphere").mesh, progress=lambda s, f: calls.append((s, f)), **options)
    positions = _positions(calls)
    assert all(b >= a for a, b in zip(positions, positions[1:])), calls
    inside = [f for s, f in calls if s == "partition" and 0.0 < f < 1.0]
    assert inside, "no report from within partitioning"
    assert calls[-1] == ("done", 1.0)


@pytest.mark.parametrize("kwargs, message", [
    (dict(partition="voronoi"), r"partition must be 'cone' or 'vsa'"),
    (dict(partition="cone", cone_angle=90.0), r"cone_angle must be in \(0, 85\]"),
    (dict(partition="cone", cone_angle=float("nan")), r"cone_angle"),
    (dict(partition="cone", chart_size=0.0), r"chart_size must be in \(0, 10\]"),
])
def test_bad_partition_options_are_parameter_errors(kwargs: dict, message: str) -> None:
    with pytest.raises(gt.ParameterError, match=message):
        gt.convert(converted("sphere").mesh, **kwargs)
