"""``gt.info()``: what geomtex runs on (version, adapter, backend, features, the limits that
bind, the shader cache) and a self-check that draws a small known scene with every object kind
and compares each with a reference computed on the CPU without geomtex: the exact intersection
of the camera's rays with a sphere.

The scene is a unit sphere (an icosphere of 5,120 faces, whose facets lie within 1.2e-3 of the
true sphere) seen from three radii away. Each kind must cover the sphere's disc (IoU against the
analytic disc) and put its surface where the sphere is (depth error on the pixels both cover), or
the check fails: a blank frame, a frame of the wrong shape or depth, or an error fails it.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np
import numpy.typing as npt

from . import _core
from ._errors import DeviceError

#: Image side and camera of the self-check (a 64² frame; 3 radii away, 40° vertical field).
SIZE = 64
EYE_DISTANCE = 3.0
YFOV_DEG = 40.0
#: What each kind must reach. Measured on lavapipe (Mesa 22.3.6): IoU 0.9964 (surfels) to 1.0,
#: depth p90 2.3e-3 (mesh) to 9.5e-3 (IGT) radii; the bounds sit ~3x above the worst. A blank
#: frame reads IoU 0, a misplaced one depth errors near the radius.
MIN_IOU = 0.985
MAX_DEPTH_P90 = 0.03
#: Shadowed pixels against the sphere's analytic shadow, away from the terminator.
MIN_SHADOW_AGREEMENT = 0.99


def _camera_rays() -> npt.NDArray[np.float64]:
    """The self-check camera's pixel rays (SIZE, SIZE, 3), world space, with z = -1 (so a ray's
    parameter is its z-depth): row 0 at the top, pixel centres at +0.5."""
    half = np.tan(np.radians(YFOV_DEG) / 2)
    centres = (np.arange(SIZE) + 0.5) / SIZE * 2 - 1
    x, y = np.meshgrid(centres * half, -centres * half)
    return np.stack([x, y, -np.ones_like(x)], axis=-1)


def _sphere_reference() -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.float64]]:
    """Coverage and z-depth of the unit sphere in the self-check's camera, per pixel, by solving
    |o + t d|² = 1 for each camera ray."""
    d = _camera_rays()
    o = np.array([0.0, 0.0, EYE_DISTANCE])
    a = (d * d).sum(-1)
    b = 2 * (d @ o)
    c = o @ o - 1.0
    disc = b * b - 4 * a * c
    hit = disc >= 0
    t = np.where(hit, (-b - np.sqrt(np.where(hit, disc, 0))) / (2 * a), np.inf)
    return hit, t


def _sphere() -> Any:
    import trimesh

    from ._mesh import Mesh

    s = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    return Mesh(s.vertices, s.faces)


def _kinds(mesh: Any) -> dict[str, Callable[[], Any]]:
    """How to make each kind of the self-check's scene from the sphere (made when first checked,
    then kept for the process)."""
    import trimesh

    from . import convert, gdm, igt

    def gdm_shell() -> Any:
        # Solid below half the shell's height, empty above: the surface drawn lies halfway up
        # the prisms, on the unit sphere when the base sphere sits half a thickness inside it.
        thickness = 0.1
        occupancy = np.zeros((8, 8, 4), bool)
        occupancy[:, :, :2] = True
        return gdm.Shell(_scaled(mesh, 1.0 - thickness / 2), gdm.Volume(occupancy), thickness=thickness)

    def igt_mesh() -> Any:
        texture = igt.build(mesh, resolution=32)
        coarse = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
        return igt.attach(texture, coarse.vertices, coarse.faces)

    def the_set() -> Any:
        return _made("set", lambda: convert(mesh, max_resolution=64))

    return {
        "mesh": lambda: mesh,
        "set": the_set,
        "surfels": lambda: the_set().to_surfels(),
        "igt": igt_mesh,
        "gdm": gdm_shell,
    }


_MADE: dict[str, Any] = {}


def _made(name: str, make: Callable[[], Any]) -> Any:
    """The self-check's object of that kind, made once per process."""
    if name not in _MADE:
        _MADE[name] = make()
    return _MADE[name]


