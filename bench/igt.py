"""Benchmark of inverse geometric textures (issue 17): a simplified mesh shaded per pixel with the
detailed mesh's attributes, found through per-cell triangle lists of a primary parameterization.

In one run, on one wgpu adapter, at 512x512:

* tables (the paper's Tables 1 and 2): for the Stanford bunny (69,451 faces), spot (textured,
  5,856 faces) and, without ``--quick``, the bunny after two Loop subdivisions (~1.1 M faces),
  with our charts and a spherical map as the primary, at resolutions 128² to 1024²: list length
  (mean over non-empty cells, max, histogram), empty cells, bytes per part and per detailed
  face, build seconds, and the frame time of the mesh simplified to 2% shaded through it (GPU
  timestamps, median of ``--repeats`` after a warm-up; front view);
* accuracy: the bunny simplified to 10%, 2% and 0.5% of its faces from five views, against
  trimesh + embree ray casting of the detailed mesh (normals interpolated by the same crease
  rule): median normal angle of the IGT-shaded frame and of the plain simplified mesh (their
  ratio), and the share of pixels whose detailed face agrees with embree's, on pixels both hit
  and not within one pixel of either silhouette; for the ray lookup (the default) and the
  projection lookup (``lookup="projection"``) of the same simplified mesh, with their frame
  times side by side;
* filtering: samples=1 against samples=5 on the bunny at 10% and 2% from two views, against
  embree at 4 x 4 rays per pixel (normals averaged per pixel): median and p90 normal angle,
  frame time;
* color: spot with its texture simplified to 5% (and 20%, 50%), against trimesh ray casting of
  the textured detailed mesh (bilinear texture color at the hit's texture coordinates): mean
  absolute RGB difference on interior pixels (``reference.albedo_difference``), and a
  side-by-side PNG;
* speed: the 1.1 M-face bunny rasterized against its simplification (2% and 0.5%) shaded
  through its IGT (512² and 2048² cells), and the plain simplified meshes, in turn in one run
  on the same adapter (median of three rounds);
* lod (the shader LoD): the bunny at 2% with its 512² texture, the camera at multiples of the
  distance where one cell spans one pixel (``lod="auto"``'s switch): frame time through the
  lists, with "auto", and fully baked; the share of pixels "auto" bakes; median normal error
  against embree of each; the pop (mean normal difference and mean shaded-gray difference
  between the lists' frame and the baked one on the same pixels), beside what the lists' own
  frame changes when the camera moves 1% nearer (the flicker there is anyway);
* occlusion (``attributes=["ao"]``): build seconds of 64 cosine-weighted rays per vertex on the
  bunny, and the per-vertex result against embree's estimate from 1,024 independent random
  rays on 400 vertices (the 200 most occluded and 200 at random): mean |difference|, bias.

``--sections`` runs some of these and merges them into the existing JSON (each section keeps
its own load figures). Results: ``bench/results/igt.json``, ``bench/results/igt.png``,
``bench/results/igt_spot.png`` and ``bench/results/igt_lod.png``. The machine's load
(``os.getloadavg``) is recorded at the start and the end.

Run from the repository root::

    nice python bench/igt.py            # all three meshes (~11 min on 2 busy cores)
    nice python bench/igt.py --quick    # bunny and spot only
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np
from _meta import write_json  # noqa: E402  (bench/ is on sys.path: run as python bench/<name>.py)

import geomtex as gt
from geomtex import reference
from render import dense_bunny  # type: ignore[import-not-found]

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared" / "meshes"
BUNNY = SHARED / "stanford-bunny.obj"
OUT = REPO / "bench" / "results"
SIZE = 512
RESOLUTIONS = (128, 256, 512, 1024)
PRIMARIES = ("charts", "spherical")
FRACTIONS = (0.1, 0.02, 0.005)
SPOT_FRACTIONS = (0.05, 0.2, 0.5)
# samples=1 against 5: these fractions, two views, against SUPERSAMPLE² embree rays per pixel.
FILTER_FRACTIONS = (0.1, 0.02)
SUPERSAMPLE = 4
# The 1.1 M-face bunny: 512² cells give lists of 14 triangles; 2048² about as many cells as faces.
DENSE_RESOLUTIONS = (512, 2048)
DENSE_TABLE_RESOLUTIONS = (256, 512, 1024)
VIEWS = ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.3, 0.8, 0.5))


def load_spot() -> gt.Mesh:
    import trimesh
    from PIL import Image

    tm = trimesh.load(SHARED / "spot.obj", force="mesh", process=False)
    tm.visual = trimesh.visual.TextureVisuals(uv=tm.visual.uv, image=Image.open(SHARED / "spot_texture.png"))
    return gt.Mesh.from_trimesh(tm)


def camera(igt: gt.igt.InverseGeometricTexture, direction: tuple[float, float, float]) -> gt.Camera:
    v = igt.vertices
    centre, diag = (v.min(0) + v.max(0)) / 2, float(np.linalg.norm(v.max(0) - v.min(0)))
    d = np.asarray(direction, float)
    up = (0.0, 0.0, 1.0) if abs(d[1]) > 0.9 * np.linalg.norm(d) else (0.0, 1.0, 0.0)
    return gt.Camera.look_at(centre + d / np.linalg.norm(d) * 1.3 * diag, centre, up=up)


def timed(renderer: gt.Renderer, obj: Any, cam: gt.Camera, repeats: int) -> tuple[gt.Frame, float]:
    """The last frame and the median GPU ms of `repeats` renders after a warm-up."""
    frame = renderer.render(obj, cam)
    ms = []
    for _ in range(repeats):
        frame = renderer.render(obj, cam)
        ms.append(frame.stats["gpu_ms"] if frame.stats["gpu_ms"] is not None else frame.stats["cpu_ms"])
    return frame, float(np.median(ms))


def decimate(mesh_vertices: np.ndarray, faces: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """pymeshlab's quadric collapse, as geomtex.igt.simplify runs it (once per mesh and fraction
    here, then attached to each texture)."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=mesh_vertices, face_matrix=faces.astype(np.int32)))
    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=int(target), preservenormal=True, qualitythr=0.5)
    m = ms.current_mesh()
    return np.asarray(m.vertex_matrix()), np.asarray(m.face_matrix())


