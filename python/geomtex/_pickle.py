"""Pickling for every public object, so a scheduler (Dask, multiprocessing) can ship them.

Each object is stored as what it is made of, never as a pointer: a set as the bytes of its .gtex
file (checksummed, exact), surfels as their .gtsurf bytes (the set and tile size), an inverse
geometric texture as its .gtigt bytes, a mesh shaded through one as that texture, its arrays and
its faces' grids, a mesh as its arrays, a displacement shell the renderer draws (the
``_core.GdmShell`` a Scene holds) as its prisms' arrays, its volume and its lookup table, a
volume as its occupancy and colors, a camera as its pose and projection numbers, a scene as its
objects and placements, a frame as its arrays. (geomtex.gdm's Volume and Shell and the lights
are plain Python objects that pickle by their own state.) A renderer holds a GPU device, which
cannot travel: pickling one stores its image size and the other side makes a renderer of its own.

The restore functions live here (a module pickle can name) and check what they are given as the
public constructors do, so a damaged pickle raises a GeomtexError rather than building a broken
object.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np

from . import _core


def restore_set(data: bytes) -> _core.GeometryTextureSet:
    return _core.GeometryTextureSet.from_bytes(data)


def restore_surfels(data: bytes) -> _core.Surfels:
    return _core.Surfels.from_bytes(data)


def restore_igt(data: bytes) -> _core.InverseGeometricTexture:
    return _core.InverseGeometricTexture.from_bytes(data)


def restore_igt_mesh(igt: _core.InverseGeometricTexture, vertices: Any, faces: Any, face_grid: Any,
                     lookup: str | None = None, samples: int | None = None,
                     lod: str | float | None = None) -> _core.IgtMesh:
    # Older pickles carry no lookup, samples or LoD: they get the defaults.
    return igt.shade(vertices, faces, [int(g) for g in face_grid], lookup=lookup, samples=samples, lod=lod)


def restore_mesh(*arrays: Any) -> Any:
    from ._mesh import Mesh

    return Mesh(*arrays)


def restore_gdm_volume(occupancy: Any, colors: Any) -> _core.GdmVolume:
    # Its seams were checked when it was first made.
    return _core.GdmVolume(np.ascontiguousarray(occupancy, dtype=np.uint8), colors, False)


def restore_gdm_shell(*state: Any) -> _core.GdmShell:
    return _core.GdmShell(*state)


def restore_camera(kind: str, world_from_camera: Any, numbers: list[float], near: float | None) -> _core.Camera:
    return _core.Camera._from_state(kind, world_from_camera, numbers, near)


Normals = Literal["crease", "smooth", "flat"]


def restore_scene(objects: list[tuple[Any, Any, Normals | None, float | None]]) -> Any:
    from ._render import Scene

    scene = Scene()
    for obj, world_from_object, normals, crease_angle in objects:
        scene.add(obj, world_from_object, normals=normals, crease_angle=crease_angle)
    return scene


def restore_renderer(width: int, height: int) -> Any:
    from ._render import Renderer

    return Renderer(width, height)


def restore_frame(*arrays: Any) -> _core.Frame:
    return _core.Frame._from_arrays(*arrays)


def _reduce_set(self: _core.GeometryTextureSet) -> tuple[Any, ...]:
    return restore_set, (self.to_bytes(),)


def _reduce_surfels(self: _core.Surfels) -> tuple[Any, ...]:
    return restore_surfels, (self.to_bytes(),)


def _reduce_igt(self: _core.InverseGeometricTexture) -> tuple[Any, ...]:
    return restore_igt, (self.to_bytes(),)


def _reduce_igt_mesh(self: _core.IgtMesh) -> tuple[Any, ...]:
    return restore_igt_mesh, (self.igt, self.vertices, self.faces, self.face_grid, self.lookup, self.samples,
                              self.lod)


def _reduce_mesh(self: _core.Mesh) -> tuple[Any, ...]:
    return restore_mesh, (self.vertices, self.faces, self.vertex_colors, self.face_colors, self.uv, self.texture)


def _reduce_gdm_volume(self: _core.GdmVolume) -> tuple[Any, ...]:
    colors = self.colors
    return restore_gdm_volume, (self.occupancy, None if colors is None else colors.reshape(self.size + (4,)))


def _reduce_gdm_shell(self: _core.GdmShell) -> tuple[Any, ...]:
    return restore_gdm_shell, self._state()


def _reduce_camera(self: _core.Camera) -> tuple[Any, ...]:
    return restore_camera, self._state()


def _reduce_scene(self: _core.Scene) -> tuple[Any, ...]:
    return restore_scene, (self._objects(),)


def _reduce_renderer(self: _core.Renderer) -> tuple[Any, ...]:
    return restore_renderer, (self.width, self.height)


def _reduce_frame(self: _core.Frame) -> tuple[Any, ...]:
    return restore_frame, (*self._arrays(), self.shadow, self.stats, self.face_id, self.barycentric, self.width,
                           self.height)


def install() -> None:
    """Attaches `__reduce__` to the extension's classes (their Python subclasses inherit it)."""
    for cls, reduce in [(_core.GeometryTextureSet, _reduce_set), (_core.Mesh, _reduce_mesh),
                        (_core.Camera, _reduce_camera), (_core.Scene, _reduce_scene),
                        (_core.Renderer, _reduce_renderer), (_core.Frame, _reduce_frame),
                        (_core.Surfels, _reduce_surfels), (_core.InverseGeometricTexture, _reduce_igt),
                        (_core.IgtMesh, _reduce_igt_mesh), (_core.GdmVolume, _reduce_gdm_volume),
                        (_core.GdmShell, _reduce_gdm_shell)]:
        setattr(cls, "__reduce__", reduce)
