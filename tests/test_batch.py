"""geomtex.batch on a real Dask LocalCluster of two worker processes: conversions bit-identical to
a serial run, a worker killed mid-run losing nothing, resumed jobs doing no work, failures
recorded, and views in Zarr identical to Renderer.render."""

from __future__ import annotations

import json
import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

import geomtex as gt
from geomtex import batch
from geomtex.testing import GENERATED, look_from

from conftest import SHARED_MESHES, pymeshlab_bunny_path

distributed = pytest.importorskip("dask.distributed")
zarr = pytest.importorskip("zarr")

OPTIONS = {"max_resolution": 48}


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=40) as cluster, distributed.Client(cluster) as c:
        yield c


def inputs(tmp: Path) -> list:
    """At least 20 inputs: generated meshes in memory, generated meshes written to files, the
    cow scan that ships inside the pymeshlab wheel (every install has it), and the shared scans
    where they are beside this checkout."""
    made = [trimesh.creation.icosphere(subdivisions=s, radius=r) for s in (2, 3, 4) for r in (1.0, 2.5)]
    made += [trimesh.creation.torus(1.0, minor, major_sections=48, minor_sections=24) for minor in (0.2, 0.35, 0.5)]
    made += [trimesh.creation.box(extents=e) for e in ((1, 1, 1), (2, 1, 0.5))]
    made += [trimesh.creation.capsule(height=h, radius=0.4, count=[24, 24]) for h in (0.5, 1.5)]
    made += [trimesh.creation.cylinder(radius=0.5, height=h, sections=48) for h in (0.3, 2.0)]
    made += [GENERATED[name]() for name in ("sphere", "torus", "fractal_terrain", "open_sheet")]
    files = []
    for i, mesh in enumerate(made[:4]):
        path = tmp / f"generated-{i}.ply"
        (mesh if isinstance(mesh, trimesh.Trimesh) else mesh.to_trimesh()).export(path)
        files.append(str(path))
    shared = [str(SHARED_MESHES / f"{n}.obj") for n in ("fandisk", "teapot") if (SHARED_MESHES / f"{n}.obj").exists()]
    cow = str(pymeshlab_bunny_path().with_name("cow.obj"))
    return made[4:] + files + [cow] + shared


