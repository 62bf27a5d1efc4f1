"""Meshes for stress-testing conversion and rendering, used by geomtex's own tests and benchmarks
and by anyone checking their own meshes:

- ``damage``: damaged and transformed copies (soup, flipped faces, holes, fins, slivers, similar);
- ``shapes``: generated meshes and height grids (``GENERATED`` by name, height fields, horizons);
- ``views``: cameras placed relative to a mesh.
"""

from __future__ import annotations

from .damage import add_fins, add_slivers, flip_faces, punch_holes, similar, soup
from .shapes import (
                     GENERATED,
                     chamfered_box,
                     flat_grid,
                     gear_plate,
                     grid_mesh,
                     height_field,
                     horizon_stack,
                     noisy_isosurface,
                     subdivided,
                     wavy_sheet,
)
from .views import look_from

__all__ = [
    "GENERATED",
    "add_fins",
    "chamfered_box",
    "add_slivers",
    "flat_grid",
    "flip_faces",
    "gear_plate",
    "grid_mesh",
    "height_field",
    "horizon_stack",
    "look_from",
    "noisy_isosurface",
    "punch_holes",
    "similar",
    "soup",
    "subdivided",
    "wavy_sheet",
]
