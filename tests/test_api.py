"""The Python surface: arrays in and out, progress and cancellation, the GIL, notebooks, the CLI."""

from __future__ import annotations

import io
import threading
import time

import numpy as np
import pytest
from PIL import Image

import geomtex as gt

from conftest import Converted, converted, pymeshlab_bunny_path


@pytest.fixture(scope="module")
def torus() -> Converted:
    return converted("torus")


def test_arrays_out_have_documented_types(torus: Converted) -> None:
    pts, nrm = torus.gts.to_points()
    assert pts.dtype == np.float64 and nrm.dtype == np.float32
    assert pts.shape == nrm.shape and pts.shape[1] == 3
    assert pts.flags.c_contiguous and nrm.flags.c_contiguous
    p = torus.gts.patch(0)
    h, w = p["height"].shape
    assert p["height"].dtype == np.uint16
    assert p["normal"].shape == (h, w, 4) and p["normal"].dtype == np.int8
    assert p["color"].shape == (h, w, 4) and p["color"].dtype == np.uint8
    assert p["faces"].dtype == np.uint32
    # world_from_patch maps the unit cube onto the box: its columns are axes * extent.
    wfp = p["world_from_patch"]
    assert np.allclose(wfp[:3, :3], (p["axes"] * p["extent"][:, None]).T)
    assert np.allclose(wfp[:3, 3], p["origin"]) and np.allclose(wfp[3], [0, 0, 0, 1])
    assert np.allclose(p["axes"] @ p["axes"].T, np.eye(3), atol=1e-12)
    assert np.linalg.det(p["axes"]) == pytest.approx(1.0)
    assert torus.gts.patch(-1)["height"].shape == torus.gts.patch(len(torus.gts) - 1)["height"].shape
    with pytest.raises(IndexError):
        torus.gts.patch(len(torus.gts))


def test_texel_points_follow_the_documented_layout(torus: Converted) -> None:
    """Point of texel (row j, column i) = world_from_patch @ ((i+.5)/W, (j+.5)/H, (q-1)/65534)."""
    recon = []
    for k in range(len(torus.gts)):
        p = torus.gts.patch(k)
        j, i = np.nonzero(p["height"])
        H, W = p["height"].shape
        local = np.column_stack([(i + 0.5) / W, (j + 0.5) / H, (p["height"][j, i] - 1.0) / 65534, np.ones(len(i))])
        recon.append((local @ p["world_from_patch"].T)[:, :3])
    assert np.allclose(np.concatenate(recon), torus.points, rtol=0, atol=1e-12)


def test_mesh_round_trips_through_trimesh() -> None:
    import trimesh

    tm = trimesh.creation.icosphere(subdivisions=2)
    m = gt.Mesh.from_trimesh(tm)
    assert m.n_vertices == len(tm.vertices) and m.n_faces == len(tm.faces)
    assert m.diagonal == pytest.approx(np.linalg.norm(tm.bounds[1] - tm.bounds[0]))
    back = m.to_trimesh()
    assert np.array_equal(back.vertices, tm.vertices) and np.array_equal(back.faces, tm.faces)
    assert isinstance(gt.convert(tm), gt.GeometryTextureSet)  # trimesh accepted directly
    assert "162 vertices, 320 faces" in repr(m)


def test_progress_reports_every_stage_in_order() -> None:
    calls: list[tuple[str, float]] = []
    gt.convert(converted("sphere").mesh, progress=lambda s, f: calls.append((s, f)))
    stages = list(dict.fromkeys(s for s, _ in calls))
    assert stages == ["geometry", "partition", "repair", "overlap", "frame", "resolution", "raster", "dilate", "done"]
    assert all(0.0 <= f <= 1.0 for _, f in calls) and calls[-1] == ("done", 1.0)


def test_progress_can_cancel_and_exceptions_propagate() -> None:
    mesh = converted("sphere").mesh
    with pytest.raises(gt.CancelledError, match="partition"):
        gt.convert(mesh, progress=lambda s, f: s != "partition")

    class Stop(Exception):
        pass

    def boom(stage: str, fraction: float) -> None:
        if stage == "frame":
            raise Stop("from the callback")

    with pytest.raises(Stop, match="from the callback"):
        gt.convert(mesh, progress=boom)


def test_tqdm_progress_bar_runs(capsys) -> None:
    gts = gt.convert(converted("sphere").mesh, progress=True, hybrid=False)
    assert len(gts) >= 2
    assert "geomtex" in capsys.readouterr().err


def test_the_terminal_bar_redraws_at_tqdms_pace_not_per_report() -> None:
    """On a terminal the bar moves by tqdm's update (redrawn at most every 0.1 s), not a redraw
    per progress report: the bunny's conversion reports ~100 times (177 redraws before)."""
    import io

    from geomtex._progress import Stages

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    reports: list[str] = []
    stream = Terminal()
    stages = Stages(stream=stream)

    def callback(stage: str, fraction: float) -> None:
        reports.append(stage)
        stages(stage, fraction)

    start = time.perf_counter()
    gt.convert(converted("sphere").mesh, max_resolution=128, progress=callback)
    stages.close()
    seconds = time.perf_counter() - start
    redraws = stream.getvalue().count("\r")
    # Measured 4 redraws for 65 reports in 0.33 s.
    assert redraws <= 3 + 10 * seconds, (redraws, len(reports), seconds)


