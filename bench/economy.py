"""What a geometry-texture set costs: bytes of maps against the mesh, memory on the adapter, and
the accuracy of the normals as stored.

For every shared mesh (``../shared/meshes``), the default ``convert``: the maps' bytes
(``stats["bytes"]``) against the mesh as float32 vertices + uint32 faces, and the bytes per
texel. For the Stanford bunny: how much the process's resident memory (VmRSS) grows when one set
is rendered on the adapter (lavapipe keeps textures in host memory), measured in a fresh process
after a warm-up frame of a small set. For the bunny and fandisk: the rendered normals against the
crease-split reference normals (``reference.corner_normals`` interpolated at trimesh's embree
hits, ``reference.RayCaster``), five views at 512², median and p99 pooled over the views. And
the noisy isosurface (pymeshlab ``create_noisy_isosurface``): converted with the defaults, does it
render (and what did the refusal say)?

``--default``: the default, error-driven ``convert`` (bound ``max_error_rel=2e-4``, tighter by
the mesh's outline ratio past the bunny's, within the mesh's bytes or, under 50k faces, an
allowance; cone partition) on every shared mesh, the noisy isosurface, the displaced icosphere
(bench/partition.py) and the 1.1 M-face loop-subdivided bunny: bytes against the mesh, seconds
against a fixed 256-texel cone conversion, the reported p99, and against trimesh over five views at
512² the worst IoU, depth median and depth p99 (one-pixel tolerance) and the pooled median normal
angle to the crease-split normals; the bunny's error-driven set at the p99 a fixed 256-texel set
reports, both rendered; and accuracy-against-bytes curves (new default, fixed, three-partition
VSA error-driven) on the bunny and the noisy isosurface, with the reported p99 against the
rendered one. Into ``economy.json["default"]`` (with ``os.getloadavg()`` before and after) and
``economy_default.png``; ~20 min.

``--budget-scan``: the noisy isosurface and the displaced icosphere converted within 1, 2, 4, 8
and 16 times their bytes (bound 1e-5 of the diagonal, so the budget binds), each rendered against
trimesh over five views at 512²: worst IoU and depth p99, bytes per covered texel and covered
texels per face, into ``bench/results/budget_scan.json`` and ``budget_scan.png``; ~15 min.

``--peak-only``: the peak resident memory of the 1.1 M-face bunny's default ``convert`` alone
(VmHWM reset after the mesh is loaded, three fresh processes, worst and median bytes per face, and
their seconds) and one profiled run's peak by stage (``GEOMTEX_PROFILE=1``), into
``bench/results/peak.json`` and ``peak.png``; ~2 min.

Before/after: ``--label main`` (run on a build of main) writes
``bench/results/economy_main.json``; a plain run writes ``bench/results/economy.json`` with main's
figures beside this build's (ratios) and ``bench/results/economy.png``.

Run from the repository root::

    nice python bench/economy.py                 # ~3 min on 2 cores
    nice python bench/economy.py --label main    # on a build of main
    nice python bench/economy.py --default       # the default, error-driven convert
    nice python bench/economy.py --peak-only     # the 1.1 M-face bunny's peak memory alone
    nice python bench/economy.py --budget-scan   # the rough meshes at 1-16x their bytes
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

import geomtex as gt
from geomtex import reference
from geomtex.testing import look_from, noisy_isosurface

REPO = Path(__file__).resolve().parents[1]
MESH_DIR = REPO.parent / "shared" / "meshes"
RESULTS = REPO / "bench" / "results"
VIEWS = [((0, 0, 1), (0, 1, 0)), ((0, 1, 0), (0, 0, -1)), ((1, 0, 0), (0, 1, 0)),
         ((1, 0.8, 1), (0, 1, 0)), ((0.3, -1, 0.2), (0, 1, 0))]
MESHES = ["stanford-bunny", "fandisk", "homer", "rocker-arm", "spot", "teapot"]


def mesh_bytes(mesh: gt.Mesh) -> int:
    """The mesh as float32 vertices and uint32 faces."""
    return 12 * len(np.asarray(mesh.vertices)) + 12 * len(np.asarray(mesh.faces))


def load(name: str) -> gt.Mesh:
    if name == "noisy-isosurface":
        return noisy_isosurface()
    return gt.load_mesh(MESH_DIR / f"{name}.obj")


def bytes_row(mesh: gt.Mesh) -> dict[str, Any]:
    t0 = time.perf_counter()
    gts = gt.convert(mesh)
    seconds = time.perf_counter() - t0
    s = gts.stats
    return {"faces": int(s["faces"]), "mesh_bytes": mesh_bytes(mesh), "map_bytes": int(s["bytes"]),
            "ratio": s["bytes"] / mesh_bytes(mesh), "texels": int(s["texels"]),
            "bytes_per_texel": s["bytes"] / max(s["texels"], 1), "charts": int(s["charts"]), "seconds": seconds}


def rss_kib() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError("no VmRSS")


def rss_child(name: str) -> None:
    """In a fresh process: VmRSS growth from rendering one default set of ``name`` (printed as
    JSON), after a warm-up frame of a small set so the renderer's own memory is not counted."""
    mesh = load(name)
    gts = gt.convert(mesh)
    fandisk = gt.load_mesh(MESH_DIR / "fandisk.obj")
    r = gt.Renderer(512, 512)
    r.render(gt.convert(fandisk, max_resolution=16), look_from(fandisk, (0, 0, 1)))
    cam = look_from(mesh, VIEWS[0][0], up=VIEWS[0][1])
    before = rss_kib()
    out: dict[str, Any] = {"map_bytes": int(gts.stats["bytes"])}
    try:
        frame = r.render(gts, cam)
        out["rendered"] = True
    except gt.GeomtexError as e:
        frame = None
        out.update(rendered=False, error=str(e))
    out["rss_increase_bytes"] = (rss_kib() - before) * 1024
    if frame is not None and "texture_bytes" in frame.stats:
        out["texture_bytes"] = frame.stats["texture_bytes"]
        out["texture_over_map_bytes"] = frame.stats["texture_bytes"] / out["map_bytes"]
    if frame is not None:
        m = reference.compare(frame, reference.raycast(mesh, cam, 512, 512), mesh.diagonal)
        out.update({k: m[k] for k in ["iou", "depth_median", "depth_p99", "depth_p99_1px"]})
    print(json.dumps(out))


