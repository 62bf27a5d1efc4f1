"""The renderer's Python face: `Scene` and `Renderer` accept anything `as_mesh` reads (trimesh
objects, mesh files) besides geomtex objects, turning it into a Mesh before the extension sees it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from . import _core
from ._mesh import as_mesh

_NATIVE = (_core.Scene, _core.GeometryTextureSet, _core.Mesh, _core.Surfels, _core.GdmShell, _core.IgtMesh)


def renderable(obj: Any) -> Any:
    """`obj` itself if the extension draws it, else a Mesh made from it."""
    core_shell = getattr(obj, "_core_shell", None)  # a geomtex.gdm.Shell
    if core_shell is not None:
        return core_shell()
    return obj if isinstance(obj, _NATIVE) else as_mesh(obj)


@dataclass(frozen=True)
class DirectionalLight:
    """Parallel light travelling along ``direction`` (world space, any length but zero): pass it
    as ``render(..., light=...)`` for shadows."""

    direction: npt.ArrayLike

    def __post_init__(self) -> None:
        object.__setattr__(self, "direction", np.asarray(self.direction, dtype=np.float64).copy())


@dataclass(frozen=True)
class PointLight:
    """Light from ``position`` (world space): pass it as ``render(..., light=...)`` for shadows."""

    position: npt.ArrayLike

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", np.asarray(self.position, dtype=np.float64).copy())


class Scene(_core.Scene):
    """Geometry-texture sets and meshes (geomtex, trimesh or a file path), each placed by a
    ``world_from_object`` 4x4 matrix."""

    def add(self, obj: Any, world_from_object: npt.ArrayLike | None = None, *,
            normals: Literal["crease", "smooth", "flat"] | None = None,
            crease_angle: float | None = None) -> int:
        """Adds `obj` (a set, Mesh, trimesh, trimesh.Scene or mesh path) placed by
        `world_from_object` (any 4x4 array-like, default identity); returns its index.

        A mesh is shaded by the same rule as ``convert``: ``normals="crease"`` (default) smooths
        within a surface and splits at edges whose faces' normals differ by ``crease_angle``
        degrees or more (default 20, in (0, 180]); ``"smooth"`` averages across every edge;
        ``"flat"`` gives each face its own normal. (A set's normals were chosen when it was
        converted: these keywords are for meshes only.)"""
        return super().add(renderable(obj), world_from_object, normals=normals, crease_angle=crease_angle)


class Renderer(_core.Renderer):
    """A headless renderer of a fixed image size; reuse it (device, targets and uploaded
    textures are kept between frames). See ``render`` for the keywords."""

    def render(self, obj: Any, camera: _core.Camera, **options: Any) -> _core.Frame:
        return super().render(renderable(obj), camera, **options)


Renderer.render.__doc__ = _core.Renderer.render.__doc__


#: This process's renderers, one per image size, kept for its life: a GPU device and its uploads
#: are dear to make and cheap to keep (notebook pictures, the viewer and batch workers share them).
_SHARED: dict[tuple[int, int], Renderer] = {}


def shared_renderer(width: int, height: int) -> Renderer:
    """This process's renderer of that size, made on first use and kept."""
    r = _SHARED.get((width, height))
    if r is None:
        r = _SHARED[(width, height)] = Renderer(width, height)
    return r
