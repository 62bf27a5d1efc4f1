"""Benchmark of outputs on request and of the process's one device.

Outputs: the Stanford bunny (``../shared/meshes``, else pymeshlab's bunny) converted by default,
five views at 512², each frame drawn with every output, with ``outputs=("depth",)`` and with
``outputs=("color",)`` in alternation (the ratios are the median of each round's, so a slow
spell of a noisy machine hits all three alike).

Device: the cost of a second ``gt.Renderer`` and of a first frame at a second size, now that every
Renderer shares one device (before, each Renderer made a device: ~1.3 s here), and what
``_core.device_counts()`` reports after a notebook-like sequence.

Results: ``bench/results/outputs.json`` and ``bench/results/outputs.png``. Run from the
repository root: ``python bench/outputs.py`` (~1 min).
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

import geomtex as gt
from geomtex import _core
from geomtex.testing import look_from

RESULTS = Path(__file__).parent / "results"
SIZE = 512
ROUNDS = 7
VIEWS = [(1, 0, 0), (0, 0, 1), (-1, 0.3, 0), (0.5, 0.5, -1), (0, 1, 0.2)]
KINDS = {"all": None, "depth": ("depth",), "color": ("color",)}


def bunny() -> gt.Mesh:
    shared = Path(__file__).resolve().parents[2] / "shared" / "meshes" / "stanford-bunny.obj"
    if shared.exists():
        return gt.load_mesh(shared)
    import pymeshlab

    return gt.load_mesh(Path(pymeshlab.__file__).parent / "tests" / "sample_meshes" / "bunny.obj")


def frame_times(gts: gt.GeometryTextureSet, mesh: gt.Mesh) -> dict[str, Any]:
    renderer = gt.Renderer(SIZE, SIZE)
    cameras = [look_from(mesh, v, up=(0, 1, 0)) for v in VIEWS]
    for kind in KINDS.values():  # warm: pipelines, uploads, targets
        renderer.render(gts, cameras[0], outputs=kind)
    per_kind: dict[str, list[float]] = {k: [] for k in KINDS}
    for _ in range(ROUNDS):
        for name, kind in KINDS.items():
            start = time.perf_counter()
            for cam in cameras:
                renderer.render(gts, cam, outputs=kind)
            per_kind[name].append((time.perf_counter() - start) * 1e3 / len(cameras))
    ms = {k: float(np.median(v)) for k, v in per_kind.items()}
    ratio = {k: float(np.median(np.array(per_kind[k]) / np.array(per_kind["all"]))) for k in KINDS}
    return {"ms_per_frame": ms, "ratio_to_all": ratio, "rounds": per_kind}


def device_costs(gts: gt.GeometryTextureSet, mesh: gt.Mesh) -> dict[str, Any]:
    cam = look_from(mesh, (1, 0, 0), up=(0, 1, 0))
    start = time.perf_counter()
    gt.Renderer(SIZE, SIZE)
    another_renderer_ms = (time.perf_counter() - start) * 1e3
    start = time.perf_counter()
    gt.Renderer(300, 200).render(gts, cam)
    new_size_first_frame_ms = (time.perf_counter() - start) * 1e3
    start = time.perf_counter()
    gt.Renderer(300, 200).render(gts, cam)
    same_size_again_ms = (time.perf_counter() - start) * 1e3
    rng = np.random.default_rng(0)
    lo, hi = (np.asarray(b) for b in mesh.bounds)
    origins = (lo + hi) / 2 + rng.normal(size=(1000, 3)) * np.linalg.norm(hi - lo)
    gts.intersects_first(origins, (lo + hi) / 2 - origins)
    return {"another_renderer_ms": another_renderer_ms, "new_size_first_frame_ms": new_size_first_frame_ms,
            "same_size_again_ms": same_size_again_ms, "counts": _core.device_counts()}


def plot(result: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ms = result["outputs"]["ms_per_frame"]
    fig, ax = plt.subplots(figsize=(5, 3))
    ax.bar(list(ms), list(ms.values()), color=["#777", "#3a7", "#37a"])
    ax.set_ylabel(f"ms per {SIZE}² frame (median)")
    ax.set_title(f"bunny, default set, 5 views: outputs read back\n{result['adapter']}", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    mesh = bunny()
    gts = gt.convert(mesh)
    result = {
        "adapter": gt.Renderer(1, 1).adapter_info["name"],
        "cores": os.cpu_count(),
        "load_average": os.getloadavg(),
        "mesh_faces": int(mesh.faces.shape[0]),
        "patches": int(gts.stats["charts"]),
        "outputs": frame_times(gts, mesh),
        "device": device_costs(gts, mesh),
    }
    RESULTS.mkdir(exist_ok=True)
    write_json(RESULTS / "outputs.json", result, indent=2)
    plot(result, RESULTS / "outputs.png")
    o = result["outputs"]
    print(f"{'outputs':<8} {'ms/frame':>9} {'ratio':>6}")
    for k in KINDS:
        print(f"{k:<8} {o['ms_per_frame'][k]:9.1f} {o['ratio_to_all'][k]:6.2f}")
    d = result["device"]
    print(f"another Renderer: {d['another_renderer_ms']:.1f} ms; first frame at a new size: "
          f"{d['new_size_first_frame_ms']:.1f} ms (again: {d['same_size_again_ms']:.1f} ms); {d['counts']}")


if __name__ == "__main__":
    main()
