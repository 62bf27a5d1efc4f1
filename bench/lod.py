"""Model only what a scene requires: bytes against accuracy, and cost against screen size.

Part 1, error-driven against fixed-resolution conversion, for the bunny and a horizon stack
(three synthetic horizons, 160 x 210 grids, triangulated): the fixed conversions sweep
``max_resolution`` (one texel size for all charts); the error-driven ones take as ``max_error``
the p99 reconstruction error each fixed one measured, with ``error_scope="set"`` (default) and
``"chart"``; one more row has every chart at 256² (the paper's layout). Per set: bytes, measured
p99 reconstruction error, conversion time, and depth error of an ``exact`` render against
trimesh + embree ray casting of the original mesh. The headline is the bytes ratio at the p99
of ``max_resolution=256``. The other shared meshes, when present, get that ratio and the worst
render agreement over three views.

Part 2, cost against screen size: fetches per frame and time as the camera backs away.

The bunny (256² maps) is rendered at 512² from an oblique view with the camera distance spaced
geometrically so that the model goes from filling the frame to 1/8 of its height (~1/64 of the
covered pixels). Per distance and preset: covered pixels, height fetches per frame (the counting
pipeline), fetches per covered pixel, wall and GPU ms (median of 3 after a warm-up), patches
drawn and culled, and depth error against trimesh + embree ray casting (IoU, median, p99).

Presets: "balanced" (linear + binary search), "exact" (max-pyramid traversal) and "exact" with
``lod=True`` (the descent stops where a patch's pyramid nodes are about a pixel, and the map
subsampled to the node corners is intersected there). Without LOD the per-pixel cost does not
fall with distance, so fetches per frame fall exactly with the covered pixels, no faster.

Results: ``bench/results/lod.json`` and ``bench/results/lod.png``.

Run from the repository root::

    python bench/lod.py            # ~12 min on 2 cores
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import geomtex as gt
from geomtex import reference, testing

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

from render import BUNNY, MESH_DIR, machine_info  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
SIZE = 512
DISTANCES = np.geomspace(1.0, 8.0, 7)  # × the full-frame distance
FIXED = (128, 181, 256, 362, 512)  # max_resolution of the fixed conversions
HORIZON_GRID = (160, 210)
OBLIQUE = (1.0, 0.8, 1.0)


def horizon_mesh() -> gt.Mesh:
    """The horizon stack's three grids as one triangle mesh."""
    grids = testing.horizon_stack(*HORIZON_GRID)
    rows, cols = HORIZON_GRID
    extent = (0.0, 10.0 * (cols - 1), 0.0, 10.0 * (rows - 1))
    meshes = [testing.grid_mesh(g, extent) for g in grids]
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    return gt.Mesh(np.vstack([np.asarray(m.vertices) for m in meshes]),
                   np.vstack([np.asarray(m.faces) + o for m, o in zip(meshes, offsets)]))


def conversion_rows(name: str, mesh: gt.Mesh, renderer: gt.Renderer) -> list[dict[str, Any]]:
    """Fixed and error-driven conversions of one mesh, each measured and rendered."""
    cam = testing.look_from(mesh, OBLIQUE, distance=1.2)
    ref = reference.raycast(mesh, cam, SIZE, SIZE)
    rows: list[dict[str, Any]] = []

    def measure(kind: str, target: float | None, **kw: Any) -> dict[str, Any]:
        t0 = time.perf_counter()
        gts = gt.convert(mesh, **kw)
        seconds = time.perf_counter() - t0
        m = reference.compare(renderer.render(gts, cam, quality="exact"), ref, mesh.diagonal)
        st = gts.stats
        row = {"mesh": name, "kind": kind, "options": {k: v for k, v in kw.items()},
               "max_error": target, "diagonal": float(mesh.diagonal), "bytes": float(st["bytes"]), "charts": int(st["charts"]),
               "chart_error": float(st["chart_error"]),
               "p99": float(st["reconstruction_error_p99"]), "convert_s": seconds,
               "resolution_median": float(np.median(st["patch_resolution"])),
               "iou": m["iou"], "depth_p99": m["depth_p99"], "depth_median": m["depth_median"]}
        print(f"{name:<8} {kind:<18} {row['bytes'] / 1e6:8.2f} MB  p99 {row['p99']:.3e}  "
              f"charts {row['charts']:4d}  {seconds:6.1f} s  IoU {row['iou']:.4f}  "
              f"depth p99 {row['depth_p99']:.1e}", flush=True)
        rows.append(row)
        return row

    fixed = {r: measure(f"fixed {r}", None, max_resolution=r) for r in FIXED}
    for r in FIXED:
        measure("error-driven set", fixed[r]["p99"], max_error=fixed[r]["p99"])
    measure("error-driven chart", fixed[256]["p99"], max_error=fixed[256]["p99"], error_scope="chart")
    # Every chart at the cap: the paper's fixed 256² per patch.
    measure("256² per patch", None, max_error=1e-12 * mesh.diagonal, max_resolution=256,
            error_scope="chart", chart_error=0.1)
    return rows


