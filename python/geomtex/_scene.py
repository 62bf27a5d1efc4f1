"""`Scene`: objects of every kind the renderer draws, each placed by a matrix."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from . import _check, _core, _kinds
from ._bridge import Wrapped
from ._rays import RayQueries

Normals = Literal["crease", "smooth", "flat"]
#: An object as a scene holds it: (object, world_from_object (4, 4), normals, crease_angle).
Placed = tuple[Any, npt.NDArray[np.float64], "str | None", "float | None"]


class Scene(RayQueries, Wrapped):
    """Objects of every kind geomtex draws (sets, meshes, surfels, IGT meshes, displacement
    shells; trimesh objects and mesh files are read as meshes), each placed by a
    ``world_from_object`` 4x4 matrix. Render it with ``Renderer.render``, trace rays through it
    with ``intersects_first`` / ``intersects_location`` / ``intersects_any``."""

    _core: _core.Scene

    def __init__(self) -> None:
        self._core = _core.Scene()
        #: The objects as added (a trimesh or a path as the Mesh read from it), in order.
        self._items: list[Any] = []

    def __reduce__(self) -> tuple[Any, ...]:
        from ._pickle import restore_scene

        return restore_scene, (self._objects(),)

    def add(self, obj: Any, world_from_object: npt.ArrayLike | None = None, *, normals: Normals | None = None,
            crease_angle: float | None = None) -> int:
        """Adds `obj` (a set, Mesh, Surfels, IgtMesh, gdm.Shell, trimesh, trimesh.Scene or mesh
        path) placed by `world_from_object` (any 4x4 array-like, default identity); returns its
        index.

        A mesh is shaded by the same rule as ``convert``: ``normals="crease"`` (default) smooths
        within a surface and splits at edges whose faces' normals differ by ``crease_angle``
        degrees or more (default 20, in (0, 180]); ``"smooth"`` averages across every edge;
        ``"flat"`` gives each face its own normal. (The other kinds carry their own normals:
        these keywords are for meshes only.)

        `world_from_object` must be affine (last row 0, 0, 0, 1), invertible and finite; any
        other matrix is a ParameterError."""
        placement = None if world_from_object is None else _check.affine("world_from_object", world_from_object)
        kind, item = _kinds.adopt(obj)
        index: int = self._core.add(kind.core_of(item), placement, normals=normals, crease_angle=crease_angle)
        self._items.append(item)
        return index

    def __len__(self) -> int:
        return len(self._items)

    def _objects(self) -> list[Placed]:
        """The scene's objects in order, as pickling stores them: (object, world_from_object
        (4, 4), normals, crease_angle), the last two None for any kind but meshes. An object added
        twice is the same Python object both times, so it is stored once."""
        placed = self._core._objects()  # the placements and normal rules as the extension holds them
        return [(item, pose, normals, crease) for item, (_, pose, normals, crease) in zip(self._items, placed)]

    def __repr__(self) -> str:
        return f"<geomtex.Scene {_kinds.describe(self._items) or 'empty'}>"
