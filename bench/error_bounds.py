"""Per-pixel error bounds (issue 43): does ``frame.error_bound`` hold, is it tight, does
``frame.coverage_uncertain`` cover every coverage difference, what do they cost, and does
``convert(..., guarantee=True)`` keep its promise?

Meshes: the Stanford bunny, fandisk and homer (``../shared/meshes``; the bunny falls back to the
bundled ``gt.data.bunny()``), the noisy isosurface (``geomtex.testing.noisy_isosurface``) and the
bunny after Loop subdivision to ~1.1 M faces (``geomtex.testing.subdivided``). Conversions: the
default ``gt.convert(mesh)``, and ``guarantee=True`` at ``max_error`` 1e-4 and 1e-3 of the
bounding-box diagonal. Views: five directions at 1.7 diagonals (``testing.look_from``, 40°), 512².

Per mesh x conversion x view:

* **holds**: every drawn pixel's world point (the pixel's ray at its z-depth: ``t = depth /
  (direction . camera.forward)``) is measured against the source mesh, scaled to a 1000-unit
  diagonal about its box centre (as ``geomtex.reference`` does) and scaled back. The distance is
  f64: Open3D's ``RaycastingScene.compute_closest_points`` (float32 BVH) finds each point's
  nearest face, and trimesh's ``triangles.closest_point`` measures the point to it in f64 (to it
  and every face sharing a corner with it where that passes the bound: float32 may pick a
  neighbour of the nearest), on every drawn pixel where ``open3d`` imports (``pip install
  open3d-cpu``, not in the bench extra: it brings dash, flask and a pytest plugin; on Debian it
  needs ``libusb-1.0-0``),
  else trimesh's ``closest_point`` on a random sample of ``--sample`` drawn pixels per view (the
  JSON says which and how many). Reported: the fraction of drawn pixels (with a known bound) whose
  distance is <= ``frame.error_bound`` (target >= 99.99%), the same with a float tolerance of 1e-6
  of the diagonal (the float32 depth and the reference's float32 are good to about 1e-7 of it),
  the exceptions (count, worst excess in diagonals and relative to the bound) and the largest
  distance / bound.
* **tight**: median bound / median distance over the drawn pixels (target <= 4).
* **coverage**: trimesh + embree ray casting of the original mesh with the frame's own pixel
  rays (``reference.RayCaster``); the pixels where it and the frame disagree about a hit; the
  fraction of them inside ``frame.coverage_uncertain`` (target 100%) and uncertain pixels per
  differing one (target <= 3). The default (exact) search and, on the first view, ``"fast"``.
* **cheap** (default conversion, first view): frame wall time with ``outputs`` the five standard
  arrays, the same plus ``"error_bound"``, plus ``"coverage_uncertain"`` and plus both, rounds
  interleaved (each round in a rotated order), median of ``--repeats``; and the same for
  depth-only frames. Bound bytes over the other maps' bytes (target <= 10%).
* **guarantee**: the measured largest distance over every view against ``max_error`` and the
  set's ``stats["error_bound_max"]``; bytes against the default set's; conversion seconds.
* **lod** (default conversion): ``render(..., lod=True, max_pixel_error=p)``: ``lod_levels``,
  whether the bound still holds, the frame time against the full-detail frame.

Results: ``bench/results/error_bounds.json`` and ``bench/results/error_bounds.png`` (measured
distance against the bound per mesh, log-log, with y = x), and ``docs/_static/error_bound.png``
(the bunny's default set, ``frame.error_bound`` over the front view).

Run from the repository root::

    nice python bench/error_bounds.py            # all five meshes (~30 min on 2 cores)
    nice python bench/error_bounds.py --quick    # bunny + fandisk, one view at 256² (~3 min)
"""

from __future__ import annotations

import argparse
import gc
import importlib.util
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

import geomtex as gt
from geomtex import reference, testing

REPO = Path(__file__).resolve().parents[1]
MESH_DIR = REPO.parent / "shared" / "meshes"
RESULTS = REPO / "bench" / "results"
PICTURE = REPO / "docs" / "_static" / "error_bound.png"

VIEWS = [("front", (0, 0, 1), (0, 1, 0)), ("top", (0, 1, 0), (0, 0, -1)), ("side", (1, 0, 0), (0, 1, 0)),
         ("oblique", (1, 0.8, 1), (0, 1, 0)), ("below", (0.3, -1, 0.2), (0, 1, 0))]
MESHES = ["stanford-bunny", "fandisk", "homer", "noisy-isosurface", "bunny-1.1M"]
QUICK_MESHES = ["stanford-bunny", "fandisk"]
#: (label, convert keywords as a function of the diagonal).
#: 1e-3 before 1e-4: where 1e-3 cannot be met at max_resolution, 1e-4 cannot either (skipped).
CONVERSIONS = [("default", lambda diag: {}),
               ("guarantee 1e-3", lambda diag: {"max_error": 1e-3 * diag, "guarantee": True}),
               ("guarantee 1e-4", lambda diag: {"max_error": 1e-4 * diag, "guarantee": True})]
