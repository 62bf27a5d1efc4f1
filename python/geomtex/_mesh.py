"""Mesh input: numpy arrays, trimesh objects and mesh files, checked before they reach Rust."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _core
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


def _colors(a: Any, n_vertices: int) -> npt.NDArray[np.uint8] | None:
    if a is None:
        return None
    arr = np.asarray(a)
    if arr.ndim == 2 and arr.shape[1] == 3:
        opaque = 255 if arr.dtype.kind != "f" else 1.0
        arr = np.concatenate([arr, np.full((arr.shape[0], 1), opaque, arr.dtype)], axis=1)
    arr = _as_real_array(arr, "vertex_colors", 4)
    if arr.shape[0] != n_vertices:
        raise MeshError(f"vertex_colors has {arr.shape[0]} rows but the mesh has {n_vertices} vertices")
    if arr.dtype.kind == "f":
        if not np.all(np.isfinite(arr)):
            raise MeshError("vertex_colors holds NaN or inf")
        arr = np.round(np.clip(arr, 0.0, 1.0) * 255.0)
    elif arr.size and (arr.min() < 0 or arr.max() > 255):
        raise MeshError("integer vertex_colors must lie in [0, 255]")
    return np.ascontiguousarray(arr, dtype=np.uint8)


class Mesh(_core.Mesh):
    """A triangle mesh: ``Mesh(vertices (N, 3), faces (M, 3), vertex_colors=None)``.

    Vertices may be any real dtype (stored as float64); faces any integer dtype; colors (N, 3|4)
    as uint8 in [0, 255] or floats in [0, 1]. Every problem raises :class:`MeshError` naming the
    vertex or face at fault. Degenerate (zero-area) faces are allowed and left out of conversion.
    """

    def __new__(cls, vertices: Any, faces: Any, vertex_colors: Any = None) -> "Mesh":
        v = _vertices(vertices)
        f = _faces(faces)
        c = _colors(vertex_colors, v.shape[0])
        return super().__new__(cls, v, f, c)  # type: ignore[return-value]  # builds cls

    @classmethod
    def from_trimesh(cls, mesh: Any) -> "Mesh":
        """From a ``trimesh.Trimesh`` (vertex colors kept when it has them), or a
        ``trimesh.Scene`` (what ``trimesh.load`` returns for GLB and multi-object files),
        flattened with its node transforms into one mesh."""
        if _is_trimesh_scene(mesh):
            mesh = _flatten_scene(mesh)
        if not (hasattr(mesh, "vertices") and hasattr(mesh, "faces")):
            raise MeshError(f"expected a trimesh.Trimesh or trimesh.Scene, got {type(mesh).__name__}")
        colors = None
        visual = getattr(mesh, "visual", None)
        if visual is not None and getattr(visual, "kind", None) == "vertex":
            colors = np.asarray(visual.vertex_colors)
        return cls(np.asarray(mesh.vertices), np.asarray(mesh.faces), colors)

    def to_trimesh(self) -> Any:
        """As a ``trimesh.Trimesh`` (no processing, so indices stay as they are)."""
        import trimesh

        return trimesh.Trimesh(self.vertices, self.faces, vertex_colors=self.vertex_colors, process=False)


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
    dropping anything."""
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


def as_mesh(obj: Any) -> _core.Mesh:
    """A geomtex Mesh from a Mesh, a trimesh.Trimesh, a trimesh.Scene (flattened) or a path."""
    if isinstance(obj, _core.Mesh):
        return obj
    if isinstance(obj, (str, os.PathLike)):
        return load_mesh(obj)
    if _is_trimesh_scene(obj) or (hasattr(obj, "vertices") and hasattr(obj, "faces")):
        return Mesh.from_trimesh(obj)
    raise MeshError(f"expected a geomtex.Mesh, trimesh.Trimesh, trimesh.Scene or a path; got {type(obj).__name__}")
