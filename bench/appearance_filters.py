"""Filters that keep the surface clean (part of bench/appearance.py).

On the Stanford bunny (pymeshlab's bunny where the shared scans are absent), converted with
the defaults but ``normals="smooth"`` (the default crease rule puts an intended shading step on
every edge sharper than 20 degrees, which would hide the filter's own), ``gts.filtered(
"gaussian", sigma)`` at sigma in texels:

- sigma = 0.01 and 0.05 texel: how far the normals move (angle between each texel's normal
  before and after), median and p99 — a filter that barely moves the surface must not move the
  shading either.
- sigma = 1, 2, 4, 8 texels: the shading step where patches meet, measured as the angle between
  the normals two neighbouring patches show at the same points of their shared chart edges
  (``gts.seam_normal_steps``: a quarter, half and three quarters along each edge, both ways),
  median, p95 and p99; the seam gaps there (``gts.seam_gaps``) in texels, median and p99; and the
  largest move of any texel point (hair-like spikes show as moves far above the p99).

``measure()`` returns the figures; ``pictures()`` renders the bunny's head filtered at 6 texels.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

import geomtex as gt
from geomtex.testing import common_points, seam_rays

REPO = Path(__file__).resolve().parents[1]
SHARED_BUNNY = REPO.parent / "shared" / "meshes" / "stanford-bunny.obj"
TINY_SIGMAS = (0.01, 0.05)
SIGMAS = (1.0, 2.0, 4.0, 8.0)
PICTURE_SIGMA = 6.0


def bunny() -> tuple[str, gt.Mesh]:
    if SHARED_BUNNY.exists():
        return "stanford-bunny", gt.load_mesh(SHARED_BUNNY)
    import pymeshlab

    path = Path(pymeshlab.__file__).parent / "tests" / "sample_meshes" / "bunny.obj"
    return "pymeshlab-bunny", gt.load_mesh(path)


def angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Degrees between unit vectors, row by row."""
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))


def crack_figures(gts: gt.GeometryTextureSet, rays: tuple[np.ndarray, np.ndarray, float]) -> dict[str, float]:
    """How many of the ``seam_rays`` pass through the surface: no hit, or a first hit more than
    6 texels beyond where the mesh is (a crack lets a ray through to the far side)."""
    origins, directions, lift = rays
    hits = gts.intersects_first(origins, directions)
    distance = np.where(hits.hit, hits.distances, np.inf)
    through = distance > lift + 6 * gts.texel_size
    return {"seam_rays": int(len(origins)), "seam_rays_through": int(through.sum())}


def seam_figures(gts: gt.GeometryTextureSet, mesh: gt.Mesh) -> dict[str, float]:
    t = gts.texel_size
    gaps = gts.seam_gaps(mesh) / t
    steps = gts.seam_normal_steps(mesh)
    return {
        "seam_gap_median_texels": float(np.median(gaps)),
        "seam_gap_p99_texels": float(np.percentile(gaps, 99)),
        "normal_step_median_deg": float(np.median(steps)),
        "normal_step_p95_deg": float(np.percentile(steps, 95)),
        "normal_step_p99_deg": float(np.percentile(steps, 99)),
        "seam_points": int(len(steps)),
    }


def measure(size: int = 512) -> dict[str, Any]:
    """The figures above; ``size`` is unused (the figures are in texel space) but kept so that
    every appearance part is called alike."""
    name, mesh = bunny()
    gts = gt.convert(mesh, normals="smooth", max_resolution=256)
    t = gts.texel_size
    _, normals0 = gts.to_points()
    rays = seam_rays(mesh, gts)
    out: dict[str, Any] = {"mesh": name, "texel_size": t, "load_average_before": os.getloadavg(),
                           "unfiltered": {**seam_figures(gts, mesh), **crack_figures(gts, rays)},
                           "tiny": [], "sigmas": []}
    for s in TINY_SIGMAS:
        _, normals = gts.filtered("gaussian", s * t).to_points()
        a = angles(normals, normals0)
        out["tiny"].append({"sigma_texels": s, "normal_change_median_deg": float(np.median(a)),
                            "normal_change_p99_deg": float(np.percentile(a, 99))})
    for s in SIGMAS:
        t0 = time.perf_counter()
        filtered = gts.filtered("gaussian", s * t)
        seconds = time.perf_counter() - t0
        before, after, cut = common_points(gts, filtered)
        moves = np.linalg.norm(after - before, axis=1) / t
        out["sigmas"].append({"sigma_texels": s, "seconds": seconds, **seam_figures(filtered, mesh),
                              "move_p99_texels": float(np.percentile(moves, 99)),
                              "move_max_texels": float(moves.max()), "texels_cut": cut,
                              "texels": int(len(before) + cut), **crack_figures(filtered, rays)})
    out["load_average_after"] = os.getloadavg()
    return out