def vm_kib(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    raise RuntimeError(f"no {field}")


def peak_child(name: str) -> None:
    """In a fresh process: the peak resident memory a default ``convert`` of ``name`` adds over
    the loaded mesh (VmHWM reset through /proc/self/clear_refs before converting), as JSON."""
    mesh = load_any(name)
    before = vm_kib("VmRSS")
    Path("/proc/self/clear_refs").write_text("5")  # VmHWM := VmRSS
    t0 = time.perf_counter()
    gts = gt.convert(mesh)
    seconds = time.perf_counter() - t0
    peak = (vm_kib("VmHWM") - before) * 1024
    faces = int(gts.stats["faces"])
    print(json.dumps({"faces": faces, "peak_bytes": peak, "peak_bytes_per_face": peak / faces,
                      "peak_child_seconds": seconds}))


def peak_row(name: str, env: dict[str, str] | None = None) -> dict[str, Any]:
    done = subprocess.run([sys.executable, __file__, "--peak-child", name], capture_output=True, text=True,
                          check=True, env=env)
    last = done.stdout.strip().splitlines()[-1]
    out = json.loads(last[last.index("{"):])
    if env is not None:
        out["stderr"] = done.stderr
    return out


def stage_memory(name: str) -> list[dict[str, Any]]:
    """Resident memory by stage of a default convert of ``name`` (``GEOMTEX_PROFILE=1`` in a fresh
    process, which resets VmHWM as each stage ends, so each stage's peak is its own; the child's
    whole-conversion peak is then not a measurement and is dropped)."""
    import os

    err = peak_row(name, env={**os.environ, "GEOMTEX_PROFILE": "1"})["stderr"]
    rows = []
    for line in err.splitlines():
        if " memory " in line and " rss " in line:
            stage = line.split(" memory ", 1)[1].split(" rss ")[0].strip()
            rss, peak = line.split(" rss ")[1].split(" MB  peak ")
            rows.append({"stage": stage, "rss_mb": float(rss), "peak_mb": float(peak.split()[0])})
    return rows


def measure_peak(name: str, runs: int) -> dict[str, Any]:
    """``--peak-only``: the peak of ``runs`` fresh conversions of ``name`` and one profiled."""
    import os

    out: dict[str, Any] = {"mesh": name, "loadavg_before": os.getloadavg(), "bar_bytes_per_face": 150,
                           "runs": [peak_row(name) for _ in range(runs)]}
    out["stages"] = stage_memory(name)
    out["loadavg_after"] = os.getloadavg()
    per_face = [r["peak_bytes_per_face"] for r in out["runs"]]
    out["peak_bytes_per_face_max"] = max(per_face)
    out["peak_bytes_per_face_median"] = float(np.median(per_face))
    out["seconds_median"] = float(np.median([r["peak_child_seconds"] for r in out["runs"]]))
    return out


def plot_peak(d: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    stages = d["stages"]
    faces = d["runs"][0]["faces"]
    base = stages[0]["rss_mb"]
    per_face = [(s["peak_mb"] - base) * 2**20 / faces for s in stages]
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.bar(range(len(stages)), per_face, color="tab:blue", label="peak resident memory in the stage (profiled run)")
    ax.axhline(d["bar_bytes_per_face"], color="tab:red", ls="--", label="bar: 150 bytes per face")
    ax.axhline(d["peak_bytes_per_face_max"], color="black", ls=":",
               label=f"whole conversion, worst of {len(d['runs'])} runs: {d['peak_bytes_per_face_max']:.0f}")
    ax.set_xticks(range(len(stages)), [s["stage"] for s in stages], rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("bytes per face above the loaded mesh")
    ax.set_title(f"{d['mesh']} ({faces:,} faces), default convert: peak memory by stage")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def rss_row(name: str) -> dict[str, Any]:
    done = subprocess.run([sys.executable, __file__, "--rss-child", name], capture_output=True, text=True, check=True)
    # pymeshlab prints "[MARCHING CUBES] Building mesh..." without a newline before it.
    last = done.stdout.strip().splitlines()[-1]
    row = json.loads(last[last.index("{"):])
    row["rss_over_map_bytes"] = row["rss_increase_bytes"] / row["map_bytes"]
    return row


def normal_row(mesh: gt.Mesh, r: gt.Renderer, gts: gt.GeometryTextureSet | None = None) -> dict[str, Any]:
    gts = gt.convert(mesh) if gts is None else gts
    corners = reference.corner_normals(mesh)
    caster = reference.RayCaster(mesh)
    angles = []
    for direction, up in VIEWS:
        cam = look_from(mesh, direction, up=up)
        ref = caster.cast(cam, r.width, r.height)
        frame = r.render(gts, cam)
        hit = np.isfinite(frame.depth) & ref["hit"]
        angles.append(reference.normal_angles(frame.normal, reference.shading_normals(mesh, corners, ref), hit))
    a = np.concatenate(angles)
    return {"median_deg": float(np.median(a)), "p99_deg": float(np.percentile(a, 99)), "pixels": int(len(a))}


def height_normal_maps(gts: gt.GeometryTextureSet) -> list[np.ndarray]:
    """Each patch's normals derived from its height field alone (central differences of the
    decoded heights, one-sided at empty neighbours, flat where a texel has no filled neighbour),
    as (H, W, 4) snorm8: what deriving normals at render time would show at texel centres."""
    maps = []
    for i in range(len(gts)):
        p = gts.patch(i)
        q = p["height"].astype(np.float64)
        top = 2.0 ** p["height_bits"] - 1
        ex, ey, ez = p["extent"]
        h, w = q.shape
        z = np.where(q > 0, (q - 1) / (top - 1) * ez, np.nan)
        grads = []
        for axis, step in ((1, ex / w), (0, ey / h)):
            pad = np.pad(z, [(1, 1) if a == axis else (0, 0) for a in range(2)], constant_values=np.nan)
            lo, mid, hi = (np.take(pad, range(k, k + z.shape[axis]), axis=axis) for k in range(3))
            g = np.where(np.isfinite(lo) & np.isfinite(hi), (hi - lo) / (2 * step),
                         np.where(np.isfinite(hi), (hi - mid) / step, (mid - lo) / step))
            grads.append(np.nan_to_num(g))
        n = np.stack([-grads[0], -grads[1], np.ones_like(z)], axis=-1)
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        out = np.zeros((h, w, 4), np.int8)
        out[..., :3] = np.round(n * 127).astype(np.int8)
        out[q == 0] = 0
        maps.append(out)
    return maps


def height_normal_row(mesh: gt.Mesh, r: gt.Renderer, path: Path) -> dict[str, Any]:
    """normal_row for the same set with its normals derived from the heights (written as a
    version-4 file by tests/legacy_gtex.py, not by geomtex, and loaded)."""
    sys.path.insert(0, str(REPO / "tests"))
    from legacy_gtex import legacy_bytes

    gts = gt.convert(mesh)
    path.write_bytes(legacy_bytes(gts, 4, height_normal_maps(gts)))
    return normal_row(mesh, r, gt.load(path))


def measure() -> dict[str, Any]:
    out: dict[str, Any] = {"bytes": {}, "normals": {}}
    names = [n for n in MESHES if (MESH_DIR / f"{n}.obj").exists()] + ["noisy-isosurface"]
    for name in names:
        out["bytes"][name] = bytes_row(load(name))
        print(name, out["bytes"][name], flush=True)
    out["rss"] = {name: rss_row(name) for name in ["stanford-bunny", "noisy-isosurface"]}
    print(out["rss"], flush=True)
    r = gt.Renderer(512, 512)
    out["normals_from_heights"] = {}
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        for name in ["stanford-bunny", "fandisk"]:
            out["normals"][name] = normal_row(load(name), r)
            out["normals_from_heights"][name] = height_normal_row(load(name), r, Path(tmp) / f"{name}.gtex")
            print(name, out["normals"][name], out["normals_from_heights"][name], flush=True)
    return out


def table(now: dict[str, Any], main: dict[str, Any] | None) -> str:
    lines = [f"{'mesh':18} {'faces':>7} {'mesh MB':>8} {'maps MB':>8} {'maps/mesh':>9} {'B/texel':>7} "
             f"{'main maps/mesh':>14} {'now/main':>8}"]
    for name, b in now["bytes"].items():
        m = (main or {}).get("bytes", {}).get(name)
        lines.append(f"{name:18} {b['faces']:7d} {b['mesh_bytes'] / 1e6:8.2f} {b['map_bytes'] / 1e6:8.2f} "
                     f"{b['ratio']:9.2f} {b['bytes_per_texel']:7.2f} "
                     + (f"{m['ratio']:14.2f} {b['map_bytes'] / m['map_bytes']:8.3f}" if m else ""))
    for name, row in now["rss"].items():
        m = (main or {}).get("rss", {}).get(name)
        lines.append(f"RSS growth rendering {name}: {row['rss_increase_bytes'] / 1e6:.0f} MB for "
                     f"{row['map_bytes'] / 1e6:.1f} MB of maps ({row['rss_over_map_bytes']:.2f}x), rendered: "
                     f"{row['rendered']}" + (f"; main: {m['rss_increase_bytes'] / 1e6:.0f} MB "
                                             f"({m['rss_over_map_bytes']:.2f}x), rendered: {m['rendered']}" if m else ""))
    for name, n in now["normals"].items():
        m = (main or {}).get("normals", {}).get(name)
        d = now.get("normals_from_heights", {}).get(name)
        lines.append(f"normals {name}: octahedral 2 B median {n['median_deg']:.3f}° p99 {n['p99_deg']:.3f}°"
                     + (f"; main (snorm8 4 B): median {m['median_deg']:.3f}° p99 {m['p99_deg']:.3f}°" if m else "")
                     + (f"; from heights (0 B): median {d['median_deg']:.3f}° p99 {d['p99_deg']:.3f}°" if d else ""))
    return "\n".join(lines)


def plot(now: dict[str, Any], main: dict[str, Any] | None, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.5))
    names = list(now["bytes"])
    x = np.arange(len(names))
    ax = axes[0]
    if main:
        ax.bar(x - 0.2, [main["bytes"][n]["ratio"] if n in main["bytes"] else 0 for n in names], 0.4, label="main")
    ax.bar(x + 0.2, [now["bytes"][n]["ratio"] for n in names], 0.4, label="this branch")
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.set_yscale("log")
    ax.set_xticks(x, names, rotation=30, ha="right")
    ax.set_ylabel("bytes of maps / bytes of mesh (float32/uint32)")
    ax.set_title("default convert: maps against the mesh")
    ax.legend()
    ax = axes[1]
    rss = list(now["rss"])
    xr = np.arange(len(rss))
    if main:
        ax.bar(xr - 0.2, [main["rss"][n]["rss_increase_bytes"] / 1e6 for n in rss], 0.4, label="main")
    ax.bar(xr + 0.2, [now["rss"][n]["rss_increase_bytes"] / 1e6 for n in rss], 0.4, label="this branch")
    ax.plot(xr + 0.2, [now["rss"][n]["map_bytes"] / 1e6 for n in rss], "k_", ms=30, label="maps (this branch)")
    ax.plot(xr + 0.2, [now["rss"][n].get("texture_bytes", 0) / 1e6 for n in rss], "r_", ms=30,
            label="textures on the adapter (this branch)")

    def refused(src: dict[str, Any] | None, n: str, who: str) -> str:
        return f"\n({who}: refused)" if src and not src["rss"][n]["rendered"] else ""

    ax.set_xticks(xr, [n + refused(main, n, "main") + refused(now, n, "this branch") for n in rss])
    ax.set_ylabel("process RSS growth on render (MB)")
    ax.set_title("memory on the adapter (lavapipe)")
    ax.legend()
    ax = axes[2]
    nn = list(now["normals"])
    xn = np.arange(len(nn))
    variants = [(-0.27, "main: snorm8 xyz, 4 B", (main or {}).get("normals")),
                (0.0, "octahedral, 2 B (kept)", now["normals"]),
                (0.27, "from heights, 0 B", now.get("normals_from_heights"))]
    for off, label, rows in variants:
        if rows:
            ax.bar(xn + off, [rows[n]["median_deg"] for n in nn], 0.27, label=f"{label}: median")
            ax.scatter(xn + off, [rows[n]["p99_deg"] for n in nn], marker="x", zorder=3, label=f"{label}: p99")
    ax.set_yscale("log")
    ax.set_xticks(xn, nn)
    ax.set_ylabel("degrees vs trimesh crease-split normals")
    ax.set_title("rendered normals, five views at 512²")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


# -- The default, error-driven convert (``--default``) ------------------------------------------

def curve_modes(name: str, mesh_bytes: int) -> dict[str, list[dict[str, Any]]]:
    """The settings each mode's curve is drawn through: the new default's bound swept on the
    bunny (the budget does not bind there), its budget swept on the noisy isosurface (where it
    does), today's fixed resolutions and today's three-partition VSA error-driven bounds."""
    noisy = name == "noisy-isosurface"
    default = ([dict(max_error_rel=2e-4, max_bytes=int(f * mesh_bytes)) for f in (0.5, 2.0, 4.0)] if noisy
               else [dict(max_error_rel=e) for e in (1e-4, 5e-4, 1e-3)])
    return {"default (cone, per-chart levels)": default,
            "fixed (vsa, max_resolution)": [dict(max_resolution=r) for r in ((32, 64) if noisy else (64, 128, 256))],
            # Three VSA partitions of 4,096 capped charts on the noisy isosurface: minutes a point.
            "error-driven before (vsa, three partitions)":
                [] if noisy else [dict(max_error_rel=e, partition="vsa") for e in (1e-4, 2e-4, 5e-4)]}


def big_bunny() -> gt.Mesh:
    from geomtex import testing

    return testing.subdivided(gt.load_mesh(MESH_DIR / "stanford-bunny.obj"), 1_000_000)


def low_poly() -> gt.Mesh:
    """About 1,000 faces: a box, a capped cylinder and a sphere joined, decimated by pymeshlab's
    quadric edge collapse."""
    import pymeshlab
    import trimesh

    parts = [trimesh.creation.box((1.0, 0.6, 0.4)),
             trimesh.creation.cylinder(0.2, 1.2, sections=48).apply_translation((0.8, 0, 0)),
             trimesh.creation.icosphere(4, 0.35).apply_translation((-0.7, 0.1, 0.2))]
    tm = trimesh.util.concatenate(parts)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(tm.vertices, tm.faces))
    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=1000)
    m = ms.current_mesh()
    return gt.Mesh(m.vertex_matrix(), m.face_matrix())


