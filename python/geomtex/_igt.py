"""The classes of ``geomtex.igt``: `InverseGeometricTexture` (the tables of a detailed mesh) and
`IgtMesh` (a simplified mesh shaded through one), each holding its extension object."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _check, _core
from ._bridge import Int, Wrapped, forward
from ._errors import ParameterError
from ._set import from_bytes_arg

_Array = npt.NDArray[Any]


def shading(lookup: Any, samples: Any, lod: Any) -> tuple[str | None, int | None, str | float | None]:
    """`lookup`, `samples` and `lod` checked (None: the extension's default)."""
    lk = None if lookup is None else _check.choice("lookup", lookup, ("ray", "projection"))
    n = None if samples is None else _check.integer("samples", samples)
    if n is not None and n not in (1, 5):
        raise _check.fail("samples", "1 or 5 (lookups per pixel)", samples)
    if lod is None or isinstance(lod, str):
        level: str | float | None = None if lod is None else _check.choice("lod", lod, ("off", "auto"))
    else:
        level = _check.real("lod", lod, 0.0, lo_open=True)
    return lk, n, level


class InverseGeometricTexture(Wrapped, core=_core.InverseGeometricTexture,
                              made_by="geomtex.igt.build, geomtex.igt.load or InverseGeometricTexture.from_bytes"):
    """An inverse geometric texture (``geomtex.igt.build``, ``geomtex.igt.load``): per cell of a
    primary parameterization (the conversion's charts, or a spherical or cylindrical map) the list
    of the detailed mesh's triangles that overlap it, those triangles in primary space, and their
    attributes."""

    _core: _core.InverseGeometricTexture

    def __reduce__(self) -> tuple[Any, ...]:
        from ._pickle import restore_igt

        return restore_igt, (self.to_bytes(),)

    @staticmethod
    def from_bytes(data: bytes | bytearray | memoryview) -> InverseGeometricTexture:
        """A texture from the bytes of a .gtigt file; FormatError for anything not an intact one."""
        return InverseGeometricTexture._wrap(_core.InverseGeometricTexture.from_bytes(from_bytes_arg(data)))

    primary = forward[str]('"charts", "spherical" or "cylindrical".')
    resolution = forward[int]("About resolution² cells over the whole primary space.")
    stats = forward[dict[str, Any]](
        "Figures: faces, grids, cells, empty_cells, empty_fraction, entries, list_mean (over non-empty "
        "cells), list_max, bytes_hash, bytes_lists, bytes_triangles, bytes_attributes, bytes_image, "
        "bytes (the four tables), bytes_per_face, seconds_<stage>, and histogram (cells per list length "
        "0..31, then 32 or more).")
    grids = forward[dict[str, _Array]](
        "Per grid (G rows): origin (G, 3), axes (G, 3, 3) rows x, y, z, cell (G, 2) world units per "
        "cell, shape (G, 2) width and height in cells, first_cell (G,).")
    cell_start = forward[npt.NDArray[np.int64]](
        "(cells + 1,) int64: the list of cell c is cell_entries[cell_start[c]:cell_start[c + 1]].")
    cell_entries = forward[npt.NDArray[np.int64]]("(L,) int64 entry indices, cell by cell.")
    entry_face = forward[npt.NDArray[np.int64]]("(E,) int64 detailed face of each entry.")
    entry_grid = forward[npt.NDArray[np.int64]]("(E,) int64 grid of each entry.")
    entry_corners = forward[npt.NDArray[np.float32]](
        "(E, 3, 2) float32 corners of each entry in its grid's primary space (cell units).")
    face_grid = forward[npt.NDArray[np.int64]]("(F,) int64 grid of each detailed face (-1: degenerate, never listed).")
    normals = forward[npt.NDArray[np.float32]]("(F, 3, 3) float32 corner normals of the detailed faces.")
    colors = forward[npt.NDArray[np.uint8] | None]("(F, 3, 4) uint8 corner colors, or None.")
    uv = forward[npt.NDArray[np.float32] | None]("(F, 3, 2) float32 corner texture coordinates, or None.")
    texture = forward[npt.NDArray[np.uint8] | None]("(H, W, 4) uint8 texture image, row 0 at the top, or None.")
    ao = forward[npt.NDArray[np.float32] | None](
        "(F, 3) float32 ambient occlusion at the corners (the unoccluded fraction of each vertex's "
        "cosine-weighted hemisphere, in steps of 1/255), or None.")
    vertices = forward[npt.NDArray[np.float64]]("(V, 3) float64 vertices of the detailed mesh.")
    faces = forward[npt.NDArray[np.int64]]("(F, 3) int64 faces of the detailed mesh.")

    def check_near(self, vertices: npt.NDArray[np.float64], faces: npt.NDArray[np.int64]) -> None:
        """Raises ParameterError unless the mesh (V, 3) / (M, 3) lies where the detailed mesh does
        (within 0.25 of its diagonal past its bounding box): what `shade` checks first."""
        self._core.check_near(vertices, faces)

    def lookup(self, points: npt.ArrayLike, grids: npt.ArrayLike | None = None
               ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
        """Per point (an (N, 3) array-like, finite): the detailed face listed under it (-1 where
        nothing is listed near), its barycentric coordinates there (N, 3) and whether one was found
        containing it (False where the nearest listed one answered); `grids` (N integers) names
        each point's grid (chart), required with the charts primary."""
        p = _check.rows("points", points)
        ids = None
        if grids is not None:
            g = _check.array("grids", grids, "iu")
            if g.shape != (len(p),):
                raise ParameterError(f"grids must be {len(p)} integers (one per point), got shape {g.shape}")
            ids = [int(x) for x in g]
        return self._core.lookup(p, ids)

    def shade(self, vertices: npt.ArrayLike, faces: npt.ArrayLike, face_grid: npt.ArrayLike,
              lookup: str | None = None, samples: Int | None = None, lod: str | float | None = None) -> IgtMesh:
        """A mesh in the detailed mesh's space ((V, 3) vertices, (F, 3) faces) shaded through this
        texture, each face searched in the grid `face_grid` names; `lookup`, `samples` and `lod` as
        for `geomtex.igt.attach`."""
        v = _check.rows("vertices", vertices, label="V", min_rows=3, max_rows=2**31)
        f = _check.indices("faces", faces, 3, len(v), label="F", min_rows=1)
        g = _check.array("face_grid", face_grid, "iu")
        if g.shape != (len(f),):
            raise ParameterError(f"face_grid must be {len(f)} integers (one per face), got shape {g.shape}")
        lk, n, level = shading(lookup, samples, lod)
        return IgtMesh._wrap(self._core.shade(v, f, [int(x) for x in g], lookup=lk, samples=n, lod=level))

    def save(self, path: str | os.PathLike[str]) -> None:
        """Writes a .gtigt file atomically."""
        self._core.save(path)

    def to_bytes(self) -> bytes:
        """The bytes of the .gtigt file `save` writes."""
        return self._core.to_bytes()


class IgtMesh(Wrapped, core=_core.IgtMesh,
              made_by="geomtex.igt.simplify, geomtex.igt.attach or InverseGeometricTexture.shade"):
    """A simplified mesh shaded through an inverse geometric texture (``geomtex.igt.simplify``,
    ``geomtex.igt.attach``); render it like a mesh (``Scene.add``, ``Renderer.render``).
    ``len(mesh)`` is its number of faces."""

    _core: _core.IgtMesh

    @property
    def igt(self) -> InverseGeometricTexture:
        """The texture it is shaded through."""
        return InverseGeometricTexture._wrap(self._core.igt)

    vertices = forward[npt.NDArray[np.float64]]("(V, 3) float64 vertices of the simplified mesh.")
    faces = forward[npt.NDArray[np.int64]]("(M, 3) int64 faces of the simplified mesh.")
    face_grid = forward[npt.NDArray[np.int64]]("(M,) int64 grid each face projects into.")
    lookup = forward[str]('"ray" or "projection": how fragments find their detailed triangle.')
    samples = forward[int]("Lookups per pixel: 1 or 5 (averaged).")
    lod = forward[str | float](
        'The shader LoD: "auto", "off", or the distance (float) beyond which the baked texture shades.')
    face_window = forward[npt.NDArray[np.float64]](
        "(M, 2) float64: per face, how far (object units) the ray lookup searches outside (the side its "
        "normal points to) and inside the face's plane (the measured distance to the detailed surface, "
        "with slack).")
    search_grids = forward[npt.NDArray[np.int64]](
        "(M, K) int64: per face, the grids the ray lookup walks (its own first; -1 pads).")

    def __len__(self) -> int:
        return len(self._core)
