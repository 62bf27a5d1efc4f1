"""Benchmark of geomtex.batch on this machine: throughput of ``convert_many`` (meshes per minute)
and ``render_views`` (views per second) on a Dask LocalCluster of 1 and 2 worker processes (one
thread each) and of 1 process with 2 threads (heavy calls release the GIL), beside the same work
done serially in this process. It also measures what each task moves: pickled bytes of a task's
arguments (a path, an in-memory mesh, a set) and of its result row, the .gtex bytes a worker
writes, and the seconds a task takes, which is what the plan for 100 workers in bench/README.md
is sized from, plus the two client-side costs that grow with a job: the scheduler's round trip
per task (no-op tasks on the 2-worker cluster) and recording a result in the manifest (one journal
line, against rewriting a manifest of 100k rows as the first version did once a second).

Inputs: the shared scans and generated meshes (icospheres, tori, pymeshlab's bunny), converted
at ``max_resolution=128``; views: 256², 24 cameras around each set.

Results: ``bench/results/batch.json`` and ``bench/results/batch.png``.

Run from the repository root::

    python bench/batch.py            # ~3 minutes
    python bench/batch.py --quick    # fewer inputs and views
"""

from __future__ import annotations

import argparse
import os
import pickle
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pymeshlab
import trimesh
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

import geomtex as gt
from geomtex import batch
from geomtex.testing import look_from
from render import machine_info, wait_idle  # type: ignore[import-not-found]

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "bench" / "results"
SHARED = REPO.parent / "shared" / "meshes"
OPTIONS = {"max_resolution": 128}


def inputs(tmp: Path, quick: bool) -> list[str]:
    """Mesh files: the shared scans present here and generated meshes written as PLY."""
    paths = [str(p) for p in sorted(SHARED.glob("*.obj"))]
    paths.append(f"{pymeshlab.__path__[0]}/tests/sample_meshes/bunny.obj")
    made = [trimesh.creation.icosphere(s) for s in (3, 4, 5)] + \
        [trimesh.creation.torus(1.0, r, major_sections=128, minor_sections=48) for r in (0.2, 0.4)]
    for i, m in enumerate(made):
        path = tmp / f"generated-{i}.ply"
        m.export(path)
        paths.append(str(path))
    return paths[:6] if quick else paths


def cluster(workers: int, threads: int) -> Any:
    from dask.distributed import Client, LocalCluster

    c = LocalCluster(n_workers=workers, threads_per_worker=threads, processes=True, dashboard_address=None,
                     silence_logs=50)
    return c, Client(c)


def run_convert(paths: list[str], out: Path, client: Any) -> tuple[float, list[dict[str, Any]]]:
    t0 = time.perf_counter()
    rows = batch.convert_many(paths, out, client=client, progress=False, **OPTIONS)
    return time.perf_counter() - t0, rows


def run_render(sets: list[str], cameras: list[Any], store: Path, client: Any) -> float:
    t0 = time.perf_counter()
    batch.render_views(sets, cameras, store, width=256, height=256, client=client, progress=False)
    return time.perf_counter() - t0


def serial(paths: list[str], out: Path, sets_cams: tuple[list[str], list[Any]]) -> dict[str, float]:
    t0 = time.perf_counter()
    for p in paths:
        gt.convert(p, **OPTIONS).save(out / (Path(p).stem + ".gtex"))
    convert_s = time.perf_counter() - t0
    sets, cameras = sets_cams
    renderer = gt.Renderer(256, 256)
    t0 = time.perf_counter()
    for s, cams in zip(sets, cameras):
        loaded = gt.load(s)
        for c in cams:
            renderer.render(loaded, c)
    return {"convert_s": convert_s, "render_s": time.perf_counter() - t0}


def task_sizes(paths: list[str], rows: list[dict[str, Any]], out: Path) -> dict[str, Any]:
    """What a task moves, in bytes, and how long it runs."""
    mesh = gt.load_mesh(paths[0])
    gts = gt.load(out / rows[0]["output"])
    return {
        "convert_args_path_bytes": len(pickle.dumps((paths[0], str(out / rows[0]["output"]), OPTIONS))),
        "convert_args_mesh_bytes": [len(pickle.dumps(gt.load_mesh(p))) for p in paths],
        "mesh_faces": [gt.load_mesh(p).n_faces for p in paths],
        "result_row_bytes": [len(pickle.dumps(r)) for r in rows],
        "gtex_bytes": [r["bytes"] for r in rows],
        "convert_task_s": [r["seconds"] for r in rows],
        "set_pickle_bytes": len(pickle.dumps(gts)),
        "first_mesh_pickle_bytes": len(pickle.dumps(mesh)),
        "camera_pickle_bytes": len(pickle.dumps(gt.Camera.look_at((0, 0, 3), (0, 0, 0)))),
        "view_chunk_bytes_raw": 256 * 256 * (4 + 12 + 4 + 4),
    }


def _noop(i: int) -> int:
    return i


def scheduler_rate(n: int = 2000) -> dict[str, float]:
    """Tasks per second the scheduler turns around on this machine: n no-op tasks submitted at
    once to a LocalCluster of 2 worker processes and gathered."""
    c, client = cluster(2, 1)
    try:
        client.run(lambda: None)
        t0 = time.perf_counter()
        futures = client.map(_noop, range(n), pure=False)
        client.gather(futures)
        seconds = time.perf_counter() - t0
    finally:
        client.close()
        c.close()
    return {"tasks": n, "seconds": seconds, "tasks_per_s": n / seconds}


