"""Open3D's ``RaycastingScene`` as a ray-casting peer, run as its users run it: the scene (its
Embree BVH) built once per mesh and kept, warmed by one cast, every core (``nthreads=0``). Open3D
is optional (``pip install open3d-cpu``; not in the bench extra: it brings Dash, whose pytest
plugin the test run does not want): ``open3d_caster`` returns None without it and the benches
leave its columns out.

Rays go in as one float32 (N, 6) tensor of origins and unit directions; a frame's rays are the
camera's own (``camera.rays``), made before the clock starts, so Open3D is not charged for ray
generation while geomtex's frames are (it makes them in the shader): the ratio leans its way.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

import geomtex as gt


class Open3dCaster:
    """A kept ``RaycastingScene`` over one mesh."""

    def __init__(self, mesh: gt.Mesh) -> None:
        import open3d as o3d

        self._o3d = o3d
        self.version = o3d.__version__
        t0 = time.perf_counter()
        self.scene = o3d.t.geometry.RaycastingScene(nthreads=0)
        self.scene.add_triangles(o3d.core.Tensor(np.asarray(mesh.vertices, np.float32)),
                                 o3d.core.Tensor(np.asarray(mesh.faces, np.uint32)))
        self.first_distances(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))  # builds the BVH
        self.build_s = time.perf_counter() - t0
        self.threads = os.cpu_count()

    def tensor(self, origins: np.ndarray, directions: np.ndarray) -> Any:
        rays = np.hstack([np.asarray(origins, np.float32).reshape(-1, 3),
                          np.asarray(directions, np.float32).reshape(-1, 3)])
        return self._o3d.core.Tensor(rays)

    def cast(self, rays: Any) -> Any:
        return self.scene.cast_rays(rays, nthreads=0)

    def first_distances(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """(N,) distance to the first hit along unit directions; inf on a miss."""
        return self.cast(self.tensor(origins, directions))["t_hit"].numpy().astype(np.float64)


def open3d_caster(mesh: gt.Mesh) -> Open3dCaster | None:
    try:
        return Open3dCaster(mesh)
    except ImportError:
        return None


def time_open3d_frame(caster: Open3dCaster, cam: gt.Camera, size: int, repeats: int,
                      warm: int = 3) -> tuple[np.ndarray, dict[str, Any]]:
    """``cast_rays`` of the camera's size x size pixel rays after ``warm`` untimed casts: the
    z-depth image (inf on a miss) and the median wall time."""
    origins, directions = cam.rays(size, size)
    rays = caster.tensor(origins, directions)
    for _ in range(warm):
        caster.cast(rays)
    walls = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        ans = caster.cast(rays)
        walls.append(1e3 * (time.perf_counter() - t0))
    t = ans["t_hit"].numpy().astype(np.float64).reshape(size, size)
    depth = t * (directions @ np.asarray(cam.forward, np.float64))
    return depth, {"wall_ms": float(np.median(walls)), "wall_ms_runs": walls, "threads": caster.threads}