def pictures(out_dir: Path, size: int = 512, tag: str = "") -> list[Path]:
    """The bunny's ears close up from two sides, unfiltered and filtered at ``PICTURE_SIGMA``
    texels, as one PNG per view (left: unfiltered, right: filtered)."""
    from PIL import Image

    _, mesh = bunny()
    gts = gt.convert(mesh, max_resolution=256)
    filtered = gts.filtered("gaussian", PICTURE_SIGMA * gts.texel_size)
    renderer = gt.Renderer(size, size)
    lo, hi = (np.asarray(b, np.float64) for b in mesh.bounds)
    # The ears stand at the top of the (y-up) scan, towards its back.
    ears = np.array([0.5 * (lo[0] + hi[0]), lo[1] + 0.85 * (hi[1] - lo[1]), lo[2] + 0.35 * (hi[2] - lo[2])])
    paths = []
    for view, direction in [("ears_front", (0.2, 0.3, 1.0)), ("ears_side", (1.0, 0.2, -0.2))]:
        d = np.asarray(direction) / np.linalg.norm(direction)
        cam = gt.Camera.look_at(ears + 0.5 * mesh.diagonal * d, ears, up=(0.0, 1.0, 0.0), yfov_deg=35.0)
        pair = [renderer.render(g, cam).color for g in (gts, filtered)]
        path = out_dir / f"appearance_filter_{view}{tag}.png"
        Image.fromarray(np.concatenate(pair, axis=1)).save(path)
        paths.append(path)
    return paths


def table(m: dict[str, Any]) -> str:
    rows = [f"filters on {m['mesh']} (texel {m['texel_size']:.3g})"]
    for r in m["tiny"]:
        rows.append(f"  sigma {r['sigma_texels']:>5} texel: normal change median "
                    f"{r['normal_change_median_deg']:.3f} deg, p99 {r['normal_change_p99_deg']:.2f} deg")
    rows.append("  sigma  step median  step p95  step p99  gap median  gap p99  move p99  move max"
                "  texels cut  seam points  rays through  (deg, texels)")
    u = m["unfiltered"]
    rows.append(f"  {'none':>5} {u['normal_step_median_deg']:11.2f} {u['normal_step_p95_deg']:9.2f} "
                f"{u['normal_step_p99_deg']:9.2f} {u['seam_gap_median_texels']:11.4f} {u['seam_gap_p99_texels']:8.3f}"
                f"{'':30} {u['seam_points']:12} {u['seam_rays_through']:6}/{u['seam_rays']}")
    for r in m["sigmas"]:
        rows.append(f"  {r['sigma_texels']:5.0f} {r['normal_step_median_deg']:11.2f} "
                    f"{r['normal_step_p95_deg']:9.2f} {r['normal_step_p99_deg']:9.2f} {r['seam_gap_median_texels']:11.4f} "
                    f"{r['seam_gap_p99_texels']:8.3f} {r['move_p99_texels']:9.2f} {r['move_max_texels']:9.2f}"
                f" {r['texels_cut']:11} {r['seam_points']:12} {r['seam_rays_through']:6}/{r['seam_rays']}")
    return "\n".join(rows)


# The targets: no step above 2 degrees (read as the p99), and seam gaps no larger than
# the filter's when the issue was filed (p99, texels, at sigma 1, 2, 4, 8).
STEP_TARGET_DEG = 2.0
GAP_TARGETS = {1.0: 0.15, 2.0: 0.17, 4.0: 0.41, 8.0: 1.32}


def plot(m: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sig = [r["sigma_texels"] for r in m["sigmas"]]
    x = np.arange(len(sig))
    fig, (a, b) = plt.subplots(1, 2, figsize=(8, 3.4))
    a.bar(x, [r["normal_step_p99_deg"] for r in m["sigmas"]], color="tab:blue")
    a.axhline(STEP_TARGET_DEG, color="k", ls="--", lw=1)
    a.set_title("seam normal step p99 (deg; dashed: target)", fontsize=8)
    b.bar(x - 0.2, [r["seam_gap_p99_texels"] for r in m["sigmas"]], 0.4, label="this filter")
    b.bar(x + 0.2, [GAP_TARGETS.get(s, np.nan) for s in sig], 0.4, label="when the issue was filed")
    b.set_title("seam gap p99 (texels)", fontsize=8)
    b.legend(fontsize=7)
    for ax in (a, b):
        ax.set_xticks(x, [f"sigma {s:g}" for s in sig], fontsize=8)
    fig.suptitle(f"gts.filtered('gaussian') on {m['mesh']}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:

    out = REPO / "bench" / "results"
    m = measure()
    print(table(m))
    write_json(out / "appearance_filters.json", m, indent=1)
    plot(m, out / "appearance_filters.png")
    print(f"wrote {out / 'appearance_filters.json'} and {out / 'appearance_filters.png'}")


if __name__ == "__main__":
    main()