def load_any(name: str) -> gt.Mesh:
    sys.path.insert(0, str(REPO / "bench"))
    from partition import displaced_icosphere

    if name == "displaced-icosphere":
        return displaced_icosphere()
    if name == "low-poly-1k":
        return low_poly()
    if name == "bunny-loop-subdivided":
        return big_bunny()
    return load(name)


def rendered(mesh: gt.Mesh, gts: gt.GeometryTextureSet, views: int = 5, size: int = 512) -> dict[str, Any]:
    """Against trimesh over ``views`` views at ``size``²: the worst view's IoU, depth median and
    depth p99 (one-pixel tolerance, of the diagonal), and the median angle of the rendered normals
    to the crease-split reference normals, pooled over the views."""
    r = gt.Renderer(size, size)
    caster = reference.RayCaster(mesh)
    corners = reference.corner_normals(mesh)
    worst = {"iou": 1.0, "depth_median": 0.0, "depth_p99_1px": 0.0}
    angles = []
    for direction, up in VIEWS[:views]:
        cam = look_from(mesh, direction, up=up)
        ref = caster.cast(cam, size, size)
        frame = r.render(gts, cam)
        m = reference.compare(frame, ref, mesh.diagonal)
        worst["iou"] = min(worst["iou"], float(m["iou"]))
        worst["depth_median"] = max(worst["depth_median"], float(m["depth_median"]))
        worst["depth_p99_1px"] = max(worst["depth_p99_1px"], float(m["depth_p99_1px"]))
        hit = np.isfinite(frame.depth) & ref["hit"]
        angles.append(reference.normal_angles(frame.normal, reference.shading_normals(mesh, corners, ref), hit))
    worst["normal_median_deg"] = float(np.median(np.concatenate(angles)))
    return worst


