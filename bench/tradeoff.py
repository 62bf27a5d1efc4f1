"""Speed vs. accuracy of the geometry-texture ray caster: search settings and map resolution.

For each mesh, map resolution and view, every search setting is rendered at 512x512 and compared
with trimesh + embree ray casting of the original mesh along the same pixel rays:

* **accuracy**: |depth difference| / bounding-box diagonal (median, p99, max) on pixels that both
  hit, normal angle (median degrees; renderer normal vs. the hit triangle's normal), hit-mask IoU;
* **cost**: height + pyramid fetches per ray-cast fragment (one ``count_fetches=True`` render, a
  machine-independent count) and ms per frame (median of ``--repeats`` plain renders: wall time
  of ``render()`` and the GPU timestamps ``gpu_ms``), and the map's bytes.

The depth is also compared with the exact first hits of the *stored* surface
(``gts.first_hits``, f64 on the CPU): that isolates the search's own error from the error of the
height-map representation, which the trimesh comparison includes.

Every (mesh, R) is converted twice, with 16-bit and with 8-bit heights (``--bits``), and the
whole plan is rendered for both: the records carry ``height_bits`` and the maps' ``bytes``.

Settings: ``linear_binary`` with ``steps_per_texel`` x ``binary_steps`` (the full grid; with
``--thin`` only 8 bisections off R = 256), the ``fast`` preset, and ``maxmip`` (the ``exact``
preset; ``balanced`` is the grid point 0.5 / 8, rendered through the preset). The references are
computed once per (mesh, view) (trimesh) and once per (mesh, R, view) (stored surface).

Results: ``bench/results/tradeoff.json`` and ``bench/results/tradeoff.png`` (Pareto plots).

Run from the repository root::

    python bench/tradeoff.py          # 2 meshes x 3 views x 4 R x 2 bits x 17 settings (~12 min)
    python bench/tradeoff.py --quick  # oblique + grazing views, presets only off R=256,
                                      # 1 timed render (~2 min)
    python bench/tradeoff.py --thin   # all views, but only 8 bisections off R=256 (~6 min)
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

import geomtex as gt
from geomtex import reference

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

from render import ForeignCpu, accuracy, machine_info, wait_idle  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
MESH_DIR = REPO.parent / "shared" / "meshes"
MESHES = {  # label -> (file, convert keywords)
    "stanford-bunny": ("stanford-bunny.obj", {}),
    "fandisk": ("fandisk.obj", {"normals": "flat"}),
}
SIZE = 512
YFOV_DEG = 40.0
DISTANCE = 1.7  # x diagonal
_G = math.radians(10.0)
VIEWS = {  # name -> direction from the model's centre to the eye (up is +Y)
    "oblique": (1.0, 0.8, 1.0),
    "front": (0.0, 0.0, 1.0),
    "grazing": (math.cos(_G), math.sin(_G), 0.0),  # 10 degrees above the horizontal
}
RESOLUTIONS = (64, 128, 256, 512)
GRID_R = 256
STEPS_PER_TEXEL = (0.125, 0.25, 0.5, 1.0, 2.0)
BINARY_STEPS = (4, 8, 12)
MIN_LINEAR, MAX_LINEAR = 2, 1024
PRESETS = {"fast": (0.25, 6), "balanced": (0.5, 8)}  # exact = maxmip
# Other processes using more than this share of a core during a timing block: wait and re-time.
BUSY = 0.25


# --------------------------------------------------------------------------- settings


def setting(spt: float | None, binary: int | None) -> dict[str, Any]:
    """A search setting; presets are rendered through ``quality=``."""
    if spt is None:
        return {"name": "maxmip", "method": "maxmip", "preset": "exact",
                "steps_per_texel": None, "binary_steps": None}
    preset = next((p for p, v in PRESETS.items() if v == (spt, binary)), None)
    return {"name": f"lb {spt:g}/{binary}", "method": "linear_binary", "preset": preset,
            "steps_per_texel": spt, "binary_steps": binary}


def settings_for(resolution: int, quick: bool, thin: bool) -> list[dict[str, Any]]:
    if resolution == GRID_R or not (quick or thin):
        pairs = [(s, b) for s in STEPS_PER_TEXEL for b in BINARY_STEPS]
    elif quick:
        pairs = []
    else:  # thinned: every steps_per_texel with 8 bisections
        pairs = [(s, 8) for s in STEPS_PER_TEXEL]
    for v in PRESETS.values():
        if v not in pairs:
            pairs.append(v)
    pairs.sort()
    return [setting(s, b) for s, b in pairs] + [setting(None, None)]


def render_kwargs(s: dict[str, Any]) -> dict[str, Any]:
    if s["preset"] is not None:
        return {"quality": s["preset"]}
    return {"method": "linear_binary", "steps_per_texel": s["steps_per_texel"],
            "min_linear_steps": MIN_LINEAR, "max_linear_steps": MAX_LINEAR,
            "binary_steps": s["binary_steps"]}


# --------------------------------------------------------------------------- measurement


def camera(centre: np.ndarray, direction: tuple[float, float, float], distance: float) -> gt.Camera:
    d = np.asarray(direction, dtype=np.float64)
    d /= np.linalg.norm(d)
    eye = centre + d * distance
    return gt.Camera.look_at(tuple(float(x) for x in eye), tuple(float(x) for x in centre),
                             up=(0.0, 1.0, 0.0), yfov_deg=YFOV_DEG)


def timed(renderer: gt.Renderer, gts: Any, cam: gt.Camera, kw: dict[str, Any],
          repeats: int) -> tuple[Any, dict[str, Any]]:
    walls, gpus = [], []
    frame: Any = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        frame = renderer.render(gts, cam, **kw)
        walls.append(1000.0 * (time.perf_counter() - t0))
        gpus.append(frame.stats["gpu_ms"])
    gok = [g for g in gpus if g is not None]
    return frame, {"wall_ms": float(np.median(walls)), "gpu_ms": float(np.median(gok)) if gok else None,
                   "wall_ms_runs": walls, "gpu_ms_runs": gpus}


def stored_surface(gts: Any, cam: gt.Camera) -> np.ndarray:
    """z-depth of the exact first hits on the stored surface (+inf on a miss)."""
    o, d = cam.rays(SIZE, SIZE)
    t, _ = gts.first_hits(o.reshape(-1, 3), d.reshape(-1, 3))
    z = t * (d.reshape(-1, 3) @ np.asarray(cam.forward, dtype=np.float64))
    return z.reshape(SIZE, SIZE)


def search_error(frame: Any, exact: np.ndarray, diag: float, texel: float) -> dict[str, Any]:
    """The search's own error: the frame's depth vs. the stored surface's exact first hits."""
    depth = np.asarray(frame.depth, dtype=np.float64)
    hit, ehit = np.isfinite(depth), np.isfinite(exact)
    both = hit & ehit
    dz = np.abs(depth[both] - exact[both])
    return {
        "surface_median": float(np.median(dz) / diag) if dz.size else float("nan"),
        "surface_p99": float(np.percentile(dz, 99) / diag) if dz.size else float("nan"),
        "surface_max": float(dz.max() / diag) if dz.size else float("nan"),
        # pixels where the search stopped on another layer than the first crossing (more than
        # one texel off in depth) or hit where the surface is missed / missed where it is hit
        "surface_off_px": int((dz > texel).sum()),
        "surface_hit_mismatch_px": int((hit ^ ehit).sum()),
        "surface_px": int(ehit.sum()),
    }


