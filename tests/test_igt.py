"""Inverse geometric textures (geomtex.igt): the lists against an independent numpy
computation, the CPU lookup against the known face of points sampled on the detailed surface,
simplification, files and bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import geomtex as gt

from conftest import SHARED_MESHES, pymeshlab_bunny_path


def _bunny_mesh() -> gt.Mesh:
    path = SHARED_MESHES / "stanford-bunny.obj"
    return gt.load_mesh(path if path.exists() else pymeshlab_bunny_path())


_built: dict[tuple[str, int], gt.igt.InverseGeometricTexture] = {}


def _igt(primary: str = "charts", resolution: int = 256) -> gt.igt.InverseGeometricTexture:
    key = (primary, resolution)
    if key not in _built:
        _built[key] = gt.igt.build(_bunny_mesh(), primary=primary, resolution=resolution)
    return _built[key]


def _chart_corners(igt: gt.igt.InverseGeometricTexture) -> np.ndarray:
    """Each entry's corners in its chart's cell units, projected here with numpy."""
    g = igt.grids
    grid = igt.entry_grid
    p = igt.vertices[igt.faces[igt.entry_face]] - g["origin"][grid][:, None, :]
    axes = g["axes"][grid]
    u = np.einsum("ekc,ec->ek", p, axes[:, 0]) / g["cell"][grid, 0][:, None]
    v = np.einsum("ekc,ec->ek", p, axes[:, 1]) / g["cell"][grid, 1][:, None]
    return np.stack([u, v], axis=-1)


def test_every_triangle_is_listed_in_every_cell_it_covers() -> None:
    igt = _igt()
    corners = _chart_corners(igt)
    # The stored corners are the same projection (float32).
    assert np.abs(corners - igt.entry_corners).max() < 1e-3
    g = igt.grids
    shape, first = g["shape"][igt.entry_grid], g["first_cell"][igt.entry_grid]
    # Points on every triangle: corners, points along the edges and inside (barycentric lattice
    # of step 1/8), each mapped to its cell; that cell's list must hold the entry.
    n = 8
    lattice = np.array([(i, j, n - i - j) for i in range(n + 1) for j in range(n + 1 - i)], float) / n
    starts, entries = igt.cell_start, igt.cell_entries
    listed = set()
    for c in range(len(starts) - 1):
        for e in entries[starts[c]:starts[c + 1]]:
            listed.add((c, int(e)))
    missing = 0
    for lam in lattice:
        pts = np.einsum("k,ekd->ed", lam, corners)
        i = np.clip(np.floor(pts[:, 0]).astype(np.int64), 0, shape[:, 0] - 1)
        j = np.clip(np.floor(pts[:, 1]).astype(np.int64), 0, shape[:, 1] - 1)
        cells = first + j * shape[:, 0] + i
        missing += sum((int(c), e) not in listed for e, c in enumerate(cells))
    assert missing == 0
    # Not loose either: every listed pair's triangle reaches its cell (bounds within 1e-3).
    cell_of = np.repeat(np.arange(len(starts) - 1), np.diff(starts))
    grid_of = np.searchsorted(g["first_cell"], cell_of, side="right") - 1
    local = cell_of - g["first_cell"][grid_of]
    ci, cj = local % g["shape"][grid_of, 0], local // g["shape"][grid_of, 0]
    lo, hi = corners[entries].min(axis=1), corners[entries].max(axis=1)
    reach = (lo[:, 0] <= ci + 1 + 1e-3) & (hi[:, 0] >= ci - 1e-3)
    reach &= (lo[:, 1] <= cj + 1 + 1e-3) & (hi[:, 1] >= cj - 1e-3)
    assert reach.all()
    s = igt.stats
    assert s["faces"] == len(igt.faces) and sum(s["histogram"]) == s["cells"]
    # Measured on the 69k-face bunny at 256²: 6.5 triangles per non-empty cell, 16 at most.
    assert 3.0 <= s["list_mean"] <= 13.0, s["list_mean"]


@pytest.mark.parametrize("primary", ["charts", "spherical"])
def test_lookup_finds_the_face_of_points_on_it(primary: str) -> None:
    igt = _igt(primary, 512)
    rng = np.random.default_rng(7)
    faces = rng.integers(0, len(igt.faces), 20000)
    lam = rng.dirichlet([1.0, 1.0, 1.0], len(faces))
    pts = np.einsum("nk,nkd->nd", lam, igt.vertices[igt.faces[faces]])
    grids = igt.face_grid[faces].tolist() if primary == "charts" else None
    found, bary, inside = igt.lookup(pts, grids)
    agree = (found == faces).mean()
    if primary == "charts":
        # Each chart's projection is bijective and affine: every point is found, with its own
        # barycentrics (measured: 100%, 2e-5 from float32 corners).
        assert agree == 1.0 and inside.all()
        assert np.abs(bary - lam).max() < 1e-3
    else:
        # The bunny is not star-shaped (ears, folds): a sphere's rays meet it more than once,
        # so the spherical map cannot be bijective (measured 82.9% agreement).
        assert 0.78 <= agree < 0.9, agree


def test_simplified_faces_project_into_their_detailed_charts() -> None:
    igt = _igt("charts", 512)
    low = gt.igt.simplify(igt, 1400)
    assert 1300 <= len(low) <= 1400 and low.face_grid.min() >= 0
    # Centroids of the simplified faces, looked up in their grid: found inside a listed
    # detailed triangle (not the fallback) for nearly all (measured 99.8%).
    c = low.vertices[low.faces].mean(axis=1)
    found, _, inside = igt.lookup(c, low.face_grid.tolist())
    assert (found >= 0).all()
    assert inside.mean() >= 0.99, inside.mean()


def test_files_round_trip_and_damage_is_a_format_error(tmp_path: Path) -> None:
    igt = _igt()
    path = tmp_path / "bunny.gtigt"
    igt.save(path)
    back = gt.igt.load(path)
    for name in ["cell_start", "cell_entries", "entry_face", "entry_corners", "normals", "faces"]:
        assert np.array_equal(getattr(back, name), getattr(igt, name)), name
    assert back.stats["list_mean"] == igt.stats["list_mean"]
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x10
    with pytest.raises(gt.FormatError, match="checksum"):
        gt.igt.InverseGeometricTexture.from_bytes(bytes(data))
    with pytest.raises(gt.FormatError, match="truncated"):
        gt.igt.InverseGeometricTexture.from_bytes(bytes(path.read_bytes()[:-5]))
    with pytest.raises(gt.FormatError, match="not a .gtigt"):
        gt.igt.InverseGeometricTexture.from_bytes(b"GTEX\r\n\x1a\n" + bytes(40))


def test_bad_input_raises_parameter_errors() -> None:
    mesh = _bunny_mesh()
    for bad in [0, -3, 100_000]:
        with pytest.raises(gt.ParameterError, match="resolution"):
            gt.igt.build(mesh, resolution=bad)
    with pytest.raises(gt.ParameterError, match="primary"):
        gt.igt.build(mesh, primary="octahedral")  # type: ignore[arg-type]
    with pytest.raises(gt.ParameterError, match="attributes"):
        gt.igt.build(mesh, attributes=["ambient"])
    igt = _igt()
    with pytest.raises(gt.ParameterError, match="grid"):
        igt.lookup(np.zeros((2, 3)))
    with pytest.raises(gt.ParameterError, match="grid id"):
        igt.lookup(np.zeros((2, 3)), [0, 10**6])
    with pytest.raises(gt.ParameterError, match="target_faces"):
        gt.igt.simplify(igt, 2)
    with pytest.raises(gt.ParameterError, match="grid"):
        igt.shade(np.eye(3), np.array([[0, 1, 2]]), [len(igt.grids["origin"])])


def test_progress_reports_and_can_cancel() -> None:
    mesh = _bunny_mesh()
    seen: list[str] = []
    gt.igt.build(mesh, resolution=64, progress=lambda s, f: seen.append(s))
    assert "partition" in seen and "lists" in seen
    with pytest.raises(gt.CancelledError):
        gt.igt.build(mesh, resolution=64, progress=lambda s, f: s != "lists")