def converted(mesh: gt.Mesh, **kw: Any) -> tuple[gt.GeometryTextureSet, float]:
    import warnings

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gt.CapWarning)  # the fixed VSA sets of rough meshes hit the chart cap
        gts = gt.convert(mesh, **kw)
    return gts, time.perf_counter() - t0


def default_row(name: str, fixed_seconds: bool) -> dict[str, Any]:
    mesh = load_any(name)
    gts, seconds = converted(mesh)
    s = gts.stats
    row = {"faces": int(s["faces"]), "mesh_bytes": mesh_bytes(mesh), "map_bytes": int(s["bytes"]),
           "ratio": s["bytes"] / mesh_bytes(mesh), "charts": int(s["charts"]), "seconds": seconds,
           "reported_p99": s["reconstruction_error_p99"] / s["diagonal"], "max_error_rel": s["max_error"] / s["diagonal"],
           "budget_bytes": s.get("max_bytes"), "budget_binding": bool(s.get("max_bytes_binding", 0)),
           "outline_ratio": s["outline_ratio"], "hybrid": bool(s.get("hybrid", 0)), "patches": len(gts),
           "faces_kept": int(s.get("triangle_faces", 0))}
    if fixed_seconds:
        # Against a fixed 256-texel conversion with the same partition (VSA's 4,096-chart cap
        # takes 35-93 s on the rough meshes, README "How it converts").
        fixed, row["fixed_256_seconds"] = converted(mesh, max_resolution=256, partition="cone")
        row["seconds_over_fixed"] = seconds / row["fixed_256_seconds"]
        del fixed
    row.update(rendered(mesh, gts))
    return row


