"""Benchmark of surfel hierarchies (issue 19, after Object Textures): level of detail by projected
perpendicular error, splatted through a 64-bit atomic visibility buffer.

In one run, on one wgpu adapter, at 512x512, for the Stanford bunny (69,451 faces) and the same
bunny after two Loop subdivisions (~1.1 M faces), both converted at ``max_resolution=192``
(RESOLUTION, below, says why) and cut into the default 8x8-texel tiles (and 32x32, at the
default error only), with a front camera backing away so that the model spans from the full
image height down to 1/16 of it:

* per distance and per ``max_pixel_error``: surfels drawn (and the finest level's count in
  view), frame time (GPU timestamps around the compute and scene passes; median of
  ``--repeats`` after a warm-up; the meshes take turns at each distance), and against trimesh
  + embree ray casting of the original mesh: coverage IoU, depth p99 in pixel footprints
  (|Δz| over z·2·tan(fov/2)/512), median normal angle, and holes (pixels inside the
  reference's silhouette, eroded by one pixel, that the frame misses);
* at the default error, the meshes' surfel frames again with the meshes taking turns render by
  render (``--turns`` each), the frame-time comparison least disturbed by a loaded machine;
* at the default error, side by side: the original mesh rasterized and the geometry textures ray
  cast by the same renderer, as GPU ms and primitives (surfels, triangles) or pixels per second.

Results: ``bench/results/surfels.json`` and ``bench/results/surfels.png``.

Run from the repository root::

    nice python bench/surfels.py            # both meshes (~6 min)
    nice python bench/surfels.py --quick    # the bunny only, 3 errors
    nice python bench/surfels.py --quick --default   # the default (hybrid) set instead, into
                                                     # surfels_default.json / .png
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

import geomtex as gt
from geomtex import reference
from render import dense_bunny  # type: ignore[import-not-found]

REPO = Path(__file__).resolve().parents[1]
BUNNY = REPO.parent / "shared" / "meshes" / "stanford-bunny.obj"
OUT = REPO / "bench" / "results"
SIZE = 512
YFOV = 45.0
FRACTIONS = (1.0, 0.5, 0.25, 0.125, 0.0625)
ERRORS = (0.25, 0.5, 1.0, 2.0, 4.0)
DEFAULT_ERROR = 1.0
# The default tile (the paper's 64/16/4/1) with every error; a 32-texel tile (six levels, down to
# one surfel per 1024 texels) at the default error, to show what coarser top levels buy far away.
TILES = (8, 32)
# One fixed resolution for both meshes, so the two hierarchies hold about the same texels and
# the comparison is of face counts alone. Not the default conversion: error-driven within the
# mesh's bytes, it gives the scan texels ~1.5 px wide at full frame, and its surfels then miss
# the accuracy on their own (IoU 0.972 at 1/16, depth p99 1.24 px at full frame).
# Not 256: since multilevel VSA the 1.1 M-face bunny's hierarchy there is 4.2 M surfels,
# 134.6 MB, past lavapipe's 128 MiB storage binding (the renderer refuses it).
RESOLUTION = 192


def camera(mesh: gt.Mesh, fraction: float) -> gt.Camera:
    """A front view whose model spans `fraction` of the image height (its largest side)."""
    lo, hi = np.asarray(mesh.bounds)
    centre, size = (lo + hi) / 2, float((hi - lo).max())
    distance = size / fraction / (2 * np.tan(np.radians(YFOV / 2)))
    return gt.Camera.look_at(centre + [0.0, 0.0, distance], centre, yfov_deg=YFOV)


def timed(renderer: gt.Renderer, obj: Any, cam: gt.Camera, repeats: int,
          **options: Any) -> tuple[gt.Frame, float, float, float]:
    """The last frame, the median GPU and wall ms of `repeats` renders after a warm-up, and the
    fastest GPU ms (the least disturbed by other processes on a shared machine)."""
    frame = renderer.render(obj, cam, **options)
    gpu, wall = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        frame = renderer.render(obj, cam, **options)
        wall.append((time.perf_counter() - t0) * 1e3)
        gpu.append(frame.stats["gpu_ms"] if frame.stats["gpu_ms"] is not None else wall[-1])
    return frame, float(np.median(gpu)), float(np.median(wall)), float(np.min(gpu))


def accuracy(frame: gt.Frame, ref: dict[str, Any], diagonal: float) -> dict[str, float]:
    m = reference.compare(frame, ref, diagonal)
    both = np.isfinite(frame.depth) & ref["hit"]
    footprint = frame.depth[both] * 2 * np.tan(np.radians(YFOV / 2)) / SIZE
    dz = np.abs(frame.depth[both] - ref["depth"][both]) / footprint
    return {
        "iou": m["iou"],
        "depth_p99_px": float(np.percentile(dz, 99)),
        "depth_p99_1px_px": float(np.percentile(dz1_px(frame, ref, both), 99)),
        "normal_deg_median": m["normal_deg_median"],
        "holes_px": m["crack_px"],
        "covered_px": m["covered_px"],
        "ref_px": m["ref_px"],
    }


def dz1_px(frame: gt.Frame, ref: dict[str, Any], both: np.ndarray) -> np.ndarray:
    """|Δz| in pixel footprints to the nearest of the reference's 3x3 depths (a silhouette that
    moved by less than a pixel costs nothing)."""
    d = np.asarray(ref["depth"], dtype=np.float64)
    padded = np.pad(d, 1, constant_values=np.inf)
    near = np.full(d.shape, np.inf)
    with np.errstate(invalid="ignore"):
        for dy in range(3):
            for dx in range(3):
                near = np.fmin(near, np.abs(frame.depth - padded[dy:dy + d.shape[0], dx:dx + d.shape[1]]))
    footprint = frame.depth[both] * 2 * np.tan(np.radians(YFOV / 2)) / SIZE
    return near[both] / footprint


def prepare(mesh: gt.Mesh, default: bool = False) -> dict[str, Any]:
    """The mesh converted at RESOLUTION (or by default: a hybrid set, whose triangles are drawn
    as its mesh beside the surfels), its hierarchies of every tile, and its ray caster."""
    t0 = time.perf_counter()
    gts = gt.convert(mesh) if default else gt.convert(mesh, max_resolution=RESOLUTION)
    convert_s = time.perf_counter() - t0
    hierarchies, build_s = {}, {}
    for tile in TILES:
        t0 = time.perf_counter()
        hierarchies[tile] = gts.to_surfels(tile=tile)
        build_s[tile] = time.perf_counter() - t0
    return {"mesh": mesh, "gts": gts, "hierarchies": hierarchies, "caster": reference.RayCaster(mesh),
            "diagonal": reference.diagonal(mesh), "convert_s": convert_s, "build_s": build_s}


def measure(name: str, state: dict[str, Any], fraction: float, renderer: gt.Renderer,
            errors: tuple[float, ...], repeats: int) -> list[dict[str, Any]]:
    """One distance of one mesh: every (tile, error) run, and the mesh and set at the default."""
    mesh, gts = state["mesh"], state["gts"]
    cam = camera(mesh, fraction)
    ref = state["caster"].cast(cam, SIZE, SIZE)
    rows = []
    runs = [(tile, err) for tile in TILES for err in (errors if tile == TILES[0] else (DEFAULT_ERROR,))]
    for tile, err in runs:
        surfels = state["hierarchies"][tile]
        frame, gpu_ms, wall_ms, gpu_min = timed(renderer, surfels, cam, repeats, max_pixel_error=err)
        s = frame.stats
        row = {"mesh": name, "tile": tile, "fraction": fraction, "max_pixel_error": err, "gpu_ms": gpu_ms,
               "gpu_ms_min": gpu_min, "wall_ms": wall_ms, "surfels_drawn": s["surfels_drawn"],
               "surfels_finest_in_view": s["surfels_considered"],
               "surfels_per_level": [s[f"surfels_level_{k}"] for k in range(surfels.levels)],
               "surfels_above_tiles": s["surfels_above_tiles"],
               **accuracy(frame, ref, state["diagonal"])}
        compared = err == DEFAULT_ERROR and tile == TILES[0]
        if compared:
            _, mesh_ms, _, _ = timed(renderer, mesh, cam, repeats)
            gframe, gtex_ms, _, _ = timed(renderer, gts, cam, repeats)
            row.update(mesh_raster_gpu_ms=mesh_ms, gtex_gpu_ms=gtex_ms,
                       surfels_per_s=s["surfels_drawn"] / (gpu_ms / 1e3),
                       mesh_triangles_per_s=mesh.n_faces / (mesh_ms / 1e3),
                       gtex_pixels_per_s=int(np.isfinite(gframe.depth).sum()) / (gtex_ms / 1e3))
        rows.append(row)
        print(f"{name:12s} tile {tile:2d} 1/{1 / fraction:<4.0f} err {err:4.2f}: {gpu_ms:7.1f} ms, "
              f"{s['surfels_drawn']:8d} of {s['surfels_considered']:8d} surfels, IoU {row['iou']:.4f}, "
              f"depth p99 {row['depth_p99_px']:.3f} px, normal {row['normal_deg_median']:.2f}°, "
              f"holes {row['holes_px']}" + (f"  | mesh {row['mesh_raster_gpu_ms']:.1f} ms, gtex "
                                              f"{row['gtex_gpu_ms']:.1f} ms" if compared else ""))
    return rows


def side_by_side(states: dict[str, dict[str, Any]], renderer: gt.Renderer,
                 repeats: int) -> dict[str, dict[str, float]]:
    """Surfel frames of every mesh at each distance at the default error, the meshes taking turns
    render by render (not run by run, as `measure` does): on a loaded machine a neighbour's
    burst then slows both alike. Median and fastest GPU ms per mesh, keyed by fraction."""
    out: dict[str, dict[str, float]] = {}
    for fraction in FRACTIONS:
        cams = {name: camera(st["mesh"], fraction) for name, st in states.items()}
        ms: dict[str, list[float]] = {name: [] for name in states}
        for name, st in states.items():  # warm-up
            renderer.render(st["hierarchies"][TILES[0]], cams[name], max_pixel_error=DEFAULT_ERROR)
        for _ in range(repeats):
            for name, st in states.items():
                frame = renderer.render(st["hierarchies"][TILES[0]], cams[name], max_pixel_error=DEFAULT_ERROR)
                ms[name].append(frame.stats["gpu_ms"])
        out[str(fraction)] = {f"{name}_{k}": float(f(v)) for name, v in ms.items()
                              for k, f in (("gpu_ms", np.median), ("gpu_ms_min", np.min))}
        print(f"side by side 1/{1 / fraction:<4.0f}: " + ", ".join(
            f"{name} {np.median(v):.1f} ms (fastest {np.min(v):.1f})" for name, v in ms.items()))
    return out


def summary(results: dict[str, Any]) -> dict[str, Any]:
    """The issue's must-show figures at the default error."""
    out: dict[str, Any] = {}
    for name, r in results.items():
        d = [row for row in r["rows"] if row["max_pixel_error"] == DEFAULT_ERROR and row["tile"] == TILES[0]]
        big = [row for row in r["rows"] if row["tile"] == TILES[1]]
        eighth = next(row for row in d if row["fraction"] == 0.125)
        out[name] = {
            "iou_min": min(row["iou"] for row in d),
            "depth_p99_px_max": max(row["depth_p99_px"] for row in d),
            "depth_p99_1px_px_max": max(row["depth_p99_1px_px"] for row in d),
            "normal_deg_median_max": max(row["normal_deg_median"] for row in d),
            "holes_px_max": max(row["holes_px"] for row in d),
            "finest_over_drawn_at_eighth": eighth["surfels_finest_in_view"] / eighth["surfels_drawn"],
            "surfels_gpu_ms": {str(row["fraction"]): row["gpu_ms"] for row in d},
            "surfels_gpu_ms_min": {str(row["fraction"]): row["gpu_ms_min"] for row in d},
            "mesh_over_surfels_ms": {str(row["fraction"]): row["mesh_raster_gpu_ms"] / row["gpu_ms"] for row in d},
            "gtex_over_surfels_ms": {str(row["fraction"]): row["gtex_gpu_ms"] / row["gpu_ms"] for row in d},
            "surfels_drawn": {str(row["fraction"]): row["surfels_drawn"] for row in d},
            "surfels_above_tiles": {str(row["fraction"]): row["surfels_above_tiles"] for row in d},
            f"tile{TILES[1]}_surfels_gpu_ms": {str(row["fraction"]): row["gpu_ms"] for row in big},
            f"tile{TILES[1]}_surfels_drawn": {str(row["fraction"]): row["surfels_drawn"] for row in big},
            f"tile{TILES[1]}_iou_min": min(row["iou"] for row in big),
            f"tile{TILES[1]}_depth_p99_px_max": max(row["depth_p99_px"] for row in big),
            f"tile{TILES[1]}_holes_px_max": max(row["holes_px"] for row in big),
        }
    names = list(results)
    if len(names) == 2:
        # Frame time and (load-independent) surfels drawn, the 1.1 M-face bunny over the scan.
        for key in ("surfels_gpu_ms", "surfels_gpu_ms_min", f"tile{TILES[1]}_surfels_gpu_ms", "surfels_drawn"):
            a, b = (out[n][key] for n in names)
            out[f"dense_over_bunny_{key}"] = {f: b[f] / a[f] for f in a}
    return out


