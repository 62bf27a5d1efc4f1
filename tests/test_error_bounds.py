"""Per-pixel error bounds (issue 43) against the source mesh, on the bundled bunny.

Each drawn pixel's world point (its ray at its z-depth) is measured against the original mesh by
trimesh (``reference.points_to_mesh``: exact closest points on a 1000-unit-diagonal copy), never by
geomtex; ``frame.error_bound`` must be at least that distance, coverage differences against
trimesh's ray casting must all lie inside ``frame.coverage_uncertain``, and ``guarantee=True``
must keep its promise. bench/error_bounds.py measures the same on five meshes and views.
Uses only the bundled bunny (no ../shared): runs as a plain clone does.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import geomtex as gt
from geomtex import reference, testing

SIZE = 256
VIEWS = [((0, 0, 1), (0, 1, 0)), ((1, 0.8, 1), (0, 1, 0))]
#: Float noise of a drawn point (float32 depth, the reference's own rounding): ~1e-7 of the
#: diagonal at these views; an exception within this much of its bound is float, not a bound
#: that fails.
FLOAT_TOL_REL = 1e-6


@pytest.fixture(scope="module")
def bunny() -> gt.Mesh:
    return gt.data.bunny()


@pytest.fixture(scope="module")
def default_set(bunny: gt.Mesh) -> Any:
    return gt.convert(bunny, hybrid=False)  # the bounds of height maps (triangles need none)


@pytest.fixture(scope="module")
def cameras(bunny: gt.Mesh) -> list[gt.Camera]:
    return [testing.look_from(bunny, d, up=u) for d, u in VIEWS]


def drawn(frame: Any, camera: gt.Camera) -> tuple[np.ndarray, np.ndarray]:
    """World points of the drawn pixels (their rays at their z-depth) and the pixels' mask."""
    depth = np.asarray(frame.depth, np.float64)
    mask = np.isfinite(depth)
    origins, directions = camera.rays(SIZE, SIZE)
    t = depth[mask] / (directions[mask] @ np.asarray(camera.forward))
    return origins[mask] + directions[mask] * t[:, None], mask


def measured(renderer: gt.Renderer, gts: Any, mesh: gt.Mesh, camera: gt.Camera) -> dict[str, Any]:
    frame = renderer.render(gts, camera, outputs=("depth", "error_bound", "coverage_uncertain"))
    points, mask = drawn(frame, camera)
    bound = np.asarray(frame.error_bound, np.float64)
    return {"frame": frame, "mask": mask, "bound": bound[mask], "dist": reference.points_to_mesh(points, mesh)}


@pytest.fixture(scope="module")
def default_views(bunny: gt.Mesh, default_set: Any, cameras: list[gt.Camera]) -> list[dict[str, Any]]:
    renderer = gt.Renderer(SIZE, SIZE)
    return [measured(renderer, default_set, bunny, cam) for cam in cameras]


def test_bound_known_exactly_where_drawn(default_views: list[dict[str, Any]]) -> None:
    for v in default_views:
        bound = np.asarray(v["frame"].error_bound)
        assert bound.shape == v["mask"].shape and bound.dtype == np.float32
        assert np.isfinite(bound[v["mask"]]).all(), "a drawn pixel of a fresh conversion has no bound"
        assert np.isnan(bound[~v["mask"]]).all(), "a pixel where nothing is drawn has a bound"
        assert (bound[v["mask"]] >= 0).all()


def test_bound_holds_at_drawn_pixels(bunny: gt.Mesh, default_views: list[dict[str, Any]]) -> None:
    diag = float(bunny.diagonal)
    for i, v in enumerate(default_views):
        excess = v["dist"] - v["bound"]
        bad = np.flatnonzero(excess > 0)
        listed = [(float(v["dist"][k] / diag), float(v["bound"][k] / diag)) for k in bad[np.argsort(-excess[bad])][:5]]
        assert len(bad) <= 1e-4 * len(excess), (f"view {i}: {len(bad)} of {len(excess)} drawn pixels farther from "
                                                 f"the mesh than their bound; worst (dist, bound)/diag: {listed}")
        # Every exception is float noise, not a bound that fails.
        assert (excess <= FLOAT_TOL_REL * diag).all(), (f"view {i}: an exception past float noise: {listed}")


def test_bound_is_tight(default_views: list[dict[str, Any]]) -> None:
    for i, v in enumerate(default_views):
        ratio = np.median(v["bound"]) / np.median(v["dist"])
        # Measured 6.94 (front) and 6.72 (oblique) on 2026-12-06 (main 18733ed); the target
        # is <= 4, not met yet (bench/error_bounds.py: the same on the other meshes). This guards
        # against a looser bound.
        assert ratio <= 10.0, f"view {i}: median bound / median distance = {ratio:.2f}"