def curve(name: str) -> list[dict[str, Any]]:
    """Bytes against reported and rendered error for each mode (3 views at 384² each)."""
    mesh = load_any(name)
    rows = []
    for mode, settings in curve_modes(name, mesh_bytes(mesh)).items():
        for kw in [{}] * ("default" in mode) + settings:
            gts, seconds = converted(mesh, **kw)
            s = gts.stats
            row = {"mode": mode if kw else "default convert", "keywords": kw, "bytes": int(s["bytes"]),
                   "ratio": s["bytes"] / mesh_bytes(mesh), "seconds": seconds,
                   "reported_p99": s["reconstruction_error_p99"] / s["diagonal"], **rendered(mesh, gts, 3, 384)}
            print(name, row, flush=True)
            rows.append(row)
    return rows


def same_bound(name: str) -> dict[str, Any]:
    """A fixed 256-texel set and the default (cone) error-driven set at the p99 it reports: their
    rendered depth p99 (one-pixel tolerance), worst of five views at 512²."""
    mesh = load_any(name)
    fixed, _ = converted(mesh, max_resolution=256)
    bound = fixed.stats["reconstruction_error_p99"]
    driven, _ = converted(mesh, max_error=bound)
    f, d = rendered(mesh, fixed), rendered(mesh, driven)
    return {"bound_rel": bound / mesh.diagonal, "fixed": f, "driven": d, "fixed_bytes": int(fixed.stats["bytes"]),
            "driven_bytes": int(driven.stats["bytes"]), "driven_reported_p99": driven.stats["reconstruction_error_p99"] / mesh.diagonal,
            "p99_ratio": d["depth_p99_1px"] / f["depth_p99_1px"]}


