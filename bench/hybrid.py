"""Hybrid sets (issue 41): the default ``convert`` (hybrid: triangles where height maps do not pay)
against all height maps (``hybrid=False``, the default before) and the mesh itself.

For every shared mesh (``../shared/meshes``), the noisy isosurface, the displaced icosphere
(bench/partition.py), a ~1k-face low-poly mesh (trimesh primitives joined, decimated by pymeshlab)
and, with ``--big``, the 1.1 M-face loop-subdivided bunny:

- bytes against the mesh (float32 vertices, uint32 faces), patches, faces kept as triangles, and
  the conversion's seconds against a fixed 256-texel cone conversion of the same mesh;
- against trimesh over five views at 512²: the worst IoU, depth p99 (one-pixel tolerance, of the
  diagonal) and the pooled median angle to the crease-split normals (bench/economy.py's
  ``rendered``);
- frame time at 512² on the CPU backend and the GPU backend (this machine: lavapipe) for the
  hybrid set, the all-height-map set and the mesh, each the median of 3 frames per view after a
  warm-up frame, summed over the five views, all in one run (compare ratios).

Into ``bench/results/hybrid.json`` and ``hybrid.png``. Run from the repository root::

    nice python bench/hybrid.py          # ~8 min on 2 cores
    nice python bench/hybrid.py --big    # also the 1.1 M-face bunny
    nice python bench/hybrid.py --only bunny-loop-subdivided   # one row, into the existing JSON
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import economy  # noqa: E402
from _meta import write_json  # noqa: E402

import geomtex as gt  # noqa: E402
from geomtex.testing import look_from  # noqa: E402

RESULTS = economy.RESULTS
SIZE = 512


def frame_seconds(obj: Any, mesh: gt.Mesh, device: str) -> float:
    """Five views at 512², each the median of 3 frames after a warm-up frame, summed."""
    r = gt.Renderer(SIZE, SIZE, device=device)
    total = 0.0
    for direction, up in economy.VIEWS:
        camera = look_from(mesh, direction, up=up)
        r.render(obj, camera)
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            r.render(obj, camera)
            times.append(time.perf_counter() - t0)
        total += float(np.median(times))
    return total


def row(name: str) -> dict[str, Any]:
    mesh = economy.load_any(name)
    own = economy.mesh_bytes(mesh)
    hybrid, hybrid_s = economy.converted(mesh)
    patches, patches_s = economy.converted(mesh, hybrid=False)
    _, fixed_s = economy.converted(mesh, max_resolution=256, partition="cone")
    s, t = hybrid.stats, hybrid.triangles
    out: dict[str, Any] = {
        "faces": len(np.asarray(mesh.faces)), "mesh_bytes": own,
        "ratio": s["bytes"] / own, "patches": len(hybrid),
        "faces_kept": 0 if t is None else len(t["faces"]),
        "clusters_bound": int(s.get("triangle_clusters_bound", 0)),
        "clusters_budget": int(s.get("triangle_clusters_budget", 0)),
        "seconds": hybrid_s, "fixed_256_seconds": fixed_s, "seconds_over_fixed": hybrid_s / fixed_s,
        "all_maps_ratio": patches.stats["bytes"] / own, "all_maps_seconds": patches_s,
    }
    out.update(economy.rendered(mesh, hybrid))
    all_maps = economy.rendered(mesh, patches)
    out.update({f"all_maps_{k}": v for k, v in all_maps.items()})
    for device in ("cpu", "gpu"):
        for label, obj in (("hybrid", hybrid), ("all_maps", patches), ("mesh", mesh)):
            out[f"{device}_{label}_ms"] = 1e3 * frame_seconds(obj, mesh, device)
        out[f"{device}_hybrid_over_all_maps"] = out[f"{device}_hybrid_ms"] / out[f"{device}_all_maps_ms"]
    return out


def table(rows: dict[str, dict[str, Any]]) -> str:
    head = (f"{'mesh':22s} {'faces':>9s} {'bytes':>6s} {'(maps)':>7s} {'patch':>6s} {'kept':>8s} {'IoU':>8s} "
            f"{'(maps)':>8s} {'p99':>8s} {'nrm°':>5s} {'s/fix':>6s} {'cpu ms':>7s} {'maps':>7s} {'mesh':>7s} "
            f"{'gpu ms':>7s} {'maps':>7s} {'mesh':>7s}")
    lines = [head]
    for name, r in rows.items():
        lines.append(
            f"{name:22s} {r['faces']:9d} {r['ratio']:6.3f} {r['all_maps_ratio']:7.2f} {r['patches']:6d} "
            f"{r['faces_kept']:8d} {r['iou']:8.5f} {r['all_maps_iou']:8.5f} {r['depth_p99_1px']:8.1e} "
            f"{r['normal_median_deg']:5.2f} {r['seconds_over_fixed']:6.2f} {r['cpu_hybrid_ms']:7.0f} "
            f"{r['cpu_all_maps_ms']:7.0f} {r['cpu_mesh_ms']:7.0f} {r['gpu_hybrid_ms']:7.0f} "
            f"{r['gpu_all_maps_ms']:7.0f} {r['gpu_mesh_ms']:7.0f}")
    return "\n".join(lines)


def plot(rows: dict[str, dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(rows)
    x = np.arange(len(names))
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.5))
    w = 0.38
    axes[0].bar(x - w / 2, [rows[n]["all_maps_ratio"] for n in names], w, label="all height maps")
    axes[0].bar(x + w / 2, [rows[n]["ratio"] for n in names], w, label="hybrid (default)")
    axes[0].axhline(1.0, color="k", lw=0.8)
    axes[0].set_yscale("log")
    axes[0].set_ylabel("bytes / mesh's bytes")
    axes[1].bar(x - w / 2, [1 - rows[n]["all_maps_iou"] for n in names], w, label="all height maps")
    axes[1].bar(x + w / 2, [max(1 - rows[n]["iou"], 1e-7) for n in names], w, label="hybrid (default)")
    axes[1].axhline(2e-3, color="k", lw=0.8, ls="--")
    axes[1].set_yscale("log")
    axes[1].set_ylabel("1 - IoU against trimesh (worst of 5 views)")
    for k, (device, style) in enumerate((("cpu", "o"), ("gpu", "s"))):
        axes[2].plot(x, [rows[n][f"{device}_hybrid_over_all_maps"] for n in names], style, label=f"{device}: hybrid / all maps")
        axes[2].plot(x, [rows[n][f"{device}_mesh_ms"] / rows[n][f"{device}_all_maps_ms"] for n in names],
                     style, mfc="none", label=f"{device}: mesh / all maps")
    axes[2].axhline(1.0, color="k", lw=0.8)
    axes[2].set_ylabel("frame time ratio (512², 5 views)")
    for ax in axes:
        ax.set_xticks(x, names, rotation=40, ha="right", fontsize=8)
    axes[0].legend(fontsize=8)
    axes[1].legend(fontsize=8)
    axes[2].legend(fontsize=7)
    fig.suptitle("Hybrid sets: bytes, accuracy and frame time (this machine; GPU backend: its adapter)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--big", action="store_true", help="also the 1.1 M-face loop-subdivided bunny")
    parser.add_argument("--only", nargs="+", help="these rows only, replacing theirs in the existing JSON")
    args = parser.parse_args()
    names = [n for n in economy.MESHES if (economy.MESH_DIR / f"{n}.obj").exists()]
    names += ["noisy-isosurface", "displaced-icosphere", "low-poly-1k"]
    if args.big:
        names.append("bunny-loop-subdivided")
    out: dict[str, Any] = {"loadavg_before": os.getloadavg(), "size": SIZE, "views": len(economy.VIEWS),
                           "cpu_threads": os.cpu_count(), "rows": {}}
    if args.only:
        names = args.only
        old = json.loads((RESULTS / "hybrid.json").read_text())
        out["rows"] = old["rows"]
        out["loadavg_before"] = old.get("loadavg_before")
    for name in names:
        out["rows"][name] = row(name)
        print(name, {k: (round(v, 6) if isinstance(v, float) else v) for k, v in out["rows"][name].items()}, flush=True)
    out["loadavg_after"] = os.getloadavg()
    print(table(out["rows"]))
    RESULTS.mkdir(parents=True, exist_ok=True)
    write_json(RESULTS / "hybrid.json", out)
    plot(out["rows"], RESULTS / "hybrid.png")
    print("wrote", RESULTS / "hybrid.json", RESULTS / "hybrid.png")


if __name__ == "__main__":
    main()