def measure(renderer: gt.Renderer, gts: Any, cam: gt.Camera, s: dict[str, Any], ref: dict,
            exact: np.ndarray, diag: float, repeats: int, wait: float) -> dict[str, Any]:
    kw = render_kwargs(s)
    counted = renderer.render(gts, cam, count_fetches=True, **kw)
    cst = counted.stats
    for attempt in (1, 2):
        probe = ForeignCpu()
        probe.start()
        frame, t = timed(renderer, gts, cam, kw, repeats)
        load = probe.stop()
        busy = load["foreign_cpu_s"] / max(load["wall_s"], 1e-9)
        t["busy_other_cores"] = busy
        t["attempt"] = attempt
        if busy <= BUSY or attempt == 2:
            break
        wait_idle(wait)
    acc = accuracy(frame, ref, diag, normals=True)
    acc.update(search_error(frame, exact, diag, float(gts.texel_size)))
    return {
        "fetches_per_pixel": float(cst["fetches_per_pixel"]),
        "fetches": int(cst["fetches"]),
        "searches": int(cst["searches"]),
        "fetches_per_search": float(cst["fetches_per_search"]),
        "count_frame_matches": bool(np.array_equal(np.asarray(counted.depth), np.asarray(frame.depth))),
        **t,
        **acc,
    }


def check_presets(renderer: gt.Renderer, gts: Any, cam: gt.Camera) -> dict[str, bool]:
    """Whether ``quality=preset`` renders exactly what the explicit settings render."""
    out = {}
    for name, (spt, b) in PRESETS.items():
        a = renderer.render(gts, cam, quality=name)
        e = renderer.render(gts, cam, method="linear_binary", steps_per_texel=spt,
                            min_linear_steps=MIN_LINEAR, max_linear_steps=MAX_LINEAR, binary_steps=b)
        out[name] = bool(np.array_equal(np.asarray(a.depth), np.asarray(e.depth)))
    a = renderer.render(gts, cam, quality="exact")
    e = renderer.render(gts, cam, method="maxmip")
    out["exact"] = bool(np.array_equal(np.asarray(a.depth), np.asarray(e.depth)))
    return out


# --------------------------------------------------------------------------- analysis


