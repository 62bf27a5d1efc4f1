"""Cost against screen size: fetches per frame and time as the camera backs away.

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

    python bench/lod.py            # ~1 min on 2 cores
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
from render import BUNNY, machine_info  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
SIZE = 512
DISTANCES = np.geomspace(1.0, 8.0, 7)  # × the full-frame distance


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=RESULTS / "lod.json")
    args = ap.parse_args(argv)
    mesh = gt.load_mesh(BUNNY)
    gts = gt.convert(mesh)
    renderer = gt.Renderer(SIZE, SIZE)
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
    args.out.write_text(json.dumps({"machine": machine_info(), "size": SIZE, "rows": rows,
                                    "ratios": ratios}, indent=1))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
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
    fig.suptitle("Bunny, camera backing away from full frame to 1/8 of the image height")
    fig.tight_layout()
    fig.savefig(args.out.with_suffix(".png"), dpi=120)
    print(f"wrote {args.out} and {args.out.with_suffix('.png')}")


if __name__ == "__main__":
    main()