def plot(results: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 3, figsize=(16, 9))
    styles = {name: style for name, style in zip(results, ("-", "--"))}
    for name, r in results.items():
        rows = [row for row in r["rows"] if row["tile"] == TILES[0]]
        errs = sorted({row["max_pixel_error"] for row in rows})
        for frac in FRACTIONS:
            sel = [row for row in rows if row["fraction"] == frac]
            label = f"{name} 1/{1 / frac:.0f}"
            for a, key in zip(ax.flat[:5], ("surfels_drawn", "gpu_ms", "iou", "depth_p99_px", "normal_deg_median")):
                a.plot(errs, [row[key] for row in sel], styles[name], marker="o", label=label)
        d = [row for row in rows if row["max_pixel_error"] == DEFAULT_ERROR]
        frac = [row["fraction"] for row in d]
        for key, lab in (("gpu_ms", f"surfels, tile {TILES[0]}"), ("mesh_raster_gpu_ms", "mesh raster"),
                         ("gtex_gpu_ms", "gtex ray cast")):
            ax[1, 2].plot(frac, [row[key] for row in d], styles[name], marker="o", label=f"{name}: {lab}")
        big = [row for row in r["rows"] if row["tile"] == TILES[1]]
        ax[1, 2].plot([row["fraction"] for row in big], [row["gpu_ms"] for row in big], styles[name], marker="s",
                      label=f"{name}: surfels, tile {TILES[1]}")
    titles = ("surfels drawn", "frame GPU ms", "coverage IoU vs trimesh", "depth p99 (pixel footprints)",
              "median normal angle (deg)")
    for a, t in zip(ax.flat[:5], titles):
        a.set_xscale("log", base=2)
        a.set_xlabel("max_pixel_error")
        a.set_title(t)
    ax[0, 0].set_yscale("log")
    ax[1, 2].set_xscale("log", base=2)
    ax[1, 2].set_yscale("log")
    ax[1, 2].set_xlabel("model height / image height")
    ax[1, 2].set_title(f"GPU ms at max_pixel_error={DEFAULT_ERROR:g}")
    ax[0, 0].legend(fontsize=6)
    ax[1, 2].legend(fontsize=7)
    fig.suptitle(f"surfels at {SIZE}², camera backing away (bench/surfels.py)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="the bunny only, three errors")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--turns", type=int, default=21, help="renders per mesh in the side-by-side timing")
    parser.add_argument("--default", action="store_true",
                        help="the default (hybrid) convert instead of max_resolution=RESOLUTION")
    args = parser.parse_args()
    renderer = gt.Renderer(SIZE, SIZE)
    errors = (0.5, 1.0, 2.0) if args.quick else ERRORS
    meshes = {"bunny": lambda: gt.load_mesh(BUNNY)}
    if not args.quick:
        meshes["bunny_loop2"] = lambda: dense_bunny(BUNNY, 2)
    load_before = os.getloadavg()
    states = {name: prepare(make(), args.default) for name, make in meshes.items()}
    rows: dict[str, list[dict[str, Any]]] = {name: [] for name in states}
    # Distance by distance, every mesh in turn: the meshes' timings at one coverage are taken
    # seconds apart, so a busy neighbour on a shared machine shifts both alike.
    for fraction in FRACTIONS:
        for name, state in states.items():
            rows[name] += measure(name, state, fraction, renderer, errors, args.repeats)
    turns = side_by_side(states, renderer, args.turns)
    results = {
        name: {"faces": st["mesh"].n_faces, "convert_s": st["convert_s"],
               "surfels_build_s": {str(t): v for t, v in st["build_s"].items()},
               "surfels": {str(t): h.stats for t, h in st["hierarchies"].items()}, "rows": rows[name]}
        for name, st in states.items()
    }
    data = {
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "machine": platform.platform(),
        "adapter": renderer.adapter_info,
        "size": SIZE,
        "yfov_deg": YFOV,
        "max_resolution": None if args.default else RESOLUTION,
        "conversion": "default (hybrid)" if args.default else f"max_resolution={RESOLUTION}",
        "triangles_kept": {name: int(st["gts"].stats.get("triangle_faces", 0)) for name, st in states.items()},
        "repeats": args.repeats,
        # 1/5/15-minute load averages (2 cores shared with other builds): timings are noisy.
        "loadavg_start": load_before,
        "loadavg_end": os.getloadavg(),
        "summary": summary(results),
        # The meshes taking turns render by render (side_by_side), args.turns renders each.
        "side_by_side_turns": args.turns,
        "side_by_side": turns,
        "meshes": results,
    }
    OUT.mkdir(parents=True, exist_ok=True)
    stem = "surfels_default" if args.default else "surfels"
    plot(results, OUT / f"{stem}.png")
    if len(states) == 2:
        a, b = states
        data["side_by_side_dense_over_bunny"] = {
            f: {k: t[f"{b}_{k}"] / t[f"{a}_{k}"] for k in ("gpu_ms", "gpu_ms_min")} for f, t in turns.items()}
    write_json(OUT / f"{stem}.json", data, indent=1)
    print(json.dumps(data["summary"], indent=1))
    print(json.dumps(data.get("side_by_side_dense_over_bunny"), indent=1))


if __name__ == "__main__":
    main()
