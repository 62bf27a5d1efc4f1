"""Benchmark of conversion speed and memory at scale: main's build against this one, in one run.

Meshes: the Stanford bunny (``../shared/meshes/stanford-bunny.obj``, 69,451 faces) and its
loop subdivision (``geomtex.testing.subdivided``, pymeshlab, until >= 1M faces: 1,111,216).
Modes: ``default`` (``convert(mesh)``, no keyword: error-driven within the mesh's bytes), ``vsa``
and ``cone`` (``convert(mesh, partition=...)``: error-driven like the default since it became so,
and at 256 texels before, when scale.json was measured; so ``cone`` is now ``default``), and
error-driven ``vsa-error`` / ``cone-error`` (``max_error_rel=1e-4``; with VSA and no
chart target this tries three partitions, so the 1.1M-face mesh runs it only with ``--modes``).
A conversion past ``--timeout`` seconds is stopped and recorded as timed out.

Every conversion runs in its own child process (``python -c WORKER``) started by a fresh
wrapper process, so ``resource.getrusage(RUSAGE_CHILDREN).ru_maxrss`` in the wrapper is the
worker's own peak. The worker also reads its ``VmHWM`` after loading the mesh, so the figure
per face is the peak *above the loaded mesh* (``convert_peak_bytes_per_face``), as well as the
whole process's (``peak_bytes_per_face``). Recorded per row: wall seconds, the set's seconds per
stage, charts, bytes, the reconstruction error p99 over the diagonal, and ``os.getloadavg()``
before and after.

"main" is the extension built from main, given as a directory holding its ``geomtex`` package
(``--main DIR``, put first on the worker's PYTHONPATH); "after" is the installed one.

Results: ``bench/results/scale.json`` and ``bench/results/scale.png``.

    cp -r python/geomtex /tmp/main-build/    # on main, after maturin develop --release
    nice python bench/scale.py --main /tmp/main-build
    python bench/scale.py --meshes bunny --modes cone       # quick, this build only
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import geomtex as gt
from geomtex import testing

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

from render import machine_info  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
MESH_DIR = REPO.parent / "shared" / "meshes"
OUT = REPO / "bench" / "results"
MODES = {
    "default": {},
    "vsa": {"partition": "vsa"},
    "cone": {"partition": "cone"},
    "vsa-error": {"partition": "vsa", "max_error_rel": 1e-4},
    "cone-error": {"partition": "cone", "max_error_rel": 1e-4},
}
STAGES = ("geometry", "partition", "repair", "overlap", "frame", "resolution", "raster", "dilate")

WORKER = """
import json, sys, time, numpy as np, geomtex as gt
def hwm():
    return next(int(l.split()[1]) * 1024 for l in open("/proc/self/status") if l.startswith("VmHWM"))
d = np.load(sys.argv[1]); mesh = gt.Mesh(d["v"], d["f"]); del d
before = hwm()
t0 = time.perf_counter(); gts = gt.convert(mesh, **json.loads(sys.argv[2])); wall = time.perf_counter() - t0
st = gts.stats
print(json.dumps({"geomtex_file": gt.__file__, "wall": wall, "hwm_before": before, "hwm_after": hwm(),
                  "seconds": dict(st["seconds"]), "charts": int(st["charts"]), "bytes": st["bytes"],
                  "rec_p99_rel": st["reconstruction_error_p99"] / st["diagonal"]}))
"""

# The wrapper's only child is the worker: RUSAGE_CHILDREN's ru_maxrss (KiB) is its peak.
WRAPPER = """
import json, resource, subprocess, sys
p = subprocess.run([sys.executable, "-c", sys.argv[1], *sys.argv[2:]], capture_output=True, text=True)
sys.stderr.write(p.stderr)
if p.returncode:
    sys.exit(p.returncode)
