"""The renderer's Python face: `Scene` and `Renderer` accept anything `as_mesh` reads (trimesh
objects, mesh files) besides geomtex objects, turning it into a Mesh before the extension sees it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from . import _check, _core
from ._errors import ParameterError
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
    """Parallel light travelling along ``direction`` (world space, three finite numbers, any
    length but zero): pass it as ``render(..., light=...)`` for shadows."""

    direction: npt.ArrayLike

    def __post_init__(self) -> None:
        object.__setattr__(self, "direction", _check.direction("direction", self.direction))


@dataclass(frozen=True)
class PointLight:
    """Light from ``position`` (world space, three finite numbers): pass it as
    ``render(..., light=...)`` for shadows."""

    position: npt.ArrayLike

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _check.vector("position", self.position))


def check_light(light: Any) -> None:
    """`render`'s ``light``: None, or a DirectionalLight or PointLight (or any object with a
    ``direction`` or a ``position``) whose vector is finite, a direction non-zero. Checked again
    here: a light's array can be changed in place after it was made."""
    if light is None:
        return
    if hasattr(light, "direction"):
        _check.direction("light.direction", light.direction)
    elif hasattr(light, "position"):
        _check.vector("light.position", light.position)
    else:
        raise _check.fail("light", "a geomtex.DirectionalLight or PointLight", light)


#: Renderer.render's keywords by the kind of value each takes (the extension checks ranges).
_RENDER_KEYWORDS = {
    "quality": "text", "method": "text", "primary": "text", "count_fetches": "flag", "lod": "flag",
    "steps_per_texel": "real", "max_pixel_error": "real", "min_linear_steps": "int", "max_linear_steps": "int",
    "binary_steps": "int", "max_traversal_steps": "int", "background": "rgba", "light": "light",
    "outputs": "names",
}


def check_render_options(options: dict[str, Any]) -> None:
    """`Renderer.render`'s keywords: known names, each of the right kind of value (None is every
    keyword's default); the light checked in full. For callers that cannot wait for the
    extension's own checks (a batch job checks them before any worker starts)."""
    for name, value in options.items():
        kind = _RENDER_KEYWORDS.get(name)
        if kind is None:
            raise ParameterError(f"unknown render keyword {name!r}; Renderer.render takes "
                                 + ", ".join(sorted(_RENDER_KEYWORDS)))
        if value is None:
            continue
        if kind == "text" and not isinstance(value, str):
            raise _check.fail(name, "a str", value)
        if kind == "names" and not (isinstance(value, str)
                                    or (isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value))):
            raise _check.fail(name, "a str or a sequence of str", value)
        if kind == "flag":
            _check.flag(name, value)
        elif kind in ("real", "int"):
            _check.number(name, value, float if kind == "real" else int)
        elif kind == "rgba":
            _check.rgba(name, value)
        elif kind == "light":
            check_light(value)


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
        converted: these keywords are for meshes only.)

        `world_from_object` must be affine (last row 0, 0, 0, 1), invertible and finite; any
        other matrix is a ParameterError."""
        placement = None if world_from_object is None else _check.affine("world_from_object", world_from_object)
        drawn = renderable(obj)
        index: int = super().add(drawn, placement, normals=normals, crease_angle=crease_angle)
        bounds = getattr(obj, "bounds", None)
        if isinstance(drawn, _core.GdmShell) and bounds is not None:
            # The extension's shell keeps no extent the viewer could read: remember the shell's.
            self.__dict__.setdefault("_extents", {})[index] = np.asarray(bounds, dtype=np.float64)
        return index


class Renderer(_core.Renderer):
    """A headless renderer of an image size (``resize`` changes it). Every Renderer of a process
    shares one GPU device, its pipelines and the objects uploaded to it: making a second
    Renderer, drawing at a second size or tracing rays costs no new device and no new upload.
    See ``render`` for the keywords."""

    def render(self, obj: Any, camera: _core.Camera, **options: Any) -> _core.Frame:
        check_render_options(options)
        return super().render(renderable(obj), camera, **options)


Renderer.render.__doc__ = _core.Renderer.render.__doc__


#: This process's renderers, one per image size, kept for its life. Every Renderer shares the
#: process's one device and its uploads, so these cost no device each: one per size keeps threads
#: drawing at different sizes from resizing one another's renderer.
_SHARED: dict[tuple[int, int], Renderer] = {}


def shared_renderer(width: int, height: int) -> Renderer:
    """This process's renderer of that size, made on first use and kept."""
    r = _SHARED.get((width, height))
    if r is None:
        r = _SHARED[(width, height)] = Renderer(width, height)
    return r