def interior(mask: np.ndarray) -> np.ndarray:
    """`mask` less its pixels within one pixel of its boundary."""
    return np.logical_and.reduce(reference._neighbours(mask, False))


def tables(name: str, mesh: gt.Mesh, renderer: gt.Renderer, repeats: int,
           resolutions: tuple[int, ...]) -> list[dict[str, Any]]:
    """Table 1 / 2 rows of one mesh: every primary and resolution."""
    low = decimate(np.asarray(mesh.vertices), np.asarray(mesh.faces), max(4, int(mesh.n_faces * 0.02)))
    rows = []
    for primary in PRIMARIES:
        for res in resolutions:
            t0 = time.perf_counter()
            igt = gt.igt.build(mesh, primary=primary, resolution=res)
            build_s = time.perf_counter() - t0
            shaded = gt.igt.attach(igt, *low)
            frame, ms = timed(renderer, shaded, camera(igt, VIEWS[0]), repeats)
            s = igt.stats
            row = {"mesh": name, "primary": primary, "resolution": res, "build_s": build_s,
                   "simplified_faces": len(shaded), "gpu_ms": ms,
                   "pixels": int(np.isfinite(frame.depth).sum()),
                   **{k: v for k, v in s.items() if not k.startswith("seconds_")}}
            rows.append(row)
            print(f"{name:12s} {primary:9s} {res:5d}  list {s['list_mean']:5.2f} max {s['list_max']:4.0f}  "
                  f"{s['bytes'] / 1e6:6.2f} MB ({s['bytes_per_face']:5.1f} B/face)  build {build_s:5.1f} s  "
                  f"frame {ms:6.1f} ms", flush=True)
    return rows


