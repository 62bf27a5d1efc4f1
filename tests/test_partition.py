"""The partitions (convert(partition="cone" | "vsa")): the cone partition keeps noise from
multiplying charts and never folds, its sets agree with trimesh's ray casting of the original
mesh, progress only moves forward, and a hit chart cap is a warning and a stat."""

from __future__ import annotations

import pytest

import geomtex as gt
from geomtex import reference, testing

from bounds import RenderBounds
from conftest import converted, shared_mesh_path

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
    # The cone leaves repair no folding chart to split; it splits charts that lie in two sheets
    # (bumps overhanging their surroundings): 159 of them measured.
    assert st["repair_splits"] == st["sheet_splits"]
    assert st["sheet_splits"] <= 500
    assert st["charts_capped"] == 0
    # Measured 62.6 MB of maps at the default max_resolution.
    assert st["bytes"] <= 1.0e8


def test_cone_bunny_agrees_with_trimesh() -> None:
    bunny = converted("stanford-bunny").mesh
    gts = gt.convert(bunny, partition="cone", max_resolution=256)
    assert gts.stats["folding_charts"] == 0
    m = reference.agreement(gt.Renderer(256, 256), gts, bunny, testing.look_from(bunny, (1, 0.4, 0.3)))
    BUNNY_CONE.check(m, "stanford-bunny", "cone")


def test_cone_charts_are_one_sheet_between_homers_fingers() -> None:
    """A cone chart once held two of homer's fingers, one above the other along its axis, and the
    bilinear cells between them were a wall that rays from above hit between the fingers."""
    homer = gt.load_mesh(shared_mesh_path("homer"))
    gts = gt.convert(homer, partition="cone", max_resolution=512)
    assert gts.stats["sheet_splits"] >= 1  # measured 11
    cam = testing.look_from(homer, (0, 1, 0), up=(0, 0, -1))
    m = reference.agreement(gt.Renderer(512, 512), gts, homer, cam)
    # Measured 2 pixels drawn where trimesh sees nothing, IoU 0.9995; before repair split
    # two-sheet charts: 42 and 0.9964.
    assert m["only_frame_px"] <= 6
    assert m["iou"] >= 0.9985


def _positions(calls: list[tuple[str, float]]) -> list[float]:
    """Where the tqdm bar of geomtex.convert(progress=True) stands after each report."""
    from geomtex._progress import STAGE_SPAN as _STAGE_SPAN

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
