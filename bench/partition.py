"""Benchmark of the two partitions, side by side in one run: VSA (the paper's, ``partition="vsa"``)
and the cone partition for height fields (``partition="cone"``).

Meshes: the shared ones (``../shared/meshes/*.obj``), pymeshlab's noisy isosurface
(``create_noisy_isosurface(resolution=96)``, 188,788 faces) and a displaced icosphere (trimesh
icosphere, subdivisions=6, 81,920 faces, vertices moved along their normals by gaussian noise of
1% of the radius, seed 0). Each converts at the default ``max_resolution`` (256) with each
partition; recorded: charts, charts before repair, repair splits, folding charts, empty fraction,
map bytes and their ratio to the mesh's float32 vertices + uint32 faces, wall seconds and the
partition stage's seconds, the reconstruction error p99 (over the diagonal), and render accuracy
against trimesh ray casting (``geomtex.reference.compare``; worst of ``--views`` views at
``--size``²; a set the renderer refuses is recorded as unrenderable with its message).

``--big`` also converts the loop-subdivided Stanford bunny (pymeshlab
``meshing_surface_subdivision_loop`` until >= 1M faces) with each partition in a child process,
recording its wall seconds and peak resident memory (``VmHWM``) before and after converting.
``--only-big`` runs just that and replaces the ``big`` entry of an existing results file.

Results: ``bench/results/partition.json`` and ``bench/results/partition.png``.

    nice python bench/partition.py                 # everything, 3 views at 384²
    python bench/partition.py --meshes bunny noisy --no-render
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

import geomtex as gt
from geomtex import reference, testing

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

from render import machine_info  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
MESH_DIR = REPO.parent / "shared" / "meshes"
OUT = REPO / "bench" / "results"
PARTITIONS = ("vsa", "cone")
VIEWS = [(1, 0.4, 0.3), (-0.6, 0.3, 1.0), (0.2, -1.0, 0.5), (0.0, 0.2, -1.0), (-1.0, -0.5, -0.2)]


def displaced_icosphere() -> gt.Mesh:
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=6)
    rng = np.random.default_rng(0)
    v = s.vertices + s.vertex_normals * rng.normal(0.0, 0.01, (len(s.vertices), 1))
    return gt.Mesh(v, s.faces)


def meshes(names: list[str] | None) -> dict[str, Any]:
    """Name -> a function making the mesh, filtered by substrings of the names."""
    out: dict[str, Any] = {p.stem: (lambda p=p: gt.load_mesh(p)) for p in sorted(MESH_DIR.glob("*.obj"))}
    out["noisy-isosurface"] = testing.noisy_isosurface
    out["displaced-icosphere"] = displaced_icosphere
    if names:
        out = {k: v for k, v in out.items() if any(n in k for n in names)}
    return out


def render_accuracy(mesh: gt.Mesh, gts: gt.GeometryTextureSet, views: int, size: int) -> dict[str, Any]:
    """Worst over the views of reference.compare's figures (IoU: lowest; errors: highest)."""
    try:
        renderer = gt.Renderer(size, size)
        caster = reference.RayCaster(mesh)
        worst: dict[str, float] = {}
        for d in VIEWS[:views]:
            cam = testing.look_from(mesh, d)
            m = reference.compare(renderer.render(gts, cam), caster.cast(cam, size, size), mesh.diagonal)
            for k in ("iou", "depth_median", "depth_p99", "depth_p99_1px", "normal_deg_median"):
                v = float(m[k])
                worst[k] = v if k not in worst else (min(worst[k], v) if k == "iou" else max(worst[k], v))
        return {"renders": True, **worst}
    except gt.GeomtexError as e:
        return {"renders": False, "error": str(e)}


def bench_mesh(name: str, make: Any, views: int, size: int) -> list[dict[str, Any]]:
    mesh = make()
    mesh_bytes = 12 * mesh.n_vertices + 12 * mesh.n_faces
    rows = []
    for partition in PARTITIONS:
        t0 = time.perf_counter()
        gts = gt.convert(mesh, partition=partition)
        wall = time.perf_counter() - t0
        st = gts.stats
        diag = st["diagonal"]
        row = {
            "mesh": name, "partition": partition, "faces": mesh.n_faces, "mesh_bytes": mesh_bytes,
            "charts": int(st["charts"]), "charts_before_repair": int(st["vsa_charts"]),
            "repair_splits": int(st["repair_splits"]), "folding_charts": int(st["folding_charts"]),
            "charts_capped": bool(st["charts_capped"]), "empty_fraction": st["empty_fraction"],
            "bytes": st["bytes"], "bytes_ratio": st["bytes"] / mesh_bytes, "texel_rel": st["texel_size"] / diag,
            "reconstruction_p99_rel": st["reconstruction_error_p99"] / diag, "seconds": wall,
            "partition_seconds": dict(st["seconds"])["partition"],
        }
        if views:
            row["render"] = render_accuracy(mesh, gts, views, size)
        rows.append(row)
        print(_line(row), flush=True)
        del gts
    return rows