def measure_default() -> dict[str, Any]:
    import os

    out: dict[str, Any] = {"loadavg_before": os.getloadavg(), "table": {}}
    names = [n for n in MESHES if (MESH_DIR / f"{n}.obj").exists()]
    for name in names + ["noisy-isosurface", "displaced-icosphere", "low-poly-1k", "bunny-loop-subdivided"]:
        out["table"][name] = default_row(name, fixed_seconds=name != "bunny-loop-subdivided")
        print(name, out["table"][name], flush=True)
    # Peak memory of the conversion alone, in a fresh process (the table's process has rendered).
    out["table"]["bunny-loop-subdivided"].update(peak_row("bunny-loop-subdivided"))
    print(out["table"]["bunny-loop-subdivided"], flush=True)
    out["same_bound"] = {"stanford-bunny": same_bound("stanford-bunny")}
    print(out["same_bound"], flush=True)
    out["curves"] = {name: curve(name) for name in ["stanford-bunny", "noisy-isosurface"]}
    out["loadavg_after"] = os.getloadavg()
    return out


def default_table(d: dict[str, Any]) -> str:
    lines = [f"{'mesh':22} {'faces':>9} {'maps/mesh':>9} {'s':>6} {'s/fixed':>7} {'reported':>9} {'IoU':>7} "
             f"{'median':>8} {'p99 1px':>8} {'normal':>6}"]
    for name, r in d["table"].items():
        lines.append(f"{name:22} {r['faces']:9d} {r['ratio']:9.3f} {r['seconds']:6.2f} "
                     f"{r.get('seconds_over_fixed', float('nan')):7.2f} {r['reported_p99']:9.2e} {r['iou']:7.4f} "
                     f"{r['depth_median']:8.1e} {r['depth_p99_1px']:8.1e} {r['normal_median_deg']:6.2f}")
    for name, b in d["same_bound"].items():
        lines.append(f"{name} at the fixed 256 set's reported p99 {b['bound_rel']:.2e}: rendered p99 "
                     f"{b['driven']['depth_p99_1px']:.2e} against {b['fixed']['depth_p99_1px']:.2e} "
                     f"({b['p99_ratio']:.2f}x), bytes {b['driven_bytes'] / b['fixed_bytes']:.2f}x")
    lines.append(f"load average before {d['loadavg_before']}, after {d['loadavg_after']}")
    return "\n".join(lines)