STANDARD = ("color", "albedo", "depth", "normal", "patch_id")
#: Float tolerance of "holds (tol)": the frame's float32 depth and Open3D's float32 distances are
#: good to ~1e-7 of the diagonal at these views; 1e-6 of it is ten times that.
FLOAT_TOL_REL = 1e-6
LOD_PIXEL_ERRORS = (1.0, 4.0)
#: (distance, bound) pairs kept per view for the plot (and the JSON, to four digits).
PLOT_SAMPLES = 100

TARGETS = {"holds": 0.9999, "tight": 4.0, "coverage_inside": 1.0, "coverage_ratio": 3.0,
           "bound_bytes_ratio": 0.10}


# --------------------------------------------------------------------------- meshes and references


def load(name: str) -> tuple[gt.Mesh, str]:
    """The mesh and where it came from."""
    if name == "noisy-isosurface":
        return testing.noisy_isosurface(), "geomtex.testing.noisy_isosurface()"
    if name == "bunny-1.1M":
        base = MESH_DIR / "stanford-bunny.obj"
        src = gt.load_mesh(base) if base.exists() else gt.data.bunny()
        return testing.subdivided(src, 1_000_000), f"testing.subdivided({base.name if base.exists() else 'gt.data.bunny()'}, 1e6)"
    path = MESH_DIR / f"{name}.obj"
    if path.exists():
        return gt.load_mesh(path), str(path.relative_to(REPO.parent))
    if name == "stanford-bunny":
        return gt.data.bunny(), "gt.data.bunny() (no ../shared)"
    raise FileNotFoundError(path)


class Distances:
    """Distance from world points to the mesh surface, measured on a copy centred on the box and
    scaled to a 1000-unit diagonal (trimesh's closest-point tolerances and Open3D's float32 are
    absolute), scaled back. Open3D where it imports, else trimesh on a sample."""

    def __init__(self, mesh: gt.Mesh, sample: int, force_trimesh: bool = False) -> None:
        v = np.asarray(mesh.vertices, np.float64)
        f = np.asarray(mesh.faces, np.int64)
        lo, hi = v.min(axis=0), v.max(axis=0)
        self.centre = (lo + hi) / 2
        self.k = 1000.0 / float(np.linalg.norm(hi - lo))
        local = (v - self.centre) * self.k
        self.local, self.faces = local, f
        self.ring: np.ndarray | None = None
        self.sample = sample
        o3d = None
        if not force_trimesh and importlib.util.find_spec("open3d") is not None:
            try:
                import open3d as o3d
            except ImportError as e:  # e.g. the wheel's libusb-1.0 is not installed
                print(f"  open3d does not import ({e}); measuring with trimesh on a sample", flush=True)
        if o3d is not None:
            self.kind = "open3d"
            self.o3d = o3d
            self.scene = o3d.t.geometry.RaycastingScene()
            self.scene.add_triangles(o3d.core.Tensor(local.astype(np.float32)),
                                     o3d.core.Tensor(f.astype(np.uint32)))
        else:
            import trimesh

            self.kind = "trimesh"
            self.tm = trimesh.Trimesh(local, f, process=False)

    def __call__(self, points: np.ndarray, bound: np.ndarray | None = None) -> np.ndarray:
        """f64 distances; with ``bound``, points past it are measured again over the faces that
        share a corner with the one found (float32 may find a neighbour of the nearest)."""
        q = (np.asarray(points, np.float64) - self.centre) * self.k
        if self.kind == "open3d":
            found = self.scene.compute_closest_points(self.o3d.core.Tensor(q.astype(np.float32)))
            face = found["primitive_ids"].numpy().astype(np.int64)
            d = self._to_faces(q, face[:, None])
            if bound is not None:
                again = np.flatnonzero(d > np.asarray(bound) * self.k)
                if len(again):
                    d[again] = self._to_faces(q[again], self._corner_ring(face[again]))
            return d / self.k
        import trimesh

        _, d, _ = trimesh.proximity.closest_point(self.tm, q)
        return np.asarray(d, np.float64) / self.k

    def _to_faces(self, q: np.ndarray, faces: np.ndarray) -> np.ndarray:
        """Least f64 distance from each point to its row of faces (-1: none)."""
        import trimesh

        n, m = faces.shape
        rows, cols = np.nonzero(faces >= 0)
        tri = self.local[self.faces[faces[rows, cols]]]
        cp = trimesh.triangles.closest_point(tri, q[rows])
        d = np.full((n, m), np.inf)
        d[rows, cols] = np.linalg.norm(cp - q[rows], axis=1)
        return d.min(axis=1)

    def _corner_ring(self, face: np.ndarray) -> np.ndarray:
        """Each face with every face sharing a corner with it, padded with -1."""
        import trimesh

        if self.ring is None:
            self.ring = trimesh.Trimesh(self.local, self.faces, process=False).vertex_faces
        ring = self.ring[self.faces[face]].reshape(len(face), -1)
        return np.concatenate([face[:, None], ring], axis=1)


