"""Benchmark of generalized displacement maps (issue 18): mesostructure tiles over a base mesh,
rendered per pixel through the prisms.

In one run, on one wgpu adapter: chain links and a weave at 64x64x16 and 64x64x32, tiled over a
decimated bunny (pymeshlab's bunny, quadric decimation to ~3k faces, box-projected texture
coordinates) and over a torus (its own continuous texture coordinates), rendered from ``--views``
views around each at ``--size``:

* against trimesh + embree ray casting of ``shell.to_mesh()`` (the explicit reference): coverage
  IoU, depth p99 (raw, and in voxels: thickness / nz), median normal angle, for the exact march
  and for the paper's lookup in the SVD-compressed 5D distance function (16 x 32 directions,
  k = 8), as the paper takes it and refined (the first surface searched exactly within
  ``REFINE`` voxels of the looked-up distance), and the march driven by the conservative table
  (``distance_function(lower_bound=True)``, k = 8 plus its margin term: each piece steps by the
  looked-up lower bound, then marches exactly), side by side;
* per pixel drawn, in the first view: table lookups, march steps and trilinear field samples of
  the fragment that drew it, for the march, the paper's lookup and the bounded march;
* frame time (whole render call, median of the views) of each, and of rasterizing the explicit
  mesh through the same renderer; bytes of the volume, the compressed table and the explicit
  mesh (float32 vertices + uint32 faces);
* the SVD trade on the chain at 64x64x16: reconstruction error (rms, voxels) and bytes against
  k = 1..16 for 8 x 16 and 16 x 32 directions; for the conservative table, the mean skip it
  offers (voxels) against k with the SVD's overshoot subtracted per row and globally.

Results: ``bench/results/gdm.json`` and ``bench/results/gdm.png``.

Run from the repository root::

    python bench/gdm.py                              # 512^2, five views: the committed figures
    nice python bench/gdm.py --size 256 --views 3    # quicker
    python bench/gdm.py --cases bunny/chain/16,bunny/chain/32   # rerun two cases into gdm.json
"""

from __future__ import annotations

import argparse
import datetime
import functools
import json
import os
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

import geomtex as gt
from geomtex import gdm, reference

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "bench" / "results"
YFOV = 45.0
K = 8
REFINE = 1.5


@functools.lru_cache(maxsize=1)
def bunny_base() -> tuple[trimesh.Trimesh, float]:
    import pymeshlab

    path = Path(pymeshlab.__file__).parent / "tests" / "sample_meshes" / "bunny.obj"
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=3000, preservenormal=True)
    m = ms.current_mesh()
    tm = trimesh.Trimesh(m.vertex_matrix(), m.face_matrix(), process=True)
    return tm, float(np.linalg.norm(tm.extents))


def shells(base: str, vol: gdm.Volume, packed: gdm.CompressedGDM, bound: gdm.CompressedGDM,
           **extra: Any) -> tuple[list[gdm.Shell], float]:
    """([the exact march, the paper's lookup, the refined lookup, the march driven by the
    conservative table], thickness); ``extra`` goes to every Shell (count_steps)."""
    kws: list[dict[str, Any]] = [{}, {"lookup": packed}, {"lookup": packed, "refine": REFINE}, {"lookup": bound}]
    made = [shells_one(base, vol, **kw, **extra) for kw in kws]
    return [m[0] for m in made], made[0][1]


def shells_one(base: str, vol: gdm.Volume, **kw: Any) -> tuple[gdm.Shell, float]:
    """(One shell of ``vol`` over `base`, its thickness), with Shell keywords ``kw``: the torus
    (its own continuous texture coordinates, 12 x 4 tiles) or the decimated bunny (box-projected,
    10 x 10 tiles), 0.08 / 1.2% of the bunny's diagonal thick."""
    if base == "torus":
        tor, uv = gdm.uv_torus(1.0, 0.35, (48, 24))
        return gdm.Shell(tor, vol, thickness=0.08, uv=uv * [12, 4], **kw), 0.08
    tm, diag = bunny_base()
    return gdm.Shell(tm, vol, thickness=0.012 * diag, tiles=(10, 10), **kw), 0.012 * diag