def accuracy(renderer: gt.Renderer, repeats: int) -> list[dict[str, Any]]:
    """The bunny at three simplifications from five views against embree."""
    import trimesh

    mesh = gt.load_mesh(BUNNY)
    igt = gt.igt.build(mesh, resolution=512)
    detailed = trimesh.Trimesh(igt.vertices, igt.faces, process=False)
    caster = reference.RayCaster(detailed)
    corners = reference.corner_normals(detailed)
    lows = {f: gt.igt.simplify(igt, int(len(igt.faces) * f)) for f in FRACTIONS}
    projected = {f: gt.igt.attach(igt, low.vertices, low.faces, lookup="projection") for f, low in lows.items()}
    rows = []
    for k, view in enumerate(VIEWS):
        cam = camera(igt, view)
        ref = caster.cast(cam, SIZE, SIZE)
        ref_normal = reference.shading_normals(detailed, corners, ref)
        for fraction, low in lows.items():
            frame, ms = timed(renderer, low, cam, repeats)
            proj, proj_ms = timed(renderer, projected[fraction], cam, repeats)
            plain, plain_ms = timed(renderer, gt.Mesh(low.vertices, low.faces), cam, repeats)
            mask = interior(ref["hit"]) & interior(np.isfinite(frame.depth))
            igt_deg = reference.normal_angles(frame.normal, ref_normal, mask)
            proj_deg = reference.normal_angles(proj.normal, ref_normal, mask)
            plain_deg = reference.normal_angles(plain.normal, ref_normal, mask)
            agree = float((frame.face_id[mask] == ref["triangle"][mask]).mean())
            row = {"view": k, "fraction": fraction, "faces": len(low), "pixels": int(mask.sum()),
                   "igt_normal_deg_median": float(np.median(igt_deg)),
                   "igt_normal_deg_p90": float(np.percentile(igt_deg, 90)),
                   "plain_normal_deg_median": float(np.median(plain_deg)),
                   "ratio": float(np.median(plain_deg) / np.median(igt_deg)),
                   "face_agreement": agree,
                   "no_face_fraction": float((frame.face_id[mask] < 0).mean()),
                   "projection_normal_deg_median": float(np.median(proj_deg)),
                   "projection_face_agreement": float((proj.face_id[mask] == ref["triangle"][mask]).mean()),
                   "window_outside_median": float(np.median(low.face_window[:, 0])),
                   "window_inside_median": float(np.median(low.face_window[:, 1])),
                   "search_grids_mean": float((low.search_grids >= 0).sum(axis=1).mean()),
                   "igt_gpu_ms": ms, "projection_gpu_ms": proj_ms, "plain_gpu_ms": plain_ms,
                   "ray_over_projection_ms": ms / proj_ms}
            rows.append(row)
            print(f"view {k} {fraction:6.3f} ({len(low):5d} faces)  normal {row['igt_normal_deg_median']:5.2f}° "
                  f"(projection {row['projection_normal_deg_median']:5.2f}°) vs plain "
                  f"{row['plain_normal_deg_median']:5.2f}° ({row['ratio']:5.1f}x)  faces {agree:.4f} "
                  f"(projection {row['projection_face_agreement']:.4f})  {ms:6.1f} ms vs projection "
                  f"{proj_ms:6.1f} ms", flush=True)
    return rows