def drawn_points(camera: gt.Camera, depth: np.ndarray) -> np.ndarray:
    """World point of every pixel at its z-depth ((H, W, 3); inf where nothing is drawn)."""
    h, w = depth.shape
    origins, directions = camera.rays(w, h)
    cos = directions @ np.asarray(camera.forward, np.float64)
    t = np.asarray(depth, np.float64) / cos
    return origins + directions * t[..., None]


# --------------------------------------------------------------------------- measurements


def holds(dist: np.ndarray, bound: np.ndarray, diag: float) -> dict[str, Any]:
    """Bound against measured distance on the pixels where both are known."""
    n = len(dist)
    if n == 0:
        return {"pixels": 0}
    excess = dist - bound
    bad = excess > 0
    tol_bad = excess > FLOAT_TOL_REL * diag
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(bound > 0, dist / bound, np.where(dist > 0, np.inf, 0.0))
    worst = int(np.argmax(excess))
    out: dict[str, Any] = {
        "pixels": n,
        "holds": float(1.0 - bad.mean()),
        "holds_tol": float(1.0 - tol_bad.mean()),
        "exceptions": int(bad.sum()),
        "exceptions_tol": int(tol_bad.sum()),
        "worst_excess_rel": float(max(excess[worst], 0.0) / diag),
        "worst_excess_over_bound": float(max(excess[worst], 0.0) / bound[worst]) if bound[worst] > 0 else
        (float("inf") if excess[worst] > 0 else 0.0),
        "max_dist_over_bound": float(np.max(ratio)),
        "dist_median_rel": float(np.median(dist) / diag),
        "dist_max_rel": float(np.max(dist) / diag),
        "bound_median_rel": float(np.median(bound) / diag),
        "bound_max_rel": float(np.max(bound) / diag),
        "tight": float(np.median(bound) / np.median(dist)) if np.median(dist) > 0 else float("inf"),
        "bound_zero_pixels": int((bound == 0).sum()),
    }
    if bad.any():
        idx = np.nonzero(bad)[0]
        top = idx[np.argsort(-excess[idx])[:5]]
        out["worst_exceptions"] = [{"dist_rel": float(dist[i] / diag), "bound_rel": float(bound[i] / diag)}
                                   for i in top]
    return out


def coverage(frame: Any, ref_hit: np.ndarray) -> dict[str, Any]:
    drawn = np.isfinite(np.asarray(frame.depth))
    diff = drawn ^ ref_hit
    out: dict[str, Any] = {"differing": int(diff.sum()), "missed": int((ref_hit & ~drawn).sum()),
                           "extra": int((drawn & ~ref_hit).sum())}
    try:
        unc = np.asarray(frame.coverage_uncertain, bool)
    except (AttributeError, gt.ParameterError) as e:
        out["coverage_uncertain"] = f"unavailable: {e}"
        return out
    out["uncertain"] = int(unc.sum())
    out["inside"] = float((diff & unc).sum() / diff.sum()) if diff.any() else 1.0
    out["outside"] = int((diff & ~unc).sum())
    out["ratio"] = float(unc.sum() / diff.sum()) if diff.any() else (0.0 if not unc.any() else float("inf"))
    return out


def frame_stats(frame: Any) -> dict[str, Any]:
    keys = ("error_bound_max", "error_bound_median", "error_bound_search", "coverage_probes", "coverage_ms",
            "lod_levels", "cpu_ms", "gpu_ms", "covered_pixels", "method")
    return {k: frame.stats[k] for k in keys if k in frame.stats}


def measure_view(renderer: gt.Renderer, gts: Any, cam: gt.Camera, dists: Distances, ref_hit: np.ndarray,
                 diag: float, rng: np.random.Generator, keep: list[np.ndarray], **options: Any) -> dict[str, Any]:
    frame = renderer.render(gts, cam, outputs=("depth", "error_bound", "coverage_uncertain", "patch_id"), **options)
    depth = np.asarray(frame.depth)
    bound = np.asarray(frame.error_bound, np.float64)
    drawn = np.isfinite(depth)
    rec: dict[str, Any] = {"drawn": int(drawn.sum()), "stats": frame_stats(frame),
                           "bound_nan_drawn": int((drawn & ~np.isfinite(bound)).sum()),
                           "bound_outside_drawn": int((~drawn & np.isfinite(bound)).sum())}
    known = drawn & np.isfinite(bound)
    idx = np.flatnonzero(known)
    if dists.kind == "trimesh" and len(idx) > dists.sample:
        idx = rng.choice(idx, dists.sample, replace=False)
    rec["measured_pixels"] = int(len(idx))
    pts = drawn_points(cam, depth).reshape(-1, 3)[idx]
    t0 = time.perf_counter()
    d = dists(pts, bound.reshape(-1)[idx])
    rec["reference_s"] = time.perf_counter() - t0
    b = bound.reshape(-1)[idx]
    rec["holds"] = holds(d, b, diag)
    # A hybrid set's triangles are the mesh's own faces (bound: float error only): tightness is
    # also taken over the height maps' pixels alone.
    on_maps = np.asarray(frame.patch_id).reshape(-1)[idx] >= 0
    if not on_maps.all():
        rec["holds_maps"] = holds(d[on_maps], b[on_maps], diag)
        rec["holds_triangles"] = holds(d[~on_maps], b[~on_maps], diag)
    take = rng.choice(len(d), min(len(d), PLOT_SAMPLES), replace=False) if len(d) else np.zeros(0, int)
    keep.append(np.stack([d[take], b[take]], axis=1) / diag)
    rec["coverage"] = coverage(frame, ref_hit)
    return rec


