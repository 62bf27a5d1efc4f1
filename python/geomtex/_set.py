"""`GeometryTextureSet`: height-map patches in oriented boxes, the package's main object.

Made by ``geomtex.convert``, ``geomtex.load``, ``GeometryTextureSet.from_bytes`` and
``GeometryTextureSet.from_heightmaps``; the patches live in the extension (``_core``), the
pictures (``_repr_png_``), grid preparation and mesh input are written in Python.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any, Literal, Sequence

import numpy as np
import numpy.typing as npt

from . import _check, _core, _grids, _preview
from ._bridge import Int, Real, Wrapped, forward
from ._mesh import as_mesh
from ._rays import RayQueries

if TYPE_CHECKING:
    from ._surfels import Surfels

MapFilter = Literal["gaussian", "high_pass"]


def from_bytes_arg(data: Any) -> bytes:
    """`from_bytes`' argument: any bytes-like object (bytes, bytearray, memoryview); anything else
    is a ParameterError naming `data`."""
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise _check.fail("data", "bytes (or a bytearray or memoryview)", data)
    return bytes(data)


class GeometryTextureSet(RayQueries, Wrapped, core=_core.GeometryTextureSet,
                         made_by="geomtex.convert, geomtex.load, GeometryTextureSet.from_bytes or "
                                 "GeometryTextureSet.from_heightmaps"):
    """Height-map patches in oriented boxes, converted from a mesh (:func:`geomtex.convert`),
    loaded from a .gtex file (:func:`geomtex.load`) or built from height grids
    (`from_heightmaps`).

    ``len(gts)`` is its number of patches. Render it with :meth:`Renderer.render`, trace rays
    with `intersects_first`, `intersects_location` and `intersects_any`, place it in a
    :class:`Scene`. It pickles as its .gtex bytes (`to_bytes`), and shows as an overview picture
    in Jupyter. Made by the functions above only: ``GeometryTextureSet(...)`` is a
    ParameterError.
    """

    _core: _core.GeometryTextureSet

    @staticmethod
    def from_heightmaps(grids: npt.ArrayLike | Sequence[npt.ArrayLike],
                        extent: Sequence[float] | Sequence[Sequence[float]] | npt.ArrayLike, *,
                        properties: npt.ArrayLike | Sequence[npt.ArrayLike] | None = None, cmap: Any = "viridis",
                        property_range: tuple[float, float] | None = None, max_resolution: Int | None = None,
                        height_bits: Literal[8, 16] | None = None) -> GeometryTextureSet:
        """Builds a set straight from regular height grids (horizons, terrain).

        The tiling runs in Rust with the GIL released.

        Parameters
        ----------
        grids : array-like or sequence of array-likes
            One (rows, columns) array, a stack of them, or a sequence of arrays of any shapes;
            NaN marks missing samples.
        extent : (x0, x1, y0, y1), or one per grid
            World extent of the grids.
        properties : array-like or sequence of array-likes, optional
            Arrays of the grids' shapes, colored through `cmap`.
        cmap : str or matplotlib.colors.Colormap, default "viridis"
            The matplotlib colormap of `properties`.
        property_range : (float, float), optional
            The values mapped to the colormap's ends (default: the properties' finite min and
            max).
        max_resolution : int, optional
            Samples per tile side (default 256); tiles share their border samples, so the
            surface has no cracks.
        height_bits : {16, 8}, optional
            As for :func:`geomtex.convert` (default 16).

        Returns
        -------
        GeometryTextureSet
            One patch per tile.

        Raises
        ------
        ParameterError
            Grids, extents or properties of the wrong shape or type, or a grid with no finite
            sample.
        """
        prepared = _grids.prepare(grids, extent, properties, cmap, property_range)
        return GeometryTextureSet._wrap(_core.GeometryTextureSet._from_prepared_grids(
            prepared, max_resolution=max_resolution, height_bits=height_bits))

    @staticmethod
    def from_bytes(data: bytes | bytearray | memoryview) -> GeometryTextureSet:
        """A set from the bytes of a .gtex file (`to_bytes`, or a file read by the caller).

        Raises
        ------
        ParameterError
            `data` is not bytes-like.
        FormatError
            The bytes are not an intact .gtex file.
        """
        return GeometryTextureSet._wrap(_core.GeometryTextureSet.from_bytes(from_bytes_arg(data)))

    stats = forward[dict[str, Any]](
        "Figures of the conversion: the mesh (faces, vertices, diagonal, degenerate_faces, "
        "boundary_edges, ...), the partition (charts, cone_partition: 1 for the cone partition, 0 for VSA, "
        "vsa_charts: its charts before repair, chart_error for VSA, charts_capped, ...), "
        "the maps (bytes, texels, texel_size, empty_fraction, height_bits, "
        "max_quantization_error), the error (reconstruction_error_p99 and _max, max_error, "
        "max_bytes, max_bytes_binding, max_bytes_exceeded, ...), per-patch arrays (patch_resolution, "
        "patch_texel, patch_error) and per-stage wall-clock seconds under \"seconds\" (empty for a "
        "loaded set). ``convert``'s keywords say which keys answer them.")
    triangles = forward[dict[str, Any] | None](
        "A hybrid set's triangles (``convert(..., hybrid=True)``), None for height maps only: "
        "vertices (V, 3) float64, faces (F, 3) uint32, cluster_starts (C + 1,) uint32 (cluster c "
        "is faces cluster_starts[c]:cluster_starts[c + 1], one chart each), source_faces (F,) "
        "uint32 (each face's index in the source mesh), kept_because (C,) str (\"bound\": no height "
        "map within the bound took fewer bytes than its faces; \"budget\": moved back so the set "
        "costs no more than the mesh) and bytes (float32 vertices, uint32 indices).")
    def _merge_distance(self) -> float:
        return float(self.texel_size)

    texel_size = forward[float]("World size of one texel (the finest patch's where texels differ).")
    world_from_patch = forward[npt.NDArray[np.float64]](
        "(P, 4, 4) float64: each patch's world_from_patch (unit cube -> world box).")

    def __len__(self) -> int:
        return len(self._core)

    def face_patch(self) -> npt.NDArray[np.int32]:
        """(M,) int32: the patch holding each source face, -1 for degenerate faces left out."""
        return self._core.face_patch()

    def patch(self, index: Int) -> dict[str, Any]:
        """One patch's maps and frame as numpy arrays (negative indices count from the end):
        height (H, W) codes, uint16 or uint8 as `height_bits` says (0 = empty, else
        h = (code - 1) / (2**height_bits - 2)), normal (H, W, 4) int8 (patch-local xyz/127; 0
        where none), color (H, W, 4) uint8 (neutral 200, 200, 200, 255 without a color map),
        has_colors (bool), outline (H, W) int8 (signed distance from each texel centre to the
        faces' outline, 127 = 2 texels, positive inside), world_from_patch (4, 4), origin (3,),
        axes (3, 3) (rows x, y, z), extent (3,), faces and ring_faces (uint32), and error_bound
        (H + 1, W + 1) float64: each cell's bound (world units) on the distance from the stored
        surface over it to the mesh, rows and columns from cell -1 (the cell between texel
        rows/columns -1 and 0), as its block of cells stores it; None for a set without bounds."""
        return self._core.patch(index)

    def to_points(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float32]]:
        """Every texel holding surface (a height, and its centre inside the outline) as a world
        point: ((N, 3) float64 points, (N, 3) float32 unit normals)."""
        return self._core.to_points()

    def first_hits(self, origins: npt.ArrayLike,
                   directions: npt.ArrayLike) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]:
        """Exact first hits of world rays on the set's surface, computed on the CPU in f64 (the
        reference the GPU searches are tested against), on every core: a hierarchy over the
        patches' boxes, and in each patch its min-max pyramid down to the cells the ray may meet;
        a hybrid set's triangles by a hierarchy over their boxes and an exact f64 triangle test.
        Distances and patch ids only (``intersects_first`` gives points and normals too); on a
        machine whose only adapter is a CPU one it is the faster of the two
        (``bench/rays.py``).

        Parameters
        ----------
        origins : (N, 3) array-like
            Ray origins, world space.
        directions : (N, 3) array-like
            Unit ray directions.

        Returns
        -------
        distances : (N,) float64 ndarray
            Distance along each ray to its first hit, +inf on a miss.
        patch_ids : (N,) int32 ndarray
            The patch hit, -1 on a miss, -2 on a hybrid set's triangles.
        """
        return self._core.first_hits(origins, directions)

    def to_surfels(self, tile: Int | None = None) -> Surfels:
        """The surfel hierarchy of this set: every surface texel a surfel, tiles of `tile` x `tile`
        texels merged 2x2 per level.

        Parameters
        ----------
        tile : int, optional
            Tile side in texels, a power of two up to 64 (default 8).

        Returns
        -------
        Surfels
            The hierarchy; render it like the set.

        Raises
        ------
        ParameterError
            `tile` is not a power of two in [1, 64].
        """
        from ._surfels import Surfels

        return Surfels._wrap(self._core.to_surfels(tile))

    def filtered(self, kind: MapFilter, sigma: Real, *, gain: Real | None = None) -> GeometryTextureSet:
        """A copy with every height map filtered; normals are filtered by the same weights in
        world space.

        Parameters
        ----------
        kind : {"gaussian", "high_pass"}
            Low-pass, or unsharp masking: h + gain (h - gaussian h).
        sigma : float
            The Gaussian's standard deviation, world units.
        gain : float, optional
            ``"high_pass"`` only (refused for ``"gaussian"``).

        Returns
        -------
        GeometryTextureSet
            The filtered copy.
        """
        return GeometryTextureSet._wrap(self._core.filtered(kind, sigma, gain=gain))

    def seam_gaps(self, mesh: Any) -> npt.NDArray[np.float64]:
        """Gaps (world units, float64) between neighbouring patches at points along their charts'
        shared edges (a quarter, half and three quarters along each, both ways). `mesh`: the mesh
        the set was converted from, as a Mesh, trimesh or path; a mesh with another face count or
        elsewhere in space raises ParameterError."""
        return self._core.seam_gaps(as_mesh(mesh)._core)

    def seam_normal_steps(self, mesh: Any) -> npt.NDArray[np.float64]:
        """Angles (degrees, float64) between the normals two neighbouring patches show at the points
        of `seam_gaps`: the shading step a viewer would see where the patches meet. `mesh` as for
        `seam_gaps`."""
        return self._core.seam_normal_steps(as_mesh(mesh)._core)

    def save(self, path: str | os.PathLike[str]) -> None:
        """Writes a .gtex file atomically (no half file is ever left behind); :func:`geomtex.load`
        reads it.

        Raises
        ------
        FileError
            The file cannot be written.
        """
        self._core.save(path)

    def to_bytes(self) -> bytes:
        """The set as the bytes of a .gtex file (what `save` writes): exact, checksummed, and how
        the set is pickled."""
        return self._core.to_bytes()

    def _repr_png_(self) -> bytes:
        """PNG bytes of the overview picture, for Jupyter."""
        return _preview.set_png(self)

