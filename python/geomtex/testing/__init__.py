"""Meshes for stress-testing conversion and rendering.

Used by geomtex's own tests and benchmarks, and by anyone checking their own meshes:

- ``damage``: damaged and transformed copies (soup, flipped faces, holes, fins, slivers, similar);
- ``shapes``: generated meshes and height grids (``GENERATED`` by name, height fields, horizons);
- ``views``: cameras placed relative to a mesh;
- ``seams``: rays at a set's chart borders, texel points compared across a filter.
"""

from __future__ import annotations

from .damage import add_fins, add_slivers, flip_faces, punch_holes, similar, soup
from .seams import common_points, seam_rays, surface_mask
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
    "common_points",
    "add_slivers",
    "flat_grid",
    "flip_faces",
    "gear_plate",
    "grid_mesh",
    "height_field",
    "horizon_stack",
    "look_from",
    "seam_rays",
    "noisy_isosurface",
    "punch_holes",
    "similar",
    "surface_mask",
    "soup",
    "subdivided",
    "wavy_sheet",
]