def timed(renderer: gt.Renderer, gts: Any, cam: gt.Camera, variants: dict[str, tuple[str, ...]],
          repeats: int) -> dict[str, Any]:
    """Median wall ms per outputs variant; rounds interleaved, each round in a rotated order."""
    names = list(variants)
    for n in names:  # warm-up: each variant's first frame
        renderer.render(gts, cam, outputs=variants[n])
    runs: dict[str, list[float]] = {n: [] for n in names}
    for r in range(repeats):
        for n in names[r % len(names):] + names[:r % len(names)]:
            t0 = time.perf_counter()
            renderer.render(gts, cam, outputs=variants[n])
            runs[n].append(1000.0 * (time.perf_counter() - t0))
    med = {n: float(np.median(v)) for n, v in runs.items()}
    base = names[0]
    return {"ms": med, "over_base": {n: med[n] / med[base] for n in names}, "runs_ms": runs}


def cheap(renderer: gt.Renderer, gts: Any, cam: gt.Camera, repeats: int) -> dict[str, Any]:
    full = {"standard": STANDARD, "+error_bound": STANDARD + ("error_bound",),
            "+coverage_uncertain": STANDARD + ("coverage_uncertain",),
            "+both": STANDARD + ("error_bound", "coverage_uncertain")}
    depth = {"depth": ("depth",), "depth+error_bound": ("depth", "error_bound"),
             "depth+coverage_uncertain": ("depth", "coverage_uncertain")}
    return {"standard": timed(renderer, gts, cam, full, repeats),
            "depth_only": timed(renderer, gts, cam, depth, repeats),
            "loadavg": list(os.getloadavg())}


def bound_bytes(gts: Any) -> dict[str, Any]:
    s = gts.stats
    out: dict[str, Any] = {"bytes": int(s["bytes"])}
    if "patch_bytes" in s:  # a hybrid set: its height maps' bytes, and its triangles'
        out.update(patch_bytes=int(s["patch_bytes"]), triangle_bytes=int(s["triangle_bytes"]),
                   triangle_faces=int(s["triangle_faces"]))
    for k in ("error_bound_bytes", "error_bound_max", "error_bound_p99"):
        if k in s:
            out[k] = float(s[k]) if k != "error_bound_bytes" else int(s[k])
    if "error_bound_bytes" in out:
        # The bound against the maps it bounds (not a hybrid set's triangles).
        maps = out.get("patch_bytes", out["bytes"]) - out["error_bound_bytes"]
        out["bound_over_maps"] = out["error_bound_bytes"] / maps if maps > 0 else None
    return out


def lod_rows(renderer: gt.Renderer, gts: Any, cam: gt.Camera, dists: Distances, ref_hit: np.ndarray,
             diag: float, rng: np.random.Generator, repeats: int) -> list[dict[str, Any]]:
    rows = []
    for p in LOD_PIXEL_ERRORS:
        try:
            rec = measure_view(renderer, gts, cam, dists, ref_hit, diag, rng, [], lod=True, max_pixel_error=p)
        except (gt.ParameterError, TypeError) as e:
            rows.append({"max_pixel_error": p, "unavailable": str(e)})
            continue
        walls = {"full": [], "lod": []}
        renderer.render(gts, cam, outputs=("depth",), lod=True, max_pixel_error=p)
        for _ in range(repeats):
            for name, kw in (("full", {}), ("lod", {"lod": True, "max_pixel_error": p})):
                t0 = time.perf_counter()
                renderer.render(gts, cam, outputs=("depth",), **kw)
                walls[name].append(1000.0 * (time.perf_counter() - t0))
        rec["max_pixel_error"] = p
        rec["ms"] = {k: float(np.median(v)) for k, v in walls.items()}
        rows.append(rec)
    return rows