def plot_default(d: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(17, 4.8))
    for ax, (name, rows) in zip(axes[:2], d["curves"].items()):
        for mode in dict.fromkeys(r["mode"] for r in rows):
            pts = sorted((r["ratio"], r["depth_p99_1px"]) for r in rows if r["mode"] == mode)
            style = "k*" if mode == "default convert" else "o-"
            ax.plot(*zip(*pts), style, ms=12 if mode == "default convert" else 5, label=mode)
        ax.axvline(1.0, color="gray", ls="--", lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("maps / mesh bytes (float32/uint32)")
        ax.set_ylabel("rendered depth p99 (1 px) / diagonal, worst of 3 views at 384²")
        ax.set_title(f"{name}: accuracy against bytes")
        ax.legend(fontsize=7)
    ax = axes[2]
    for name, rows in d["curves"].items():
        for mode in dict.fromkeys(r["mode"] for r in rows):
            sel = [r for r in rows if r["mode"] == mode]
            ax.scatter([r["reported_p99"] for r in sel], [r["depth_p99_1px"] for r in sel], s=14, label=f"{name}: {mode}")
    lim = [1e-6, 1e-1]
    ax.plot(lim, lim, "k--", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("reported reconstruction p99 / diagonal")
    ax.set_ylabel("rendered depth p99 (1 px) / diagonal")
    ax.set_title("the error measure against rendering")
    ax.legend(fontsize=5)
    fig.tight_layout()
    fig.savefig(path, dpi=100)


# -- How many bytes the rough meshes need (``--budget-scan``) -------------------------------------

SCAN_FACTORS = (1.0, 2.0, 4.0, 8.0, 16.0)


def budget_scan_row(name: str, mesh: gt.Mesh, factor: float) -> dict[str, Any]:
    """One rough mesh converted within ``factor`` times its bytes, under a bound (1e-5 of the
    diagonal) tight enough that the budget binds, rendered as the issue measures: five views at
    512² against trimesh."""
    budget = int(factor * mesh_bytes(mesh))
    gts, seconds = converted(mesh, max_error_rel=1e-5, max_bytes=budget)
    s = gts.stats
    covered = int(s["texels"]) - int(s["empty_texels"])
    row = {"factor": factor, "map_bytes": int(s["bytes"]), "ratio": s["bytes"] / mesh_bytes(mesh),
           "budget_binding": bool(s["max_bytes_binding"]), "seconds": seconds, "texels": int(s["texels"]),
           "covered_texels": covered, "bytes_per_covered_texel": s["bytes"] / covered,
           "covered_texels_per_face": covered / int(s["faces"]), "reported_p99": s["reconstruction_error_p99"] / s["diagonal"]}
    row.update(rendered(mesh, gts))
    return row


def measure_budget_scan() -> dict[str, Any]:
    import os

    out: dict[str, Any] = {"loadavg_before": os.getloadavg(), "factors": list(SCAN_FACTORS), "meshes": {}}
    for name in ["noisy-isosurface", "displaced-icosphere"]:
        mesh = load_any(name)
        rows = []
        for factor in SCAN_FACTORS:
            rows.append(budget_scan_row(name, mesh, factor))
            print(name, rows[-1], flush=True)
        out["meshes"][name] = rows
    out["loadavg_after"] = os.getloadavg()
    return out


def budget_scan_table(d: dict[str, Any]) -> str:
    lines = [f"{'mesh':20} {'budget':>6} {'maps/mesh':>9} {'s':>6} {'B/covered':>9} {'covered/face':>12} "
             f"{'IoU':>7} {'p99 1px':>8}"]
    for name, rows in d["meshes"].items():
        for r in rows:
            lines.append(f"{name:20} {r['factor']:6.0f} {r['ratio']:9.3f} {r['seconds']:6.1f} "
                         f"{r['bytes_per_covered_texel']:9.2f} {r['covered_texels_per_face']:12.2f} "
                         f"{r['iou']:7.4f} {r['depth_p99_1px']:8.1e}")
    lines.append(f"load average before {d['loadavg_before']}, after {d['loadavg_after']}")
    return "\n".join(lines)


def plot_budget_scan(d: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for name, rows in d["meshes"].items():
        x = [r["ratio"] for r in rows]
        axes[0].plot(x, [1.0 - r["iou"] for r in rows], "o-", label=name)
        axes[1].plot(x, [r["depth_p99_1px"] for r in rows], "o-", label=name)
    for ax, bar, label in [(axes[0], 1.0 - 0.998, "1 - IoU (worst of five views, 512²)"),
                           (axes[1], 1e-3, "depth p99 (1 px) / diagonal, worst of five views")]:
        ax.axhline(bar, color="red", ls="--", lw=0.8, label="issue 15's bar")
        ax.axvline(1.0, color="gray", ls="--", lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("maps / mesh bytes (float32/uint32)")
        ax.set_ylabel(label)
        ax.legend(fontsize=7)
    fig.suptitle("rough meshes: rendered accuracy against the bytes a height-field set is given")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--label", default="now", help="'main' writes economy_main.json")
    parser.add_argument("--rss-child", help=argparse.SUPPRESS)
    parser.add_argument("--peak-child", help=argparse.SUPPRESS)
    parser.add_argument("--plot-only", action="store_true", help="redraw the PNG from economy.json")
    parser.add_argument("--default", action="store_true",
                        help="the default (error-driven) convert: table, curves; into economy.json['default']")
    parser.add_argument("--peak-only", action="store_true",
                        help="peak memory of the 1.1 M-face bunny's default convert alone: into peak.json + PNG")
    parser.add_argument("--budget-scan", action="store_true",
                        help="the rough meshes at 1-16x their bytes: into budget_scan.json + PNG")
    args = parser.parse_args()
    if args.budget_scan:
        d = measure_budget_scan()
        write_json(RESULTS / "budget_scan.json", d, indent=1)
        plot_budget_scan(d, RESULTS / "budget_scan.png")
        print(budget_scan_table(d))
        return
    if args.peak_only:
        d = measure_peak("bunny-loop-subdivided", runs=3)
        write_json(RESULTS / "peak.json", d, indent=1)
        plot_peak(d, RESULTS / "peak.png")
        print({k: v for k, v in d.items() if k != "stages"})
        return
    if args.default:
        path = RESULTS / "economy.json"
        saved = json.loads(path.read_text()) if path.exists() else {}
        saved["default"] = measure_default()
        write_json(path, saved, indent=1)
        plot_default(saved["default"], RESULTS / "economy_default.png")
        print(default_table(saved["default"]))
        return
    if args.plot_only:
        saved = json.loads((RESULTS / "economy.json").read_text())
        plot(saved["now"], saved["main"], RESULTS / "economy.png")
        return
    if args.peak_child:
        peak_child(args.peak_child)
        return
    if args.rss_child:
        rss_child(args.rss_child)
        return
    now = measure()
    RESULTS.mkdir(exist_ok=True)
    if args.label == "main":
        write_json(RESULTS / "economy_main.json", now, indent=1)
        print(table(now, None))
        return
    main_path = RESULTS / "economy_main.json"
    before = json.loads(main_path.read_text()) if main_path.exists() else None
    write_json(RESULTS / "economy.json", {"now": now, "main": before}, indent=1)
    plot(now, before, RESULTS / "economy.png")
    print(table(now, before))


if __name__ == "__main__":
    main()
