"""Faithful appearance (issue 16), every part in one run: crease-aware normals, exact outlines,
colors from every source and filters that keep the surface clean, each against its independent
reference (trimesh ray casting of the original mesh; see each part's module for what it
measures and how).

Parts: ``appearance_normals.py``, ``appearance_outlines.py``, ``appearance_colors.py``,
``appearance_filters.py`` (each also runs on its own and writes its own JSON). This script runs
them all at one image size and writes ``bench/results/appearance.json`` (every part's figures
under its name) and ``bench/results/appearance.png`` (each part's headline figure against the
issue's target). The parts write their own pictures (PNG pairs, ours beside the reference or
before beside after) into ``bench/results/``.

The outline part's "before" column needs a checkout of a commit before outline maps with its
module built (GEOMTEX_BEFORE_CHECKOUT=path; see appearance_outlines.py).

Run from the repository root (about 15 minutes on 2 cores)::

    python bench/appearance.py
    python bench/appearance.py --size 256 --parts normals,colors

With ``--parts``, the parts not run keep their figures from ``results/appearance.json`` when it
was written at the same size.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "bench" / "results"
PARTS = ("normals", "outlines", "colors", "filters")


def run(parts: list[str], size: int) -> dict[str, Any]:
    sys.path.insert(0, str(Path(__file__).parent))
    results: dict[str, Any] = {"size": size}
    for part in parts:
        module = importlib.import_module(f"appearance_{part}")
        t0 = time.perf_counter()
        results[part] = module.measure(size)
        results[part]["bench_seconds"] = time.perf_counter() - t0
        print(f"== {part} ({results[part]['bench_seconds']:.0f} s)")
        if hasattr(module, "table"):
            print(module.table(results[part]))
    return results


def headline(results: dict[str, Any]) -> list[tuple[str, list[str], list[float], float, str]]:
    """Per part: (title, labels, values, target, unit) for the summary plot."""
    panels = []
    if "normals" in results:
        m = results["normals"]["meshes"]
        panels.append(("normal error, median (target <= 2 deg)", list(m),
                       [m[k]["crease"]["median"] for k in m], 2.0, "deg"))
        panels.append(("normal error, p99 (target <= 10 deg)", list(m),
                       [m[k]["crease"]["p99"] for k in m], 10.0, "deg"))
    if "outlines" in results:
        m = results["outlines"]["meshes"]
        panels.append(("coverage 1 - IoU, worst view (target <= 0.005)", list(m),
                       [1.0 - min(min(r["after"]["iou"], r["after_exact"]["iou"]) for r in m[k]["views"]) for k in m],
                       0.005, ""))
    if "colors" in results:
        m = results["colors"]["meshes"]
        panels.append(("albedo mean |diff|, interior (target <= 3/255)", list(m),
                       [m[k]["mean"] for k in m], 3.0, "/255"))
    if "filters" in results:
        f = results["filters"]
        labels = [f"{r['sigma_texels']:g} texel" for r in f["sigmas"]]
        panels.append(("seam normal step, p99 (target <= 2 deg)", labels,
                       [r["normal_step_p99_deg"] for r in f["sigmas"]], 2.0, "deg"))
    return panels


def plot(results: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = headline(results)
    fig, axes = plt.subplots(1, len(panels), figsize=(3.6 * len(panels), 3.6), squeeze=False)
    for ax, (title, labels, values, target, unit) in zip(axes[0], panels):
        x = np.arange(len(labels))
        ax.bar(x, values, color=["tab:green" if v <= target else "tab:red" for v in values])
        ax.axhline(target, color="k", ls="--", lw=1)
        ax.set_xticks(x, labels, rotation=35, ha="right", fontsize=8)
        ax.set_title(title, fontsize=8)
        ax.set_ylabel(unit)
    fig.suptitle(f"geomtex appearance at {results['size']}² (dashed: the issue's target)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--parts", default=",".join(PARTS), help="comma-separated subset of " + ", ".join(PARTS))
    args = ap.parse_args()
    parts = [p for p in args.parts.split(",") if p]
    unknown = set(parts) - set(PARTS)
    if unknown:
        ap.error(f"unknown parts {sorted(unknown)}; choose from {PARTS}")
    results = run(parts, args.size)
    # Parts not run this time keep their figures from the last run at the same size.
    previous = OUT / "appearance.json"
    if previous.exists():
        old = json.loads(previous.read_text())
        if old.get("size") == args.size:
            results = {**{k: v for k, v in old.items() if k in PARTS}, **results}
    OUT.mkdir(parents=True, exist_ok=True)
    write_json(OUT / "appearance.json", results, indent=1)
    plot(results, OUT / "appearance.png")
    print(f"wrote {OUT / 'appearance.json'} and {OUT / 'appearance.png'}")


if __name__ == "__main__":
    main()