def cameras(mesh: trimesh.Trimesh, views: int, up: int) -> list[gt.Camera]:
    """Views around the `up` axis (2: the torus's z, 1: the bunny's y), each a little above."""
    lo, hi = mesh.bounds
    centre, size = (lo + hi) / 2, float(np.linalg.norm(hi - lo))
    a1, a2 = [(0, 1), (2, 0)][up == 1]
    out = []
    for k in range(views):
        a = 2 * np.pi * k / views + 0.3
        offset = np.zeros(3)
        offset[a1], offset[a2], offset[up] = np.cos(a), np.sin(a), 0.55 + 0.2 * np.sin(3 * a)
        out.append(gt.Camera.look_at(centre + size * 0.9 * offset, centre, up=tuple(np.eye(3)[up]), yfov_deg=YFOV))
    return out


def tolerant(depth: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """|depth - nearest reference depth in its 3x3 neighbourhood| (a one-pixel tolerance)."""
    pad = np.pad(ref, 1, constant_values=np.nan)
    h, w = ref.shape
    stack = np.stack([pad[i:i + h, j:j + w] for i in range(3) for j in range(3)])
    with np.errstate(invalid="ignore"):
        return np.nanmin(np.abs(stack - depth[None]), axis=0)


def accuracy(frame: Any, ref: dict) -> dict[str, float]:
    a, b = np.isfinite(frame.depth), np.isfinite(ref["depth"])
    both = a & b
    d = np.abs(frame.depth[both] - ref["depth"][both])
    r = np.where(b, ref["depth"], np.nan)
    d1 = tolerant(np.where(a, frame.depth, np.nan), r)[both]
    cos = np.abs(np.einsum("ij,ij->i", frame.normal[both], ref["normal"][both]))
    return {"iou": float((a & b).sum() / max((a | b).sum(), 1)), "p99": float(np.quantile(d, 0.99)) if d.size else 0.0,
            "p99_1px": float(np.quantile(d1, 0.99)) if d.size else 0.0,
            "normal_nan": int(np.isnan(cos).sum()),
            "normal_deg": float(np.degrees(np.nanmedian(np.arccos(np.clip(cos, 0, 1))))) if d.size else 0.0}


def timed(renderer: gt.Renderer, obj: Any, cam: gt.Camera) -> tuple[Any, float]:
    t = time.perf_counter()
    frame = renderer.render(obj, cam)
    return frame, time.perf_counter() - t


def step_counts(base: str, vol: gdm.Volume, packed: gdm.CompressedGDM, bound: gdm.CompressedGDM,
                renderer: gt.Renderer, cam: gt.Camera) -> dict[str, dict[str, float]]:
    """Per pixel drawn, in one view: the table lookups, march steps and trilinear field samples of
    the fragment that drew it (``count_steps``), for the exact march, the paper's lookup and the
    bounded march."""
    (exact, lookup, _, bounded), _ = shells(base, vol, packed, bound, count_steps=True)
    out = {}
    for name, shell in (("exact", exact), ("lookup", lookup), ("bound", bounded)):
        frame = renderer.render(shell, cam)
        drawn = np.isfinite(frame.depth)
        counts = np.asarray(frame.normal)[drawn].astype(np.float64)
        out[name] = {"lookups_mean": float(counts[:, 0].mean()), "steps_mean": float(counts[:, 1].mean()),
                     "field_mean": float(counts[:, 2].mean()), "steps_p99": float(np.quantile(counts[:, 1], 0.99)),
                     "pixels": int(drawn.sum())}
    return out


def run_case(pattern: str, nz: int, base: str, size: int, views: int) -> dict[str, Any]:
    vol = gdm.Volume.procedural(pattern, (64, 64, nz))  # type: ignore[arg-type]
    t = time.perf_counter()
    table = vol.distance_function((16, 32))
    precompute = time.perf_counter() - t
    packed = table.compress(K)
    t = time.perf_counter()
    lower = vol.distance_function((16, 32), lower_bound=True)
    precompute_bound = time.perf_counter() - t
    bound = lower.compress(K)
    (exact, lookup, refined, bounded), thickness = shells(base, vol, packed, bound)
    kinds = (("exact", exact), ("lookup", lookup), ("refined", refined), ("bound", bounded))
    up = 2 if base == "torus" else 1
    t = time.perf_counter()
    explicit = exact.to_mesh()
    to_mesh_s = time.perf_counter() - t
    caster = reference.RayCaster(explicit)
    renderer = gt.Renderer(size, size)
    explicit_gt = gt.as_mesh(explicit)
    rows: dict[str, list] = {"ms_mesh": []}
    for name, shell in kinds:
        rows[name], rows[f"ms_{name}"] = [], []
        renderer.render(shell, cameras(explicit, 1, up)[0])  # warm-up: pipelines and uploads
    renderer.render(explicit_gt, cameras(explicit, 1, up)[0])
    for cam in cameras(explicit, views, up):
        ref = caster.cast(cam, size, size)
        for name, shell in kinds:
            frame, s = timed(renderer, shell, cam)
            rows[name].append(accuracy(frame, ref))
            rows[f"ms_{name}"].append(1000 * s)
        rows["ms_mesh"].append(1000 * timed(renderer, explicit_gt, cam)[1])
    voxel = thickness / nz
    summary: dict[str, Any] = {"pattern": pattern, "size": [64, 64, nz], "base": base, "base_faces": len(exact.faces),
                               "thickness": thickness, "voxel": voxel, "precompute_s": precompute,
                               "to_mesh_s": to_mesh_s, "explicit_faces": len(explicit.faces),
                               "bytes_volume": vol.nbytes, "bytes_table": table.nbytes, "bytes_svd": packed.nbytes,
                               "bytes_explicit": int(len(explicit.vertices) * 12 + len(explicit.faces) * 12),
                               "svd_rms": packed.error["rms"], "normals_bent": exact.untangled,
                               "precompute_bound_s": precompute_bound, "bytes_bound": bound.nbytes,
                               "bound_mean": float(lower.distance.mean()),
                               "bound_svd_mean": float(np.maximum(bound.reconstruct(), 0).mean())}
    summary["refine"] = REFINE
    summary["counts"] = step_counts(base, vol, packed, bound, renderer, cameras(explicit, views, up)[0])
    for name, _ in kinds:
        r = rows[name]
        summary[name] = {"iou_min": min(x["iou"] for x in r), "p99_max": max(x["p99"] for x in r),
                         "p99_voxels_max": max(x["p99"] for x in r) / voxel,
                         "p99_1px_voxels_max": max(x["p99_1px"] for x in r) / voxel,
                         "normal_deg_max": max(x["normal_deg"] for x in r), "views": r,
                         "ms_median": float(np.median(rows[f"ms_{name}"]))}
    summary["mesh_ms_median"] = float(np.median(rows["ms_mesh"]))
    return summary


def inverted_cost(size: int, views: int) -> dict[str, Any]:
    """What the bunny's inverted prisms (tops turned over at creases) covered before the shell bent
    its normals: pixels of the bench's views whose ray first meets the shell's top surface on an
    inverted prism's top, against all it covers (embree on the top surface; the cameras framed on
    that surface, within a shell's thickness of the explicit mesh's framing)."""
    tm, diag = bunny_base()
    t = 0.012 * diag
    v, f = np.asarray(tm.vertices), np.asarray(tm.faces)
    before, _ = gdm._welded_normals(v, f, t, rounds=0)
    after, moved = gdm._welded_normals(v, f, t)
    inverted = gdm._inverted_prisms(v, f, before, t)
    top = trimesh.Trimesh(v + t * before, f, process=False)
    caster = reference.RayCaster(top)
    rows = []
    for cam in cameras(top, views, 1):
        tri = caster.cast(cam, size, size)["triangle"]
        rows.append({"shell_px": int((tri >= 0).sum()), "inverted_px": int(inverted[tri[tri >= 0]].sum())})
    bend = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", before, after), -1, 1)))
    return {"faces": len(f), "inverted_prisms": int(inverted.sum()),
            "inverted_after": int(gdm._inverted_prisms(v, f, after, t).sum()), "positions": len(v),
            "positions_bent": moved, "max_bend_deg": float(bend.max()), "views": rows}


def svd_trade() -> list[dict[str, Any]]:
    vol = gdm.Volume.procedural("chain", (64, 64, 16))
    out = []
    for dirs in ((8, 16), (16, 32)):
        table = vol.distance_function(dirs)
        for k in (1, 2, 4, 8, 12, 16):
            p = table.compress(k)
            out.append({"directions": list(dirs), "k": k, "rms": p.error["rms"], "p99": p.error["p99"],
                        "bytes": p.nbytes, "table_bytes": table.nbytes})
    return out


def bound_trade() -> list[dict[str, Any]]:
    """What keeping the SVD conservative costs (chain, 64x64x16, 16 x 32): the mean of the
    lower-bound table (voxels: the skip a lookup can give) against the mean of its k-term SVD
    with the overshoot subtracted per row (what compress() stores) and globally."""
    vol = gdm.Volume.procedural("chain", (64, 64, 16))
    lower = vol.distance_function((16, 32), lower_bound=True)
    exact = vol.distance_function((16, 32))
    out = []
    for k in (1, 2, 4, 8, 12, 16):
        p = lower.compress(k)
        plain = np.einsum("xypk,ktz->xyztp", p.weights[..., :-1], p.eigen[:-1])
        glob = plain - max(float((plain - lower.distance).max()), 0.0)
        out.append({"k": k, "bound_mean": float(lower.distance.mean()), "exact_mean": float(exact.distance.mean()),
                    "per_row_mean": float(np.maximum(p.reconstruct(), 0).mean()),
                    "global_mean": float(np.maximum(glob, 0).mean()),
                    "margin_mean": float(p.weights[..., -1].mean()), "margin_max": float(p.weights[..., -1].max()),
                    "bytes": p.nbytes})
    return out


# Values one lookup reads per term (weights at 4 texels x 2 azimuths, eigen maps at 2 x 2) and
# per trilinear field sample (its 8 voxels): the load-free proxy of a pixel's work below.
READS_PER_TERM, READS_PER_FIELD = 12, 8


def reads(counts: dict[str, float], terms: int) -> float:
    """Values read per pixel drawn: lookups x terms x 12 + march steps (one radius each) + field
    samples x 8. A proxy of the shader's work that does not depend on the machine's load."""
    return (counts["lookups_mean"] * terms * READS_PER_TERM + counts["steps_mean"]
            + counts["field_mean"] * READS_PER_FIELD)


def mode_work(renderer: gt.Renderer, shell: gdm.Shell, counted: gdm.Shell, cam: gt.Camera, ref: dict,
              voxel: float, terms: int) -> dict[str, float]:
    """One mode's frame against the explicit reference (IoU, depth p99 in voxels, normal) and,
    from its count_steps twin, its work per pixel drawn."""
    acc = accuracy(renderer.render(shell, cam), ref)
    frame = renderer.render(counted, cam)
    drawn = np.isfinite(frame.depth)
    c = np.asarray(frame.normal)[drawn].astype(np.float64)
    row = {"lookups_mean": float(c[:, 0].mean()), "steps_mean": float(c[:, 1].mean()),
           "field_mean": float(c[:, 2].mean()), "pixels": int(drawn.sum()), "terms": terms,
           "iou": acc["iou"], "p99_voxels": acc["p99"] / voxel, "normal_deg": acc["normal_deg"]}
    row["reads_mean"] = reads(row, terms)
    return row


def slice_cost(size: int, rounds: int) -> list[dict[str, Any]]:
    """The paper's claim that GDM cost does not grow with depth resolution, against each mode, in
    one run: per tile and base, the shells at 16 and 32 slices and the explicit meshes rendered
    from the first view, interleaved round by round (the order rotated each round) so the machine's
    load falls on all of them alike; frame ms (median of the rounds) and, from count_steps, the
    work per pixel drawn, and each frame against embree on to_mesh() (IoU, depth p99 in voxels,
    normal; first view only). Modes: the exact march, the paper's lookup (k = 8), the bounded march
    with the conservative table at k = 8 and at k = 2 (fewer values per lookup, a larger margin)."""
    tables: dict[tuple[str, int], tuple[gdm.Volume, dict[str, gdm.CompressedGDM]]] = {}
    for pattern in ("chain", "weave"):
        for nz in (16, 32):
            vol = gdm.Volume.procedural(pattern, (64, 64, nz))  # type: ignore[arg-type]
            lower = vol.distance_function((16, 32), lower_bound=True)
            tables[pattern, nz] = vol, {"lookup": vol.distance_function((16, 32)).compress(K),
                                        "bound": lower.compress(K), "bound_k2": lower.compress(2)}
    renderer = gt.Renderer(size, size)
    out = []
    for base in ("torus", "bunny"):
        for pattern in ("chain", "weave"):
            objs: dict[str, Any] = {}
            counts: dict[str, dict[str, float]] = {}
            cam: gt.Camera | None = None
            for nz in (16, 32):
                vol, t = tables[pattern, nz]
                modes = {"exact": None, **t}
                for name, table in modes.items():
                    kw = {} if table is None else {"lookup": table}
                    objs[f"{name}/{nz}"], thickness = shells_one(base, vol, **kw)
                    if f"mesh/{nz}" not in objs:
                        explicit = objs[f"{name}/{nz}"].to_mesh()
                        # One camera for both slice counts (the 16-slice mesh frames it).
                        cam = cam or cameras(explicit, 1, 2 if base == "torus" else 1)[0]
                        objs[f"mesh/{nz}"] = gt.as_mesh(explicit)
                        ref = reference.RayCaster(explicit).cast(cam, size, size)
                    counted = shells_one(base, vol, count_steps=True, **kw)[0]
                    terms = 0 if table is None else int(table.eigen.shape[0])
                    counts[f"{name}/{nz}"] = mode_work(renderer, objs[f"{name}/{nz}"], counted, cam, ref,
                                                       thickness / nz, terms)
            names = list(objs)
            for name in names:
                renderer.render(objs[name], cam)  # warm-up: pipelines and uploads
            ms: dict[str, list[float]] = {n: [] for n in names}
            load = list(os.getloadavg())
            for r in range(rounds):
                for name in names[r % len(names):] + names[:r % len(names)]:
                    ms[name].append(1000 * timed(renderer, objs[name], cam)[1])
            out.append({"pattern": pattern, "base": base, "size": size, "rounds": rounds, "load_start": load,
                        "load_end": list(os.getloadavg()), "ms": ms,
                        "ms_median": {n: float(np.median(v)) for n, v in ms.items()}, "counts": counts})
            med = out[-1]["ms_median"]
            print(f"slices {base:6} {pattern:6}: " + ", ".join(f"{n} {med[n]:.0f} ms" for n in names)
                  + " | reads/px, IoU, p99 vox " + ", ".join(f"{n} {v['reads_mean']:.0f} {v['iou']:.4f} "
                                                            f"{v['p99_voxels']:.2f}" for n, v in counts.items()), flush=True)
    return out


def plot(results: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, c, b, e) = plt.subplots(1, 4, figsize=(21, 4))
    for dirs in ((8, 16), (16, 32)):
        rows = [r for r in results["svd"] if r["directions"] == list(dirs)]
        a.plot([r["k"] for r in rows], [r["rms"] for r in rows], "o-", label=f"{dirs[0]}x{dirs[1]} directions")
        for r in rows:
            a.annotate(f"{r['bytes'] / 1e6:.1f} MB", (r["k"], r["rms"]), fontsize=6)
    a.set_xlabel("SVD terms k")
    a.set_ylabel("rms error of d (voxels)")
    a.set_title("chain 64x64x16: SVD trade")
    a.legend()
    rows = results.get("bound_svd", [])
    if rows:
        ks = [r["k"] for r in rows]
        c.plot(ks, [r["bound_mean"] for r in rows], "k--", label="lower-bound table (uncompressed)")
        c.plot(ks, [r["per_row_mean"] for r in rows], "o-", label="SVD, overshoot subtracted per row")
        c.plot(ks, [r["global_mean"] for r in rows], "s-", label="SVD, overshoot subtracted globally")
        c.plot(ks, [r["exact_mean"] for r in rows], ":", label="exact table (not a bound)")
        c.set_xlabel("SVD terms k")
        c.set_ylabel("mean skip a lookup offers (voxels)")
        c.set_title("chain 64x64x16, 16x32: conservative table")
        c.legend(fontsize=7)
    labels = [f"{c['pattern']}/{c['size'][2]}\n{c['base']}" for c in results["cases"]]
    x = np.arange(len(labels))
    bars = [("exact", "exact march"), ("lookup", "GDM lookup k=8"), ("refined", f"lookup refined ±{REFINE} vox"),
            ("bound", "march driven by bound table k=8")]
    for off, (key, name) in zip((-0.32, -0.16, 0.0, 0.16), bars):
        b.bar(x + off, [c[key]["ms_median"] if key in c else np.nan for c in results["cases"]], 0.16, label=name)
    b.bar(x + 0.32, [c["mesh_ms_median"] for c in results["cases"]], 0.16, label="to_mesh() rasterized")
    b.set_xticks(x, labels, fontsize=7)
    b.set_ylabel("frame ms (whole call)")
    b.set_yscale("log")
    b.legend(fontsize=7)
    slices = results.get("slices", [])
    if slices:
        modes = [("exact", "exact march"), ("lookup", "GDM lookup k=8"), ("bound", "bounded march k=8"),
                 ("bound_k2", "bounded march k=2"), ("mesh", "to_mesh() rasterized")]
        x = np.arange(len(slices))
        for i, (key, name) in enumerate(modes):
            ratio = [s["ms_median"][f"{key}/32"] / s["ms_median"][f"{key}/16"] for s in slices]
            e.bar(x + (i - 2) * 0.16, ratio, 0.16, label=name)
        e.axhline(1.0, color="k", lw=0.5)
        e.set_xticks(x, [f"{s['pattern']}\n{s['base']}" for s in slices], fontsize=7)
        e.set_ylabel("frame ms at 32 slices / at 16 (interleaved)")
        e.set_title("cost against depth resolution")
        e.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--views", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds of the slice-count timing")
    ap.add_argument("--slices-size", type=int, default=256, help="frame size of the slice-count timing")
    ap.add_argument("--slices-only", action="store_true", help="rerun only the slice-count section "
                    "(slice_cost) into the existing gdm.json, its cases and SVD trade kept")
    ap.add_argument("--cases", default="", help="only these, e.g. bunny/chain/16,bunny/chain/32: rerun and "
                    "replaced in the existing gdm.json, its other cases and SVD trade kept")
    args = ap.parse_args()
    only = {tuple(c.split("/")) for c in args.cases.split(",") if c}
    path = OUT / "gdm.json"
    if args.slices_only:
        slices = slice_cost(args.slices_size, args.rounds)
        results = json.loads(path.read_text())  # read again: another run may have written it since
        results["slices"] = slices
        write_json(path, results, indent=1, default=str)
        plot(results, OUT / "gdm.png")
        return
    old = json.loads(path.read_text()) if only and path.exists() else None
    if old is not None and (old["size"], old["views"]) != (args.size, args.views):
        raise SystemExit("--cases must use the size and views of the existing gdm.json")
    cases = []
    for base in ("torus", "bunny"):
        for pattern in ("chain", "weave"):
            for nz in (16, 32):
                if only and (base, pattern, str(nz)) not in only:
                    kept = [c for c in (old or {}).get("cases", [])
                            if (c["base"], c["pattern"], c["size"][2]) == (base, pattern, nz)]
                    cases.extend(kept)
                    continue
                # Timings are noisy on a shared machine: each case says how loaded it ran.
                load = list(os.getloadavg())
                c = run_case(pattern, nz, base, args.size, args.views)
                c.update(date=datetime.datetime.now(datetime.timezone.utc).isoformat(), load_start=load,
                         load_end=list(os.getloadavg()))
                cases.append(c)
                print(f"{base:6} {pattern:6} nz={nz:2} | exact IoU {c['exact']['iou_min']:.4f} p99 "
                      f"{c['exact']['p99_voxels_max']:.2f} vox (1 px tol. {c['exact']['p99_1px_voxels_max']:.2f}) normal {c['exact']['normal_deg_max']:.1f} deg "
                      f"{c['exact']['ms_median']:.0f} ms | lookup IoU {c['lookup']['iou_min']:.3f} p99 "
                      f"{c['lookup']['p99_voxels_max']:.1f} vox {c['lookup']['ms_median']:.0f} ms | refined IoU "
                      f"{c['refined']['iou_min']:.3f} p99 {c['refined']['p99_voxels_max']:.1f} vox "
                      f"(1 px {c['refined']['p99_1px_voxels_max']:.1f}) {c['refined']['ms_median']:.0f} ms | mesh "
                      f"{c['mesh_ms_median']:.0f} ms ({c['explicit_faces']} faces) | bytes vol {c['bytes_volume']} "
                      f"svd {c['bytes_svd']} explicit {c['bytes_explicit']}", flush=True)
                b = c["bound"]
                print(f"    bound: IoU {b['iou_min']:.4f} p99 {b['p99_voxels_max']:.2f} vox normal "
                      f"{b['normal_deg_max']:.2f} deg {b['ms_median']:.0f} ms | counts {c['counts']} | "
                      f"precompute {c['precompute_bound_s']:.1f} s", flush=True)
    results = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(), "machine": platform.platform(),
               "adapter": gt.Renderer(8, 8).adapter_info, "size": args.size, "views": args.views, "k": K,
               "cases": cases, "svd": old["svd"] if old is not None else svd_trade(),
               "bound_svd": old["bound_svd"] if old is not None and "bound_svd" in old else bound_trade()}
    if old is not None:
        results["rerun"] = sorted("/".join(c) for c in only)
        if "slices" in old:
            results["slices"] = old["slices"]
    else:
        results["slices"] = slice_cost(args.slices_size, args.rounds)
    results["inverted"] = inverted_cost(args.size, args.views)
    print(f"inverted prisms (bunny): {results['inverted']}")
    for r in results["svd"]:
        print(f"svd {r['directions']} k={r['k']:2}: rms {r['rms']:.3f} vox, {r['bytes'] / 1e6:.2f} MB "
              f"(table {r['table_bytes'] / 1e6:.1f} MB)")
    OUT.mkdir(parents=True, exist_ok=True)
    write_json(path, results, indent=1, default=str)
    plot(results, OUT / "gdm.png")


if __name__ == "__main__":
    main()
