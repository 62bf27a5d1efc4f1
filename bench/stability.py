"""Stability report: geomtex at the extremes, each case checked against trimesh ray casting.

Cases (every render is compared with trimesh + embree ray casting of the same mesh, transformed
the same way, through ``geomtex.reference.agreement``):

* **transforms** - the Stanford bunny translated by 1e6 and 1e7, scaled by 1e-6, 1e-4, 1e4, 1e6,
  and as is, from two views with the "balanced" and "exact" presets (512x512);
* **grazing** - the fractal terrain seen 0.1-10 degrees above its plane (512x512), and rays 0.1-10
  degrees above a flat chart and the wavy open sheet from an eye just above them (160x160);
* **eye inside** - 60 seeded eyes inside the torus's patch boxes looking anywhere (160x160);
* **damaged meshes** - single triangle, triangle soup, 10% reversed faces, 5% holes, 200
  non-manifold fins, 20% slivers plus 100 zero-area faces: stats and agreement (256x256);
* **a million faces** - the bunny after two Loop subdivisions (1.1 M faces): conversion time by
  stage and peak memory (measured in a child process so nothing else counts), then agreement.

Bounds: the issue's (IoU >= 0.97, median <= 0.2%, p99 <= 2% of the diagonal) and the renderer
issue's tighter ones (0.99, 0.1%, 1%). Where the view is mostly silhouette (an eye inside a box, a
surface seen edge-on) the documented bound is on the 1-pixel-tolerant p99 and on coverage: IoU
within the bound or hit masks differing only within a pixel of each other (``mask_far_px == 0``),
as the tests hold.

Results: ``bench/results/stability.json`` and ``bench/results/stability.png``.

Run from the repository root::

    python bench/stability.py           # everything (~5 min on 2 cores)
    python bench/stability.py --quick   # no million-face case, fewer inside/grazing samples
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np
from tqdm import tqdm

import geomtex as gt
from geomtex import reference, testing

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

from render import BUNNY, machine_info  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
ISSUE = {"iou": 0.97, "median": 2e-3, "p99": 2e-2}
RENDERER = {"iou": 0.99, "median": 1e-3, "p99": 1e-2}
KEEP = ("iou", "depth_median", "depth_p99", "depth_p99_1px", "mask_far_px", "nan", "covered_px", "ref_px")


def within(m: dict[str, Any], bound: dict[str, float], silhouette: bool = False) -> bool:
    """Whether figures meet a bound; ``silhouette``: the documented bound for views that are
    mostly silhouette (1-pixel-tolerant p99, masks differing only next to each other)."""
    if m["nan"]:
        return False
    if silhouette:
        return bool((m["mask_far_px"] == 0 or m["iou"] >= bound["iou"]) and m["depth_median"] <= bound["median"]
                    and m["depth_p99_1px"] <= bound["p99"])
    return bool(m["iou"] >= bound["iou"] and m["depth_median"] <= bound["median"] and m["depth_p99"] <= bound["p99"])


def worst(ms: list[dict[str, Any]]) -> dict[str, Any]:
    """The worst of each figure over several renders (min IoU, max errors, total NaN)."""
    out: dict[str, Any] = {}
    for k in KEEP:
        vals = [m[k] for m in ms]
        out[k] = float(min(vals)) if k == "iou" else (int(sum(vals)) if k in ("nan", "mask_far_px") else float(max(vals)))
    return out


def record(group: str, case: str, ms: list[dict[str, Any]], silhouette: bool = False, **extra: Any) -> dict[str, Any]:
    w = worst(ms)
    return {"group": group, "case": case, "renders": len(ms), **w,
            "meets_issue_bound": all(within(m, ISSUE, silhouette) for m in ms),
            "meets_renderer_bound": all(within(m, RENDERER, silhouette) for m in ms),
            "bound": "silhouette (1 px)" if silhouette else "plain", **extra}


def two_views(renderer: gt.Renderer, gts: Any, mesh: gt.Mesh, qualities: tuple[str, ...] = ("balanced", "exact")) -> list[dict[str, Any]]:
    return [reference.agreement(renderer, gts, mesh, testing.look_from(mesh, d), quality=q)
            for d in [(1, 0.8, 1), (0.3, -1, 0.2)] for q in qualities]


# --------------------------------------------------------------------------- the cases


def transforms(bunny: gt.Mesh) -> list[dict[str, Any]]:
    r = gt.Renderer(512, 512)
    out = []
    for case, scale, offset in [("as is", 1.0, 0.0), ("translated 1e6", 1.0, 1e6), ("translated 1e7", 1.0, 1e7),
                                ("scaled 1e-6", 1e-6, 0.0), ("scaled 1e-4", 1e-4, 0.0), ("scaled 1e4", 1e4, 0.0),
                                ("scaled 1e6", 1e6, 0.0), ("1e-3 at 1e7", 1e-3, 1e7)]:
        mesh = testing.similar(bunny, scale, [offset, -offset, 0.5 * offset])
        out.append(record("transforms", f"bunny {case}", two_views(r, gt.convert(mesh), mesh)))
    return out


def grazing(quick: bool) -> list[dict[str, Any]]:
    out = []
    terrain = testing.GENERATED["fractal_terrain"]()
    tgts = gt.convert(terrain)
    r = gt.Renderer(512, 512)
    for elevation in [0.1, 0.5, 2.0, 10.0]:
        e = np.radians(elevation)
        ms_ = [reference.agreement(r, tgts, terrain, testing.look_from(terrain, (np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e))), quality=q)
               for a in np.radians([0.0, 35.0]) for q in ("balanced", "exact")]
        out.append(record("grazing", f"terrain {elevation} deg above its plane", ms_))
    small = gt.Renderer(160, 160)
    surfaces = {"flat chart": testing.flat_grid(), "wavy sheet": testing.wavy_sheet()}
    rng = np.random.default_rng(5)
    for name, mesh in surfaces.items():
        gts = gt.convert(mesh)
        lo, hi = (np.asarray(b) for b in mesh.bounds)
        for elevation in [0.1, 0.5, 2.0, 10.0]:
            ms_ = []
            for _ in range(3 if quick else 8):
                e, a = np.radians(elevation), rng.uniform(0, 2 * np.pi)
                forward = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), -np.sin(e)])
                eye = lo + rng.uniform(0.3, 0.7, 3) * (hi - lo)
                eye[2] = hi[2] + 0.02 * mesh.diagonal
                cam = gt.Camera.look_at(eye, eye + forward, up=(0, 0, 1), yfov_deg=30)
                m = reference.agreement(small, gts, mesh, cam, quality="balanced")
                if m["ref_px"] >= 1000:
                    ms_.append(m)
            if ms_:
                out.append(record("grazing", f"{name}, eye above, rays {elevation} deg", ms_, silhouette=True))
    return out


def eye_inside(quick: bool) -> list[dict[str, Any]]:
    torus = testing.GENERATED["torus"]()
    gts = gt.convert(torus)
    r = gt.Renderer(160, 160)
    rng = np.random.default_rng(7)
    out = []
    for quality in ("balanced", "exact"):
        ms_ = []
        for _ in range(10 if quick else 30):
            eye = (gts.world_from_patch[rng.integers(len(gts))] @ np.array([*rng.uniform(0, 1, 3), 1.0]))[:3]
            d = rng.normal(size=3)
            up = (0.0, 0.0, 1.0) if abs(d[2]) < 0.9 * np.linalg.norm(d) else (0.0, 1.0, 0.0)
            m = reference.agreement(r, gts, torus, gt.Camera.look_at(eye, eye + d, up=up, yfov_deg=60), quality=quality)
            if m["ref_px"] + m["covered_px"] > 200:
                ms_.append(m)
        out.append(record("eye inside", f"torus, eye in a patch box, {quality}", ms_, silhouette=True))
    return out


def damaged(bunny: gt.Mesh) -> list[dict[str, Any]]:
    r = gt.Renderer(256, 256)
    cases: dict[str, Callable[[], gt.Mesh]] = {
        "single triangle": testing.GENERATED["single_triangle"],
        "clean bunny": lambda: bunny,
        "triangle soup": lambda: testing.soup(bunny),
        "10% faces reversed": lambda: testing.flip_faces(bunny, 0.10, seed=1)[0],
        "5% holes (40)": lambda: testing.punch_holes(bunny, 0.05, holes=40, seed=2),
        "200 non-manifold fins": lambda: testing.add_fins(bunny, 200, seed=3),
        "20% slivers + 100 zero-area": lambda: testing.add_slivers(bunny, 0.20, zero_area=100, seed=4),
    }
    out = []
    for case, make in cases.items():
        mesh = make()
        t0 = time.perf_counter()
        gts = gt.convert(mesh)
        seconds = time.perf_counter() - t0
        stats = {k: gts.stats[k] for k in ("charts", "degenerate_faces", "duplicate_vertices", "boundary_edges",
                                          "nonmanifold_edges", "inconsistent_edges", "flipped_faces", "folding_charts")}
        out.append(record("damaged meshes", case, two_views(r, gts, mesh, ("balanced",)),
                          faces=len(mesh.faces), convert_s=seconds, stats=stats))
    return out


# Memory from /proc (VmHWM is this process's own peak; getrusage's ru_maxrss would carry the
# parent's peak across fork + exec).
_CHILD = """
import json, sys, time
import numpy as np, geomtex as gt
def status(key):
    line = next(l for l in open("/proc/self/status") if l.startswith(key + ":"))
    return int(line.split()[1]) / 1024