def pareto(points: list[tuple[float, float, Any]]) -> list[tuple[float, float, Any]]:
    """Points not beaten in both cost (x) and error (y), by increasing cost."""
    front: list[tuple[float, float, Any]] = []
    for x, y, tag in sorted(points, key=lambda p: (p[0], p[1])):
        if not front or y < front[-1][1]:
            front.append((x, y, tag))
    return front


def select(records: list[dict[str, Any]], **kv: Any) -> list[dict[str, Any]]:
    return [r for r in records if all(r.get(k) == v for k, v in kv.items())]


def headline_figure(records: list[dict[str, Any]], mesh: str = "stanford-bunny", resolution: int = GRID_R,
                    view: str = "oblique", bits: int = 16) -> dict[str, Any] | None:
    group = select(records, mesh=mesh, R=resolution, view=view, height_bits=bits)
    mm = [r for r in group if r["method"] == "maxmip"]
    lin = [r for r in group if r["method"] == "linear_binary"]
    if not mm or not lin:
        return None
    m = mm[0]
    best = min(lin, key=lambda r: (r["depth_p99"], r["fetches_per_pixel"]))
    # the cheapest linear setting whose p99 is at least as good as maxmip's
    matching = [r for r in lin if r["depth_p99"] <= m["depth_p99"]]
    cheapest = min(matching, key=lambda r: r["fetches_per_pixel"]) if matching else None
    ratio = m["fetches_per_pixel"] / best["fetches_per_pixel"]
    return {
        "mesh": mesh, "R": resolution, "view": view, "height_bits": bits,
        "best_linear": {k: best[k] for k in ("setting", "steps_per_texel", "binary_steps", "depth_p99",
                                             "depth_median", "fetches_per_pixel", "gpu_ms", "wall_ms",
                                             "surface_p99", "surface_off_px")},
        "maxmip": {k: m[k] for k in ("depth_p99", "depth_median", "fetches_per_pixel", "gpu_ms", "wall_ms",
                                     "surface_p99", "surface_off_px")},
        "fetch_ratio_maxmip_over_best": ratio,
        "p99_ratio_maxmip_over_best": m["depth_p99"] / best["depth_p99"],
        "maxmip_matches_p99": bool(m["depth_p99"] <= best["depth_p99"]),
        "maxmip_within_half_fetches": bool(ratio <= 0.5),
        "goal_met": bool(m["depth_p99"] <= best["depth_p99"] and ratio <= 0.5),
        "cheapest_linear_matching_maxmip_p99": None if cheapest is None else {
            k: cheapest[k] for k in ("setting", "depth_p99", "fetches_per_pixel", "gpu_ms")},
    }


def bits_summary(records: list[dict[str, Any]], meshes_info: dict[str, Any]) -> list[dict[str, Any]]:
    """Per (mesh, R, view): the exact search's depth error with 16- and with 8-bit heights, the
    8-bit rounding bound (half a code step of the tallest patch) and the bytes ratio."""
    out = []
    for r16 in select(records, method="maxmip", height_bits=16):
        r8 = select(records, method="maxmip", height_bits=8, mesh=r16["mesh"], R=r16["R"], view=r16["view"])
        if not r8:
            continue
        info = meshes_info[r16["mesh"]]["resolutions"][r16["R"]]
        out.append({"mesh": r16["mesh"], "R": r16["R"], "view": r16["view"],
                    "p99_16": r16["depth_p99"], "p99_8": r8[0]["depth_p99"],
                    "median_16": r16["depth_median"], "median_8": r8[0]["depth_median"],
                    "rounding_8": info[8]["max_quantization_error_over_diag"],
                    "bytes_ratio": r8[0]["bytes"] / r16["bytes"]})
    return out


def collapses(records: list[dict[str, Any]], off_fraction: float = 0.01) -> list[dict[str, Any]]:
    """Settings where the search lands on the wrong layer: more than ``off_fraction`` of the
    pixels end more than one texel (in depth) from the stored surface's first crossing."""
    out = []
    for r in records:
        if r["method"] == "maxmip":
            continue
        frac = r["surface_off_px"] / max(r["surface_px"], 1)
        if frac <= off_fraction:
            continue
        m = select(records, mesh=r["mesh"], R=r["R"], view=r["view"], height_bits=r["height_bits"],
                   method="maxmip")
        m = m[0] if m else None
        out.append({"mesh": r["mesh"], "R": r["R"], "view": r["view"], "height_bits": r["height_bits"],
                    "setting": r["setting"],
                    "off_fraction": frac, "depth_p99": r["depth_p99"], "surface_p99": r["surface_p99"],
                    "depth_median": r["depth_median"], "iou": r["iou"],
                    "maxmip_depth_p99": m["depth_p99"] if m else None,
                    "maxmip_iou": m["iou"] if m else None,
                    "fetches_per_pixel": r["fetches_per_pixel"]})
    return out


