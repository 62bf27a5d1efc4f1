"""`Surfels`: a surfel hierarchy over a geometry-texture set (``GeometryTextureSet.to_surfels``,
``geomtex.load_surfels``)."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _core
from ._bridge import Wrapped, forward
from ._set import GeometryTextureSet, from_bytes_arg

_Array = npt.NDArray[Any]


class Surfels(Wrapped, core=_core.Surfels,
              made_by="GeometryTextureSet.to_surfels(tile) or geomtex.load_surfels(path)"):
    """A surfel hierarchy over a geometry-texture set: every surface texel a surfel, tiles of
    `tile` x `tile` texels merged 2x2 per level (level 0 finest). Render it like a set
    (``Renderer.render(surfels, camera, max_pixel_error=1.0)``, ``Scene.add(surfels)``).
    ``len(surfels)`` is its number of surfels."""

    _core: _core.Surfels

    @staticmethod
    def from_bytes(data: bytes | bytearray | memoryview) -> Surfels:
        """A hierarchy from the bytes of a .gtsurf file; FormatError for anything not an intact
        one."""
        return Surfels._wrap(_core.Surfels.from_bytes(from_bytes_arg(data)))

    tile = forward[int]("Tile side in texels (a power of two up to 64).")
    levels = forward[int]("Levels per tile: log2(tile) + 1.")
    positions = forward[npt.NDArray[np.float64]](
        "(N, 3) float64 world positions of every surfel, tile by tile, each tile level by level.")
    normals = forward[npt.NDArray[np.float32]]("(N, 3) float32 world unit normals.")
    radii = forward[npt.NDArray[np.float64]]("(N,) float64 disc radii (world units).")
    colors = forward[npt.NDArray[np.uint8]]("(N, 4) uint8 RGBA colors.")
    level = forward[npt.NDArray[np.int32]]("(N,) int32 level of each surfel (0 = finest).")
    parent = forward[npt.NDArray[np.int64]]("(N,) int64 index of each surfel's parent one level up, -1 at the top.")
    tile_of = forward[npt.NDArray[np.int32]]("(N,) int32 tile of each surfel.")
    tile_patch = forward[npt.NDArray[np.int32]]("(T,) int32 patch of each tile.")
    tile_start = forward[npt.NDArray[np.int64]](
        "(T, levels + 1) int64: tile t's surfels of level l are `start[t, l]:start[t, l + 1]`.")
    tile_error = forward[npt.NDArray[np.float64]](
        "(T, levels) float64 perpendicular error of each tile's levels (world units).")
    tile_cone = forward[npt.NDArray[np.float64]](
        "(T, levels, 4) float64 normal cone of each tile's levels: unit axis xyz, half angle (radians).")
    nodes = forward[dict[str, _Array]](
        "The quadtree above the tiles as arrays (M nodes, T tiles): position (M, 3), normal (M, 3) and "
        "radius (M,) of each node's surfel, level (M,) (counting on from the tiles' top level), parent "
        "(M,) (-1 at a root), error (M,) (world units), cone (M, 4) (unit axis, half angle of the "
        "tiles' top-level normals below), sphere (M, 4) (centre, radius), and tile_parent (T,) (each "
        "tile's node, -1 where none).")
    stats = forward[dict[str, Any]](
        "tile, levels, tiles, surfels, surfels_per_level (finest first), nodes and nodes_per_level "
        "(the quadtree above the tiles, lowest level first), bytes (GPU records).")

    @property
    def source(self) -> GeometryTextureSet:
        """The set the hierarchy was built from."""
        return GeometryTextureSet._wrap(self._core.source)

    def __len__(self) -> int:
        return len(self._core)

    def save(self, path: str | os.PathLike[str]) -> None:
        """Writes a .gtsurf file atomically: the source set and the tile size (the hierarchy is
        rebuilt, deterministically, on load)."""
        self._core.save(path)

    def to_bytes(self) -> bytes:
        """The bytes of the .gtsurf file `save` writes."""
        return self._core.to_bytes()
