"""Independent references for checking geomtex: distances computed by trimesh/scipy on the
original mesh, never by geomtex itself.

Units: everything is returned in the mesh's own units unless a name says ``_rel`` (divided by
the bounding-box diagonal).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

# trimesh's triangle closest-point test compares products of squared edge lengths with an
# absolute tolerance (~1e-12), so millimetre triangles in metre units land in the wrong Voronoi
# region and come back up to a triangle-size away. Distances scale linearly, so we measure on a
# copy scaled to this diagonal and scale back.
_REFERENCE_DIAGONAL = 1000.0


def _trimesh(mesh: Any) -> Any:
    import trimesh

    if isinstance(mesh, trimesh.Trimesh):
        return mesh
    return trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), process=False)


def diagonal(mesh: Any) -> float:
    tm = _trimesh(mesh)
    return float(np.linalg.norm(tm.bounds[1] - tm.bounds[0]))


def points_to_mesh(points: npt.ArrayLike, mesh: Any) -> npt.NDArray[np.float64]:
    """Exact distance from each point to the mesh surface (trimesh closest_point)."""
    import trimesh

    tm = _trimesh(mesh)
    pts = np.asarray(points, dtype=np.float64)
    centre = tm.bounds.mean(axis=0)
    k = _REFERENCE_DIAGONAL / max(diagonal(tm), 1e-300)
    scaled = trimesh.Trimesh((tm.vertices - centre) * k, tm.faces, process=False)
    _, d, _ = trimesh.proximity.closest_point(scaled, (pts - centre) * k)
    return np.asarray(d, dtype=np.float64) / k


def mesh_to_points(mesh: Any, points: npt.ArrayLike, samples: int = 200_000, seed: int = 1) -> npt.NDArray[np.float64]:
    """Distance from area-uniform samples of the mesh surface to the nearest of ``points``
    (how well the points cover the surface)."""
    import trimesh
    from scipy.spatial import cKDTree

    tm = _trimesh(mesh)
    samp, _ = trimesh.sample.sample_surface(tm, samples, seed=seed)
    d, _ = cKDTree(np.asarray(points, dtype=np.float64)).query(samp)
    return np.asarray(d, dtype=np.float64)