v, f = np.load(sys.argv[1] + "/v.npy"), np.load(sys.argv[1] + "/f.npy")
mesh = gt.Mesh(v, f)
before = status("VmRSS")
t0 = time.perf_counter()
gts = gt.convert(mesh)
seconds = time.perf_counter() - t0
peak = status("VmHWM")
gts.save(sys.argv[1] + "/set.gtex")
print(json.dumps({"convert_s": seconds, "rss_before_mib": before, "rss_peak_mib": peak,
                  "stages_s": gts.stats["seconds"], "charts": gts.stats["charts"], "bytes": gts.stats["bytes"]}))
"""


def million_faces(bunny: gt.Mesh) -> list[dict[str, Any]]:
    mesh = testing.subdivided(bunny, 1_000_000)
    with tempfile.TemporaryDirectory() as tmp:
        np.save(f"{tmp}/v.npy", np.asarray(mesh.vertices))
        np.save(f"{tmp}/f.npy", np.asarray(mesh.faces))
        child = subprocess.run([sys.executable, "-c", _CHILD, tmp], capture_output=True, text=True, check=True)
        figures = json.loads(child.stdout.strip().splitlines()[-1])
        gts = gt.load(f"{tmp}/set.gtex")
    figures["convert_extra_mib"] = figures["rss_peak_mib"] - figures["rss_before_mib"]
    return [record("a million faces", "bunny, Loop-subdivided twice", two_views(gt.Renderer(512, 512), gts, mesh),
                   faces=len(mesh.faces), **figures)]


# --------------------------------------------------------------------------- report


def table(records: list[dict[str, Any]]) -> str:
    rows = [("group", "case", "n", "NaN", "IoU", "median", "p99", "p99 1px", "far px", "issue", "renderer")]
    for r in records:
        rows.append((r["group"], r["case"], str(r["renders"]), str(r["nan"]), f"{r['iou']:.4f}", f"{r['depth_median']:.1e}",
                     f"{r['depth_p99']:.1e}", f"{r['depth_p99_1px']:.1e}", str(r["mask_far_px"]),
                     "yes" if r["meets_issue_bound"] else "NO", "yes" if r["meets_renderer_bound"] else "no"))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(row, widths)) for row in rows)


def plot(records: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 0.28 * len(records) + 1.5))
    y = np.arange(len(records))[::-1]
    for key, marker, label in [("depth_median", "o", "median"), ("depth_p99", "s", "p99"),
                               ("depth_p99_1px", "^", "p99, 1-px tolerance")]:
        ax.scatter([max(r[key], 1e-9) for r in records], y, marker=marker, label=label)
    for value, style, label in [(ISSUE["p99"], "--", "issue p99 bound"), (RENDERER["p99"], ":", "renderer p99 bound"),
                                (RENDERER["median"], "-.", "renderer median bound")]:
        ax.axvline(value, color="grey", linestyle=style, label=label)
    ax.set_yticks(y, [f"{r['group']}: {r['case']}" + ("" if r["meets_issue_bound"] else "  (FAILS)") for r in records],
                  fontsize=7)
    ax.set_xscale("log")
    ax.set_xlabel("|depth - trimesh depth| / diagonal (worst over the case's renders)")
    ax.legend(fontsize=7, loc="lower right")
    ax.set_title("geomtex at the extremes: depth error against trimesh ray casting")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="skip the million-face case, fewer samples")
    ap.add_argument("--out", type=Path, default=RESULTS / "stability.json")
    args = ap.parse_args(argv)
    bunny = gt.load_mesh(BUNNY)
    steps: list[tuple[str, Callable[[], list[dict[str, Any]]]]] = [
        ("transforms", lambda: transforms(bunny)),
        ("grazing", lambda: grazing(args.quick)),
        ("eye inside", lambda: eye_inside(args.quick)),
        ("damaged meshes", lambda: damaged(bunny)),
    ]
    if not args.quick:
        steps.append(("a million faces", lambda: million_faces(bunny)))
    records: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    for name, step in tqdm(steps, desc="stability"):
        records += step()
    print(table(records))
    passed = sum(r["meets_issue_bound"] for r in records)
    print(f"\n{passed}/{len(records)} cases within the issue's bounds; "
          f"{sum(r['meets_renderer_bound'] for r in records)} within the renderer issue's")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_json(args.out, {"machine": machine_info(), "quick": args.quick, "seconds": time.perf_counter() - t0,
                          "bounds": {"issue": ISSUE, "renderer": RENDERER}, "records": records}, indent=1)
    plot(records, args.out.with_suffix(".png"))
    print(f"wrote {args.out} and {args.out.with_suffix('.png')}")


if __name__ == "__main__":
    main()
