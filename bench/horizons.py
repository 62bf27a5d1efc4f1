"""Horizons: a stack of three 1588 x 1188 height grids (the Geometry Textures paper's horizon
size; ~11 million triangles as a mesh) turned into geometry textures and rendered.

Measured in one run: ``GeometryTextureSet.from_heightmaps`` time, patches and bytes (against the
triangulated grids' vertex + index bytes as float32/uint32), render time on this adapter, and
depth error against trimesh + embree ray casting of the triangulated grids (two triangles per cell
with four finite corners) from three views with the "balanced" and "exact" presets. The trimesh
reference alone needs ~11 GB and about 40 s per view on 2 cores, so this is a benchmark, not a
test (tests/test_grids.py checks a 400 x 300 stack the same way).

Results: ``bench/results/horizons.json`` and ``bench/results/horizons.png`` (the oblique view).

Run from the repository root::

    python bench/horizons.py            # ~3 min on 2 cores
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import geomtex as gt
from geomtex import reference, testing

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

from render import machine_info  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
ROWS, COLS = 1188, 1588
EXTENT = (0.0, 10.0 * (COLS - 1), 0.0, 10.0 * (ROWS - 1))
VIEWS = {"oblique": (1.0, 0.8, 0.6), "from the side, 3° up": (1.0, 0.0, 0.05), "steep": (0.2, -0.3, 1.0)}
SIZE = 512


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=RESULTS / "horizons.json")
    args = ap.parse_args(argv)
    grids = testing.horizon_stack(ROWS, COLS)
    t0 = time.perf_counter()
    gts = gt.GeometryTextureSet.from_heightmaps(grids, EXTENT, properties=grids, cmap="viridis")
    build_s = time.perf_counter() - t0
    meshes = [testing.grid_mesh(g, EXTENT) for g in grids]
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    mesh = gt.Mesh(np.vstack([np.asarray(m.vertices) for m in meshes]),
                   np.vstack([np.asarray(m.faces) + o for m, o in zip(meshes, offsets)]))
    mesh_bytes = len(mesh.vertices) * 12 + len(mesh.faces) * 12
    renderer = gt.Renderer(SIZE, SIZE)
    views = []
    for name, direction in VIEWS.items():
        cam = testing.look_from(mesh, direction)
        t0 = time.perf_counter()
        ref = reference.raycast(mesh, cam, SIZE, SIZE)
        ref_s = time.perf_counter() - t0
        for quality in ("balanced", "exact"):
            renderer.render(gts, cam, quality=quality)  # warm-up: uploads the set once
            t0 = time.perf_counter()
            frame = renderer.render(gts, cam, quality=quality)
            ms = 1000 * (time.perf_counter() - t0)
            m = reference.compare(frame, ref, mesh.diagonal)
            views.append({"view": name, "quality": quality, "render_ms": ms, "trimesh_s": ref_s,
                          **{k: m[k] for k in ("iou", "depth_median", "depth_p99", "mask_far_px", "nan_depth",
                                                "covered_px", "ref_px")}})
            if name == "oblique" and quality == "exact":
                frame.save(args.out.with_suffix(".png"))
    result: dict[str, Any] = {
        "machine": machine_info(), "grids": len(grids), "rows": ROWS, "columns": COLS,
        "missing_samples": gts.stats["missing_samples"], "triangles": len(mesh.faces),
        "build_s": build_s, "patches": len(gts), "bytes": gts.stats["bytes"], "mesh_bytes_f32": mesh_bytes,
        "views": views,
        "within_renderer_bounds": all(v["iou"] >= 0.99 and v["depth_median"] <= 1e-3 and v["depth_p99"] <= 1e-2
                                      and v["nan_depth"] == 0 for v in views),
    }
    print(f"{len(grids)} grids of {ROWS} x {COLS} ({len(mesh.faces):,} triangles as a mesh): built in {build_s:.2f} s, "
          f"{len(gts)} patches, {gts.stats['bytes'] / 1e6:.1f} MB of maps (mesh as float32/uint32: {mesh_bytes / 1e6:.1f} MB)")
    print(f"{'view':<22} {'quality':<9} {'ms':>7} {'IoU':>7} {'median':>9} {'p99':>9} {'trimesh s':>9}")
    for v in views:
        print(f"{v['view']:<22} {v['quality']:<9} {v['render_ms']:7.1f} {v['iou']:7.4f} {v['depth_median']:9.1e} "
              f"{v['depth_p99']:9.1e} {v['trimesh_s']:9.1f}")
    print("within the renderer issue's bounds:", result["within_renderer_bounds"])
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_json(args.out, result, indent=1)
    print(f"wrote {args.out} and {args.out.with_suffix('.png')}")


if __name__ == "__main__":
    main()
