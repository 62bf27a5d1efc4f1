"""``GeometryTextureSet.from_heightmaps``: argument checking and coloring here, the tiling itself
is in Rust, src/grids.rs.

Grids are (rows, columns) arrays of heights: row j, column i lies at (x0 + i dx, y0 + j dy) with
dx = (x1 - x0) / (columns - 1) and dy = (y1 - y0) / (rows - 1) from ``extent = (x0, x1, y0, y1)``
(one extent for every grid, as horizons of one survey share their lattice, or one per grid).
NaN marks missing data. ``properties`` (same shapes) are mapped to RGBA8 through a matplotlib
colormap over ``property_range`` (default: the finite minimum and maximum of all of them).
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
import numpy.typing as npt

from ._errors import ParameterError

Prepared = tuple[npt.NDArray[np.float64], tuple[float, float, float, float], npt.NDArray[np.uint8] | None]


def _grid_list(grids: Any, what: str) -> list[npt.NDArray[np.float64]]:
    # One grid (2-D), a stack of equal grids (3-D), or a sequence of grids of any shapes.
    try:
        whole = np.asarray(grids, dtype=np.float64)
    except (TypeError, ValueError):
        whole = None
    if whole is not None and whole.ndim in (2, 3):
        items: list[Any] = [whole] if whole.ndim == 2 else list(whole)
    else:
        try:
            items = list(grids) if whole is None or whole.ndim > 0 else [whole]
        except TypeError:
            raise ParameterError(
                f"{what} must be a 2-D array or a sequence of them, got {type(grids).__name__}") from None
    out = []
    for k, g in enumerate(items):
        try:
            a = np.asarray(g, dtype=np.float64)
        except (TypeError, ValueError):
            raise ParameterError(f"{what}[{k}] is not numeric") from None
        if a.ndim != 2:
            raise ParameterError(f"{what}[{k}] must be 2-D (rows, columns), got shape {a.shape}")
        out.append(np.ascontiguousarray(a))
    if not out:
        raise ParameterError(f"no {what} given")
    return out


def prepare(grids: Any, extent: Any, properties: Any, cmap: Any, property_range: Any) -> list[Prepared]:
    zs = _grid_list(grids, "grids")
    try:
        ext = np.asarray(extent, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"extent must be (x0, x1, y0, y1) numbers, got {extent!r}") from None
    if not np.all(np.isfinite(ext)):
        raise ParameterError(f"extent must be finite, got {extent!r}")
    if ext.shape == (4,):
        ext = np.broadcast_to(ext, (len(zs), 4))
    if ext.shape != (len(zs), 4):
        raise ParameterError(f"extent must be (x0, x1, y0, y1) or one such per grid, got shape {ext.shape}")
    colors: list[npt.NDArray[np.uint8] | None] = [None] * len(zs)
    if properties is not None:
        props = _grid_list(properties, "properties")
        if len(props) != len(zs) or any(p.shape != z.shape for p, z in zip(props, zs)):
            raise ParameterError("properties must match the grids one to one, shape for shape")
        colors = list(_colorize(props, cmap, property_range))
    out: list[Prepared] = []
    for z, (x0, x1, y0, y1), c in zip(zs, ext, colors):
        rows, cols = z.shape
        dx = (x1 - x0) / max(cols - 1, 1)
        dy = (y1 - y0) / max(rows - 1, 1)
        out.append((z, (float(x0), float(y0), float(dx), float(dy)), c))
    return out


def _colorize(props: Sequence[npt.NDArray[np.float64]], cmap: Any, property_range: Any) -> list[npt.NDArray[np.uint8]]:
    try:
        import matplotlib
        from matplotlib.colors import Colormap
    except ImportError as e:
        raise ImportError(f"properties are colored through a matplotlib colormap, and matplotlib is not installed "
                          f"({e}); pip install matplotlib, or geomtex[notebook]") from e

    if isinstance(cmap, Colormap):
        colormap = cmap
    else:
        try:
            colormap = matplotlib.colormaps[cmap]
        except (KeyError, TypeError):
            raise ParameterError(f"cmap must be a matplotlib colormap or its name, got {cmap!r}") from None
    if property_range is None:
        finite = [p[np.isfinite(p)] for p in props]
        values = np.concatenate(finite) if finite else np.zeros(0)
        lo, hi = (float(values.min()), float(values.max())) if values.size else (0.0, 1.0)
    else:
        try:
            lo, hi = (float(v) for v in property_range)
        except (TypeError, ValueError):
            lo = hi = float("nan")
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise ParameterError(f"property_range must be two finite numbers, low < high, got {property_range!r}")
    scale = 1.0 / (hi - lo) if hi > lo else 0.0
    return [np.ascontiguousarray(colormap(np.nan_to_num((p - lo) * scale, nan=0.0), bytes=True), dtype=np.uint8)
            for p in props]


def from_heightmaps(grids: Any, extent: Any, *, properties: Any = None, cmap: Any = "viridis",
                    property_range: Any = None, max_resolution: int | None = None,
                    height_bits: int | None = None) -> Any:
    """``GeometryTextureSet.from_heightmaps`` (documented there): the grids checked and tiled in
    Rust, the properties colored through `cmap`."""
    from . import _core

    prepared = prepare(grids, extent, properties, cmap, property_range)
    return _core.GeometryTextureSet._from_prepared_grids(
        prepared, max_resolution=max_resolution, height_bits=height_bits)