def _scaled(mesh: Any, scale: float) -> Any:
    from ._mesh import Mesh

    return Mesh(np.asarray(mesh.vertices) * scale, mesh.faces)


def _compare(drawn_depth: npt.NDArray[Any], hit: npt.NDArray[np.bool_],
             depth: npt.NDArray[np.float64]) -> dict[str, Any]:
    drawn = np.isfinite(drawn_depth)
    both = drawn & hit
    union = (drawn | hit).sum()
    iou = float(both.sum() / union) if union else 0.0
    error = float(np.quantile(np.abs(drawn_depth[both] - depth[both]), 0.9)) if both.any() else float("inf")
    return {"passed": iou >= MIN_IOU and error <= MAX_DEPTH_P90, "iou": round(iou, 4),
            "depth_p90": float(f"{error:.3g}")}


def _ray_query(gts: Any, hit: npt.NDArray[np.bool_], depth: npt.NDArray[np.float64]) -> dict[str, Any]:
    """The set's ray queries along the self-check's camera rays, against the analytic sphere."""
    d = _camera_rays().reshape(-1, 3)
    lengths = np.linalg.norm(d, axis=1)
    hits = gts.intersects_first(np.array([0.0, 0.0, EYE_DISTANCE]), d)
    return _compare(np.where(hits.hit, hits.distances / lengths, np.inf).reshape(SIZE, SIZE), hit, depth)


def _shadow(renderer: Any, camera: Any, gts: Any, hit: npt.NDArray[np.bool_],
            depth: npt.NDArray[np.float64]) -> dict[str, Any]:
    """The set's shadow rays under a directional light: on a convex sphere a point is in shadow
    exactly where its normal faces away from the light. Pixels within ~6° of the terminator,
    where a facet decides, are left out."""
    from ._render import DirectionalLight

    travel = np.array([1.0, -1.0, -0.5]) / np.linalg.norm([1.0, -1.0, -0.5])
    frame = renderer.render(gts, camera, light=DirectionalLight(travel))
    points = _camera_rays() * np.where(hit, depth, 0)[..., None]
    points[..., 2] += EYE_DISTANCE
    facing = -(points @ travel)  # the unit sphere's normal is the point itself
    judged = hit & (np.abs(facing) > 0.1) & np.isfinite(frame.depth)
    shadow = frame.shadow if frame.shadow is not None else np.zeros_like(hit)
    agree = float(np.mean(shadow[judged] == (facing[judged] < 0))) if judged.any() else 0.0
    return {"passed": agree >= MIN_SHADOW_AGREEMENT, "agreement": round(agree, 4)}


def self_check() -> dict[str, dict[str, Any]]:
    """Per kind (and for ray queries): passed, IoU and depth p90 (radii) against the analytic
    sphere, or the error it raised."""
    from ._camera import Camera
    from ._render import shared_renderer

    hit, depth = _sphere_reference()
    mesh = _made("sphere", _sphere)
    camera = Camera.look_at((0.0, 0.0, EYE_DISTANCE), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), yfov_deg=YFOV_DEG)
    renderer = shared_renderer(SIZE, SIZE)
    results: dict[str, dict[str, Any]] = {}
    kinds = _kinds(mesh)

    def drawn(name: str) -> Callable[[], dict[str, Any]]:
        return lambda: _compare(renderer.render(_made(name, kinds[name]), camera).depth, hit, depth)

    checks = {name: drawn(name) for name in kinds}
    checks["ray_query"] = lambda: _ray_query(kinds["set"](), hit, depth)
    checks["shadow"] = lambda: _shadow(renderer, camera, kinds["set"](), hit, depth)
    for name, check in checks.items():
        start = time.perf_counter()
        try:
            results[name] = check()
        except DeviceError as e:
            # The CPU backend refuses the kinds only the GPU draws, naming why: not a wrong
            # answer, and reported apart from one ("passed": None).
            refused = renderer.device == "cpu"
            results[name] = {"passed": None if refused else False, "error": f"DeviceError: {e}"}
        except Exception as e:  # the check reports every failure, whatever raised it
            results[name] = {"passed": False, "error": f"{type(e).__name__}: {e}"}
        results[name]["seconds"] = round(time.perf_counter() - start, 3)
    return results