def measure_mesh(name: str, views: list[tuple[str, Any, Any]], size: int, args: argparse.Namespace,
                 picture: bool) -> dict[str, Any]:
    mesh, source = load(name)
    diag = float(mesh.diagonal)
    print(f"== {name}: {len(np.asarray(mesh.faces)):,} faces ({source})", flush=True)
    t0 = time.perf_counter()
    dists = Distances(mesh, args.sample, force_trimesh=args.trimesh)
    caster = reference.RayCaster(mesh)
    ref_s = time.perf_counter() - t0
    renderer = gt.Renderer(size, size)
    rng = np.random.default_rng(43)
    cams = [(v, testing.look_from(mesh, d, up=u)) for v, d, u in views]
    ref_hits = {v: caster.cast(cam, size, size)["hit"] for v, cam in cams}
    out: dict[str, Any] = {"faces": int(len(np.asarray(mesh.faces))), "source": source, "diagonal": diag,
                           "reference": dists.kind, "reference_build_s": ref_s, "conversions": {}}
    default_bytes = None
    for label, kw in CONVERSIONS:
        kwargs = kw(diag)
        if label == "guarantee 1e-4" and "cannot bound" in out["conversions"].get("guarantee 1e-3", {}).get("refused", ""):
            out["conversions"][label] = {"keywords": kwargs, "refused": "skipped: 1e-3 could not be met"}
            continue
        t0 = time.perf_counter()

        def stop_late(stage: str, fraction: float) -> bool:
            return label == "default" or time.perf_counter() - t0 < args.convert_timeout

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", gt.CapWarning)
                gts = gt.convert(mesh, progress=stop_late, **kwargs)
        except (gt.ParameterError, gt.CancelledError, TypeError) as e:
            why = (f"cancelled after {args.convert_timeout:.0f} s" if isinstance(e, gt.CancelledError) else str(e))
            out["conversions"][label] = {"keywords": kwargs, "refused": why,
                                         "seconds": time.perf_counter() - t0}
            print(f"  {label}: {why} ({time.perf_counter() - t0:.0f} s)", flush=True)
            continue
        seconds = time.perf_counter() - t0
        print(f"  {label}: converted in {seconds:.1f} s, {gts.stats['bytes']:,} bytes", flush=True)
        rec: dict[str, Any] = {"keywords": kwargs, "seconds": seconds, "set": bound_bytes(gts)}
        if label == "default":
            default_bytes = rec["set"]["bytes"]
        rec["bytes_over_default"] = rec["set"]["bytes"] / default_bytes if default_bytes else None
        keep: list[np.ndarray] = []
        rec["views"] = {}
        for v, cam in cams:
            rec["views"][v] = measure_view(renderer, gts, cam, dists, ref_hits[v], diag, rng, keep)
            h = rec["views"][v]["holds"]
            c = rec["views"][v]["coverage"]
            print(f"  {label:15s} {v:8s} holds {h.get('holds', float('nan')):.6f} "
                  f"({h.get('exceptions', 0)} exc, {h.get('exceptions_tol', 0)} past tol) "
                  f"tight {h.get('tight', float('nan')):.2f} max d/b {h.get('max_dist_over_bound', float('nan')):.3g} "
                  f"cov diff {c['differing']} inside {c.get('inside', float('nan')):.3f} "
                  f"ratio {c.get('ratio', float('nan')):.2f}", flush=True)
        rec["samples_rel"] = [[float(f"{x:.4g}") for x in row] for row in np.concatenate(keep)] if keep else []
        rec["summary"] = summarise(rec, diag)
        if label == "default":
            first_v, first_cam = cams[0]
            fast = measure_view(renderer, gts, first_cam, dists, ref_hits[first_v], diag, rng, [], quality="fast")
            rec["fast_first_view"] = fast
            print(f"  fast search, {first_v}: holds {fast['holds'].get('holds', float('nan')):.6f}, coverage "
                  f"{fast['coverage']}", flush=True)
            rec["cheap"] = cheap(renderer, gts, first_cam, args.repeats)
            print(f"  cost: {rec['cheap']['standard']['over_base']} {rec['cheap']['depth_only']['over_base']}", flush=True)
            rec["lod"] = lod_rows(renderer, gts, first_cam, dists, ref_hits[first_v], diag, rng, args.repeats)
            for row in rec["lod"]:
                print(f"  lod {row.get('max_pixel_error')}: levels {row.get('stats', {}).get('lod_levels')} holds "
                      f"{row.get('holds', {}).get('holds')} ms {row.get('ms')}", flush=True)
            if picture:
                save_picture(gts, mesh)
        else:
            e = kwargs["max_error"]
            s = rec["summary"]
            rec["guarantee"] = {"max_error_rel": e / diag, "measured_max_rel": s["dist_max_rel"],
                                "holds_every_view": bool(s["dist_max_rel"] * diag <= e),
                                "set_bound_max_rel": rec["set"].get("error_bound_max", float("nan")) / diag,
                                "set_bound_within": bool(rec["set"].get("error_bound_max", np.inf) <= e)}
        out["conversions"][label] = rec
        del gts
        gc.collect()
    return out


