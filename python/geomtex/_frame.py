"""`Frame`: one rendered image (``Renderer.render``), numpy arrays with row 0 at the top."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _core, _preview
from ._bridge import Wrapped, forward

#: What a frame holds besides its per-pixel outputs, in the order ``Frame._from_arrays`` takes it
#: after them.
EXTRAS = ("shadow", "stats", "face_id", "barycentric", "width", "height")


class Frame(Wrapped, core=_core.Frame,
            made_by="Renderer.render"):
    """One rendered image (:meth:`Renderer.render`): numpy arrays, row 0 at the top.

    The per-pixel outputs are `color`, `albedo`, `depth`, `normal`, `patch_id`, `error_bound`
    and `coverage_uncertain` (those the render asked for: `outputs`; all but
    `coverage_uncertain` by default), `shadow` with a light, `face_id` and `barycentric` with an
    IGT mesh; `stats` holds the render's figures. `error_bound` is a per-pixel bound on the
    distance from the drawn point to the source mesh (NaN where nothing is drawn or no bound is
    known), `coverage_uncertain` the pixels whose coverage could differ from the source mesh's.
    In Jupyter it shows as its color image; `save` writes that image. Frames pickle (the arrays
    they hold).
    """

    _core: _core.Frame

    def __reduce__(self) -> tuple[Any, ...]:
        from ._pickle import restore_frame

        # The outputs named after patch_id came later: they follow the extras (older pickles,
        # without them, still load).
        arrays = self._core._arrays()
        return restore_frame, (*arrays[:5], *(getattr(self, name) for name in EXTRAS), *arrays[5:])

    @staticmethod
    def _from_arrays(color: npt.NDArray[np.uint8] | None, albedo: npt.NDArray[np.uint8] | None,
                     depth: npt.NDArray[np.float32] | None, normal: npt.NDArray[np.float32] | None,
                     patch_id: npt.NDArray[np.int32] | None, shadow: npt.NDArray[np.bool_] | None,
                     stats: dict[str, Any], face_id: npt.NDArray[np.int32] | None = None,
                     barycentric: npt.NDArray[np.float32] | None = None, width: int | None = None,
                     height: int | None = None, error_bound: npt.NDArray[np.float32] | None = None,
                     coverage_uncertain: npt.NDArray[np.bool_] | None = None) -> Frame:
        """A frame from arrays of the shapes and dtypes a render gives, None for outputs not asked
        for (how a pickled frame is made again); ParameterError when they do not fit together."""
        return Frame._wrap(_core.Frame._from_arrays(color, albedo, depth, normal, patch_id, shadow, stats,
                                                    face_id, barycentric, width, height, error_bound,
                                                    coverage_uncertain))

    outputs = forward[list[str]]("The names of the per-pixel outputs this frame holds (``render``'s "
                                 "``outputs``); reading another is a ParameterError.")
    width = forward[int]("Image width in pixels.")
    height = forward[int]("Image height in pixels.")

    color = forward[npt.NDArray[np.uint8]]("(H, W, 4) uint8 RGBA, headlight-shaded; the background on a miss.")
    albedo = forward[npt.NDArray[np.uint8]](
        "(H, W, 4) uint8 RGBA unshaded base color (the surface's own color: no light, no shadow); 0 "
        "(transparent black) on a miss, whatever the background.")
    depth = forward[npt.NDArray[np.float32]](
        "(H, W) float32 z-depth: distance along the camera's forward axis in world units, +inf on a miss.")
    normal = forward[npt.NDArray[np.float32]]("(H, W, 3) float32 world-space unit normals, 0 on a miss.")
    patch_id = forward[npt.NDArray[np.int32]](
        "(H, W) int32: patch index (numbered across the scene's texture sets), -1 on a miss, -2 - k for "
        "the scene's k-th mesh, IGT mesh or displacement shell (counted together, in order).")
    error_bound = forward[npt.NDArray[np.float32]](
        "(H, W) float32: per drawn pixel a bound (world units) on the distance from the point it shows "
        "to the source mesh: its cell's bound from the set's error-bound maps (or its patch's level "
        "bound under ``lod``), plus a term for rounding: on the CPU backend the float32 depth's own "
        "rounding, measured pixel by pixel, and a few float64 steps; on the GPU 4 float32 steps of its "
        "distance from the eye and of its patch box's size. A plain Mesh's pixels get only the rounding "
        "term. NaN where nothing is drawn "
        "or no bound is known: patches without a bound map, Surfels, IgtMesh and gdm.Shell pixels, and "
        "every set pixel of a linear search (quality 'fast' or 'balanced'), whose hits stop within "
        "its last step off the stored surface (``stats['error_bound_search']``). It bounds drawn "
        "points only: a surface left undrawn is what ``coverage_uncertain`` is for.")
    coverage_uncertain = forward[npt.NDArray[np.bool_]](
        "(H, W) bool: true where the pixel's coverage (drawn or not) could differ from the source "
        "mesh's. Only pixels beside a coverage transition are candidates: eight probe rays around "
        "each one's centre, at its drawn surface's error bound plus a tenth of a texel (outline "
        "rounding) projected to pixels, mark it when a probe's hit or miss differs from its own. "
        "Every candidate is uncertain where its bound is unknown or the scene holds objects the "
        "ray queries do not trace (Surfels, IgtMesh). Opt-in: ``outputs=[..., "
        "'coverage_uncertain']``.")
    shadow = forward[npt.NDArray[np.bool_] | None](
        "(H, W) bool, true where the render's light cannot see the surface; None without a light.")
    face_id = forward[npt.NDArray[np.int32] | None](
        "(H, W) int32: the detailed mesh's face each pixel shows through an IgtMesh, -1 elsewhere; None "
        "when the scene holds no IgtMesh.")
    barycentric = forward[npt.NDArray[np.float32] | None](
        "(H, W, 3) float32 barycentric coordinates of each pixel's point in its `face_id` face (0 where "
        "there is none); None when the scene holds no IgtMesh.")
    stats = forward[dict[str, Any]](
        "gpu_ms (GPU timestamps, None where unsupported), cpu_ms (the whole call), patches_drawn, "
        "patches_culled (boxes outside the view), meshes_drawn, texture_bytes (the drawn sets' maps and "
        "pyramids on the adapter), setup_ms (of cpu_ms, the one-off a set's first frame pays: upload, "
        "ownership, tile pieces; 0 after), near, method, primary, covered_pixels, searches and "
        "searches_per_pixel (covered_pixels and the per-pixel figures None without \"patch_id\" in "
        "``outputs``); with a light the shadow pass's figures (shadow_ms, shadowed_pixels, ...); "
        "with surfels their counts (surfels_drawn, ...); with count_fetches also fetches, "
        "fetches_per_pixel, fetches_per_search and piece_tests_per_pixel; with \"error_bound\" "
        "error_bound_max and error_bound_median (world units, over the drawn pixels with a bound; None "
        "without any), error_bound_unknown_pixels (drawn, NaN bound) and error_bound_search (\"exact\" "
        "for the max-pyramid search, else a note that sets get no bound, NaN); with "
        "\"coverage_uncertain\" coverage_probes and coverage_ms; with ``lod`` lod_rule (\"pixel\", or "
        "\"bound\" with max_pixel_error) and lod_levels (drawn patches per stop level, 0 = exact).")

    def _repr_png_(self) -> bytes:
        """The color image over white as PNG bytes, for Jupyter."""
        return _preview.frame_png(self)

    def save(self, path: str | os.PathLike[str]) -> None:
        """Writes the color image over white (what ``_repr_png_`` shows) in the format the
        extension names (.png, .jpg, ...), atomically: no half file is ever left behind."""
        _preview.save_frame(self, path)