def disagreement(renderer: gt.Renderer, gts: Any, cam: gt.Camera, best: dict[str, Any], ref: dict,
                 diag: float) -> dict[str, Any]:
    """Where maxmip and the best linear setting differ, and which is nearer to the mesh there;
    how many of maxmip's top-1% errors lie next to a change of patch id (patch borders)."""
    fm = renderer.render(gts, cam, method="maxmip")
    fl = renderer.render(gts, cam, **render_kwargs(best))
    zm, zl = (np.asarray(f.depth, dtype=np.float64) for f in (fm, fl))
    zr = np.asarray(ref["depth"], dtype=np.float64)
    both = np.isfinite(zm) & np.isfinite(zl) & np.isfinite(zr)
    zm, zl, zr = (np.where(both, z, 0.0) for z in (zm, zl, zr))
    em, el = np.abs(zm - zr) / diag, np.abs(zl - zr) / diag
    differ = both & (np.abs(zm - zl) / diag > 1e-5)
    pid = np.asarray(fm.patch_id)
    border = np.zeros(pid.shape, dtype=bool)
    for shift in ((0, 1), (1, 0), (0, -1), (-1, 0)):
        border |= np.roll(pid, shift, axis=(0, 1)) != pid
    top = both & (em > np.percentile(em[both], 99))
    return {
        "linear_setting": best["name"],
        "pixels_differing_by_1e-5_diag": int(differ.sum()),
        "of_which_linear_farther": int((differ & (zl > zm)).sum()),
        "of_which_maxmip_nearer_mesh": int((differ & (em < el)).sum()),
        "p99_maxmip_excluding_those": float(np.percentile(em[both & ~differ], 99)),
        "p99_linear_excluding_those": float(np.percentile(el[both & ~differ], 99)),
        "maxmip_top1pct_at_patch_borders": float((top & border).sum() / max(top.sum(), 1)),
        "hit_pixels_at_patch_borders": float((both & border).sum() / max(both.sum(), 1)),
    }


# --------------------------------------------------------------------------- reporting


def _table(header: tuple[str, ...], rows: list[tuple[str, ...]]) -> str:
    widths = [max(len(str(c)) for c in col) for col in zip(header, *rows)]
    line = lambda cells: "  ".join(  # noqa: E731
        c.ljust(w) if i < 5 else c.rjust(w) for i, (c, w) in enumerate(zip(cells, widths)))
    return "\n".join([line(header), line(tuple("-" * w for w in widths))] + [line(r) for r in rows])


def label(r: dict[str, Any]) -> str:
    return r["setting"] + (f" ({r['preset']})" if r["preset"] else "")


def records_table(records: list[dict[str, Any]]) -> str:
    header = ("mesh", "R", "bits", "view", "setting", "p99 |dz|/diag", "median", "normal deg", "IoU",
              "srf p99", "srf off px", "fetch/px", "wall ms", "gpu ms", "MB", "busy")
    rows = []
    for r in records:
        rows.append((r["mesh"], str(r["R"]), str(r["height_bits"]), r["view"], label(r), f"{r['depth_p99']:.2e}",
                     f"{r['depth_median']:.2e}", f"{r['normal_deg_median']:.2f}", f"{r['iou']:.4f}",
                     f"{r['surface_p99']:.1e}", str(r["surface_off_px"] + r["surface_hit_mismatch_px"]),
                     f"{r['fetches_per_pixel']:.1f}", f"{r['wall_ms']:.0f}",
                     "-" if r["gpu_ms"] is None else f"{r['gpu_ms']:.0f}", f"{r['bytes'] / 1e6:.1f}",
                     f"{100 * r['busy_other_cores']:.0f}%"))
    return _table(header, rows)


def preset_rows(records: list[dict[str, Any]], mesh: str = "stanford-bunny", resolution: int = GRID_R,
                view: str = "oblique") -> list[dict[str, Any]]:
    out = []
    for bits in (16, 8):
        for p in ("fast", "balanced", "exact"):
            rs = [r for r in select(records, mesh=mesh, R=resolution, view=view, height_bits=bits)
                  if r["preset"] == p]
            if rs:
                out.append({"preset": p, "height_bits": bits, **{k: rs[0][k] for k in (
                    "setting", "depth_p99", "depth_median", "normal_deg_median", "iou",
                    "fetches_per_pixel", "wall_ms", "gpu_ms", "bytes")}})
    return out


# --------------------------------------------------------------------------- plot