# Peak resident memory from /proc/self/status's VmHWM: ru_maxrss would carry the parent's peak
# over fork + exec on Linux, and this parent has converted every other mesh by then.
CHILD = """
import sys, time, numpy as np, geomtex as gt
def hwm():
    return next(int(l.split()[1]) * 1024 for l in open("/proc/self/status") if l.startswith("VmHWM"))
d = np.load(sys.argv[1]); mesh = gt.Mesh(d["v"], d["f"]); del d
before = hwm()
t0 = time.perf_counter(); gts = gt.convert(mesh, partition=sys.argv[2]); wall = time.perf_counter() - t0
after = hwm()
print(wall, before, after, gts.stats["charts"], dict(gts.stats["seconds"])["partition"])
"""


def bench_big() -> list[dict[str, Any]]:
    """The loop-subdivided bunny, each partition converted in a child process (peak RSS)."""
    big = testing.subdivided(gt.load_mesh(MESH_DIR / "stanford-bunny.obj"), 1_000_000)
    faces = big.n_faces
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.npz"
        np.savez(path, v=big.vertices, f=big.faces)
        for partition in PARTITIONS:
            out = subprocess.run([sys.executable, "-c", CHILD, str(path), partition], check=True,
                                 capture_output=True, text=True).stdout.split()
            wall, before, after, charts, part = (float(x) for x in out[-5:])
            row = {"mesh": "bunny-loop-subdivided", "partition": partition, "faces": faces,
                   "seconds": wall, "partition_seconds": part, "charts": int(charts),
                   "peak_rss_bytes": after, "rss_before_convert_bytes": before,
                   "peak_bytes_per_face": after / faces, "convert_peak_bytes_per_face": (after - before) / faces}
            print(f"{row['mesh']:22s} {partition:4s} faces {faces} charts {row['charts']} {wall:.1f} s "
                  f"(partition {part:.1f} s), peak {after / 1e6:.0f} MB = {row['peak_bytes_per_face']:.0f} B/face, "
                  f"{row['convert_peak_bytes_per_face']:.0f} B/face above the loaded mesh", flush=True)
            rows.append(row)
    return rows


def _line(r: dict[str, Any]) -> str:
    render = r.get("render", {})
    acc = (f"IoU {render['iou']:.4f} p99 {render['depth_p99']:.1e} p99(1px) {render['depth_p99_1px']:.1e}"
           if render.get("renders") else ("unrenderable" if render else ""))
    return (f"{r['mesh']:20s} {r['partition']:4s} charts {r['charts']:6d} (before repair {r['charts_before_repair']:5d}) "
            f"fold {r['folding_charts']} empty {r['empty_fraction']:.2f} maps {r['bytes'] / 1e6:7.1f} MB "
            f"= {r['bytes_ratio']:6.1f}x mesh, rec p99 {r['reconstruction_p99_rel']:.1e}, {r['seconds']:6.2f} s "
            f"(partition {r['partition_seconds']:.2f} s) {acc}")


def plot(rows: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(r["mesh"] for r in rows))
    by = {(r["mesh"], r["partition"]): r for r in rows}
    panels = [("charts", "charts", True), ("bytes_ratio", "map bytes / mesh bytes", True),
              ("seconds", "convert seconds", True), ("reconstruction_p99_rel", "reconstruction p99 / diagonal", True)]
    fig, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 4.5))
    x = np.arange(len(names))
    for ax, (key, label, log) in zip(axes, panels):
        for k, p in enumerate(PARTITIONS):
            ax.bar(x + (k - 0.5) * 0.4, [by[(n, p)][key] for n in names], 0.4, label=p)
        ax.set_xticks(x, names, rotation=45, ha="right")
        ax.set_title(label)
        if log:
            ax.set_yscale("log")
    axes[0].legend()
    fig.suptitle("VSA vs cone partition, default convert (max_resolution 256)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", nargs="*")
    ap.add_argument("--views", type=int, default=3)
    ap.add_argument("--size", type=int, default=384)
    ap.add_argument("--no-render", action="store_true")
    ap.add_argument("--big", action="store_true")
    ap.add_argument("--only-big", action="store_true")
    args = ap.parse_args()
    if args.only_big:
        record = json.loads((OUT / "partition.json").read_text())
        record["big"] = bench_big()
        write_json(OUT / "partition.json", record, indent=1)
        return
    rows: list[dict[str, Any]] = []
    for name, make in meshes(args.meshes).items():
        rows += bench_mesh(name, make, 0 if args.no_render else args.views, args.size)
    big = bench_big() if args.big else []
    OUT.mkdir(parents=True, exist_ok=True)
    record = {"machine": machine_info(), "views": 0 if args.no_render else args.views, "size": args.size,
              "rows": rows, "big": big}
    write_json(OUT / "partition.json", record, indent=1)
    plot(rows, OUT / "partition.png")
    print(f"wrote {OUT / 'partition.json'} and {OUT / 'partition.png'}")


if __name__ == "__main__":
    main()