def summarise(rec: dict[str, Any], diag: float) -> dict[str, Any]:
    """Pooled over the views."""
    hs = [v["holds"] for v in rec["views"].values() if v["holds"].get("pixels")]
    cs = [v["coverage"] for v in rec["views"].values()]
    n = sum(h["pixels"] for h in hs)
    diff = sum(c["differing"] for c in cs)
    unc = sum(c.get("uncertain", 0) for c in cs)
    outside = sum(c.get("outside", 0) for c in cs)
    return {
        "pixels": n,
        "holds": sum(h["holds"] * h["pixels"] for h in hs) / n if n else None,
        "holds_tol": sum(h["holds_tol"] * h["pixels"] for h in hs) / n if n else None,
        "exceptions": sum(h["exceptions"] for h in hs),
        "exceptions_tol": sum(h["exceptions_tol"] for h in hs),
        "worst_excess_rel": max((h["worst_excess_rel"] for h in hs), default=None),
        "max_dist_over_bound": max((h["max_dist_over_bound"] for h in hs), default=None),
        "tight_worst_view": max((h["tight"] for h in hs), default=None),
        # Over the height maps' pixels only (hybrid sets; the same as above for all-map sets).
        "tight_maps_worst_view": max((v.get("holds_maps", v["holds"]).get("tight", 0.0)
                                      for v in rec["views"].values() if v["holds"].get("pixels")), default=None),
        # Over the triangles' pixels only (hybrid sets; None where no view shows one).
        "tight_triangles_worst_view": max((v["holds_triangles"]["tight"] for v in rec["views"].values()
                                           if v.get("holds_triangles", {}).get("pixels")), default=None),
        "tight_median_view": float(np.median([h["tight"] for h in hs])) if hs else None,
        "dist_max_rel": max((h["dist_max_rel"] for h in hs), default=None),
        "bound_nan_drawn": sum(v["bound_nan_drawn"] for v in rec["views"].values()),
        "coverage_differing": diff,
        "coverage_outside": outside,
        "coverage_inside": (diff - outside) / diff if diff else 1.0,
        "coverage_ratio": unc / diff if diff else (0.0 if unc == 0 else float("inf")),
    }


# --------------------------------------------------------------------------- reporting


def save_picture(gts: Any, mesh: gt.Mesh) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    cam = testing.look_from(mesh, (0, 0, 1), up=(0, 1, 0))
    frame = gt.Renderer(512, 512).render(gts, cam, outputs=("color", "depth", "error_bound"))
    rel = np.asarray(frame.error_bound, np.float64) / float(mesh.diagonal)
    color = np.asarray(frame.color)
    # Cropped to the drawn pixels with a margin.
    rows, cols = np.nonzero(np.isfinite(np.asarray(frame.depth)))
    r0, r1 = max(rows.min() - 8, 0), min(rows.max() + 9, rel.shape[0])
    c0, c1 = max(cols.min() - 8, 0), min(cols.max() + 9, rel.shape[1])
    rel, color = rel[r0:r1, c0:c1], color[r0:r1, c0:c1]
    finite = rel[np.isfinite(rel) & (rel > 0)]
    fig, axes = plt.subplots(1, 2, figsize=(8.4, 3.6), gridspec_kw={"width_ratios": [1, 1.22]})
    axes[0].imshow(np.where(color[..., 3:] > 0, color[..., :3], 255))
    axes[0].set_title("frame.color")
    im = axes[1].imshow(np.ma.masked_invalid(np.where(rel > 0, rel, np.nan)), cmap="viridis",
                        norm=LogNorm(vmin=max(finite.min(), finite.max() / 1e3), vmax=finite.max()))
    axes[1].set_title("frame.error_bound / diagonal")
    fig.colorbar(im, ax=axes[1], fraction=0.046, pad=0.04)
    for a in axes:
        a.set_axis_off()
    fig.tight_layout()
    PICTURE.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(PICTURE, dpi=80)
    plt.close(fig)
    print(f"  wrote {PICTURE} ({PICTURE.stat().st_size // 1024} KB)", flush=True)


def fmt(x: Any, spec: str = ".3g") -> str:
    if x is None:
        return "-"
    if isinstance(x, float) and not np.isfinite(x):
        return str(x)
    return format(x, spec)