row = json.loads(p.stdout.splitlines()[-1])
row["ru_maxrss"] = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
print(json.dumps(row))
"""


def run_one(path: Path, faces: int, mode: str, version: str, main_dir: str | None, timeout: float) -> dict[str, Any]:
    env = dict(os.environ)
    if version == "main":
        env["PYTHONPATH"] = main_dir + os.pathsep + env.get("PYTHONPATH", "")
    load_before = os.getloadavg()
    row: dict[str, Any] = {"mode": mode, "version": version, "faces": faces, "options": MODES[mode],
                           "loadavg_before": load_before}
    # Its own session, so a conversion past the timeout is stopped with the worker under it.
    p = subprocess.Popen([sys.executable, "-c", WRAPPER, WORKER, str(path), json.dumps(MODES[mode])],
                         env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        stdout, stderr = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.communicate()
        row.update(timed_out=True, timeout_seconds=timeout, loadavg_after=os.getloadavg())
        return row
    if p.returncode:
        raise RuntimeError(f"{mode} {version} failed:\n{stderr}")
    r = json.loads(stdout.splitlines()[-1])
    row.update(
        timed_out=False, seconds=r["wall"], stage_seconds=r["seconds"], charts=r["charts"], bytes=r["bytes"],
        reconstruction_p99_rel=r["rec_p99_rel"], peak_rss_bytes=r["ru_maxrss"],
        rss_before_convert_bytes=r["hwm_before"], peak_bytes_per_face=r["ru_maxrss"] / faces,
        convert_peak_bytes_per_face=(r["ru_maxrss"] - r["hwm_before"]) / faces, geomtex_file=r["geomtex_file"],
        loadavg_after=os.getloadavg(),
    )
    return row


def _line(mesh: str, r: dict[str, Any]) -> str:
    head = f"{mesh:22s} {r['mode']:10s} {r['version']:5s}"
    if r["timed_out"]:
        return f"{head} timed out after {r['timeout_seconds']:.0f} s"
    st = r["stage_seconds"]
    stages = " ".join(f"{k} {st[k]:.2f}" for k in STAGES if k in st)
    return (f"{head} {r['seconds']:7.2f} s  charts {r['charts']:5d}  {r['bytes'] / 1e6:6.1f} MB  "
            f"rec p99 {r['reconstruction_p99_rel']:.1e}  peak {r['convert_peak_bytes_per_face']:5.0f} B/face above "
            f"the mesh ({r['peak_bytes_per_face']:.0f} in all)  load {r['loadavg_before'][0]:.1f}  [{stages}]")


def plot(record: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    meshes = list(record["meshes"])
    fig, axes = plt.subplots(2, len(meshes), figsize=(7 * len(meshes), 8), squeeze=False)
    colors = plt.get_cmap("tab10")
    for col, name in enumerate(meshes):
        rows = [r for r in record["meshes"][name]["rows"] if not r["timed_out"]]
        labels = [f"{r['mode']}\n{r['version']}" for r in rows]
        x = np.arange(len(rows))
        ax = axes[0][col]
        bottom = np.zeros(len(rows))
        for k, stage in enumerate(STAGES):
            v = np.array([r["stage_seconds"].get(stage, 0.0) for r in rows])
            ax.bar(x, v, 0.6, bottom=bottom, label=stage, color=colors(k))
            bottom += v
        # Error-driven VSA keeps one of three conversions: its wall time is more than its stages.
        ax.scatter(x, [r["seconds"] for r in rows], marker="_", s=400, color="black", label="wall", zorder=3)
        ax.set_xticks(x, labels, fontsize=8)
        ax.set_ylabel("seconds (bars: stages of the set kept)")
        ax.set_title(f"{name} ({record['meshes'][name]['faces']:,} faces)")
        if col == 0:
            ax.legend(fontsize=7)
        ax = axes[1][col]
        ax.bar(x, [r["convert_peak_bytes_per_face"] for r in rows], 0.6, color="tab:gray")
        ax.axhline(150, color="tab:red", lw=1, ls="--")
        ax.set_xticks(x, labels, fontsize=8)
        ax.set_ylabel("peak RSS above the loaded mesh, bytes / face")
    fig.suptitle("convert: main vs this build (wall seconds by stage; peak memory per face)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--main", help="directory holding main's built geomtex package")
    ap.add_argument("--meshes", nargs="*", default=["bunny", "bunny-1.1M"])
    ap.add_argument("--modes", nargs="*", help="default: all five, but vsa-error on the bunny only")
    ap.add_argument("--timeout", type=float, default=180.0, help="seconds per conversion")
    ap.add_argument("--out", default=str(OUT / "scale.json"))
    args = ap.parse_args()
    versions = (["main"] if args.main else []) + ["after"]
    bunny = gt.load_mesh(MESH_DIR / "stanford-bunny.obj")
    makers = {"bunny": lambda: bunny, "bunny-1.1M": lambda: testing.subdivided(bunny, 1_000_000)}
    record: dict[str, Any] = {"machine": machine_info(), "loadavg_start": os.getloadavg(), "main": args.main,
                              "meshes": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.meshes:
            mesh = makers[name]()
            path = Path(tmp) / f"{name}.npz"
            np.savez(path, v=mesh.vertices, f=mesh.faces)
            rows = []
            modes = args.modes or [m for m in MODES if not (name == "bunny-1.1M" and m == "vsa-error")]
            for mode in modes:
                for version in versions:
                    r = run_one(path, mesh.n_faces, mode, version, args.main, args.timeout)
                    print(_line(name, r), flush=True)
                    rows.append(r)
            record["meshes"][name] = {"faces": mesh.n_faces, "rows": rows}
    record["loadavg_end"] = os.getloadavg()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_json(out, record, indent=1)
    plot(record, out.with_suffix(".png"))
    print(f"wrote {out} and {out.with_suffix('.png')}")


if __name__ == "__main__":
    main()
