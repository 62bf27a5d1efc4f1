"""Generalized displacement maps (geomtex.gdm): the 5D distance function against a plain
small-step walk in numpy, its SVD compression, the shell's explicit mesh (watertight, on the
offset surfaces it should lie between), and bad input."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import geomtex as gt
from geomtex import gdm


@pytest.fixture(scope="module")
def weave() -> gdm.Volume:
    return gdm.Volume.procedural("weave", (16, 16, 8))


@pytest.fixture(scope="module")
def weave_table(weave: gdm.Volume) -> gdm.DistanceFunction:
    return weave.distance_function(directions=(8, 16))


def walk(occ: np.ndarray, origins: np.ndarray, dirs: np.ndarray, step: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """Small fixed steps through the tiled grid: (t, hit) per ray, independent of the core."""
    nx, ny, nz = occ.shape
    t = np.zeros(len(origins))
    done = np.zeros(len(origins), bool)
    hit = np.zeros(len(origins), bool)
    while not done.all():
        p = origins + dirs * t[:, None]
        out = (p[:, 2] < 0) | (p[:, 2] >= nz)
        q = np.floor(p).astype(int)
        inside = ~out & occ[q[:, 0] % nx, q[:, 1] % ny, np.clip(q[:, 2], 0, nz - 1)]
        hit |= ~done & inside
        done |= out | inside
        t = np.where(done, t, t + step)
    return t, hit


def test_distance_function_matches_a_small_step_walk(weave: gdm.Volume, weave_table: gdm.DistanceFunction) -> None:
    rng = np.random.default_rng(1)
    nx, ny, nz = weave.size
    cells = rng.integers(0, [nx, ny, nz, 8, 16], size=(400, 5))
    dirs = gdm.direction_vectors((8, 16))[cells[:, 3], cells[:, 4]]
    t, hit = walk(weave.occupancy, cells[:, :3] + 0.5, dirs)
    table = weave_table.distance[tuple(cells.T)]
    # The walk overshoots by less than one 1e-3 step.
    assert np.abs(table - t).max() < 2e-3
    assert np.array_equal(weave_table.hit[tuple(cells.T)], hit)
    assert 0.2 < hit.mean() < 0.95  # measured 0.5 over the table: both kinds of rays are exercised


def test_inside_solid_is_zero_and_misses_end_on_the_slab(weave: gdm.Volume,
                                                          weave_table: gdm.DistanceFunction) -> None:
    d, hit = weave_table.distance, weave_table.hit
    assert (d[weave.occupancy] == 0).all() and hit[weave.occupancy].all()
    # A ray straight into a filled voxel below (theta near pi, from the empty voxel above it).
    occ = weave.occupancy
    above = np.argwhere(~occ[:, :, 1:] & occ[:, :, :-1])[0] + [0, 0, 1]
    t, h = weave.march([above + 0.5], [[0, 0, -1]])
    assert h[0] and t[0] == pytest.approx(0.5, abs=1e-6)
    dirs = gdm.direction_vectors((8, 16))
    z = np.arange(8)[None, None, :, None, None] + 0.5 + dirs[None, None, None, :, :, 2] * d
    miss = ~hit
    ends = z[miss]
    assert np.minimum(np.abs(ends), np.abs(ends - 8)).max() < 1e-4


def test_svd_error_falls_with_k(weave_table: gdm.DistanceFunction) -> None:
    errors = [weave_table.compress(k).error["rms"] for k in (1, 2, 4, 8, 16)]
    assert all(a > b for a, b in zip(errors, errors[1:]))
    full = weave_table.compress(64)  # full rank of the 64 (theta, z) columns: exact
    assert full.error["max"] < 1e-4  # float32 round-off, measured 2.3e-5
    k8 = weave_table.compress(8)
    assert k8.nbytes < weave_table.nbytes / 4
    assert np.sqrt(np.mean((k8.reconstruct() - weave_table.distance) ** 2)) == pytest.approx(k8.error["rms"], rel=1e-4)


def test_to_mesh_is_watertight_and_lies_in_the_shell() -> None:
    tor, uv = gdm.uv_torus(1.0, 0.35, (48, 24))
    vol = gdm.Volume.procedural("chain", (32, 32, 8))
    shell = gdm.Shell(tor, vol, thickness=0.08, uv=uv * [12, 4])
    mesh = shell.to_mesh()
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume > 0
    # Every vertex between the base torus and its 0.08 offset (measured radii 0.374..0.399: the
    # links sit mid-shell; the coarse torus's chords lie up to ~0.005 inside).
    ring = np.hypot(mesh.vertices[:, 0], mesh.vertices[:, 1]) - 1.0
    r = np.hypot(ring, mesh.vertices[:, 2])
    assert r.min() > 0.35 - 0.01 and r.max() < 0.35 + 0.08 + 0.005
    # Solid share of the shell: the volume's occupancy, up to marching cubes' smoothing and the
    # shell's curvature (measured 0.0189 of the shell against 0.0215 occupancy: 12% less).
    shell_volume = 2 * np.pi**2 * 1.0 * ((0.35 + 0.08) ** 2 - 0.35**2)
    assert mesh.volume / shell_volume == pytest.approx(vol.occupancy.mean(), rel=0.3)


def test_box_uv_shell_over_a_mesh_without_uv() -> None:
    sphere = trimesh.creation.icosphere(2)
    shell = gdm.Shell(sphere, gdm.Volume.procedural("lattice", (16, 16, 8)), thickness=0.05, tiles=(4, 4))
    assert shell.uv_source == "box"
    mesh = shell.to_mesh()
    r = np.linalg.norm(mesh.vertices, axis=1)
    assert r.min() > 0.98 and r.max() < 1.06  # measured 0.989..1.044
    # Prisms share vertex normals: no two copies of a vertex extrude differently.
    assert np.allclose(np.linalg.norm(shell.normals, axis=1), 1)


def test_bad_input_raises_parameter_errors() -> None:
    grid = np.zeros((8, 8, 4), bool)
    with pytest.raises(gt.ParameterError, match="empty"):
        gdm.Volume(grid)
    with pytest.raises(gt.ParameterError, match="full"):
        gdm.Volume(~grid)
    half = grid.copy()
    half[-1, :, :2] = True
    with pytest.raises(gt.ParameterError, match="does not tile along x"):
        gdm.Volume(half)
    assert gdm.Volume(half, check_seams=False).size == (8, 8, 4)
    nan = np.zeros((8, 8, 4))
    nan[1, 2, 3] = np.nan
    with pytest.raises(gt.ParameterError, match=r"NaN.*\(1, 2, 3\)"):
        gdm.Volume(nan)
    with pytest.raises(gt.ParameterError, match="shape"):
        gdm.Volume(np.ones((8, 8)))
    with pytest.raises(gt.ParameterError, match="voxels along each axis"):
        gdm.Volume.procedural("chain", (1, 64, 16))
    with pytest.raises(gt.ParameterError, match="pattern must be"):
        gdm.Volume.procedural("chainmail", (8, 8, 8))  # type: ignore[arg-type]
    vol = gdm.Volume.procedural("weave", (8, 8, 4))
    with pytest.raises(gt.ParameterError, match="directions"):
        vol.distance_function(directions=(1, 32))
    table = vol.distance_function(directions=(4, 8))
    for k in (0, 17, 2.5, True):
        with pytest.raises(gt.ParameterError, match="k must be"):
            table.compress(k)  # type: ignore[arg-type]
    tor = trimesh.creation.torus(1.0, 0.3)
    for bad in (0, -1, float("nan"), "thick"):
        with pytest.raises(gt.ParameterError, match="thickness"):
            gdm.Shell(tor, vol, thickness=bad)  # type: ignore[arg-type]
    with pytest.raises(gt.ParameterError, match="uv must be"):
        gdm.Shell(tor, vol, thickness=0.1, uv=np.zeros((3, 2)))
    with pytest.raises(gt.ParameterError, match="tiles"):
        gdm.Shell(tor, vol, thickness=0.1, tiles=(0, 2))


def test_distance_function_reports_progress_and_can_be_cancelled() -> None:
    vol = gdm.Volume.procedural("chain", (16, 16, 8))
    seen: list[float] = []
    vol.distance_function((4, 8), progress=lambda stage, f: seen.append(f))
    assert seen[0] == 0 and seen[-1] == 1 and len(seen) == 17
    with pytest.raises(gt.CancelledError):
        vol.distance_function((4, 8), progress=lambda stage, f: f < 0.5)