OTHER_MESHES = ("fandisk", "teapot", "spot", "homer", "rocker-arm")
OTHER_VIEWS = [(1.0, 0.8, 1.0), (-1.0, 0.3, -0.5), (0.2, -1.0, 0.4)]


def other_mesh_rows(renderer: gt.Renderer) -> list[dict[str, Any]]:
    """The shared meshes (when present): bytes at max_resolution=256's p99, and the worst render
    agreement with trimesh over three views, fixed and error-driven."""
    rows = []
    for name in OTHER_MESHES:
        path = MESH_DIR / f"{name}.obj"
        if not path.exists():
            continue
        mesh = gt.load_mesh(path)
        t0 = time.perf_counter()
        fixed = gt.convert(mesh)
        t1 = time.perf_counter()
        driven = gt.convert(mesh, max_error=fixed.stats["reconstruction_error_p99"])
        t2 = time.perf_counter()
        row: dict[str, Any] = {"mesh": name, "faces": int(fixed.stats["faces"]),
                               "fixed_p99": float(fixed.stats["reconstruction_error_p99"]),
                               "driven_p99": float(driven.stats["reconstruction_error_p99"]),
                               "bytes_ratio": float(driven.stats["bytes"] / fixed.stats["bytes"]),
                               "chart_error": float(driven.stats["chart_error"]),
                               "fixed_s": t1 - t0, "driven_s": t2 - t1}
        for label, gts in (("fixed", fixed), ("driven", driven)):
            ms = [reference.agreement(renderer, gts, mesh, testing.look_from(mesh, d), quality="exact")
                  for d in OTHER_VIEWS]
            row[f"{label}_iou_min"] = min(m["iou"] for m in ms)
            row[f"{label}_depth_p99_max"] = max(m["depth_p99"] for m in ms)
        print(f"{name:<10} bytes x{row['bytes_ratio']:.3f} at p99 {row['fixed_p99']:.2e} "
              f"(driven {row['driven_p99']:.2e}, chart_error {row['chart_error']}), "
              f"{row['driven_s']:.1f} s vs {row['fixed_s']:.1f} s; IoU >= {row['driven_iou_min']:.4f} "
              f"(fixed {row['fixed_iou_min']:.4f}), depth p99 <= {row['driven_depth_p99_max']:.1e} "
              f"(fixed {row['fixed_depth_p99_max']:.1e})", flush=True)
        rows.append(row)
    return rows


def bytes_at(rows: list[dict[str, Any]], kind_prefix: str, p99: float) -> float:
    """Bytes at a p99, interpolated log-log along the rows of one kind (sorted by p99)."""
    pts = sorted((r["p99"], r["bytes"]) for r in rows if r["kind"].startswith(kind_prefix))
    x = np.log([p for p, _ in pts])
    y = np.log([b for _, b in pts])
    return float(np.exp(np.interp(np.log(p99), x, y)))


