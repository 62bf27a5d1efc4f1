"""The SVD trade of the paper's GDM lookup in images (issue 18): chain links (64x64x16) over the
torus, rendered through the lookup in the SVD-compressed 5D distance function for k = 1..16 terms
and for every term (the uncompressed table), with 8 x 16 or 16 x 32 sampled directions, against
trimesh + embree ray casting of ``shell.to_mesh()``; beside them the table's own reconstruction
error and bytes, and the exact march as the floor.

Per (directions, k), worst over ``--views`` views at ``--size``: coverage IoU, depth p99 in voxels
(raw and with a one-pixel tolerance), median normal angle, for the lookup as the paper takes it
and refined (``refined``: the first surface searched exactly within ``bench/gdm.py``'s REFINE
voxels of the looked-up distance); the table's rms error (voxels) and the compressed bytes.
The torus has 12 tiles around its ring, so views 120 degrees apart see the same image: three
views measure what one does.

Results: ``bench/results/gdm_lookup.json`` and ``bench/results/gdm_lookup.png``.

Run from the repository root::

    nice python bench/gdm_lookup.py --views 1        # 256^2, one view: the committed figures
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
from pathlib import Path
from typing import Any

from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

import geomtex as gt
from geomtex import gdm, reference

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "bench" / "results"
KS = (1, 2, 4, 8, 12, 16)
DIRECTIONS = ((8, 16), (16, 32))


def worst(rows: list[dict[str, float]], voxel: float) -> dict[str, float]:
    return {"iou_min": min(r["iou"] for r in rows), "p99_voxels_max": max(r["p99"] for r in rows) / voxel,
            "p99_1px_voxels_max": max(r["p99_1px"] for r in rows) / voxel,
            "normal_deg_max": max(r["normal_deg"] for r in rows)}


def main() -> None:
    import gdm as bench_gdm  # bench/gdm.py: cameras and the accuracy measure, shared

    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--views", type=int, default=3)
    args = ap.parse_args()
    tor, uv = gdm.uv_torus(1.0, 0.35, (48, 24))
    vol = gdm.Volume.procedural("chain", (64, 64, 16))
    thickness = 0.08
    voxel = thickness / 16

    def shell(lookup: Any = None, refine: float = 0.0) -> gdm.Shell:
        return gdm.Shell(tor, vol, thickness=thickness, uv=uv * [12, 4], lookup=lookup, refine=refine)

    exact = shell()
    explicit = exact.to_mesh()
    caster = reference.RayCaster(explicit)
    cams = bench_gdm.cameras(explicit, args.views, 2)
    refs = [caster.cast(cam, args.size, args.size) for cam in cams]
    r = gt.Renderer(args.size, args.size)

    def measure(s: gdm.Shell) -> dict[str, float]:
        return worst([bench_gdm.accuracy(r.render(s, cam), ref) for cam, ref in zip(cams, refs)], voxel)

    results: dict[str, Any] = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(),
                               "machine": platform.platform(), "adapter": r.adapter_info, "load": os.getloadavg(),
                               "size": args.size, "views": args.views, "voxel": voxel, "exact": measure(exact),
                               "rows": []}
    print(f"exact march: {results['exact']}", flush=True)
    for dirs in DIRECTIONS:
        table = vol.distance_function(dirs)
        # The last k keeps every term: the uncompressed table, the lookup's own limit.
        for k in (*KS, dirs[0] * vol.size[2]):
            packed = table.compress(k)
            row = {"directions": list(dirs), "k": k, "rms": packed.error["rms"], "bytes": packed.nbytes,
                   "table_bytes": table.nbytes, **measure(shell(packed)),
                   "refine": bench_gdm.REFINE, "refined": measure(shell(packed, bench_gdm.REFINE))}
            results["rows"].append(row)
            print(f"{dirs[0]:2}x{dirs[1]:2} k={k:2}: table rms {row['rms']:5.2f} vox, {row['bytes'] / 1e6:5.2f} MB | "
                  f"IoU {row['iou_min']:.3f}, p99 {row['p99_voxels_max']:6.1f} vox "
                  f"(1 px tol. {row['p99_1px_voxels_max']:6.1f}), normal {row['normal_deg_max']:.1f} deg | refined IoU "
                  f"{row['refined']['iou_min']:.3f}, p99 {row['refined']['p99_voxels_max']:6.1f} vox (1 px tol. "
                  f"{row['refined']['p99_1px_voxels_max']:6.1f})", flush=True)
    OUT.mkdir(parents=True, exist_ok=True)
    write_json(OUT / "gdm_lookup.json", results, indent=1, default=str)
    plot(results, OUT / "gdm_lookup.png")


def plot(results: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    for dirs in DIRECTIONS:
        rows = [r for r in results["rows"] if r["directions"] == list(dirs)]
        ks = [r["k"] for r in rows]
        label = f"{dirs[0]}x{dirs[1]} directions"
        axes[0].plot(ks, [r["rms"] for r in rows], "o-", label=label)
        for r in rows:
            axes[0].annotate(f"{r['bytes'] / 1e6:.1f} MB", (r["k"], r["rms"]), fontsize=6)
        line = axes[1].plot(ks, [r["iou_min"] for r in rows], "o-", label=label)[0]
        axes[1].plot(ks, [r["refined"]["iou_min"] for r in rows], "s:", color=line.get_color(), label=label + ", refined")
        axes[2].plot(ks, [r["p99_1px_voxels_max"] for r in rows], "o-", label=label)
        axes[2].plot(ks, [r["refined"]["p99_1px_voxels_max"] for r in rows], "s:", color=line.get_color(),
                     label=label + ", refined")
    axes[1].axhline(results["exact"]["iou_min"], color="k", ls="--", lw=0.8, label="exact march")
    axes[2].axhline(results["exact"]["p99_1px_voxels_max"], color="k", ls="--", lw=0.8, label="exact march")
    for ax, title in zip(axes, ("table rms error (voxels)", "image IoU against to_mesh()",
                                "image depth p99, 1 px tolerance (voxels)")):
        ax.set(xlabel="SVD terms k", title=title, xscale="log")
        ax.legend(fontsize=7)
    axes[2].set_yscale("log")
    fig.suptitle(f"GDM lookup, chain 64x64x16 over the torus, {results['size']}², worst of {results['views']} views")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    main()