def table(d: dict[str, Any]) -> str:
    head = (f"{'mesh':18s} {'conversion':15s} {'bytes':>10s} {'x def':>6s} {'conv s':>7s} {'holds':>9s} "
            f"{'holds tol':>9s} {'exc':>5s} {'max d/b':>8s} {'tight':>6s} {'d max/diag':>10s} {'b max/diag':>10s} "
            f"{'cov diff':>8s} {'inside':>7s} {'unc/diff':>8s} {'eb ms x':>8s} {'cu ms x':>8s} {'eb bytes':>8s}")
    lines = [head, "-" * len(head)]
    for name, m in d["meshes"].items():
        for label, c in m["conversions"].items():
            if "refused" in c:
                lines.append(f"{name:18s} {label:15s} refused: {c['refused'][:80]}")
                continue
            s = c["summary"]
            ch = c.get("cheap", {}).get("standard", {}).get("over_base", {})
            lines.append(
                f"{name:18s} {label:15s} {c['set']['bytes']:10d} {c['bytes_over_default']:6.2f} {c['seconds']:7.1f} "
                f"{fmt(s['holds'], '.6f'):>9s} {fmt(s['holds_tol'], '.6f'):>9s} {s['exceptions']:5d} "
                f"{fmt(s['max_dist_over_bound']):>8s} {fmt(s['tight_worst_view'], '.2f'):>6s} "
                f"{fmt(s['dist_max_rel']):>10s} {fmt(c['set'].get('error_bound_max', float('nan')) / m['diagonal']):>10s} "
                f"{s['coverage_differing']:8d} {fmt(s['coverage_inside'], '.3f'):>7s} {fmt(s['coverage_ratio'], '.2f'):>8s} "
                f"{fmt(ch.get('+error_bound'), '.2f'):>8s} {fmt(ch.get('+coverage_uncertain'), '.2f'):>8s} "
                f"{fmt(c['set'].get('bound_over_maps'), '.3f'):>8s}")
    return "\n".join(lines)


def summary_rows(d: dict[str, Any]) -> list[dict[str, Any]]:
    """One flat record per mesh x conversion (the benchmark page's first table)."""
    rows = []
    for name, m in d["meshes"].items():
        for label, c in m["conversions"].items():
            if "refused" in c:
                rows.append({"mesh": name, "conversion": label, "refused": c["refused"][:80]})
                continue
            s = c["summary"]
            ch = c.get("cheap", {})
            rows.append({
                "mesh": name, "conversion": label, "bytes": c["set"]["bytes"], "bytes_over_default": c["bytes_over_default"],
                "convert_s": c["seconds"], "holds": s["holds"], "holds_tol": s["holds_tol"], "exceptions": s["exceptions"],
                "max_dist_over_bound": s["max_dist_over_bound"], "tight_worst_view": s["tight_worst_view"],
                "tight_maps_worst_view": s.get("tight_maps_worst_view"),
                "tight_triangles_worst_view": s.get("tight_triangles_worst_view"),
                "triangle_faces": c["set"].get("triangle_faces", 0),
                "dist_max_rel": s["dist_max_rel"],
                "set_bound_max_rel": c["set"].get("error_bound_max", float("nan")) / m["diagonal"],
                "coverage_differing": s["coverage_differing"], "coverage_inside": s["coverage_inside"],
                "coverage_ratio": s["coverage_ratio"],
                "error_bound_ms_ratio": ch.get("standard", {}).get("over_base", {}).get("+error_bound"),
                "coverage_uncertain_ms_ratio": ch.get("standard", {}).get("over_base", {}).get("+coverage_uncertain"),
                "bound_bytes_over_maps": c["set"].get("bound_over_maps")})
    return rows


def verdicts(d: dict[str, Any]) -> dict[str, Any]:
    """Each target against the worst figure over the meshes and conversions."""
    rows = [(n, lab, c) for n, m in d["meshes"].items() for lab, c in m["conversions"].items() if "summary" in c]
    worst_hold = min(rows, key=lambda r: r[2]["summary"]["holds"] if r[2]["summary"]["holds"] is not None else 1)
    worst_tight = max(rows, key=lambda r: r[2]["summary"]["tight_worst_view"] or 0)
    worst_tight_maps = max(rows, key=lambda r: r[2]["summary"].get("tight_maps_worst_view") or 0)
    worst_inside = min(rows, key=lambda r: r[2]["summary"]["coverage_inside"])
    worst_ratio = max(rows, key=lambda r: r[2]["summary"]["coverage_ratio"])
    byte_rows = [(n, lab, c["set"]["bound_over_maps"]) for n, lab, c in rows if c["set"].get("bound_over_maps") is not None]
    guarantee = [(n, lab, c["guarantee"]) for n, lab, c in rows if "guarantee" in c]
    out: dict[str, Any] = {
        "holds": {"worst": worst_hold[2]["summary"]["holds"], "where": worst_hold[:2], "target": TARGETS["holds"]},
        "tight": {"worst": worst_tight[2]["summary"]["tight_worst_view"], "where": worst_tight[:2],
                  "target": TARGETS["tight"]},
        "tight_maps": {"worst": worst_tight_maps[2]["summary"].get("tight_maps_worst_view"),
                       "where": worst_tight_maps[:2], "target": TARGETS["tight"]},
        "coverage_inside": {"worst": worst_inside[2]["summary"]["coverage_inside"], "where": worst_inside[:2],
                            "target": TARGETS["coverage_inside"]},
        "coverage_ratio": {"worst": worst_ratio[2]["summary"]["coverage_ratio"], "where": worst_ratio[:2],
                           "target": TARGETS["coverage_ratio"]},
    }
    if byte_rows:
        b = max(byte_rows, key=lambda r: r[2])
        out["bound_bytes_ratio"] = {"worst": b[2], "where": b[:2], "target": TARGETS["bound_bytes_ratio"]}
    refused = [f"{n} {lab}: {c['refused'][:120]}" for n, m in d["meshes"].items()
               for lab, c in m["conversions"].items() if "refused" in c]
    out["refused"] = refused
    if guarantee:
        out["guarantee"] = {"every_view": all(g["holds_every_view"] for _, _, g in guarantee),
                            "set_bound_within": all(g["set_bound_within"] for _, _, g in guarantee),
                            "cases": len(guarantee)}
    for k, v in out.items():
        if isinstance(v, dict) and "target" in v and v["worst"] is not None:
            v["pass"] = bool(v["worst"] >= v["target"]) if k in ("holds", "coverage_inside") else bool(v["worst"] <= v["target"])
    return out