def plot(records: list[dict[str, Any]], path: Path, grazing_view: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FuncFormatter

    cmap = plt.get_cmap("viridis")
    colour = {s: cmap(i / (len(STEPS_PER_TEXEL) - 1) * 0.9) for i, s in enumerate(STEPS_PER_TEXEL)}
    marker = {4: "v", 6: "D", 8: "o", 12: "s"}
    trimesh_label = "p99 |Δdepth| / diagonal vs. trimesh"

    def plain_log_ticks(axis: Any) -> None:
        """Log-axis labels as plain numbers, minor ones only at 2x and 5x."""
        def fmt(v: float, _pos: Any, minor: bool = False) -> str:
            lead = round(v / 10 ** math.floor(math.log10(v) + 1e-9))
            return f"{v:g}" if not minor or lead in (2, 5) else ""
        axis.set_major_formatter(FuncFormatter(fmt))
        axis.set_minor_formatter(FuncFormatter(lambda v, p: fmt(v, p, True)))

    def scatter(ax: Any, group: list[dict[str, Any]], xkey: str, xlabel: str, title: str,
                ykey: str = "depth_p99", ylabel: str = trimesh_label) -> None:
        pts = []
        for r in group:
            x, y = r[xkey], r[ykey]
            if x is None or not np.isfinite(y):
                continue
            pts.append((x, y, r))
            if r["method"] == "maxmip":
                ax.scatter(x, y, marker="*", s=420, color="crimson", edgecolor="black", zorder=6)
                ax.annotate("maxmip (exact)", (x, y), xytext=(4, -16), textcoords="offset points",
                            fontsize=10, color="crimson", weight="bold", va="top",
                            bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8})
            else:
                ax.scatter(x, y, marker=marker[r["binary_steps"]], s=70, color=colour[r["steps_per_texel"]],
                           edgecolor="black", linewidth=0.5, zorder=4)
                if r["preset"]:
                    ax.annotate(r["preset"], (x, y), xytext=(7, 7), textcoords="offset points",
                                fontsize=9.5, weight="bold",
                                bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8})
        if not pts:
            ax.set_visible(False)
            return
        front = pareto(pts)
        fx = [p[0] for p in front]
        fy = [p[1] for p in front]
        xmax = max(p[0] for p in pts) * 1.15
        ax.step(fx + [xmax], fy + [fy[-1]], where="post", color="0.35", ls="--", lw=1.2, zorder=3)
        ax.set_xscale("log")
        ax.set_yscale("log")
        lo, hi = min(p[1] for p in pts), max(p[1] for p in pts)
        ax.set_ylim(lo / max(1.6, (hi / lo) ** 0.1), hi * 1.25)  # room for the label under maxmip
        plain_log_ticks(ax.xaxis)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_title(title, fontsize=11)
        ax.grid(which="major", alpha=0.3)
        ax.grid(which="minor", alpha=0.1)

    fig, axes = plt.subplots(2, 3, figsize=(20, 12))
    bunny = select(records, mesh="stanford-bunny", R=GRID_R, height_bits=16)
    obl = select(bunny, view="oblique")
    fetch_label = "fetches per ray-cast pixel (height + pyramid reads)"
    scatter(axes[0, 0], obl, "fetches_per_pixel", fetch_label,
            f"(a) bunny, {GRID_R}² maps, oblique view: error vs. fetches")
    scatter(axes[0, 1], obl, "gpu_ms", "GPU ms per 512² frame (lavapipe, median)",
            f"(b) bunny, {GRID_R}² maps, oblique view: error vs. time")
    scatter(axes[0, 2], obl, "fetches_per_pixel", fetch_label,
            f"(c) bunny, {GRID_R}² maps, oblique view: search error only\n"
            "(vs. exact first hits of the stored surface, gts.first_hits)",
            ykey="surface_p99", ylabel="p99 |Δdepth| / diagonal vs. stored surface")
    scatter(axes[1, 0], select(bunny, view=grazing_view), "fetches_per_pixel", fetch_label,
            f"(d) bunny, {GRID_R}² maps, {grazing_view} view (10° above horizontal)")
    scatter(axes[1, 1], select(records, mesh="fandisk", R=GRID_R, view="oblique", height_bits=16), "fetches_per_pixel",
            fetch_label, f"(e) fandisk (CAD, flat normals), {GRID_R}² maps, oblique view")

    # (f) resolution: error vs. bytes for the presets
    ax = axes[1, 2]
    pcol = {"fast": "tab:blue", "balanced": "tab:green", "exact": "crimson"}
    for mesh, ls, mk, offset in (("stanford-bunny", "-", "o", (6, 6)), ("fandisk", "--", "s", (6, -14))):
        for p, bits in [(p, b) for b in (16, 8) for p in ("fast", "balanced", "exact")]:
            rs = sorted((r for r in select(records, mesh=mesh, view="oblique", height_bits=bits)
                         if r["preset"] == p), key=lambda r: r["R"])
            if not rs or (bits == 8 and p != "exact"):
                continue
            ax.plot([r["bytes"] / 1e6 for r in rs], [r["depth_p99"] for r in rs],
                    ls if bits == 16 else ":", marker=mk, color=pcol[p], ms=7,
                    mfc=pcol[p] if bits == 16 else "white", label=f"{mesh} {p}, {bits}-bit")
            if p == "exact" and bits == 16:
                for r in rs:
                    ax.annotate(f"R={r['R']}", (r["bytes"] / 1e6, r["depth_p99"]), xytext=offset,
                                textcoords="offset points", fontsize=8.5, color="crimson",
                                ha="left")
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain_log_ticks(ax.xaxis)
    ax.set_xlabel("map size (MB, gts.stats['bytes'])")
    ax.set_ylabel(trimesh_label)
    ax.set_title("(f) map resolution R ∈ {64, 128, 256, 512} and height bits: presets, oblique view\n"
                 "solid: bunny, dashed: fandisk, dotted + hollow: exact with 8-bit heights", fontsize=11)
    ax.grid(which="major", alpha=0.3)
    ax.grid(which="minor", alpha=0.1)
    ax.legend(fontsize=8.5, ncol=2, loc="upper right")

    handles = [Line2D([], [], ls="", marker="o", ms=9, color=colour[s], markeredgecolor="black",
                      label=f"{s:g} steps/texel") for s in STEPS_PER_TEXEL]
    handles += [Line2D([], [], ls="", marker=marker[b], ms=8, color="0.8", markeredgecolor="black",
                       label=f"{b} binary steps" + (" (fast preset)" if b == 6 else "")) for b in (4, 6, 8, 12)]
    handles += [Line2D([], [], ls="", marker="*", ms=16, color="crimson", markeredgecolor="black",
                       label="maxmip (exact)"),
                Line2D([], [], ls="--", color="0.35", label="Pareto front")]
    axes[0, 0].legend(handles=handles, fontsize=8.5, loc="upper right", title="linear_binary",
                      title_fontsize=9)
    fig.suptitle("geomtex ray casting: speed vs. accuracy ((a)-(e): 16-bit heights; 512² frames, camera at 1.7 × diagonal, yfov 40°, "
                 "Mesa lavapipe on 2 CPU cores)", fontsize=14)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(path, dpi=90)
    plt.close(fig)


