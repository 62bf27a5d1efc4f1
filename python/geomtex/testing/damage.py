"""Damaged and transformed copies of a mesh, as real files carry them: STL triangle soup, reversed
triangles, scan holes, fins, slivers; and similarity transforms (scale, offset).

Each function returns a new :class:`geomtex.Mesh` and leaves its input alone; the random ones take
a seed so a failure can be replayed.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .._mesh import Mesh
from ._arrays import arrays


def similar(mesh: Mesh, scale: float = 1.0, offset: npt.ArrayLike = (0.0, 0.0, 0.0)) -> Mesh:
    """The mesh scaled about the origin, then translated (float64 throughout)."""
    v, f = arrays(mesh)
    return Mesh(v * scale + np.asarray(offset, np.float64), f)


def soup(mesh: Mesh) -> Mesh:
    """Every face with its own three vertices, as STL stores them: no index is shared."""
    v, f = arrays(mesh)
    return Mesh(v[f.ravel()], np.arange(f.size).reshape(-1, 3))


def flip_faces(mesh: Mesh, fraction: float, seed: int = 0) -> tuple[Mesh, npt.NDArray[np.int64]]:
    """The mesh with a random ``fraction`` of its faces wound the other way; also which ones."""
    v, f = arrays(mesh)
    picked = np.sort(np.random.default_rng(seed).choice(len(f), round(fraction * len(f)), replace=False))
    f = f.copy()
    f[picked] = f[picked][:, ::-1]
    return Mesh(v, f), picked


def punch_holes(mesh: Mesh, fraction: float, holes: int = 40, seed: int = 0) -> Mesh:
    """The mesh less ``fraction`` of its faces, taken as ``holes`` round holes around random
    faces."""
    v, f = arrays(mesh)
    centroids = v[f].mean(axis=1)
    rng = np.random.default_rng(seed)
    centres = centroids[rng.choice(len(f), holes, replace=False)]
    distance = np.full(len(f), np.inf)
    for c in centres:  # one centre at a time: (faces x holes) distances would not fit a 1M mesh
        distance = np.minimum(distance, np.linalg.norm(centroids - c, axis=1))
    return Mesh(v, f[distance > np.quantile(distance, fraction)])


def add_fins(mesh: Mesh, count: int, height: float = 0.01, seed: int = 0) -> Mesh:
    """The mesh plus ``count`` fins: triangles standing on existing edges, so each such edge is
    shared by three faces (non-manifold). ``height`` is a fraction of the diagonal."""
    v, f = arrays(mesh)
    rng = np.random.default_rng(seed)
    edges = f[rng.choice(len(f), count, replace=False)][:, :2]
    lo, hi = v.min(axis=0), v.max(axis=0)
    up = rng.normal(size=(count, 3))
    up *= (height * np.linalg.norm(hi - lo) / np.linalg.norm(up, axis=1))[:, None]
    apex = v[edges].mean(axis=1) + up
    fins = np.column_stack([edges, len(v) + np.arange(count)])
    return Mesh(np.vstack([v, apex]), np.vstack([f, fins]))


def add_slivers(mesh: Mesh, fraction: float, zero_area: int = 0, seed: int = 0) -> Mesh:
    """Splits a random ``fraction`` of the faces in two at a point 1e-9 of an edge from a corner
    (a needle and a near-copy, with a T-junction on the neighbour), then appends ``zero_area``
    faces with a repeated vertex."""
    v, f = arrays(mesh)
    rng = np.random.default_rng(seed)
    picked = rng.choice(len(f), round(fraction * len(f)), replace=False)
    a, b, c = f[picked].T
    split = len(v) + np.arange(len(picked))
    points = v[a] * (1 - 1e-9) + v[b] * 1e-9
    degenerate = f[rng.choice(len(f), zero_area)][:, [0, 0, 1]]
    faces = np.vstack([np.delete(f, picked, axis=0), np.column_stack([a, split, c]),
                       np.column_stack([split, b, c]), degenerate])
    return Mesh(np.vstack([v, points]), faces)
