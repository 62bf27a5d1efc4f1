"""Benchmark of ray queries and shadows: geomtex's GPU tracer against trimesh + embree with its
intersector kept (``mesh.ray`` caches its BVH; ``reference.RayCaster`` does the same; one core)
and, where installed (``pip install open3d-cpu``), Open3D's ``RaycastingScene`` with its scene
kept on every core (bench/peers.py), in one run.

Rays: from random points on a sphere (radius one diagonal) around the Stanford bunny toward
random points in its bounding box, as in tests/test_rays.py. Per ray count: wall time of
``gts.intersects_first`` (nearest hit, "exact" quality) and of ``gts.intersects_any`` on the GPU
backend, of ``intersects_first`` on the CPU backend (``device="cpu"``, set and mesh), embree's
first hits with locations, the throughput of each (million rays per second), hit/miss agreement
and the distance error against embree (fraction of the bounding-box diagonal); and the same rays
through the bunny *as a mesh* in a ``gt.Scene`` (the tracer's hierarchy over its triangles).

Parallel rays: 1M rays sharing one direction, from random points on a plane beside the bunny's
box across it (what shadow rays toward a directional light are), which the tracer walks through
tiles seen along that direction instead of the hierarchy; same figures.

Shadows: the bunny (converted, then as a mesh) on a ground plane (a mesh) at 512², three
directional lights: the frame with and without ``light=`` rendered in alternation (the ratio is
the median of each pair's), the load average beside them, and the shadow mask against embree's
shadow rays cast from embree's own hits (tests/test_shadows.py at 128²).

Results: ``bench/results/rays.json`` and ``bench/results/rays.png``.

Run from the repository root::

    python bench/rays.py            # 10k, 100k and 1M rays (~1 min)
    python bench/rays.py --quick    # 10k and 100k
    python bench/rays.py --shadows-only   # the shadow frames alone (bench/results/shadows.json)
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)
from peers import Open3dCaster, open3d_caster  # type: ignore[import-not-found]

import geomtex as gt
from geomtex.testing.views import rays_around
from render import BUNNY, ForeignCpu, machine_info, ray_caster, wait_idle  # type: ignore[import-not-found]

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "bench" / "results"
COUNTS_FULL = (10_000, 100_000, 1_000_000)
COUNTS_QUICK = (10_000, 100_000)


def timed(call: Callable[[], Any], repeats: int) -> tuple[Any, float]:
    """The last result and the median wall time (ms) of ``repeats`` calls after a warm-up."""
    result = call()
    walls = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = call()
        walls.append(1e3 * (time.perf_counter() - t0))
    return result, float(np.median(walls))


PARALLEL_DIRECTION = (0.3, -1.0, 0.2)


def parallel_rays(mesh: gt.Mesh, n: int, seed: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """``n`` rays along PARALLEL_DIRECTION from random points of a square one diagonal behind
    the box's centre (against the direction), half a diagonal on a side either way."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in mesh.bounds)
    diag, centre = float(mesh.diagonal), (lo + hi) / 2
    d = np.asarray(PARALLEL_DIRECTION) / np.linalg.norm(PARALLEL_DIRECTION)
    u = np.cross(d, [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(d, u)
    ab = np.random.default_rng(seed).uniform(-0.5 * diag, 0.5 * diag, (n, 2))
    origins = centre - diag * d + ab[:, :1] * u + ab[:, 1:] * v
    return origins, np.tile(d, (n, 1))


def open3d_figures(o3d: Open3dCaster | None, origins: np.ndarray, dirs: np.ndarray, ref: np.ndarray,
                   diag: float, repeats: int, gt_ms: float, mesh_ms: float) -> dict[str, Any]:
    """Open3D's first hits of the same rays (bench/peers.py: scene kept, every core), timed like
    the others, and their agreement with embree's; empty without Open3D."""
    if o3d is None:
        return {}
    rays = o3d.tensor(origins, dirs)
    ans, ms = timed(lambda: o3d.cast(rays), repeats)
    t = ans["t_hit"].numpy().astype(np.float64)
    both = np.isfinite(t) & np.isfinite(ref)
    err = np.abs(t[both] - ref[both]) / diag
    return {"open3d_ms": ms, "open3d_mrays_s": len(t) / ms / 1e3, "open3d_threads": o3d.threads,
            "open3d_over_geomtex": gt_ms / ms, "open3d_over_mesh": mesh_ms / ms,
            "open3d_hit_agreement": float(np.mean(np.isfinite(t) == np.isfinite(ref))),
            "open3d_distance_p99": float(np.percentile(err, 99)) if err.size else None}


def measure(gts: Any, caster: Any, mesh: gt.Mesh, n: int, parallel: bool = False,
            o3d: Open3dCaster | None = None) -> dict[str, Any]:
    origins, dirs = parallel_rays(mesh, n) if parallel else rays_around(mesh, n)
    diag = mesh.diagonal
    repeats = 3 if n <= 100_000 else 1
    foreign = ForeignCpu()
    foreign.start()
    hits, gt_ms = timed(lambda: gts.intersects_first(origins, dirs, device="gpu"), repeats)
    _, any_ms = timed(lambda: gts.intersects_any(origins, dirs, device="gpu"), repeats)
    # The CPU backend (src/render/cpu: pieces of the patches in a BVH, min-max pyramid search).
    cpu_hits, cpu_ms = timed(lambda: gts.intersects_first(origins, dirs, device="cpu"), repeats)
    cpu_t = cpu_hits.distances
    _, embree_ms = timed(lambda: caster.first_hits(origins, dirs), repeats)
    as_mesh = gt.Scene()
    as_mesh.add(mesh)
    mesh_hits, mesh_ms = timed(lambda: as_mesh.intersects_first(origins, dirs, device="gpu"), repeats)
    cpu_mesh_hits, cpu_mesh_ms = timed(lambda: as_mesh.intersects_first(origins, dirs, device="cpu"), repeats)
    ref = caster.first_distances(origins, dirs)
    peer = open3d_figures(o3d, origins, dirs, ref, diag, repeats, gt_ms, mesh_ms)
    if peer:
        peer.update(open3d_over_cpu_set=cpu_ms / peer["open3d_ms"], open3d_over_cpu_mesh=cpu_mesh_ms / peer["open3d_ms"])
    busy = foreign.stop()
    both = hits.hit & np.isfinite(ref)
    err = np.abs(hits.distances[both] - ref[both]) / diag
    mesh_both = mesh_hits.hit & np.isfinite(ref)
    mesh_err = np.abs(mesh_hits.distances[mesh_both] - ref[mesh_both]) / diag
    cpu_both = np.isfinite(cpu_t) & np.isfinite(ref)
    cpu_err = np.abs(cpu_t[cpu_both] - ref[cpu_both]) / diag
    cpu_mesh_both = cpu_mesh_hits.hit & np.isfinite(ref)
    cpu_mesh_err = np.abs(cpu_mesh_hits.distances[cpu_mesh_both] - ref[cpu_mesh_both]) / diag
    return {
        "cpu_mesh_first_ms": cpu_mesh_ms, "cpu_mesh_mrays_s": n / cpu_mesh_ms / 1e3,
        "cpu_mesh_hit_agreement": float(np.mean(cpu_mesh_hits.hit == np.isfinite(ref))),
        "cpu_mesh_distance_p99": float(np.percentile(cpu_mesh_err, 99)),
        **peer, "embree_threads": 1,
        "cpu_first_ms": cpu_ms, "cpu_mrays_s": n / cpu_ms / 1e3, "gpu_over_cpu": gt_ms / cpu_ms,
        "cpu_hit_agreement": float(np.mean(np.isfinite(cpu_t) == np.isfinite(ref))),
        "cpu_distance_p99": float(np.percentile(cpu_err, 99)),
        "mesh_first_ms": mesh_ms, "mesh_mrays_s": n / mesh_ms / 1e3, "embree_over_mesh": mesh_ms / embree_ms,
        "mesh_hit_agreement": float(np.mean(mesh_hits.hit == np.isfinite(ref))),
        "mesh_distance_p99": float(np.percentile(mesh_err, 99)), "mesh_distance_max": float(mesh_err.max()),
        "rays": n, "parallel": parallel, "geomtex_first_ms": gt_ms, "geomtex_any_ms": any_ms, "embree_ms": embree_ms,
        "geomtex_mrays_s": n / gt_ms / 1e3, "embree_mrays_s": n / embree_ms / 1e3,
        "embree_over_geomtex": gt_ms / embree_ms,
        "hit_agreement": float(np.mean(hits.hit == np.isfinite(ref))),
        "hits": int(hits.hit.sum()), "reference_hits": int(np.isfinite(ref).sum()),
        "distance_p99": float(np.percentile(err, 99)), "distance_median": float(np.median(err)),
        "distance_max": float(err.max()), "other_processes_cpu_s": busy,
    }


SHADOW_SIZE = 512
LIGHTS = ((0.3, -1.0, 0.2), (1.0, -0.6, -0.4), (-0.5, -1.0, 0.8))


def side_by_side(plain: Callable[[], Any], lit: Callable[[], Any], repeats: int) -> tuple[Any, float, float, float]:
    """The last lit frame, the median wall times (ms) of unshadowed and shadowed frames rendered
    in alternation (so that both see the same load), and the median of each pair's ratio."""
    plain(), lit()
    walls = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        plain()
        t1 = time.perf_counter()
        frame = lit()
        walls.append((t1 - t0, time.perf_counter() - t1))
    p, q = (1e3 * np.array(w) for w in zip(*walls))
    return frame, float(np.median(p)), float(np.median(q)), float(np.median(q / p))


def shadows(gts: Any, mesh: gt.Mesh, as_mesh: bool) -> list[dict[str, Any]]:
    import sys

    sys.path.insert(0, str(REPO / "tests"))
    import test_shadows as ts  # type: ignore[import-not-found]

    ts.SIZE = SHADOW_SIZE
    bunny = type("Converted", (), {"mesh": mesh, "gts": gts})()
    scene, whole, camera, diag = ts.bunny_on_ground(bunny, as_mesh)
    r = gt.Renderer(SHADOW_SIZE, SHADOW_SIZE)
    records = []
    for direction in LIGHTS:
        light = gt.DirectionalLight(direction)
        load = os.getloadavg()
        lit, plain_ms, lit_ms, ratio = side_by_side(
            lambda: r.render(scene, camera), lambda: r.render(scene, camera, light=light), 7)
        hit, ref = ts.embree_shadow(whole, camera, np.asarray(direction, float), diag, size=SHADOW_SIZE)
        both = hit & np.isfinite(lit.depth)
        wrong = (lit.shadow != ref) & both
        records.append({
            "bunny": "mesh" if as_mesh else "set", "light": direction, "frame_ms": plain_ms, "lit_frame_ms": lit_ms,
            "lit_over_plain": ratio, "shadow_rays": int(np.isfinite(lit.depth).sum()),
            "agreement": float(1 - wrong.sum() / both.sum()),
            "off_edge_disagreements": int((wrong & ~ts.near_edge(ref)).sum()),
            "shadowed": int(lit.shadow.sum()), "embree_shadowed": int(ref[both].sum()),
            "shadow_ms": lit.stats["shadow_ms"], "shadow_trace_ms": lit.stats["shadow_trace_ms"],
            "loadavg_before": load, "loadavg_after": os.getloadavg(),
        })
        q = records[-1]
        print(f"{q['bunny']}, light {direction}: frame {plain_ms:.0f} ms, with shadows {lit_ms:.0f} ms ({q['lit_over_plain']:.2f}x); "
              f"agreement {q['agreement']:.4f}, off-edge {q['off_edge_disagreements']}; "
              f"shadow {q['shadow_ms']:.1f} ms, of it tracing {q['shadow_trace_ms']:.1f} ms; load {load[0]:.1f}")
    return records


def plot(records: list[dict[str, Any]], path: Path, adapter: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = [r["rays"] for r in records]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.loglog(n, [r["geomtex_first_ms"] for r in records], "o-", label="geomtex intersects_first")
    ax.loglog(n, [r["geomtex_any_ms"] for r in records], "s--", label="geomtex intersects_any")
    ax.loglog(n, [r["mesh_first_ms"] for r in records], "d-.", label="geomtex, the bunny as a mesh")
    ax.loglog(n, [r["cpu_first_ms"] for r in records], "s--", label="geomtex set, CPU backend")
    ax.loglog(n, [r["cpu_mesh_first_ms"] for r in records], "d--", label="geomtex mesh, CPU backend")
    ax.loglog(n, [r["embree_ms"] for r in records], "^-", label="trimesh + embree, intersector kept (1 core)")
    if records and "open3d_ms" in records[0]:
        ax.loglog(n, [r["open3d_ms"] for r in records], "v-",
                  label=f"Open3D RaycastingScene, kept ({records[0]['open3d_threads']} threads)")
    ax.set_xlabel("rays per call")
    ax.set_ylabel("wall time (ms)")
    ax.set_title(f"Ray queries, Stanford bunny (256-texel maps), {adapter}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--wait-idle", type=float, default=30.0)
    parser.add_argument("--shadows-only", action="store_true",
                        help="only the shadow frames, into bench/results/shadows.json")
    args = parser.parse_args()
    mesh = gt.load_mesh(str(BUNNY))
    gts = gt.convert(mesh, max_resolution=256)
    if args.shadows_only:
        wait_idle(args.wait_idle)
        machine = machine_info()
        machine["adapter"] = dict(gt.Renderer(8, 8).adapter_info)
        result = {"machine": machine, "shadows": shadows(gts, mesh, False) + shadows(gts, mesh, True)}
        OUT.mkdir(parents=True, exist_ok=True)
        write_json(OUT / "shadows.json", result, indent=2)
        return
    caster, build_s = ray_caster(mesh)
    o3d = open3d_caster(mesh)
    print("Open3D:", f"{o3d.version}, scene built in {o3d.build_s:.2f} s (kept), {o3d.threads} threads"
          if o3d else "not installed (pip install open3d-cpu); its columns are left out")
    records = []
    for n in COUNTS_QUICK if args.quick else COUNTS_FULL:
        wait_idle(args.wait_idle)
        records.append(measure(gts, caster, mesh, n, o3d=o3d))
        r = records[-1]
        print(f"{n:>9,} rays: CPU backend, set {r['cpu_first_ms']:8.1f} ms ({r['gpu_over_cpu']:.1f}x faster than the "
              f"tracer here; agreement {r['cpu_hit_agreement']:.5f}, p99 {r['cpu_distance_p99']:.1e}), mesh "
              f"{r['cpu_mesh_first_ms']:8.1f} ms (agreement {r['cpu_mesh_hit_agreement']:.5f})")
        if o3d:
            print(f"{n:>9,} rays: Open3D {r['open3d_ms']:7.1f} ms ({r['open3d_threads']} threads), "
                  f"{r['open3d_over_geomtex']:.1f}x the set's speed, {r['open3d_over_mesh']:.1f}x the mesh's "
                  f"(CPU backend: {r['open3d_over_cpu_set']:.1f}x, {r['open3d_over_cpu_mesh']:.1f}x); "
                  f"agreement with embree {r['open3d_hit_agreement']:.5f}, p99 {r['open3d_distance_p99']:.1e}")
        print(f"{n:>9,} rays: geomtex {r['geomtex_first_ms']:8.1f} ms (any {r['geomtex_any_ms']:8.1f}), "
              f"embree {r['embree_ms']:7.1f} ms, embree {r['embree_over_geomtex']:.1f}x faster; agreement "
              f"{r['hit_agreement']:.5f}, p99 {r['distance_p99']:.1e} of the diagonal; as a mesh "
              f"{r['mesh_first_ms']:8.1f} ms, agreement {r['mesh_hit_agreement']:.5f}, p99 {r['mesh_distance_p99']:.1e}")
    wait_idle(args.wait_idle)
    parallel = measure(gts, caster, mesh, COUNTS_QUICK[-1] if args.quick else COUNTS_FULL[-1], parallel=True, o3d=o3d)
    print(f"{parallel['rays']:>9,} parallel rays: geomtex {parallel['geomtex_first_ms']:8.1f} ms, embree "
          f"{parallel['embree_ms']:7.1f} ms ({parallel['embree_over_geomtex']:.1f}x); agreement "
          f"{parallel['hit_agreement']:.5f}, p99 {parallel['distance_p99']:.1e}; as a mesh {parallel['mesh_first_ms']:8.1f} ms")
    shadow_records = shadows(gts, mesh, False) + shadows(gts, mesh, True)
    OUT.mkdir(parents=True, exist_ok=True)
    machine = machine_info()
    machine["adapter"] = dict(gt.Renderer(8, 8).adapter_info)
    result = {"machine": machine, "embree_build_and_first_cast_s": build_s,
              "open3d": {"version": o3d.version, "build_and_first_cast_s": o3d.build_s, "threads": o3d.threads} if o3d else None,
              "records": records,
              "parallel": parallel, "shadows": shadow_records}
    write_json(OUT / "rays.json", result, indent=2)
    plot(records, OUT / "rays.png", machine["adapter"]["name"])


if __name__ == "__main__":
    main()
