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
    """Objects of every kind geomtex draws, each placed by a ``world_from_object`` 4x4 matrix.

    Sets, meshes, surfels, IGT meshes and displacement shells mix in one scene (trimesh objects
    and mesh files are read as meshes). Render it with :meth:`Renderer.render`, trace rays
    through it with `intersects_first`, `intersects_location` and `intersects_any`. ``Scene()``
    is empty; `add` fills it, and ``len(scene)`` counts what was added. Pickles with its
    objects.

    Examples
    --------
    >>> scene = gt.Scene()
    >>> scene.add(gts)                                   # identity placement
    >>> scene.add("bunny.obj", np.diag([2.0, 2.0, 2.0, 1.0]), normals="flat")
    >>> frame = gt.Renderer(512, 512).render(scene, camera)
    """

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
        """Adds an object to the scene.

        Parameters
        ----------
        obj : GeometryTextureSet, Mesh, Surfels, igt.IgtMesh, gdm.Shell, trimesh or path
            What to add; a ``trimesh.Trimesh``, ``trimesh.Scene`` or mesh path is read as a
            :class:`Mesh` once, here.
        world_from_object : (4, 4) array-like, optional
            Its placement (default identity): affine (last row 0, 0, 0, 1), invertible and
            finite.
        normals : {"crease", "smooth", "flat"}, optional
            Meshes only (the other kinds carry their own normals): the same rule as
            :func:`convert`'s. ``"crease"`` (default) smooths within a surface and splits at
            edges whose faces' normals differ by `crease_angle` degrees or more; ``"smooth"``
            averages across every edge; ``"flat"`` gives each face its own normal.
        crease_angle : float, optional
            Meshes only: degrees, in (0, 180] (default 20).

        Returns
        -------
        int
            The object's index among everything added, sets included. (``Frame.patch_id``
            numbers only the meshes, IGT meshes and shells, -2 - k in the order added.)

        Raises
        ------
        ParameterError
            A matrix that is not affine, invertible and finite, normals keywords for a kind
            that is not a mesh, or a value out of range.
        MeshError
            `obj` is no kind the renderer draws, or an unusable mesh.
        """
        placement = None if world_from_object is None else _check.affine("world_from_object", world_from_object)
        kind, item = _kinds.adopt(obj)
        index: int = self._core.add(kind.core_of(item), placement, normals=normals, crease_angle=crease_angle)
        self._items.append(item)
        return index

    def __len__(self) -> int:
        return len(self._items)

    def _merge_distance(self) -> float:
        """The largest texel of the scene's sets, stretched by their placements; 0 without sets."""
        merge = 0.0
        for item, pose, _, _ in self._objects():
            size = getattr(item, "texel_size", None)
            if isinstance(size, float):
                merge = max(merge, size * float(np.linalg.norm(pose[:3, :3], axis=0).max()))
        return merge

    def _objects(self) -> list[Placed]:
        """The scene's objects in order, as pickling stores them: (object, world_from_object
        (4, 4), normals, crease_angle), the last two None for any kind but meshes. An object added
        twice is the same Python object both times, so it is stored once."""
        placed = self._core._objects()  # the placements and normal rules as the extension holds them
        return [(item, pose, normals, crease) for item, (_, pose, normals, crease) in zip(self._items, placed)]

    def __repr__(self) -> str:
        return f"<geomtex.Scene {_kinds.describe(self._items) or 'empty'}>"
