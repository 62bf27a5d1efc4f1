"""Cameras and rays placed relative to a mesh, for tests and benchmarks that look at it from a
direction or cast rays at it."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .._camera import Camera
from .._mesh import Mesh


def look_from(mesh: Mesh, direction: npt.ArrayLike, distance: float = 1.7, yfov_deg: float = 40.0,
              up: npt.ArrayLike | None = None) -> Camera:
    """A camera ``distance`` diagonals from the bounding-box centre along ``direction``, looking
    back at the centre; ``up`` defaults to +z unless the view is near vertical, then +y. A y-up
    mesh (most scans, the Stanford bunny among them) shows upright with ``up=(0, 1, 0)``; the
    default stays +z because the tests' and benchmarks' recorded views were taken with it."""
    lo, hi = (np.asarray(b, np.float64) for b in mesh.bounds)
    centre = (lo + hi) / 2
    d = np.asarray(direction, np.float64)
    d = d / np.linalg.norm(d)
    if up is None:
        up = (0.0, 0.0, 1.0) if abs(d[2]) < 0.9 else (0.0, 1.0, 0.0)
    return Camera.look_at(centre + d * distance * mesh.diagonal, centre, up=tuple(np.asarray(up, np.float64)),
                          yfov_deg=yfov_deg)


def rays_around(mesh: Mesh, n: int, seed: int = 3) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """``n`` rays from random points on a sphere (radius one diagonal) about the bounding-box
    centre toward random points in the box: (origins, unit directions), each (n, 3)."""
    lo, hi = (np.asarray(b, np.float64) for b in mesh.bounds)
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 3))
    origins = (lo + hi) / 2 + u / np.linalg.norm(u, axis=1, keepdims=True) * mesh.diagonal
    d = lo + rng.random((n, 3)) * (hi - lo) - origins
    return origins, d / np.linalg.norm(d, axis=1, keepdims=True)