def _shader_cache() -> str:
    """Mesa's on-disk shader cache: where it is, or that it is off (a cold cache makes a first
    frame compile its shaders; see the README's notes on first frames)."""
    if os.environ.get("MESA_SHADER_CACHE_DISABLE", "").lower() in ("1", "true", "yes"):
        return "disabled (MESA_SHADER_CACHE_DISABLE)"
    base = os.environ.get("MESA_SHADER_CACHE_DIR") or os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    path = Path(base) / "mesa_shader_cache" if "MESA_SHADER_CACHE_DIR" not in os.environ else Path(base)
    return f"{path} ({'present' if path.exists() else 'not yet written'})"


class Info(dict):  # type: ignore[type-arg]
    """What :func:`geomtex.info` returns: a dict of what geomtex runs on, printed as a table."""

    def __str__(self) -> str:
        rows: list[tuple[str, str]] = []
        for key, value in self.items():
            if key == "self_check":
                for kind, result in value.items():
                    detail = result.get("error") or ", ".join(
                        f"{k} {v}" for k, v in result.items() if k not in ("passed", "seconds"))
                    verdict = {True: "pass", None: "refused"}.get(result["passed"], "FAIL")
                    rows.append((f"self-check {kind}", f"{verdict} ({detail}; {result['seconds']} s)"))
            else:
                rows.append((key, str(value)))
        width = max(len(k) for k, _ in rows)
        return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)

    def _repr_pretty_(self, p: Any, cycle: bool) -> None:
        p.text(str(self))


def info(check: bool = True) -> Info:
    """What geomtex runs on, and a self-check that it draws correctly there.

    ``print(gt.info())`` shows it as a table; ``python -m geomtex info`` prints the same.

    Parameters
    ----------
    check : bool, default True
        Run the self-check: a 64² frame of a unit sphere drawn by every object kind (mesh, set,
        surfels, IGT mesh, GDM shell), traced by ray queries and shadowed, each compared with
        the exact intersection of the same rays with the sphere. Takes a second or two.

    Returns
    -------
    Info
        A dict: ``version``; the GPU adapter picked (``name``, ``backend``, ``device_type``,
        ``driver``, ``driver_info``), the optional features in use (64-bit atomics,
        timestamps) and the limits that bind (largest texture side, largest storage binding and
        buffer); ``shader_cache`` (Mesa's); with `check`, ``self_check`` (per kind:
        ``passed``, IoU and depth p90 in radii, or the ``error`` it raised; and ``seconds``);
        then what this process has made on the adapter: ``devices_made`` (one per process:
        every Renderer, ray query, preview and the viewer share it), ``target_sets_made`` (one
        per image size drawn), ``target_sizes_kept``, ``kinds_made`` (object kinds whose
        pipelines were made, each when its first object is drawn) and ``uploads`` (objects
        copied to the adapter, each once while it lives).

    Raises
    ------
    DeviceError
        No usable adapter was found (the message says why and how to fix it).
    """
    from ._render import shared_renderer

    result = Info(version=_core.__version__)
    result.update(shared_renderer(SIZE, SIZE).adapter_info)
    result["shader_cache"] = _shader_cache()
    if check:
        result["self_check"] = self_check()
    # What the process made on the adapter: one device whatever the sizes drawn and rays traced.
    result.update(_core.device_counts())
    return result
