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

Before/after: ``--label main`` (run on a build of main) writes
``bench/results/economy_main.json``; a plain run writes ``bench/results/economy.json`` with main's
figures beside this build's (ratios) and ``bench/results/economy.png``.

Run from the repository root::

    nice python bench/economy.py                 # ~3 min on 2 cores
    nice python bench/economy.py --label main    # on a build of main
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
            "bytes_per_texel": s["bytes"] / s["texels"], "charts": int(s["charts"]), "seconds": seconds}


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--label", default="now", help="'main' writes economy_main.json")
    parser.add_argument("--rss-child", help=argparse.SUPPRESS)
    parser.add_argument("--plot-only", action="store_true", help="redraw the PNG from economy.json")
    args = parser.parse_args()
    if args.plot_only:
        saved = json.loads((RESULTS / "economy.json").read_text())
        plot(saved["now"], saved["main"], RESULTS / "economy.png")
        return
    if args.rss_child:
        rss_child(args.rss_child)
        return
    now = measure()
    RESULTS.mkdir(exist_ok=True)
    if args.label == "main":
        (RESULTS / "economy_main.json").write_text(json.dumps(now, indent=1))
        print(table(now, None))
        return
    main_path = RESULTS / "economy_main.json"
    before = json.loads(main_path.read_text()) if main_path.exists() else None
    (RESULTS / "economy.json").write_text(json.dumps({"now": now, "main": before}, indent=1))
    plot(now, before, RESULTS / "economy.png")
    print(table(now, before))


if __name__ == "__main__":
    main()
