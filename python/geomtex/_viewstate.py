"""`ViewState`, what a viewer shows, and the keywords ``geomtex.show`` takes: here, without the
viewer's imports, so that ``geomtex.show`` names its keywords while ``geomtex.viewer`` is
imported only when first used."""

from __future__ import annotations

import inspect
from dataclasses import dataclass, field
from typing import Any, Literal

from ._bridge import keyword_parameters

Shading = Literal["shaded", "patches", "normals", "depth"]
Compare = Literal["textures", "mesh", "beside", "overlay"]


@dataclass
class ViewState:
    """Where the camera is and what is drawn; every control of the viewer edits one field
    (``Viewer.set`` changes any of them, ``show`` takes them as keywords)."""

    #: Camera azimuth about world +Y, degrees (0: looking along -Z).
    azimuth_deg: float = 30.0
    #: Camera elevation, degrees, kept within (-89, 89).
    elevation_deg: float = 20.0
    #: Camera distance from the box centre, in bounding-box diagonals.
    distance: float = 1.3
    #: Vertical field of view, degrees.
    yfov_deg: float = 40.0
    #: ``Renderer.render``'s quality: "fast", "balanced" or "exact".
    quality: str = "exact"
    #: ``Renderer.render``'s lod (max-pyramid search only).
    lod: bool = False
    #: "shaded", "patches" (each patch tinted), "normals" or "depth".
    shading: str = "shaded"
    #: "textures", or with the original mesh "mesh", "beside" or "overlay".
    compare: str = "textures"
    #: The last frame's ``Frame.stats``.
    stats: dict[str, Any] = field(default_factory=dict)


_KW = inspect.Parameter.KEYWORD_ONLY
#: ``show``'s keywords: the viewer's size, the original mesh, and the starting view (`compare` by
#: default "beside" with a mesh, else "textures").
SHOW_KEYWORDS = [
    inspect.Parameter("mesh", _KW, default=None, annotation="Any"),
    inspect.Parameter("width", _KW, default=512, annotation="int"),
    inspect.Parameter("height", _KW, default=384, annotation="int"),
    inspect.Parameter("compare", _KW, default=None, annotation="Compare | None"),
    *keyword_parameters(ViewState, drop=("compare", "stats")),
]