# --------------------------------------------------------------------------- main


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="oblique and grazing views only; off R=256 only the three presets; 1 timed render")
    parser.add_argument("--thin", action="store_true",
                        help="off R=256 only 8 bisections per steps_per_texel (plus the presets)")
    parser.add_argument("--meshes", nargs="+", default=list(MESHES), choices=list(MESHES))
    parser.add_argument("--resolutions", nargs="+", type=int, default=list(RESOLUTIONS))
    parser.add_argument("--bits", nargs="+", type=int, default=[16, 8], choices=[16, 8],
                        help="height bits to convert with")
    parser.add_argument("--repeats", type=int, default=None, help="timed renders per setting (default 3, quick 1)")
    parser.add_argument("--wait-idle", type=float, default=20.0, metavar="S",
                        help="when other processes were busy during a timing, wait up to S s and re-time once")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results", help="output folder")
    parser.add_argument("--plot-only", action="store_true", help="redraw tradeoff.png from tradeoff.json in --out")
    args = parser.parse_args(argv)
    if args.plot_only:
        data = json.loads((args.out / "tradeoff.json").read_text())
        plot(data["records"], args.out / "tradeoff.png", "grazing")
        print(f"wrote {args.out / 'tradeoff.png'}")
        return
    repeats = args.repeats if args.repeats is not None else (1 if args.quick else 3)
    if repeats < 1:
        parser.error("--repeats must be at least 1")
    views = {k: v for k, v in VIEWS.items() if not args.quick or k in ("oblique", "grazing")}

    machine = machine_info()
    renderer = gt.Renderer(SIZE, SIZE)
    machine["adapter"] = dict(renderer.adapter_info)
    print(f"adapter: {machine['adapter']}")
    t_start = time.perf_counter()

    plan = {R: settings_for(R, args.quick, args.thin) for R in args.resolutions}
    diagnosis: dict[str, Any] | None = None
    total = len(args.meshes) * len(views) * len(args.bits) * sum(len(s) for s in plan.values())
    bar = tqdm(total=total, desc="tradeoff", unit="setting")
    records: list[dict[str, Any]] = []
    meshes_info: dict[str, Any] = {}
    preset_checks: dict[str, Any] = {}
    for mesh_name in args.meshes:
        fname, conv_kw = MESHES[mesh_name]
        path = MESH_DIR / fname
        if not path.is_file():
            raise SystemExit(f"missing {path}")
        mesh = gt.load_mesh(str(path))
        lo, hi = (np.asarray(b, dtype=np.float64) for b in mesh.bounds)
        centre, diag = (lo + hi) / 2, float(mesh.diagonal)
        cams = {v: camera(centre, d, DISTANCE * diag) for v, d in views.items()}
        refs = {}
        t0 = time.perf_counter()
        for v, cam in cams.items():  # once per (mesh, view): independent of R and the setting
            refs[v] = reference.raycast(mesh, cam, SIZE, SIZE)
        meshes_info[mesh_name] = {"file": fname, "faces": int(mesh.n_faces), "diagonal": diag,
                                  "convert": conv_kw, "reference_s": time.perf_counter() - t0,
                                  "reference_hit_px": {v: int(r["hit"].sum()) for v, r in refs.items()},
                                  "resolutions": {}}
        for R, bits in [(R, b) for R in args.resolutions for b in args.bits]:
            t0 = time.perf_counter()
            gts = gt.convert(mesh, max_resolution=R, height_bits=bits, **conv_kw)
            conv_s = time.perf_counter() - t0
            st = gts.stats
            meshes_info[mesh_name]["resolutions"].setdefault(R, {})[bits] = {
                "convert_s": conv_s, "bytes": int(st["bytes"]), "texels": int(st["texels"]),
                "charts": int(st["charts"]), "texel_size_over_diag": float(st["texel_size"]) / diag,
                "max_quantization_error_over_diag": float(st["max_quantization_error"]) / diag}
            # warm-up: upload and pipeline creation of both builds and both methods
            for kw in ({"quality": "fast"}, {"method": "maxmip"}):
                for cf in (False, True):
                    renderer.render(gts, cams["oblique"], count_fetches=cf, **kw)
            if R == GRID_R:
                preset_checks[f"{mesh_name} {bits}-bit"] = check_presets(renderer, gts, cams["oblique"])
            for v, cam in cams.items():
                exact = stored_surface(gts, cam)
                for s in plan[R]:
                    bar.set_postfix_str(f"{mesh_name} R={R} {bits}-bit {v} {s['name']}")
                    m = measure(renderer, gts, cam, s, refs[v], exact, diag, repeats, args.wait_idle)
                    records.append({"mesh": mesh_name, "R": R, "height_bits": bits, "view": v,
                                    "setting": s["name"],
                                    **{k: s[k] for k in ("method", "preset", "steps_per_texel",
                                                         "binary_steps")},
                                    "bytes": int(st["bytes"]), **m})
                    bar.update()
                if (mesh_name, R, bits, v) == ("stanford-bunny", GRID_R, 16, "oblique"):
                    fig = headline_figure(records)
                    if fig:
                        best = next(x for x in plan[R] if x["name"] == fig["best_linear"]["setting"])
                        diagnosis = disagreement(renderer, gts, cam, best, refs[v], diag)
            del gts
            gc.collect()
    bar.close()
    elapsed = time.perf_counter() - t_start

    print(f"\nAll records (512², camera at {DISTANCE} x diagonal, yfov {YFOV_DEG:g}°; errors vs. trimesh "
          f"on pixels both hit, / diagonal; ms = median of {repeats}; busy = other processes' CPU)")
    print(records_table(records))

    presets = preset_rows(records)
    if presets:
        print(f"\nPresets, bunny, R={GRID_R}, oblique view:")
        print(_table(("preset", "setting", "bits", "", "", "p99", "median", "normal deg", "IoU", "fetch/px",
                      "wall ms", "gpu ms", "MB"),
                     [(p["preset"], p["setting"], str(p["height_bits"]), "", "", f"{p['depth_p99']:.2e}",
                       f"{p['depth_median']:.2e}", f"{p['normal_deg_median']:.2f}", f"{p['iou']:.4f}",
                       f"{p['fetches_per_pixel']:.1f}", f"{p['wall_ms']:.0f}",
                       "-" if p["gpu_ms"] is None else f"{p['gpu_ms']:.0f}", f"{p['bytes'] / 1e6:.1f}")
                      for p in presets]))

    bits_rows = bits_summary(records, meshes_info)
    if bits_rows:
        print("\n8- vs 16-bit heights, exact search (maxmip): depth error vs. trimesh / diagonal")
        print(_table(("mesh", "R", "view", "", "", "p99 16-bit", "p99 8-bit", "median 16", "median 8",
                      "max rounding 8-bit", "bytes 8/16"),
                     [(b["mesh"], str(b["R"]), b["view"], "", "", f"{b['p99_16']:.2e}", f"{b['p99_8']:.2e}",
                       f"{b['median_16']:.2e}", f"{b['median_8']:.2e}", f"{b['rounding_8']:.2e}",
                       f"{b['bytes_ratio']:.2f}") for b in bits_rows]))

    figure = headline_figure(records)
    if figure:
        figure["disagreement"] = diagnosis
        b, m = figure["best_linear"], figure["maxmip"]
        print(f"\nBunny, R={GRID_R}, oblique view — maxmip vs. the best linear_binary setting by p99:")
        print(f"  best linear_binary: {b['setting']}: p99 {b['depth_p99']:.3e}, {b['fetches_per_pixel']:.1f} fetches/px, "
              f"{b['gpu_ms']:.0f} GPU ms")
        print(f"  maxmip:             p99 {m['depth_p99']:.3e}, {m['fetches_per_pixel']:.1f} fetches/px, "
              f"{m['gpu_ms']:.0f} GPU ms")
        print(f"  fetch ratio maxmip/best = {figure['fetch_ratio_maxmip_over_best']:.3f}, "
              f"p99 ratio = {figure['p99_ratio_maxmip_over_best']:.3f}")
        print(f"  goal (p99 <= best and <= 50% of its fetches): "
              f"{'met' if figure['goal_met'] else 'NOT met'} (p99 {'matches' if figure['maxmip_matches_p99'] else 'does not match'}, "
              f"fetches {'within' if figure['maxmip_within_half_fetches'] else 'above'} 50%)")
        c = figure["cheapest_linear_matching_maxmip_p99"]
        if c:
            print(f"  cheapest linear_binary with p99 <= maxmip's: {c['setting']} ({c['depth_p99']:.3e}, "
                  f"{c['fetches_per_pixel']:.1f} fetches/px)")
        else:
            print("  no linear_binary setting reaches maxmip's p99")
        print(f"  vs. the stored surface (search error only): maxmip p99 {m['surface_p99']:.1e}, "
              f"{m['surface_off_px']} px more than a texel off; {b['setting']}: p99 {b['surface_p99']:.1e}, "
              f"{b['surface_off_px']} px off")
        if diagnosis:
            g = diagnosis
            print(f"  maxmip and {g['linear_setting']} differ (> 1e-5 diag) on {g['pixels_differing_by_1e-5_diag']} px; "
                  f"there the linear search ends farther in {g['of_which_linear_farther']} and maxmip is nearer "
                  f"the mesh in {g['of_which_maxmip_nearer_mesh']}; without them both p99 = "
                  f"{g['p99_maxmip_excluding_those']:.2e} / {g['p99_linear_excluding_those']:.2e}; "
                  f"{100 * g['maxmip_top1pct_at_patch_borders']:.0f}% of maxmip's top-1% errors are next to "
                  f"a patch-id change ({100 * g['hit_pixels_at_patch_borders']:.0f}% of all pixels)")

    col = collapses(records)
    print(f"\nCollapses: settings where > 1% of pixels end more than a texel from the first crossing "
          f"of the stored surface ({len(col)}; maxmip: "
          f"{sum(r['surface_off_px'] for r in records if r['method'] == 'maxmip')} px in all records):")
    for c in col:
        print(f"  {c['mesh']} R={c['R']} {c['height_bits']}-bit {c['view']} {c['setting']}: {100 * c['off_fraction']:.1f}% off, "
              f"p99 {c['depth_p99']:.2e} (maxmip {c['maxmip_depth_p99']:.2e}), IoU {c['iou']:.4f} "
              f"(maxmip {c['maxmip_iou']:.4f}), {c['fetches_per_pixel']:.0f} fetches/px")
    mismatch = [r for r in records if not r["count_frame_matches"]]
    if mismatch:
        print(f"\nnote: the counting build's depth differs from the plain render in {len(mismatch)} records")
    print(f"\nsweep: {elapsed / 60:.1f} min")

    machine["sweep_s"] = elapsed
    result = {
        "machine": machine,
        "settings": {
            "quick": args.quick, "thin": args.thin, "size": [SIZE, SIZE], "yfov_deg": YFOV_DEG,
            "distance_diag": DISTANCE, "views": views, "up": [0.0, 1.0, 0.0],
            "resolutions": args.resolutions, "grid_resolution": GRID_R,
            "steps_per_texel": STEPS_PER_TEXEL, "binary_steps": BINARY_STEPS,
            "min_linear_steps": MIN_LINEAR, "max_linear_steps": MAX_LINEAR,
            "settings_per_resolution": {R: [s["name"] for s in ss] for R, ss in plan.items()},
            "presets": {**{k: {"method": "linear_binary", "steps_per_texel": v[0], "binary_steps": v[1]}
                           for k, v in PRESETS.items()}, "exact": {"method": "maxmip"}},
            "preset_equals_explicit_settings": preset_checks,
            "timed_renders": repeats, "timing": "median wall ms of render() (perf_counter) and of "
            "frame.stats['gpu_ms']; one count_fetches render per setting for fetches_per_pixel",
            "errors": "vs. geomtex.reference.raycast (trimesh + embree on the original mesh); depth on "
            "pixels both hit, divided by the bounding-box diagonal; normal angle in degrees. surface_*: "
            "depth vs. gts.first_hits (exact first crossing of the stored height maps, f64 CPU) / diagonal; "
            "surface_off_px: pixels more than one texel off in depth, surface_hit_mismatch_px: hit vs. miss "
            "disagreements",
            "thin_means": "off R=256 only 8 bisections (plus presets)",
            "height_bits": args.bits,
        },
        "meshes": meshes_info,
        "presets_bunny_oblique": presets,
        "maxmip_vs_best_linear": figure,
        "maxmip_vs_best_linear_8bit": headline_figure(records, bits=8),
        "height_bits_exact": bits_rows,
        "collapses": col,
        "records": records,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    json_path = args.out / "tradeoff.json"
    write_json(json_path, result, indent=2)
    png_path = args.out / "tradeoff.png"
    plot(records, png_path, "grazing")
    print(f"wrote {json_path} and {png_path}")


if __name__ == "__main__":
    main()