def manifest_costs(row: dict[str, Any], n: int, tmp: Path) -> dict[str, float]:
    """Seconds to record n result rows through batch's journal (one appended line each), beside
    one rewrite of a manifest that holds n rows (what recording cost when the manifest was
    rewritten as results arrived), and the bytes of each."""
    rows = {f"k{i}": {**row, "key": f"k{i}"} for i in range(n)}
    path = tmp / "manifest-cost"
    path.mkdir()
    t0 = time.perf_counter()
    with batch._Journal(str(path / batch.JOURNAL)) as journal:
        for r in rows.values():
            journal.append(r)
    journal_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    batch._write_json_atomically(str(path / batch.MANIFEST), {"version": 1, "options": OPTIONS, "rows": rows})
    rewrite_s = time.perf_counter() - t0
    return {"rows": n, "journal_s": journal_s, "journal_us_per_row": 1e6 * journal_s / n,
            "journal_bytes": (path / batch.JOURNAL).stat().st_size, "rewrite_s": rewrite_s,
            "manifest_bytes": (path / batch.MANIFEST).stat().st_size}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--max-idle-wait", type=float, default=60.0)
    args = parser.parse_args()
    n_views = 8 if args.quick else 24
    results: dict[str, Any] = {"machine": machine_info(), "load_average_before": os.getloadavg(), "options": OPTIONS, "views_per_set": n_views,
                               "image": [256, 256], "configs": {}}
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        paths = inputs(tmp, args.quick)
        meshes = [gt.load_mesh(p) for p in paths]
        cameras = [[look_from(m, (np.cos(a), 0.5, np.sin(a)), distance=1.4)
                    for a in np.linspace(0, 2 * np.pi, n_views, endpoint=False)] for m in meshes]
        results["inputs"] = [Path(p).name for p in paths]
        wait_idle(args.max_idle_wait)
        (tmp / "serial").mkdir()
        # The serial baseline renders the sets the first cluster run writes, so run that first.
        configs = [("1 worker", 1, 1), ("2 workers", 2, 1), ("1 worker x 2 threads", 1, 2)]
        sets: list[str] = []
        for name, workers, threads in configs:
            c, client = cluster(workers, threads)
            try:
                client.run(lambda: None)  # workers up and imported
                out = tmp / name.replace(" ", "_")
                convert_s, rows = run_convert(paths, out, client)
                bad = [r for r in rows if r["status"] != "done"]
                assert not bad, bad
                sets = [str(out / r["output"]) for r in rows]
                render_s = run_render(sets, cameras, tmp / f"{name.replace(' ', '_')}.zarr", client)
            finally:
                client.close()
                c.close()
            row = {"workers": workers, "threads": threads, "convert_s": convert_s, "render_s": render_s,
                   "meshes_per_min": 60 * len(paths) / convert_s, "views_per_s": len(paths) * n_views / render_s}
            results["configs"][name] = row
            print(f"{name:22s} convert {convert_s:6.1f} s ({row['meshes_per_min']:5.1f} meshes/min)  "
                  f"render {render_s:6.1f} s ({row['views_per_s']:5.1f} views/s)")
            if name == "1 worker":
                results["tasks"] = task_sizes(paths, rows, out)
        s = serial(paths, tmp / "serial", (sets, cameras))
        results["serial"] = {**s, "meshes_per_min": 60 * len(paths) / s["convert_s"],
                             "views_per_s": len(paths) * n_views / s["render_s"]}
        print(f"{'serial (this process)':22s} convert {s['convert_s']:6.1f} s  render {s['render_s']:6.1f} s")
        results["scheduler"] = scheduler_rate()
        print(f"scheduler: {results['scheduler']['tasks_per_s']:.0f} no-op tasks/s (2 workers)")
        row = batch.read_manifest(tmp / "1_worker")["rows"]
        results["manifest"] = manifest_costs(next(iter(row.values())), 100_000, tmp)
        m = results["manifest"]
        print(f"manifest: journal {m['journal_us_per_row']:.1f} us/row; one rewrite of {m['rows']} rows "
              f"{m['rewrite_s']:.2f} s ({m['manifest_bytes'] / 1e6:.0f} MB)")
    results["load_average_after"] = os.getloadavg()
    OUT.mkdir(parents=True, exist_ok=True)
    write_json(OUT / "batch.json", results, indent=1)
    plot(results)


def plot(results: dict[str, Any]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = ["serial (this process)", *results["configs"]]
    rows = [results["serial"], *results["configs"].values()]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    for ax, key, label in ((axes[0], "meshes_per_min", "meshes converted per minute"),
                           (axes[1], "views_per_s", "views rendered per second (256²)")):
        ax.barh(names, [r[key] for r in rows], color=["#999", "#1f77b4", "#2ca02c", "#ff7f0e"])
        ax.set_xlabel(label)
        ax.invert_yaxis()
    fig.suptitle(f"geomtex.batch on {results['machine'].get('cpu', 'this machine')} ({len(results['inputs'])} meshes)",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(OUT / "batch.png", dpi=110)


if __name__ == "__main__":
    main()
