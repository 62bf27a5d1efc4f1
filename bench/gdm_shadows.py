"""Benchmark of shadows and ray queries through displacement shells (issue 18): chain links and a
weave (64x64x16) over a torus, traced by the shared tracer (a hierarchy over the prisms, each leaf
searched by the same prism march the frames use).

In one run, on one wgpu adapter, at ``--size``:

* shadows under three directional lights: the shadow mask against embree shadow rays cast on
  ``shell.to_mesh()`` from embree's own hits (the explicit reference), on the pixels both hit:
  agreement, and disagreements farther than one pixel from a shadow edge; frame time with and
  without the light (median of ``--repeats``) and their ratio;
* ray queries: ``--rays`` rays from random points on a sphere around the torus toward random
  points in its bounding box: hit/miss agreement with embree on ``to_mesh()``, p99 distance error
  in voxels (thickness / nz), and the time of our call beside embree's with its intersector kept
  (its BVH built by a first call, not counted).

Results: ``bench/results/gdm_shadows.json`` and ``bench/results/gdm_shadows.png``.

Run from the repository root::

    nice python bench/gdm_shadows.py                 # 512^2, 262,144 rays
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import geomtex as gt
from geomtex import gdm, reference

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "bench" / "results"
sys.path.insert(0, str(REPO / "tests"))
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)
from test_shadows import embree_shadow, near_edge  # noqa: E402  (the tests' reference, reused)

LIGHTS = [(0.3, 0.4, -1.0), (-1.0, 0.2, -0.5), (0.2, 1.0, -0.3)]
THICKNESS, LAYERS = 0.08, 16
VOXEL = THICKNESS / LAYERS


def torus_shell(pattern: str) -> gdm.Shell:
    tor, uv = gdm.uv_torus(1.0, 0.35, (48, 24))
    vol = gdm.Volume.procedural(pattern, (64, 64, LAYERS))
    return gdm.Shell(tor, vol, thickness=THICKNESS, uv=uv * [12, 4])


def median_ms(fn: Any, repeats: int) -> tuple[Any, float]:
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append((time.perf_counter() - t0) * 1e3)
    return out, float(np.median(times))


def shadows(shell: gdm.Shell, whole: Any, size: int, repeats: int) -> list[dict[str, Any]]:
    cam = gt.Camera.look_at((0.0, -2.2, 1.6), (0, 0, 0), up=(0, 0, 1), yfov_deg=45)
    r = gt.Renderer(size, size)
    rows = []
    for direction in LIGHTS:
        light = gt.DirectionalLight(direction)
        _, plain_ms = median_ms(lambda: r.render(shell, cam), repeats)
        lit, lit_ms = median_ms(lambda: r.render(shell, cam, light=light), repeats)
        hit, ref = embree_shadow(whole, cam, np.asarray(direction, float), 2.0, size)
        both = hit & np.isfinite(lit.depth)
        wrong = (lit.shadow != ref) & both
        rows.append({"direction": direction, "agreement": float(1 - wrong.sum() / both.sum()),
                     "off_edge_px": int((wrong & ~near_edge(ref)).sum()), "both_px": int(both.sum()),
                     "shadowed_ours": int((lit.shadow & both).sum()), "shadowed_ref": int((ref & both).sum()),
                     "plain_ms": plain_ms, "lit_ms": lit_ms, "cost": lit_ms / plain_ms})
    return rows


def queries(shell: gdm.Shell, whole: Any, count: int, seed: int = 0) -> dict[str, Any]:
    rng = np.random.default_rng(seed)
    lo, hi = whole.bounds
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo)
    start = rng.normal(size=(count, 3))
    origins = centre + radius * start / np.linalg.norm(start, axis=1)[:, None]
    targets = lo + rng.random((count, 3)) * (hi - lo)
    dirs = targets - origins
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    scene = gt.Scene()
    scene.add(shell)
    r = gt.Renderer(8, 8)
    r.intersect(scene, origins[:1024], dirs[:1024])  # uploads and pipelines, as embree's BVH below
    (dist, _, _), ours_ms = median_ms(lambda: r.intersect(scene, origins, dirs), 1)
    caster = reference.RayCaster(whole)
    caster.first_hits(origins[:1024], dirs[:1024])
    (loc, idx, _), embree_ms = median_ms(lambda: caster.first_hits(origins, dirs), 1)
    ref = np.full(count, np.inf)
    ref[idx] = np.linalg.norm(loc - origins[idx], axis=1)
    ours, theirs = np.isfinite(dist), np.isfinite(ref)
    both = ours & theirs
    return {"rays": count, "hit_fraction": float(theirs.mean()), "agreement": float((ours == theirs).mean()),
            "p99_voxels": float(np.quantile(np.abs(dist[both] - ref[both]), 0.99) / VOXEL),
            "ours_ms": ours_ms, "embree_ms": embree_ms}


def plot(results: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    for k, case in enumerate(results["cases"]):
        x = np.arange(len(case["shadows"])) + 0.35 * k
        a.bar(x, [100 * s["agreement"] for s in case["shadows"]], 0.35, label=case["pattern"])
        b.bar(x, [s["cost"] for s in case["shadows"]], 0.35, label=case["pattern"])
    a.axhline(98, color="k", lw=0.8, ls="--")
    a.set(ylim=(95, 100), xticks=np.arange(len(LIGHTS)) + 0.17, xticklabels=[str(d) for d in LIGHTS],
          ylabel="shadow agreement with embree on to_mesh() (%)", title=f"{results['size']}², pixels both hit")
    b.set(xticks=np.arange(len(LIGHTS)) + 0.17, xticklabels=[str(d) for d in LIGHTS],
          ylabel="lit / unlit frame time", title="cost of the shadow rays")
    a.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--rays", type=int, default=1 << 18)
    args = ap.parse_args()
    cases = []
    for pattern in ("chain", "weave"):
        shell = torus_shell(pattern)
        whole = shell.to_mesh()
        case = {"pattern": pattern, "explicit_faces": len(whole.faces),
                "shadows": shadows(shell, whole, args.size, args.repeats),
                "queries": queries(shell, whole, args.rays)}
        for s in case["shadows"]:
            print(f"{pattern:6} light {s['direction']}: agreement {s['agreement']:.4f}, off-edge {s['off_edge_px']} px, "
                  f"frame {s['plain_ms']:.0f} -> {s['lit_ms']:.0f} ms ({s['cost']:.2f}x)", flush=True)
        q = case["queries"]
        print(f"{pattern:6} {q['rays']} rays: agreement {q['agreement']:.5f}, p99 {q['p99_voxels']:.2f} voxel, "
              f"ours {q['ours_ms']:.0f} ms, embree {q['embree_ms']:.0f} ms", flush=True)
        cases.append(case)
    results = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(), "machine": platform.platform(),
               "adapter": gt.Renderer(8, 8).adapter_info, "load": os.getloadavg(), "size": args.size,
               "cases": cases}
    OUT.mkdir(parents=True, exist_ok=True)
    write_json(OUT / "gdm_shadows.json", results, indent=1, default=str)
    plot(results, OUT / "gdm_shadows.png")


if __name__ == "__main__":
    main()
