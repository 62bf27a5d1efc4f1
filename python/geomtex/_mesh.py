"""Mesh input: numpy arrays, trimesh objects and mesh files, checked before they reach Rust."""

from __future__ import annotations

import os
import warnings
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _core
from ._bridge import Wrapped, forward
from ._errors import FileError, FormatError, MeshError, ParameterError


def _as_real_array(a: Any, name: str, cols: int) -> npt.NDArray[Any]:
    try:
        arr = np.asarray(a)
    except Exception as e:  # ragged lists and the like
        raise MeshError(f"{name} could not be read as an array: {e}") from None
    if arr.dtype == object or arr.dtype.kind not in "fiub":
        raise MeshError(f"{name} must hold real numbers; got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != cols:
        raise MeshError(f"{name} must have shape (N, {cols}); got {arr.shape}")
    return arr


def _vertices(a: Any) -> npt.NDArray[np.float64]:
    arr = _as_real_array(a, "vertices", 3)
    if arr.dtype.kind == "b":
        raise MeshError("vertices must hold real numbers; got dtype bool")
    return np.ascontiguousarray(arr, dtype=np.float64)


def _faces(a: Any) -> npt.NDArray[np.int64]:
    arr = _as_real_array(a, "faces", 3)
    if arr.dtype.kind == "f":
        if arr.size and not np.all(np.isfinite(arr) & (arr == np.round(arr))):
            bad = int(np.argwhere(~(np.isfinite(arr) & (arr == np.round(arr))))[0][0])
            raise MeshError(f"faces must hold integer indices; face {bad} holds {arr[bad].tolist()}")
    elif arr.dtype.kind not in "iu":
        raise MeshError(f"faces must hold integer indices; got dtype {arr.dtype}")
    if arr.dtype == np.uint64 and arr.size and arr.max() > np.iinfo(np.int64).max:
        bad = int(np.argwhere(arr > np.iinfo(np.int64).max)[0][0])
        raise MeshError(f"face {bad} references vertex {int(arr[bad].max())}, far past any mesh")
    return np.ascontiguousarray(arr, dtype=np.int64)


def _rgba(a: Any, name: str, shape: tuple[int, ...]) -> npt.NDArray[np.uint8]:
    """RGBA8 from uint8 in [0, 255] or floats in [0, 1], the last axis 3 (alpha 255 added) or 4;
    `shape` is the expected shape without that axis."""
    try:
        arr = np.asarray(a)
    except Exception as e:
        raise MeshError(f"{name} could not be read as an array: {e}") from None
    if arr.dtype == object or arr.dtype.kind not in "fiu":
        raise MeshError(f"{name} must hold real numbers; got dtype {arr.dtype}")
    if arr.ndim == len(shape) + 1 and arr.shape[-1] == 3:
        opaque = 255 if arr.dtype.kind != "f" else 1.0
        arr = np.concatenate([arr, np.full(arr.shape[:-1] + (1,), opaque, arr.dtype)], axis=-1)
    if arr.ndim != len(shape) + 1 or arr.shape[-1] != 4:
        want = ", ".join(["N" if n < 0 else str(n) for n in shape] + ["3|4"])
        raise MeshError(f"{name} must have shape ({want}); got {arr.shape}")
    for axis, n in enumerate(shape):
        if n >= 0 and arr.shape[axis] != n:
            raise MeshError(f"{name} has {arr.shape[axis]} rows but the mesh has {n}")
    if arr.dtype.kind == "f":
        if not np.all(np.isfinite(arr)):
            raise MeshError(f"{name} holds NaN or inf")
        arr = np.round(np.clip(arr, 0.0, 1.0) * 255.0)
    elif arr.size and (arr.min() < 0 or arr.max() > 255):
        raise MeshError(f"integer {name} must lie in [0, 255]")
    return np.ascontiguousarray(arr, dtype=np.uint8)


def _colors(a: Any, name: str, n: int, unit: str) -> npt.NDArray[np.uint8] | None:
    if a is None:
        return None
    arr = np.asarray(a)
    if arr.ndim == 2 and arr.shape[1] in (3, 4) and arr.shape[0] != n:
        raise MeshError(f"{name} has {arr.shape[0]} rows but the mesh has {n} {unit}")
    return _rgba(arr, name, (n,))


def _uv(a: Any, n_vertices: int, n_faces: int) -> npt.NDArray[np.float64]:
    arr = np.asarray(a)
    if arr.dtype == object or arr.dtype.kind not in "fiu":
        raise MeshError(f"uv must hold real numbers; got dtype {arr.dtype}")
    if arr.shape == (n_vertices, 2) or arr.shape == (n_faces, 3, 2):
        return np.ascontiguousarray(arr, dtype=np.float64)
    raise MeshError(f"uv must have shape ({n_vertices}, 2) (per vertex) or ({n_faces}, 3, 2) (per face corner); "
                    f"got {arr.shape}")


def _image(image: Any) -> npt.NDArray[np.uint8]:
    """(H, W, 4) uint8 from a Pillow image (converted to RGBA, with a warning for modes other
    than RGB/RGBA) or an (H, W), (H, W, 3|4) array."""
    if hasattr(image, "mode") and hasattr(image, "convert"):
        if image.mode not in ("RGB", "RGBA"):
            _warn(f"texture image mode {image.mode!r} converted to RGBA")
        image = np.asarray(image.convert("RGBA"))
    arr = np.asarray(image)
    if arr.ndim == 2:
        arr = np.repeat(arr[:, :, None], 3, axis=2)
    return _rgba(arr, "texture", (-1, -1))


class AppearanceWarning(UserWarning):
    """A mesh's color source that geomtex cannot carry (UVs without an image, a texture without
    UVs, a converted image mode, a texture on a rasterized mesh...)."""


def _warn(message: str) -> None:
    warnings.warn(message, AppearanceWarning, stacklevel=3)


class Mesh(Wrapped, core=_core.Mesh):
    """A triangle mesh: ``Mesh(vertices (N, 3), faces (M, 3), vertex_colors=None,
    face_colors=None, uv=None, texture=None)``.

    Vertices may be any real dtype (stored as float64); faces any integer dtype; vertex colors
    (N, 3|4) and face colors (M, 3|4) as uint8 in [0, 255] or floats in [0, 1] (RGB gets alpha
    255). ``uv``: texture coordinates, (N, 2) per vertex or (M, 3, 2) per face corner, (0, 0) at
    the image's bottom-left, repeating outside [0, 1]; ``texture``: the image, (H, W, 3|4) uint8
    or float array with row 0 at the top, or a Pillow image. ``uv`` and ``texture`` come
    together; one alone is dropped with an :class:`AppearanceWarning`. Several sources: the
    texture wins, then face colors, then vertex colors (with a warning). Every problem raises
    :class:`MeshError` naming the vertex or face at fault. Degenerate (zero-area) faces are
    allowed and left out of conversion.
    """

    _core: _core.Mesh

    def __init__(self, vertices: Any, faces: Any, vertex_colors: Any = None, face_colors: Any = None,
                 uv: Any = None, texture: Any = None) -> None:
        v = _vertices(vertices)
        f = _faces(faces)
        c = _colors(vertex_colors, "vertex_colors", v.shape[0], "vertices")
        fc = _colors(face_colors, "face_colors", f.shape[0], "faces")
        if (uv is None) != (texture is None):
            _warn("texture coordinates without a texture image are dropped" if texture is None
                  else "a texture image without texture coordinates is dropped")
            uv = texture = None
        t = None if texture is None else _image(texture)
        u = None if uv is None else _uv(uv, v.shape[0], f.shape[0])
        sources = [n for n, x in [("texture", t), ("face_colors", fc), ("vertex_colors", c)] if x is not None]
        if len(sources) > 1:
            _warn(f"{' and '.join(sources)} given: {sources[0]} is used")
        self._core = _core.Mesh(v, f, c, fc, u, t)

    vertices = forward[npt.NDArray[np.float64]]("(N, 3) float64 vertex positions (a copy).")
    faces = forward[npt.NDArray[np.uint32]]("(M, 3) uint32 vertex indices (a copy).")
    vertex_colors = forward[npt.NDArray[np.uint8] | None]("(N, 4) uint8 RGBA vertex colors, or None.")
    face_colors = forward[npt.NDArray[np.uint8] | None]("(M, 4) uint8 RGBA face colors, or None.")
    uv = forward[npt.NDArray[np.float64] | None](
        "float64 texture coordinates, (N, 2) per vertex or (M, 3, 2) per face corner, or None.")
    texture = forward[npt.NDArray[np.uint8] | None](
        "(H, W, 4) uint8 RGBA texture image (row 0 at the top), or None.")
    textured = forward[bool]("Whether the mesh carries texture coordinates and a texture image.")
    n_vertices = forward[int]("Number of vertices.")
    n_faces = forward[int]("Number of faces.")
    diagonal = forward[float]("Length of the bounding-box diagonal.")
    bounds = forward[npt.NDArray[np.float64]]("(2, 3) float64: the bounding box's min and max corners.")

    @classmethod
    def from_trimesh(cls, mesh: Any) -> "Mesh":
        """From a ``trimesh.Trimesh`` or a ``trimesh.Scene`` (what ``trimesh.load`` returns for
        GLB and multi-object files, flattened with its node transforms into one mesh). Its
        visual is kept: vertex or face colors, or texture coordinates with the material's image
        (PBR baseColorTexture times baseColorFactor, or a simple material's image); a material
        with a flat color only gives that color. What cannot be carried is dropped with an
        :class:`AppearanceWarning`."""
        if _is_trimesh_scene(mesh):
            mesh = _flatten_scene(mesh)
        if not (hasattr(mesh, "vertices") and hasattr(mesh, "faces")):
            raise MeshError(f"expected a trimesh.Trimesh or trimesh.Scene, got {type(mesh).__name__}")
        colors = _trimesh_colors(getattr(mesh, "visual", None), len(mesh.faces))
        return cls(np.asarray(mesh.vertices), np.asarray(mesh.faces), **colors)

    def to_trimesh(self) -> Any:
        """As a ``trimesh.Trimesh`` (no processing, so indices stay as they are), with vertex
        or face colors, or per-vertex texture coordinates and the texture."""
        import trimesh

        tm = trimesh.Trimesh(self.vertices, self.faces, vertex_colors=self.vertex_colors,
                             face_colors=self.face_colors, process=False)
        uv, texture = self.uv, self.texture
        if uv is not None and texture is not None and uv.ndim == 2:
            from PIL import Image

            tm.visual = trimesh.visual.TextureVisuals(uv=uv, image=Image.fromarray(texture))
        elif uv is not None:
            _warn("per-corner texture coordinates are not carried to trimesh")
        return tm


def _trimesh_colors(visual: Any, n_faces: int) -> dict[str, Any]:
    """Keyword arguments of :class:`Mesh` for a trimesh visual."""
    kind = getattr(visual, "kind", None)
    if kind == "vertex":
        return {"vertex_colors": np.asarray(visual.vertex_colors)}
    if kind == "face":
        return {"face_colors": np.asarray(visual.face_colors)}
    if kind != "texture":
        return {}
    material = getattr(visual, "material", None)
    image, flat = _material_image(material)
    uv = getattr(visual, "uv", None)
    if image is not None and uv is not None and len(uv):
        return {"uv": np.asarray(uv), "texture": image}
    instead = "the material's flat color is used" if flat is not None else "no color is carried"
    if image is not None:
        _warn(f"the material's texture image has no texture coordinates; {instead}")
    elif uv is not None and len(uv):
        _warn(f"texture coordinates without a texture image; {instead}")
    if flat is None:
        return {}
    return {"face_colors": np.tile(np.asarray(flat, dtype=np.uint8)[:4], (n_faces, 1))}


def _material_image(material: Any) -> tuple[Any, Any]:
    """(RGBA image array or None, flat RGBA color or None) of a trimesh material."""
    if material is None:
        return None, None
    flat = getattr(material, "main_color", None)
    image = getattr(material, "baseColorTexture", None)
    if image is not None:
        factor = getattr(material, "baseColorFactor", None)
        rgba = _image(image)
        if factor is not None and np.any(np.asarray(factor) != 255):
            rgba = np.round(rgba * (np.asarray(factor, dtype=np.float64) / 255.0)).astype(np.uint8)
        return rgba, flat
    image = getattr(material, "image", None)
    if image is not None and _is_placeholder(image):
        return None, None
    return (None if image is None else _image(image)), flat


def _is_placeholder(image: Any) -> bool:
    """Whether `image` is the 2 x 2 gray trimesh invents for texture coordinates that came
    without a material (an OBJ with `vt` lines but no .mtl): no color source at all."""
    if getattr(image, "size", None) != (2, 2):
        return False
    return bool(np.all(np.asarray(image.convert("RGBA")) == [100, 100, 100, 255]))


def _is_trimesh_scene(obj: Any) -> bool:
    return any(c.__module__.startswith("trimesh") and c.__name__ == "Scene" for c in type(obj).__mro__)


def _flatten_scene(scene: Any) -> Any:
    """The scene's triangle meshes, each moved by its node's transform, as one Trimesh."""
    import trimesh

    meshes = [g for g in scene.dump() if isinstance(g, trimesh.Trimesh) and len(g.faces)]
    if not meshes:
        kinds = sorted({type(g).__name__ for g in scene.geometry.values()}) or ["nothing"]
        raise MeshError(f"the trimesh.Scene holds no triangles (it holds {', '.join(kinds)})")
    return meshes[0] if len(meshes) == 1 else trimesh.util.concatenate(meshes)


def load_mesh(path: str | os.PathLike[str]) -> Mesh:
    """Reads OBJ/PLY/STL/OFF (anything trimesh reads) into a :class:`Mesh`, without merging or
    dropping anything.

    Parameters
    ----------
    path : str or os.PathLike
        The mesh file; its colors, texture coordinates and texture come along where trimesh
        reads them.

    Returns
    -------
    Mesh
        The mesh.

    Raises
    ------
    ParameterError
        `path` is not a str or path.
    FileError
        There is no such file.
    FormatError
        trimesh cannot read it, or it holds no triangles.
    MeshError
        The triangles it holds are unusable (the message names the file).
    """
    import trimesh

    if not isinstance(path, (str, os.PathLike)):
        raise ParameterError(f"path must be a str or os.PathLike, got {path!r}")
    p = os.fspath(path)
    if not os.path.exists(p):
        raise FileError(f"no such mesh file: {p}")
    try:
        loaded = trimesh.load(p, force="mesh", process=False)
    except Exception as e:
        raise FormatError(f"{p}: cannot read as a mesh ({type(e).__name__}: {e})") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise FormatError(f"{p}: holds no triangles")
    try:
        return Mesh.from_trimesh(loaded)
    except MeshError as e:
        raise MeshError(f"{p}: {e}") from None


def as_mesh(obj: Any) -> Mesh:
    """A geomtex :class:`Mesh` from a Mesh (returned as it is), a ``trimesh.Trimesh``, a
    ``trimesh.Scene`` (its meshes moved by their transforms and joined) or a mesh file path
    (:func:`load_mesh`).

    Raises
    ------
    MeshError
        `obj` is none of those, or its triangles are unusable.
    """
    if isinstance(obj, Mesh):
        return obj
    if isinstance(obj, (str, os.PathLike)):
        return load_mesh(obj)
    if _is_trimesh_scene(obj) or (hasattr(obj, "vertices") and hasattr(obj, "faces")):
        return Mesh.from_trimesh(obj)
    raise MeshError(f"expected a geomtex.Mesh, trimesh.Trimesh, trimesh.Scene or a path; got {type(obj).__name__}")
