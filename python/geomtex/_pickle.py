"""Pickling for every public object, so a scheduler (Dask, multiprocessing) can ship them.

Each object is stored as what it is made of, never as a pointer: a set as the bytes of its .gtex
file (checksummed, exact), surfels as their .gtsurf bytes (the set and tile size), an inverse
geometric texture as its .gtigt bytes, a mesh shaded through one as that texture, its arrays and
its faces' grids, a mesh as its arrays, a displacement shell as its attributes (its volume as its
occupancy and colors), a camera as its pose and projection numbers, a scene as its objects and
placements, a frame as its arrays. The lights are plain Python objects that pickle by their own
state. A renderer holds a GPU device, which cannot travel: pickling one stores its image size and
the other side makes a renderer of its own.

Who says how: the kinds a Scene draws pickle through their row of the kinds table (geomtex._kinds,
which registers each with copyreg); the other classes by their own ``__reduce__``. Either way the
restore functions live here (a module pickle can name, so their names stay as they are) and check
what they are given as the public constructors do, so a damaged pickle raises a GeomtexError
rather than building a broken object.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

if TYPE_CHECKING:
    from ._camera import Camera
    from ._frame import Frame
    from ._igt import IgtMesh, InverseGeometricTexture
    from ._mesh import Mesh
    from ._render import Renderer
    from ._scene import Scene
    from ._set import GeometryTextureSet
    from ._surfels import Surfels
    from .gdm import Shell

# The classes are imported where used: this module is imported by the modules defining them.


def restore_set(data: bytes) -> GeometryTextureSet:
    from ._set import GeometryTextureSet

    return GeometryTextureSet.from_bytes(data)


def restore_surfels(data: bytes) -> Surfels:
    from ._surfels import Surfels

    return Surfels.from_bytes(data)


def restore_igt(data: bytes) -> InverseGeometricTexture:
    from ._igt import InverseGeometricTexture

    return InverseGeometricTexture.from_bytes(data)


def restore_igt_mesh(igt: InverseGeometricTexture, vertices: Any, faces: Any, face_grid: Any,
                     lookup: str | None = None, samples: int | None = None,
                     lod: str | float | None = None) -> IgtMesh:
    # Older pickles carry no lookup, samples or LoD: they get the defaults.
    return igt.shade(vertices, faces, [int(g) for g in face_grid], lookup=lookup, samples=samples, lod=lod)


def mesh_arrays(mesh: Mesh) -> tuple[Any, ...]:
    """What a mesh is made of, in `restore_mesh`'s order."""
    return mesh.vertices, mesh.faces, mesh.vertex_colors, mesh.face_colors, mesh.uv, mesh.texture


def restore_mesh(*arrays: Any) -> Mesh:
    from ._mesh import Mesh

    return Mesh(*arrays)


def restore_shell(state: dict[str, Any]) -> Shell:
    from .gdm import Shell

    return Shell._from_state(state)


def restore_camera(kind: str, world_from_camera: Any, numbers: list[float], near: float | None) -> Camera:
    from ._camera import Camera

    return Camera._from_state(kind, world_from_camera, numbers, near)


Normals = Literal["crease", "smooth", "flat"]


def restore_scene(objects: list[tuple[Any, Any, Normals | None, float | None]]) -> Scene:
    from ._scene import Scene

    scene = Scene()
    for obj, world_from_object, normals, crease_angle in objects:
        scene.add(obj, world_from_object, normals=normals, crease_angle=crease_angle)
    return scene


def restore_renderer(width: int, height: int, device: str = "auto") -> Renderer:
    from ._render import Renderer

    return Renderer(width, height, device=device)  # type: ignore[arg-type]


def restore_frame(*arrays: Any) -> Frame:
    from ._frame import Frame

    return Frame._from_arrays(*arrays)
