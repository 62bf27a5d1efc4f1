"""Two builds side by side: the same frames and ray queries through two checkouts' packages,
alternating in rounds, each in a process of its own (``python bench/before_after.py OLD NEW``, each
a folder holding a built ``geomtex`` package, e.g. ``python/`` of two checkouts).

Per build: the Stanford bunny (``../shared/meshes``, else pymeshlab's bunny) converted by default,
five views at 512² (ms per frame, median of the rounds' medians) and 100k random rays
(``intersects_first``); and whether the two builds' frames and hits are identical (depth, color,
normal, patch ids, distances). Results: ``bench/results/before_after.json``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

RESULTS = Path(__file__).parent / "results"
ROUNDS = 5

# Run in each build's process: times one round, saves its arrays.
_ROUND = r"""
import json, sys, time
from pathlib import Path
import numpy as np
import geomtex as gt
from geomtex.testing import look_from
shared = Path(sys.argv[2]) / "meshes" / "stanford-bunny.obj"
if shared.exists():
    mesh = gt.load_mesh(shared)
else:
    import pymeshlab
    mesh = gt.load_mesh(Path(pymeshlab.__file__).parent / "tests" / "sample_meshes" / "bunny.obj")
import warnings
warnings.simplefilter("ignore")
gts = gt.convert(mesh)
r = gt.Renderer(512, 512)
views = [(1, 0, 0), (0, 0, 1), (-1, 0.3, 0), (0.5, 0.5, -1), (0, 1, 0.2)]
cams = [look_from(mesh, v, up=(0, 1, 0)) for v in views]
r.render(gts, cams[0])
times, frames = [], []
for cam in cams:
    start = time.perf_counter()
    f = r.render(gts, cam)
    times.append((time.perf_counter() - start) * 1e3)
    frames.append(f)
lo, hi = (np.asarray(b) for b in mesh.bounds)
rng = np.random.default_rng(3)
origins = (lo + hi) / 2 + rng.normal(size=(100_000, 3)) * np.linalg.norm(hi - lo)
targets = lo + rng.random((100_000, 3)) * (hi - lo)
gts.intersects_first(origins[:10], (targets - origins)[:10])
start = time.perf_counter()
hits = gts.intersects_first(origins, targets - origins)
rays_ms = (time.perf_counter() - start) * 1e3
np.savez(sys.argv[1], depth=np.stack([f.depth for f in frames]), color=np.stack([f.color for f in frames]),
         normal=np.stack([f.normal for f in frames]), patch_id=np.stack([f.patch_id for f in frames]),
         distances=hits.distances, patch_ids=hits.patch_ids)
print(json.dumps({"frame_ms": times, "rays_ms": rays_ms}))
"""


def one_round(package: Path, out: Path) -> dict[str, object]:
    env = {**os.environ, "PYTHONPATH": str(package)}
    shared = Path(__file__).resolve().parents[2] / "shared"
    run = subprocess.run([sys.executable, "-c", _ROUND, str(out), str(shared)], env=env, capture_output=True,
                         text=True, timeout=900, check=True)
    return json.loads(run.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


def main() -> None:
    builds = {"before": Path(sys.argv[1]).resolve(), "after": Path(sys.argv[2]).resolve()}
    rounds: dict[str, list[dict[str, object]]] = {k: [] for k in builds}
    identical = {}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(ROUNDS):
            for name, package in (builds.items() if k % 2 == 0 else reversed(builds.items())):
                rounds[name].append(one_round(package, Path(tmp) / f"{name}.npz"))
        a, b = np.load(Path(tmp) / "before.npz"), np.load(Path(tmp) / "after.npz")
        for key in a.files:
            identical[key] = bool(np.array_equal(a[key], b[key], equal_nan=True))
    summary = {name: {"frame_ms": float(np.median([np.median(r["frame_ms"]) for r in rs])),  # type: ignore[call-overload]
                      "rays_100k_ms": float(np.median([r["rays_ms"] for r in rs]))}
               for name, rs in rounds.items()}
    result = {"builds": {k: str(v) for k, v in builds.items()}, "cores": os.cpu_count(), "rounds": rounds,
              "summary": summary, "identical": identical, "load_average": os.getloadavg()}
    RESULTS.mkdir(exist_ok=True)
    write_json(RESULTS / "before_after.json", result, indent=2)
    for name, s in summary.items():
        print(f"{name:<7} {s['frame_ms']:7.1f} ms/frame   {s['rays_100k_ms']:8.1f} ms / 100k rays")
    print("identical:", identical)


if __name__ == "__main__":
    main()