def color(renderer: gt.Renderer) -> list[dict[str, Any]]:
    """Spot with its texture, simplified, against the textured detailed mesh; a PNG of 5%."""
    from PIL import Image

    spot = load_spot()
    igt = gt.igt.build(spot, resolution=512)
    rows, images = [], []
    for fraction in SPOT_FRACTIONS:
        low = gt.igt.simplify(igt, int(spot.n_faces * fraction))
        projected = gt.igt.attach(igt, low.vertices, low.faces, lookup="projection")
        for k, view in enumerate(((1.0, 0.3, 0.2), (0.2, 0.3, 1.0))):
            cam = camera(igt, view)
            frame = renderer.render(low, cam)
            proj = renderer.render(projected, cam)
            ref = reference.raycast_albedo(spot, cam, SIZE, SIZE)
            d = reference.albedo_difference(frame.albedo, ref, np.isfinite(frame.depth))
            dp = reference.albedo_difference(proj.albedo, ref, np.isfinite(proj.depth))
            both = ref["hit"] & (frame.face_id >= 0)
            rows.append({"fraction": fraction, "faces": len(low), "view": k, **d,
                         "face_agreement": float((frame.face_id[both] == ref["triangle"][both]).mean()),
                         "projection_mean": dp["mean"]})
            print(f"spot {fraction:4.2f} ({len(low)} faces) view {k}: mean |Δcolor| {d['mean']:.2f}/255 "
                  f"(projection {dp['mean']:.2f}) on {d['interior_px']} px", flush=True)
            if fraction == SPOT_FRACTIONS[0] and k == 0:
                plain = renderer.render(gt.Mesh(low.vertices, low.faces), cam)
                images = [frame.albedo, ref["albedo"], plain.albedo]
    Image.fromarray(np.concatenate(images, axis=1)).save(OUT / "igt_spot.png")
    return rows