def plot(d: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(d["meshes"])
    fig, axes = plt.subplots(1, len(names), figsize=(3.6 * len(names), 3.6), squeeze=False)
    colors = {"default": "C0", "guarantee 1e-4": "C1", "guarantee 1e-3": "C2"}
    for ax, name in zip(axes[0], names):
        lo, hi = np.inf, 0.0
        for label, c in d["meshes"][name]["conversions"].items():
            s = np.asarray(c.get("samples_rel", []), np.float64).reshape(-1, 2)
            if not len(s):
                continue
            floor = 1e-9
            x, y = np.maximum(s[:, 1], floor), np.maximum(s[:, 0], floor)
            ax.scatter(x, y, s=3, alpha=0.5, color=colors.get(label, "C3"), label=label, rasterized=True)
            lo, hi = min(lo, x.min(), y.min()), max(hi, x.max(), y.max())
        if hi > 0:
            ax.plot([lo, hi], [lo, hi], "k-", lw=0.8, label="distance = bound")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("frame.error_bound / diagonal")
        ax.set_title(name, fontsize=10)
    axes[0][0].set_ylabel("measured distance to mesh / diagonal")
    axes[0][0].legend(fontsize=7, markerscale=3)
    fig.suptitle("Drawn points: distance to the source mesh against the per-pixel bound (below the line: holds)",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="bunny + fandisk, one view at 256²")
    ap.add_argument("--meshes", nargs="+", help=f"a subset of {MESHES}")
    ap.add_argument("--size", type=int, help="image side (default 512, 256 with --quick)")
    ap.add_argument("--repeats", type=int, default=7, help="timed frames per variant (median)")
    ap.add_argument("--sample", type=int, default=20_000,
                    help="pixels per view measured by trimesh where open3d does not import")
    ap.add_argument("--trimesh", action="store_true", help="measure distances with trimesh even with open3d")
    ap.add_argument("--convert-timeout", type=float, default=300.0,
                    help="seconds after which a guarantee conversion is cancelled (recorded as such)")
    ap.add_argument("--out", type=Path, default=RESULTS / "error_bounds.json")
    args = ap.parse_args()
    names = args.meshes or (QUICK_MESHES if args.quick else MESHES)
    views = VIEWS[:1] if args.quick else VIEWS
    size = args.size or (256 if args.quick else 512)
    if args.quick:
        args.repeats = min(args.repeats, 5)
    t_start = time.perf_counter()
    d: dict[str, Any] = {"quick": args.quick, "size": size, "views": [v[0] for v in views],
                         "targets": TARGETS, "float_tol_rel": FLOAT_TOL_REL, "loadavg_before": list(os.getloadavg()),
                         "meshes": {}}
    for name in names:
        try:
            d["meshes"][name] = measure_mesh(name, views, size, args, picture=name == "stanford-bunny" and not args.quick)
        except FileNotFoundError as e:
            print(f"  skipped {name}: {e}", flush=True)
        gc.collect()
        RESULTS.mkdir(exist_ok=True)
        write_json(args.out, {**d, "partial": True})  # what is done so far, should a later mesh fail
    d["verdicts"] = verdicts(d)
    d = {"table": summary_rows(d), **d}
    d["loadavg_after"] = list(os.getloadavg())
    d["seconds"] = time.perf_counter() - t_start
    RESULTS.mkdir(exist_ok=True)
    write_json(args.out, d)
    plot(d, args.out.with_suffix(".png"))
    print(table(d))
    for k, v in d["verdicts"].items():
        print(f"{k}: {v}")
    print(f"wrote {args.out} ({d['seconds']:.0f} s)")


if __name__ == "__main__":
    sys.exit(main())