@pytest.mark.filterwarnings("ignore::geomtex.CapWarning")  # the default's budget binds on the bunny (1.24x)
def test_gil_is_released_during_conversion(bunny: Converted) -> None:
    """A Python thread keeps running while Rust converts: its counter advances throughout."""
    ticks = []
    done = threading.Event()

    def count() -> None:
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    start = time.perf_counter()
    gt.convert(bunny.mesh)
    end = time.perf_counter()
    done.set()
    t.join()
    during = [x for x in ticks if start < x < end]
    # With the GIL held for the whole conversion the thread could not tick at all in between.
    assert len(during) >= 0.2 * (end - start) / 0.001 * 0.1, (len(during), end - start)
    gaps = np.diff(during)
    assert gaps.max() < 0.25 * (end - start), f"thread stalled {gaps.max():.3f} s of {end - start:.3f} s"


def test_repr_png_is_a_picture(torus: Converted) -> None:
    png = torus.gts._repr_png_()
    img = Image.open(io.BytesIO(png))
    assert img.format == "PNG" and img.size[0] == 2 * img.size[1] - 48
    pixels = np.asarray(img.convert("RGB"))
    assert (pixels.std(axis=(0, 1)) > 10).all()  # not blank
    assert "patches" in repr(torus.gts) and "empty" in repr(torus.gts)


def test_command_line_converts_and_reports(tmp_path, capsys) -> None:
    from geomtex.__main__ import main

    sheet = converted("open_sheet").mesh.to_trimesh()
    src = tmp_path / "sheet.ply"
    sheet.export(src)
    assert main([str(src), "-o", str(tmp_path / "out"), "--quiet", "--max-resolution", "64"]) == 0
    out = capsys.readouterr().out
    assert "folding charts" in out and "seconds: total" in out
    assert "(VSA " in out and "one for every patch" in out and "error bound" not in out, out
    gts = gt.load(tmp_path / "out" / "sheet.gtex")
    assert gts.stats["faces"] == len(sheet.faces)
    assert Image.open(tmp_path / "out" / "sheet.png").size == (1024, 536)
    (tmp_path / "bad.obj").write_text("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert main([str(tmp_path / "bad.obj"), "-o", str(tmp_path / "o2"), "--quiet"]) == 2
    assert "MeshError" in capsys.readouterr().err
    assert pymeshlab_bunny_path().exists()  # the default the CLI falls back on


def test_command_line_says_what_ran_and_logs_a_line_per_stage(tmp_path, capsys) -> None:
    """Error-driven by default: the table names the cone partition and the per-patch texels, and
    progress written to a log (not a terminal) is one line per stage, not tqdm's redraws."""
    from geomtex.__main__ import main

    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out.strip() == f"geomtex {gt.__version__}"
    src = tmp_path / "sheet.ply"
    converted("open_sheet").mesh.to_trimesh().export(src)
    assert main([str(src), "-o", str(tmp_path / "out")]) == 0
    out, err = capsys.readouterr()
    assert "(cone partition " in out and "texel sizes chosen per patch (error-driven)" in out, out
    assert "chart_error" not in out and "finest of" in out
    stages = [line for line in err.splitlines() if line.startswith("geomtex: ")]
    assert "\r" not in err and stages[0] == "geomtex: geometry" and stages[-1].startswith("geomtex: done in"), err
    assert len(stages) == len(set(stages)) <= 10, stages  # measured 9: each stage once, then done


def test_every_public_submodule_is_an_attribute_without_importing_optional_dependencies() -> None:
    """``gt.batch``, ``gt.reference``, ``gt.testing`` and ``gt.viewer`` are reachable after a plain
    ``import geomtex as gt`` (PEP 562, imported on first use), while ``import geomtex`` alone
    imports none of them nor Dask, Zarr or ipywidgets. In a fresh interpreter: this one has
    imported them already."""
    import subprocess
    import sys

    script = """
import sys
import geomtex as gt
optional = ("dask", "distributed", "zarr", "ipywidgets", "embreex")
lazy = ("geomtex.batch", "geomtex.reference", "geomtex.testing", "geomtex.viewer")
assert not [m for m in optional + lazy if m in sys.modules], [m for m in optional + lazy if m in sys.modules]
assert {"batch", "reference", "testing", "viewer", "gdm", "igt"} <= set(dir(gt))
assert callable(gt.batch.convert_many) and callable(gt.batch.read_manifest)
assert callable(gt.reference.raycast) and callable(gt.viewer.show) and "sphere" in gt.testing.GENERATED
assert gt.batch is sys.modules["geomtex.batch"]
from geomtex import batch, reference, testing, viewer  # noqa: F401  (the usual form still works)
assert not [m for m in ("dask", "distributed", "zarr", "ipywidgets") if m in sys.modules]
try:
    gt.no_such_thing
except AttributeError as e:
    assert "no attribute 'no_such_thing'" in str(e)
else:
    raise AssertionError("gt.no_such_thing did not raise AttributeError")
"""
    subprocess.run([sys.executable, "-c", script], check=True, timeout=120)