def filtering(renderer: gt.Renderer, repeats: int) -> list[dict[str, Any]]:
    """One sample per pixel against five (samples=5: the centre and four points of the pixel's
    footprint, averaged), against embree's ray cast of the detailed bunny at SUPERSAMPLE² rays
    per pixel with its normals averaged per pixel (pixels whose rays all hit, not within a pixel
    of a silhouette): median and p90 normal angle, and frame time."""
    import trimesh

    mesh = gt.load_mesh(BUNNY)
    igt = gt.igt.build(mesh, resolution=512)
    detailed = trimesh.Trimesh(igt.vertices, igt.faces, process=False)
    caster = reference.RayCaster(detailed)
    corners = reference.corner_normals(detailed)
    k = SUPERSAMPLE
    rows = []
    for fraction in FILTER_FRACTIONS:
        one = gt.igt.simplify(igt, int(len(igt.faces) * fraction))
        five = gt.igt.attach(igt, one.vertices, one.faces, samples=5)
        for view in VIEWS[:2]:
            cam = camera(igt, view)
            ref = caster.cast(cam, SIZE * k, SIZE * k)
            normals = reference.shading_normals(detailed, corners, ref).reshape(SIZE, k, SIZE, k, 3).sum(axis=(1, 3))
            hit = ref["hit"].reshape(SIZE, k, SIZE, k).all(axis=(1, 3))
            row: dict[str, Any] = {"fraction": fraction, "faces": len(one), "view": VIEWS.index(view)}
            for name, low in (("one", one), ("five", five)):
                frame, ms = timed(renderer, low, cam, max(1, repeats // 2))
                mask = interior(hit) & interior(np.isfinite(frame.depth))
                deg = reference.normal_angles(frame.normal, normals, mask)
                row |= {f"{name}_deg_median": float(np.median(deg)), f"{name}_deg_p90": float(np.percentile(deg, 90)),
                        f"{name}_gpu_ms": ms, "pixels": int(mask.sum())}
            rows.append(row)
            print(f"filtering {fraction:5.3f} view {row['view']}: normal vs {k}x{k} supersampled median "
                  f"{row['one_deg_median']:.3f}° (1 sample) / {row['five_deg_median']:.3f}° (5), p90 "
                  f"{row['one_deg_p90']:.3f}° / {row['five_deg_p90']:.3f}°; {row['one_gpu_ms']:.0f} / "
                  f"{row['five_gpu_ms']:.0f} ms", flush=True)
    return rows


def speed(renderer: gt.Renderer, repeats: int) -> dict[str, Any]:
    """The 1.1 M-face bunny rasterized, against its simplifications shaded through its IGT (at
    two resolutions) and plain, in turn in one run."""
    dense = dense_bunny(BUNNY, 2)
    lows = {f: decimate(np.asarray(dense.vertices), np.asarray(dense.faces), int(dense.n_faces * f))
            for f in (0.02, 0.005)}
    objects: dict[str, Any] = {"detailed_mesh": dense}
    builds: dict[str, Any] = {}
    for res in DENSE_RESOLUTIONS:
        t0 = time.perf_counter()
        igt = gt.igt.build(dense, resolution=res)
        builds[str(res)] = {"build_s": time.perf_counter() - t0,
                            "stats": {k: v for k, v in igt.stats.items() if k != "histogram"}}
        for f, low in lows.items():
            # No lod="auto" twin: its attach (the windows) costs as much again as this one's
            # (~6 min on 2 busy cores), and since issue 17 the face-id lookup, which LoD frames
            # pay too, is the only lookup a pixel makes; the lod section measures the LoD.
            objects[f"igt_{res}_{f}"] = gt.igt.attach(igt, *low)
    for f, low in lows.items():
        objects[f"plain_{f}"] = gt.Mesh(*low)
    cam = camera(igt, VIEWS[0])
    ms: dict[str, list[float]] = {k: [] for k in objects}
    for _ in range(3):  # rounds: each object in turn, so a busy neighbour shifts all alike
        for k, obj in objects.items():
            ms[k].append(timed(renderer, obj, cam, max(1, repeats // 3))[1])
    medians = {k: float(np.median(v)) for k, v in ms.items()}
    out = {"faces": int(dense.n_faces), "builds": builds,
           "simplified_faces": {str(f): len(low[1]) for f, low in lows.items()}, "gpu_ms": medians,
           "speedup": {k: medians["detailed_mesh"] / v for k, v in medians.items() if k.startswith("igt_")}}
    print(json.dumps(out["gpu_ms"], indent=1), flush=True)
    return out


# Camera distances of the LoD sweep, in units of the distance where one cell spans one pixel.
LOD_DISTANCES = (0.5, 0.7, 1.0, 1.4, 2.0, 4.0)


def lod(renderer: gt.Renderer, repeats: int) -> list[dict[str, Any]]:
    """The shader LoD's sweep over camera distance (see the module's docstring)."""
    import trimesh

    mesh = gt.load_mesh(BUNNY)
    igt = gt.igt.build(mesh, resolution=512)
    low = gt.igt.simplify(igt, int(len(igt.faces) * 0.02))
    shaded = {name: gt.igt.attach(igt, low.vertices, low.faces, lod=value)
              for name, value in (("lists", "off"), ("auto", "auto"), ("baked", 1e-9))}
    detailed = trimesh.Trimesh(igt.vertices, igt.faces, process=False)
    caster = reference.RayCaster(detailed)
    corners = reference.corner_normals(detailed)
    v = igt.vertices
    centre = (v.min(0) + v.max(0)) / 2
    pixel = 2 * np.tan(np.radians(45.0) / 2) / SIZE
    switch = float(igt.grids["cell"][0, 0]) / pixel
    d = np.asarray(VIEWS[0]) / np.linalg.norm(VIEWS[0])
    rows = []
    for k in LOD_DISTANCES:
        cam = gt.Camera.look_at(centre + d * switch * k, centre)
        frames, ms = {}, {}
        for name, obj in shaded.items():
            frames[name], ms[name] = timed(renderer, obj, cam, repeats)
        closer = renderer.render(shaded["lists"], gt.Camera.look_at(centre + d * switch * k * 0.99, centre))
        ref = caster.cast(cam, SIZE, SIZE)
        ref_normal = reference.shading_normals(detailed, corners, ref)
        lists, auto, baked = frames["lists"], frames["auto"], frames["baked"]
        mask = interior(ref["hit"]) & interior(np.isfinite(lists.depth))
        both = mask & interior(np.isfinite(closer.depth))

        def gray(f: gt.Frame) -> np.ndarray:
            return f.color[..., :3].astype(float).mean(axis=-1)

        row = {"distance_over_switch": k, "distance": switch * k, "pixels": int(mask.sum()),
               "lists_gpu_ms": ms["lists"], "auto_gpu_ms": ms["auto"], "baked_gpu_ms": ms["baked"],
               "auto_baked_share": float((auto.normal == baked.normal).all(axis=-1)[mask].mean()),
               "pop_normal_deg_mean": float(reference.normal_angles(lists.normal, baked.normal, mask).mean()),
               "pop_gray_mean": float(np.abs(gray(lists) - gray(baked))[mask].mean()),
               "motion_normal_deg_mean": float(reference.normal_angles(lists.normal, closer.normal, both).mean()),
               "motion_gray_mean": float(np.abs(gray(lists) - gray(closer))[both].mean())}
        for name, f in frames.items():
            row[f"{name}_normal_deg_median"] = float(np.median(reference.normal_angles(f.normal, ref_normal, mask)))
        rows.append(row)
        print(f"lod {k:4.1f} x switch ({switch * k:.3f}): {ms['lists']:6.1f} ms lists, {ms['auto']:6.1f} auto "
              f"({100 * row['auto_baked_share']:3.0f}% baked), {ms['baked']:6.1f} baked; pop "
              f"{row['pop_normal_deg_mean']:.2f}° / {row['pop_gray_mean']:.2f} gray (1% motion: "
              f"{row['motion_normal_deg_mean']:.2f}° / {row['motion_gray_mean']:.2f}); median error "
              f"{row['lists_normal_deg_median']:.3f}° lists, {row['baked_normal_deg_median']:.3f}° baked", flush=True)
    return rows


def occlusion(repeats: int) -> dict[str, Any]:
    """Ambient occlusion per vertex on the bunny against embree (see the module's docstring)."""
    import trimesh

    mesh = gt.load_mesh(BUNNY)
    seconds = []
    for _ in range(max(1, repeats // 2)):
        igt = gt.igt.build(mesh, resolution=128, attributes=["normals", "ao"])
        seconds.append(igt.stats["seconds_occlusion"])
    ao = igt.ao
    assert ao is not None
    vertex_ao = np.ones(len(igt.vertices), np.float32)
    vertex_ao[igt.faces] = ao
    tm = trimesh.Trimesh(igt.vertices, igt.faces, process=False)
    rng = np.random.default_rng(2)
    picked = np.concatenate([np.argsort(vertex_ao)[:200], rng.choice(len(igt.vertices), 200, replace=False)])
    rays = 1024
    ref = reference.occlusion(tm, picked, rays, seed=3)
    diff = vertex_ao[picked] - ref
    out = {"vertices": len(igt.vertices), "rays": 64, "seconds": float(np.median(seconds)),
           "reference_rays": rays, "compared": len(picked), "mean_abs_diff": float(np.abs(diff).mean()),
           "bias": float(diff.mean()), "p95_abs_diff": float(np.percentile(np.abs(diff), 95)),
           "reference_min": float(ref.min()), "mean_ao": float(vertex_ao.mean())}
    print(f"occlusion: {out['seconds']:.1f} s for {out['vertices']} vertices x 64 rays; against embree "
          f"(1,024 rays) mean |diff| {out['mean_abs_diff']:.4f}, bias {out['bias']:+.4f}", flush=True)
    return out


def plot_lod(rows: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    k = [r["distance_over_switch"] for r in rows]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for name, style in (("lists", "-o"), ("auto", "-s"), ("baked", "--^")):
        ax[0].plot(k, [r[f"{name}_gpu_ms"] for r in rows], style, label=name)
    ax[0].set_yscale("log")
    ax[0].set_title("frame ms (bunny 2% + IGT 512²)")
    ax[1].plot(k, [r["pop_normal_deg_mean"] for r in rows], "-o", label="pop: lists vs baked")
    ax[1].plot(k, [r["motion_normal_deg_mean"] for r in rows], "--s", label="lists, camera 1% nearer")
    ax[1].set_title("mean normal difference (°)")
    for a in ax:
        a.set_xscale("log", base=2)
        a.set_xlabel("camera distance / distance where a cell spans a pixel")
        a.axvline(1.0, color="gray", lw=0.8)
        a.legend()
    fig.suptitle(f"shader LoD at {SIZE}² (bench/igt.py)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def summary(data: dict[str, Any]) -> dict[str, Any]:
    acc = data["accuracy"]
    out: dict[str, Any] = {}
    for f in FRACTIONS:
        rows = [r for r in acc if r["fraction"] == f]
        out[f"bunny_{f}"] = {
            "faces": rows[0]["faces"],
            "igt_normal_deg_median": [min(r["igt_normal_deg_median"] for r in rows),
                                      max(r["igt_normal_deg_median"] for r in rows)],
            "plain_normal_deg_median": [min(r["plain_normal_deg_median"] for r in rows),
                                        max(r["plain_normal_deg_median"] for r in rows)],
            "ratio": [min(r["ratio"] for r in rows), max(r["ratio"] for r in rows)],
            "face_agreement": [min(r["face_agreement"] for r in rows), max(r["face_agreement"] for r in rows)],
            "projection_normal_deg_median": [min(r["projection_normal_deg_median"] for r in rows),
                                             max(r["projection_normal_deg_median"] for r in rows)],
            "projection_face_agreement": [min(r["projection_face_agreement"] for r in rows),
                                          max(r["projection_face_agreement"] for r in rows)],
            "igt_gpu_ms": float(np.median([r["igt_gpu_ms"] for r in rows])),
            "projection_gpu_ms": float(np.median([r["projection_gpu_ms"] for r in rows])),
            "ray_over_projection_ms": [min(r["ray_over_projection_ms"] for r in rows),
                                       max(r["ray_over_projection_ms"] for r in rows)],
            "plain_gpu_ms": float(np.median([r["plain_gpu_ms"] for r in rows])),
        }
    for f in SPOT_FRACTIONS:
        rows = [r for r in data["color"] if r["fraction"] == f]
        out[f"spot_{f}_color_mean"] = [min(r["mean"] for r in rows), max(r["mean"] for r in rows)]
        out[f"spot_{f}_projection_color_mean"] = [min(r["projection_mean"] for r in rows),
                                                  max(r["projection_mean"] for r in rows)]
    for f in FILTER_FRACTIONS:
        rows = [r for r in data["filtering"] if r["fraction"] == f]
        out[f"filtering_{f}"] = {key: [min(r[key] for r in rows), max(r[key] for r in rows)]
                                 for key in ("one_deg_median", "five_deg_median", "one_deg_p90", "five_deg_p90",
                                             "one_gpu_ms", "five_gpu_ms")}
    if data.get("speed"):
        out["speed"] = data["speed"]["gpu_ms"] | {"speedup": data["speed"]["speedup"]}
    if data.get("lod"):
        at = min(data["lod"], key=lambda r: abs(r["distance_over_switch"] - 1.0))
        out["lod_at_switch"] = {key: at[key] for key in (
            "lists_gpu_ms", "auto_gpu_ms", "baked_gpu_ms", "auto_baked_share", "pop_normal_deg_mean",
            "pop_gray_mean", "motion_normal_deg_mean", "motion_gray_mean", "lists_normal_deg_median",
            "baked_normal_deg_median")}
    if data.get("occlusion"):
        out["occlusion"] = data["occlusion"]
    return out


def plot(data: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 4, figsize=(19, 4.2))
    for mesh in sorted({r["mesh"] for r in data["tables"]}):
        for primary, style in zip(PRIMARIES, ("-o", "--s")):
            rows = [r for r in data["tables"] if r["mesh"] == mesh and r["primary"] == primary]
            res = [r["resolution"] for r in rows]
            ax[0].plot(res, [r["list_mean"] for r in rows], style, label=f"{mesh} {primary}")
            ax[1].plot(res, [r["bytes"] / 1e6 for r in rows], style, label=f"{mesh} {primary}")
            ax[2].plot(res, [r["gpu_ms"] for r in rows], style, label=f"{mesh} {primary}")
    for a, title in zip(ax[:3], ("triangles per non-empty cell (mean)", "MB (four tables)",
                                 "frame ms, 2% mesh + IGT")):
        a.set_xscale("log", base=2)
        a.set_xlabel("resolution (cells a side)")
        a.set_title(title)
    ax[0].legend(fontsize=7)
    acc = data["accuracy"]
    for key, style, label in (("igt_normal_deg_median", "-o", "IGT, ray lookup"),
                              ("projection_normal_deg_median", "-.^", "IGT, projection lookup"),
                              ("plain_normal_deg_median", "--s", "plain")):
        med = [np.median([r[key] for r in acc if r["fraction"] == f]) for f in FRACTIONS]
        ax[3].plot([100 * f for f in FRACTIONS], med, style, label=label)
    ax[3].set_xscale("log")
    ax[3].set_yscale("log")
    ax[3].set_xlabel("% of the bunny's faces kept")
    ax[3].set_title("median normal error vs embree (°, 5 views)")
    ax[3].legend()
    fig.suptitle(f"inverse geometric textures at {SIZE}² (bench/igt.py)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)


SECTIONS = ("tables", "dense_tables", "accuracy", "color", "filtering", "speed", "lod", "occlusion")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="bunny and spot only")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--sections", default=",".join(SECTIONS),
                        help="comma-separated sections to run, merged into the existing JSON")
    args = parser.parse_args()
    sections = args.sections.split(",")
    unknown = set(sections) - set(SECTIONS)
    if unknown:
        parser.error(f"unknown sections {sorted(unknown)}; choose from {SECTIONS}")
    renderer = gt.Renderer(SIZE, SIZE)
    OUT.mkdir(parents=True, exist_ok=True)
    path = OUT / "igt.json"
    full = set(sections) == set(SECTIONS)
    data: dict[str, Any] = {} if full or not path.exists() else json.loads(path.read_text())
    stamp = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
             "machine": platform.platform(), "adapter": renderer.adapter_info, "size": SIZE,
             "repeats": args.repeats, "load_start": os.getloadavg()}
    if full:
        data |= stamp
    runs = {
        "tables": lambda: tables("bunny", gt.load_mesh(BUNNY), renderer, args.repeats, RESOLUTIONS)
        + tables("spot", load_spot(), renderer, args.repeats, RESOLUTIONS),
        # The paper's tables for the 1.1M-face bunny too (issue 17), at the resolutions its lists
        # stay short on (Table 2's range).
        "dense_tables": lambda: None if args.quick else tables(
            "bunny_loop2", dense_bunny(BUNNY, 2), renderer, args.repeats, DENSE_TABLE_RESOLUTIONS),
        "accuracy": lambda: accuracy(renderer, args.repeats),
        "color": lambda: color(renderer),
        "filtering": lambda: filtering(renderer, args.repeats),
        "speed": lambda: None if args.quick else speed(renderer, args.repeats),
        "lod": lambda: lod(renderer, args.repeats),
        "occlusion": lambda: occlusion(args.repeats),
    }
    for name in sections:
        start = os.getloadavg()
        data[name] = runs[name]()
        if not full:
            data.setdefault("section_runs", {})[name] = stamp | {"load_start": start, "load_end": os.getloadavg()}
    data["load_end"] = os.getloadavg()
    data["summary"] = summary(data)
    write_json(path, data, indent=1)
    if "tables" in data and "accuracy" in data:
        plot(data, OUT / "igt.png")
    if data.get("lod"):
        plot_lod(data["lod"], OUT / "igt_lod.png")
    print(json.dumps({k: data["summary"][k] for k in ("lod_at_switch", "occlusion") if k in data["summary"]},
                     indent=1))


if __name__ == "__main__":
    main()