def test_coverage_differences_are_uncertain(bunny: gt.Mesh, cameras: list[gt.Camera],
                                            default_views: list[dict[str, Any]]) -> None:
    caster = reference.RayCaster(bunny)
    for i, (cam, v) in enumerate(zip(cameras, default_views)):
        hit = caster.cast(cam, SIZE, SIZE)["hit"]
        differ = hit ^ v["mask"]
        uncertain = np.asarray(v["frame"].coverage_uncertain, bool)
        assert uncertain.shape == hit.shape
        outside = differ & ~uncertain
        assert not outside.any(), (f"view {i}: {outside.sum()} of {differ.sum()} pixels where coverage differs "
                                   f"from trimesh are not in coverage_uncertain: {np.argwhere(outside)[:10].tolist()}")
        # Uncertain pixels per differing one: measured 137 / 9 (front) and 139 / 7 (oblique); the
        # issue's target is <= 3, not met yet. This guards against a looser mask.
        assert uncertain.sum() <= 40 * max(differ.sum(), 1), (f"view {i}: {uncertain.sum()} uncertain pixels for "
                                                             f"{differ.sum()} that differ")


@pytest.mark.parametrize("which", ["bunny", "icosphere"])
def test_guarantee_keeps_its_promise(which: str, bunny: gt.Mesh) -> None:
    """At 1e-2 of the diagonal every drawn point lies within it, on a scan (the bundled bunny,
    1.4 s) and on a coarse icosphere (320 faces: facets the bilinear cells must follow). At 1e-3
    the bunny refuses (5 patches stay over it at max_resolution, 14 s; measured 2026-12-06)."""
    import trimesh

    mesh = bunny if which == "bunny" else gt.Mesh.from_trimesh(trimesh.creation.icosphere(subdivisions=2))
    diag = float(mesh.diagonal)
    e = 1e-2 * diag
    gts = gt.convert(mesh, max_error=e, guarantee=True, hybrid=False)
    assert gts.stats["error_bound_max"] <= e
    renderer = gt.Renderer(SIZE, SIZE)
    for i, (d, u) in enumerate(VIEWS):
        cam = testing.look_from(mesh, d, up=u)
        v = measured(renderer, gts, mesh, cam)
        assert v["mask"].sum() > 1000
        assert v["dist"].max() <= e * (1 + 1e-6), f"view {i}: a drawn point {v['dist'].max() / diag:.3g} diag away"
        # The frame adds its float term (4 f32 ulps of eye distance plus patch reach) to the stored
        # bound, which the guarantee holds at e: measured 9.4e-5 of e over it (icosphere).
        assert np.nanmax(np.asarray(v["frame"].error_bound)) <= e * (1 + 3e-4)


def test_guarantee_refuses_what_it_cannot_keep() -> None:
    import trimesh

    ball = gt.Mesh.from_trimesh(trimesh.creation.icosphere(subdivisions=2))
    diag = float(ball.diagonal)
    e = 1e-2 * diag
    with pytest.raises(gt.ParameterError, match="max_bytes"):
        gt.convert(ball, max_error=e, guarantee=True, max_bytes=2_000)
    # A bound no level reaches: the refusal names the patches over it, with their bounds.
    with pytest.raises(gt.ParameterError, match=r"patch\(es\) stay over it .*patch \(bound\): \d+ \("):
        gt.convert(ball, max_error=1e-3 * diag, guarantee=True, max_resolution=8, hybrid=False)
    # A hybrid set keeps such charts as triangles (exact) instead: the promise holds.
    kept = gt.convert(ball, max_error=1e-3 * diag, guarantee=True, max_resolution=8)
    assert kept.triangles is not None and kept.stats.get("error_bound_max", 0.0) <= 1e-3 * diag


def test_small_patches_keep_their_bound_within_a_tenth_of_their_maps() -> None:
    """Bound bytes against map bytes on patches of 2 to 24 texels a side (the noisy isosurface's
    hybrid sets keep only 2 x 2-texel patches). Measured: 2 of 20 bytes (10.0%) at 2 x 2, the
    exponent byte and one code, 4.4-8.1% from 3 x 3 to 24 x 24; an f32 scale per patch and
    2 x 2-cell blocks (the version-6 layout) took 8 bytes, 40%, at 2 x 2 (that build fails
    here). Each stored cell bound holds what was asked, at most one code step (2^(1/16)) above
    its block's largest."""
    rng = np.random.default_rng(3)
    for n in [2, 3, 5, 8, 13, 24]:
        gts = gt.GeometryTextureSet.from_heightmaps(rng.normal(size=(n, n)), (0.0, n, 0.0, n))
        shapes = [gts.patch(k)["height"].shape for k in range(len(gts))]
        asked = [rng.uniform(1e-4, 1e-2, size=(h + 1, w + 1)) for h, w in shapes]
        bounded = gt.GeometryTextureSet._wrap(gts._core._with_cell_bounds(asked))
        for k, a in enumerate(asked):
            stored = bounded.patch(k)["error_bound"]
            assert stored.shape == a.shape and (stored >= a).all()
            assert stored.max() <= a.max() * 2 ** (1 / 16) * (1 + 1e-12)
        bound = bounded.stats["error_bound_bytes"]
        maps = bounded.stats["bytes"] - bound
        assert maps == 5 * sum(h * w for h, w in shapes)  # 16-bit heights, normals, outline
        assert bound <= 0.1 * maps, (n, shapes, bound, maps)