def kill_a_busy_worker(c, killed: dict) -> None:
    """Waits until a conversion is running, then SIGKILLs that worker process."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        busy = [addr for addr, keys in c.processing().items() if keys]
        done = len(c.who_has())
        if busy and done >= 3:
            addr = busy[0]
            pid = c.run(os.getpid, workers=[addr])[addr]
            killed.update(pid=pid, in_flight=list(c.processing()[addr]))
            os.kill(pid, signal.SIGKILL)
            return
        time.sleep(0.02)


def test_convert_many_is_serial_bit_for_bit_and_survives_a_killed_worker(client, tmp_path) -> None:
    sources = inputs(tmp_path)
    assert len(sources) >= 20
    out = tmp_path / "out"
    killed: dict = {}
    killer = threading.Thread(target=kill_a_busy_worker, args=(client, killed))
    killer.start()
    rows = batch.convert_many(sources, out, client=client, progress=False, **OPTIONS)
    killer.join()
    assert killed, "no worker was killed: the run ended before a task was seen running"
    # One row per input, every one done, its file there exactly once.
    assert [r["status"] for r in rows] == ["done"] * len(sources), [r["error"] for r in rows]
    files = sorted(p.name for p in out.glob("*.gtex"))
    assert files == sorted(r["output"] for r in rows)
    # (A worker killed while writing leaves at most a temporary file, never a partial .gtex.)
    manifest = batch.read_manifest(out)
    assert sorted(manifest["rows"]) == sorted(r["key"] for r in rows)
    # The tasks that were running on the killed worker finished on another worker.
    # (Task keys are geomtex-convert-<input key>-<run>.)
    rerun = [r for r in rows if any(str(k).startswith(f"geomtex-convert-{r['key']}-") for k in killed["in_flight"])]
    assert rerun and all(r["worker_pid"] != killed["pid"] for r in rerun)
    # Bit-identical to converting each input here, one after another.
    for source, row in zip(sources, rows):
        serial = gt.convert(source, **OPTIONS).to_bytes()
        assert (out / row["output"]).read_bytes() == serial, row["input"]


def test_a_finished_job_does_no_work_and_failures_are_recorded(client, tmp_path, monkeypatch) -> None:
    bad = tmp_path / "truncated.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nf 1 2 3\n")  # a face naming a vertex that is not there
    good = [trimesh.creation.icosphere(2), trimesh.creation.box()]
    out = tmp_path / "out"
    rows = batch.convert_many([*good, bad], out, client=client, progress=False, **OPTIONS)
    assert [r["status"] for r in rows] == ["done", "done", "failed"]
    assert "truncated.obj" in rows[2]["input"] and rows[2]["error"].startswith(("MeshError", "FormatError"))
    stamps = {p.name: p.stat().st_mtime_ns for p in out.glob("*.gtex")}

    def no_work(*args, **kwargs):
        raise AssertionError("a finished job submitted work again")

    monkeypatch.setattr(batch, "_run_conversions", no_work)
    again = batch.convert_many([*good, bad], out, client=client, progress=False, **OPTIONS)
    assert [r["status"] for r in again] == ["done", "done", "failed"]
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.gtex")} == stamps
    with pytest.raises(gt.ParameterError, match="options"):
        batch.convert_many(good, out, client=client, progress=False, max_resolution=64)
    monkeypatch.undo()
    # A file lost since is converted again; the rest is not touched.
    (out / rows[0]["output"]).unlink()
    again = batch.convert_many(good, out, client=client, progress=False, **OPTIONS)
    assert (out / rows[0]["output"]).exists() and [r["status"] for r in again] == ["done", "done"]
    assert (out / rows[1]["output"]).stat().st_mtime_ns == stamps[rows[1]["output"]]


def test_render_views_matches_the_renderer_frame_by_frame(client, tmp_path) -> None:
    meshes = [trimesh.creation.icosphere(3), trimesh.creation.torus(1.0, 0.3), trimesh.creation.box(),
              trimesh.creation.capsule(), GENERATED["fractal_terrain"]()]
    sets = [gt.convert(m, **OPTIONS) for m in meshes]
    sets[1].save(tmp_path / "torus.gtex")  # one set travels as a path
    objects = [sets[0], str(tmp_path / "torus.gtex"), *sets[2:]]
    cameras = [[look_from(gt.as_mesh(m), (np.cos(a), 0.4, np.sin(a)), distance=1.5) for a in np.linspace(0, 6, 20)]
               for m in meshes]
    width, height = 64, 48
    store = tmp_path / "views.zarr"
    group = batch.render_views(objects, cameras, store, width=width, height=height, client=client,
                               outputs=("depth", "normal", "color", "patch_id"), progress=False)
    assert group["depth"].shape == (5, 20, height, width) and group["depth"].chunks == (1, 1, height, width)
    assert group["done"][...].all()
    renderer = gt.Renderer(width, height)
    for i, s in enumerate(sets):
        for v, camera in enumerate(cameras[i]):
            frame = renderer.render(s, camera)
            assert np.array_equal(group["depth"][i, v], frame.depth), (i, v)  # bit-identical, inf included
            assert np.array_equal(group["color"][i, v], frame.color), (i, v)
            assert np.array_equal(group["patch_id"][i, v], frame.patch_id), (i, v)
            assert np.array_equal(group["normal"][i, v], frame.normal), (i, v)
    # A rerun renders only views not yet done.
    writable = zarr.open_group(store, mode="r+")
    done = writable["done"][...]
    done[2, 5] = False
    writable["done"][...] = done
    writable["depth"][2, 5] = np.zeros((height, width), np.float32)
    group = batch.render_views(objects, cameras, store, width=width, height=height, client=client,
                               outputs=("depth", "normal", "color", "patch_id"), progress=False)
    assert np.array_equal(group["depth"][2, 5], renderer.render(sets[2], cameras[2][5]).depth)


def test_bad_batch_arguments_are_refused(tmp_path) -> None:
    with pytest.raises(gt.FileError, match="cannot read"):
        batch.convert_many([tmp_path / "missing.obj"], tmp_path, progress=False)
    with pytest.raises(gt.ParameterError, match="twice"):
        batch.convert_many([trimesh.creation.box()] * 2, tmp_path, progress=False)
    with pytest.raises(gt.ParameterError, match="client"):
        batch.convert_many([trimesh.creation.box()], tmp_path, client=3, progress=False)
    cam = gt.Camera.look_at((0, 0, 3), (0, 0, 0))
    with pytest.raises(gt.ParameterError, match="outputs"):
        batch.render_views([trimesh.creation.box()], [cam], tmp_path / "v.zarr", width=8, height=8,
                           outputs=("depth", "face"))
    with pytest.raises(gt.ParameterError, match="cameras"):
        batch.render_views([trimesh.creation.box()] * 2, [[cam], [cam, cam]], tmp_path / "v.zarr", width=8, height=8)


def test_a_job_killed_mid_run_resumes_from_its_journal(client, tmp_path) -> None:
    """Results are journalled one line each while a job runs; a job killed before it folded the
    journal into the manifest (its last line torn) resumes from it: the journalled inputs are
    skipped, the torn one converted again."""
    good = [trimesh.creation.icosphere(2), trimesh.creation.box(), trimesh.creation.torus(1.0, 0.3)]
    out = tmp_path / "out"
    rows = batch.convert_many(good, out, client=client, progress=False, **OPTIONS)
    assert not (out / batch.JOURNAL).exists()  # folded into the manifest when the job ended
    # The state a kill leaves: the manifest as the job began, two whole lines and a torn one.
    manifest = batch.read_manifest(out)
    manifest["rows"] = {}
    (out / batch.MANIFEST).write_text(json.dumps(manifest))
    lines = [json.dumps(r) for r in rows]
    (out / batch.JOURNAL).write_text(lines[0] + "\n" + lines[1] + "\n" + lines[2][: len(lines[2]) // 2])
    assert sorted(batch.read_manifest(out)["rows"]) == sorted(r["key"] for r in rows[:2])
    stamps = {r["output"]: (out / r["output"]).stat().st_mtime_ns for r in rows}
    again = batch.convert_many(good, out, client=client, progress=False, **OPTIONS)
    assert [r["status"] for r in again] == ["done"] * 3
    assert [(out / r["output"]).stat().st_mtime_ns == stamps[r["output"]] for r in rows] == [True, True, False]
    assert sorted(batch.read_manifest(out)["rows"]) == sorted(r["key"] for r in rows)
    # A damaged line that is not the last is refused, naming the journal.
    (out / batch.JOURNAL).write_text("{not json\n" + lines[0] + "\n")
    with pytest.raises(gt.FormatError, match="journal line 1"):
        batch.read_manifest(out)
