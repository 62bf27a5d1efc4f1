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


def raycast(mesh: Any, camera: Any, width: int, height: int) -> dict[str, npt.NDArray[Any]]:
    """First hits of the camera's pixel rays on the mesh, by trimesh (embreex when installed).

    Same conventions as ``Renderer.render``: row 0 at the top, ``depth`` is z-depth along the
    camera's forward axis (+inf on a miss), ``normal`` the hit triangle's unit normal (0 on a
    miss), ``hit`` a boolean mask, ``triangle`` the hit face (-1 on a miss).
    """
    tm = _trimesh(mesh)
    origins, directions = camera.rays(width, height)
    o = origins.reshape(-1, 3)
    d = directions.reshape(-1, 3)
    # Ray casting on a copy centred on the mesh: embree intersects in float32, so a model far
    # from the origin would lose its detail otherwise.
    centre = tm.bounds.mean(axis=0)
    local = type(tm)(tm.vertices - centre, tm.faces, process=False)
    locations, ray_index, tri_index = local.ray.intersects_location(o - centre, d, multiple_hits=False)
    depth = np.full(len(o), np.inf)
    normal = np.zeros((len(o), 3))
    triangle = np.full(len(o), -1, dtype=np.int64)
    # z-depth: the hit's distance from the ray's origin along the camera's forward axis (the
    # origin is the eye for perspective cameras and lies on the camera plane for orthographic).
    forward = np.asarray(camera.forward)
    depth[ray_index] = (locations + centre - o[ray_index]) @ forward
    normal[ray_index] = tm.face_normals[tri_index]
    triangle[ray_index] = tri_index
    shape = (height, width)
    return {
        "depth": depth.reshape(shape).astype(np.float32),
        "normal": normal.reshape(shape + (3,)).astype(np.float32),
        "hit": np.isfinite(depth).reshape(shape),
        "triangle": triangle.reshape(shape),
    }