def plot(data: dict[str, Any], path: Path) -> None:
    """The bytes/error plot of part 1 and the fetches and depth error of part 2."""
    conversions, rows = data["conversions"], data["rows"]
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.4))
    for name, marker in (("bunny", "o"), ("horizons", "s")):
        for kind, color in (("fixed", "C0"), ("error-driven set", "C3")):
            rs = sorted((r for r in conversions if r["mesh"] == name and r["kind"].startswith(kind)),
                        key=lambda r: r["p99"])
            axes[0].loglog([r["p99"] / r["diagonal"] for r in rs], [r["bytes"] for r in rs], marker + "-",
                           color=color, label=f"{name}: {kind}")
        for kind, color in (("error-driven chart", "C1"), ("256² per patch", "C7")):
            rs = [r for r in conversions if r["mesh"] == name and r["kind"] == kind]
            axes[0].loglog([r["p99"] / r["diagonal"] for r in rs], [r["bytes"] for r in rs], marker,
                           color=color, label=f"{name}: {kind}")
    axes[0].set_xlabel("measured p99 reconstruction error / diagonal")
    axes[0].legend(fontsize=7)
    axes[0].grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("map bytes")
    axes[0].set_title("error-driven vs fixed resolution")
    axes = axes[1:]
    for q, color in (("balanced", "C0"), ("exact", "C1"), ("exact+lod", "C2")):
        rs = [r for r in rows if r["quality"] == q]
        axes[0].loglog([r["covered_px"] for r in rs], [r["fetches_per_frame"] for r in rs], "o-", color=color, label=q)
        axes[1].loglog([r["covered_px"] for r in rs], [r["depth_p99"] for r in rs], "o-", color=color, label=q)
    axes[0].set_ylabel("height fetches per frame")
    axes[1].set_ylabel("p99 |Δdepth| / diagonal (vs trimesh)")
    axes[1].axhline(1e-2, color="grey", linestyle=":", label="renderer bound")
    for ax in axes:
        ax.set_xlabel("covered pixels (512² frame)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    axes[1].set_title("bunny, camera backing away to 1/8 of the image height", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=RESULTS / "lod.json")
    ap.add_argument("--replot", action="store_true", help="only redraw the PNG from the JSON")
    args = ap.parse_args(argv)
    if args.replot:
        plot(json.loads(args.out.read_text()), args.out.with_suffix(".png"))
        return
    mesh = gt.load_mesh(BUNNY)
    renderer = gt.Renderer(SIZE, SIZE)
    conversions: list[dict[str, Any]] = []
    headline = {}
    for name, m in (("bunny", mesh), ("horizons", horizon_mesh())):
        crows = conversion_rows(name, m, renderer)
        conversions += crows
        base = next(r for r in crows if r["kind"] == "fixed 256")
        driven = next(r for r in crows if r["kind"] == "error-driven set" and r["max_error"] == base["p99"])
        per_chart = next(r for r in crows if r["kind"] == "error-driven chart")
        headline[name] = {
            "fixed_256_bytes": base["bytes"], "fixed_256_p99": base["p99"],
            "error_driven_bytes": driven["bytes"], "error_driven_p99": driven["p99"],
            "bytes_ratio": driven["bytes"] / base["bytes"],
            "bytes_ratio_at_equal_p99": bytes_at(crows, "error-driven set", base["p99"]) / base["bytes"],
            "chart_scope_bytes_ratio": per_chart["bytes"] / base["bytes"],
            "chart_scope_p99": per_chart["p99"],
        }
        h = headline[name]
        print(f"{name}: at max_resolution=256's p99 {base['p99']:.3e}, error-driven uses "
              f"{h['bytes_ratio']:.3f} of the bytes (p99 {driven['p99']:.3e}); interpolated at equal p99 "
              f"{h['bytes_ratio_at_equal_p99']:.3f}; error_scope='chart' {h['chart_scope_bytes_ratio']:.3f}")

    others = other_mesh_rows(gt.Renderer(256, 256))

    gts = gt.convert(mesh)
    rows = []
    for k in DISTANCES:
        cam = testing.look_from(mesh, (1.0, 0.8, 1.0), distance=1.2 * k)
        ref = reference.raycast(mesh, cam, SIZE, SIZE)
        for label, quality, lod in (("balanced", "balanced", False), ("exact", "exact", False),
                                    ("exact+lod", "exact", True)):
            counted = renderer.render(gts, cam, quality=quality, lod=lod, count_fetches=True)
            renderer.render(gts, cam, quality=quality, lod=lod)
            walls, gpus = [], []
            for _ in range(3):
                t0 = time.perf_counter()
                frame = renderer.render(gts, cam, quality=quality, lod=lod)
                walls.append(1000 * (time.perf_counter() - t0))
                if frame.stats["gpu_ms"] is not None:
                    gpus.append(frame.stats["gpu_ms"])
            m = reference.compare(frame, ref, mesh.diagonal)
            covered = int(np.isfinite(frame.depth).sum())
            fragments = counted.stats["fetches_per_pixel"]  # per ray-cast fragment
            total = float(counted.stats["fetches"])
            rows.append({"distance": float(k), "quality": label, "covered_px": covered,
                         "fetches_per_frame": total, "fetches_per_covered_px": total / max(covered, 1),
                         "fetches_per_fragment": fragments, "wall_ms": statistics.median(walls),
                         "gpu_ms": statistics.median(gpus) if gpus else None,
                         "patches_drawn": frame.stats["patches_drawn"], "patches_culled": frame.stats["patches_culled"],
                         "iou": m["iou"], "depth_median": m["depth_median"], "depth_p99": m["depth_p99"]})
    print(f"{'dist':>5} {'quality':<10} {'covered':>8} {'fetches':>10} {'/px':>6} {'ms':>7} {'drawn':>5} {'IoU':>7} {'p99':>8}")
    for r in rows:
        print(f"{r['distance']:5.2f} {r['quality']:<10} {r['covered_px']:8d} {r['fetches_per_frame']:10.0f} "
              f"{r['fetches_per_covered_px']:6.1f} {r['wall_ms']:7.1f} {r['patches_drawn']:5d} {r['iou']:7.4f} "
              f"{r['depth_p99']:8.1e}")
    ratios = {}
    for q in ("balanced", "exact", "exact+lod"):
        near, far = (next(r for r in rows if r["quality"] == q and r["distance"] == d)
                     for d in (DISTANCES[0], DISTANCES[-1]))
        ratios[q] = {"covered": near["covered_px"] / far["covered_px"],
                     "fetches": near["fetches_per_frame"] / far["fetches_per_frame"]}
        print(f"{q}: full frame -> 1/8 height: covered pixels / {ratios[q]['covered']:.1f}, "
              f"fetches per frame / {ratios[q]['fetches']:.1f}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_json(args.out, {"machine": machine_info(), "size": SIZE, "rows": rows,
                          "ratios": ratios, "conversions": conversions,
                          "error_driven": headline, "other_meshes": others}, indent=1)

    plot(json.loads(args.out.read_text()), args.out.with_suffix(".png"))
    print(f"wrote {args.out} and {args.out.with_suffix('.png')}")


if __name__ == "__main__":
    main()
