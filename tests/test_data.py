"""The bundled mesh (gt.data.bunny) and what a plain install needs: no pymeshlab for the default
mesh, no matplotlib for `import geomtex`."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import geomtex as gt


def _fresh(script: str) -> subprocess.CompletedProcess[str]:
    """Runs `script` in a new interpreter (this one has imported pymeshlab and matplotlib)."""
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)


def test_bunny_is_pymeshlabs_bunny_in_float32() -> None:
    pymeshlab = pytest.importorskip("pymeshlab")
    from conftest import pymeshlab_bunny_path

    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(pymeshlab_bunny_path()))
    want_v, want_f = ms.current_mesh().vertex_matrix(), ms.current_mesh().face_matrix()
    mesh = gt.data.bunny()
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    assert isinstance(mesh, gt.Mesh)
    assert v.shape == want_v.shape == (28_088, 3) and f.shape == want_f.shape == (56_172, 3)
    # The OBJ's coordinates rounded to float32, nothing else: same faces, same order.
    assert np.array_equal(v, want_v.astype(np.float32).astype(np.float64))
    assert np.abs(v - want_v).max() <= np.spacing(np.float32(np.abs(want_v).max()))
    assert np.array_equal(f, want_f)


def test_bunny_is_a_fresh_closed_mesh_each_call() -> None:
    a, b = gt.data.bunny(), gt.data.bunny()
    assert a is not b and np.array_equal(np.asarray(a.vertices), np.asarray(b.vertices))
    f = np.asarray(a.faces)
    # Closed: every undirected edge is shared by exactly two faces.
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all()
    lo, hi = np.asarray(a.vertices).min(axis=0), np.asarray(a.vertices).max(axis=0)
    assert np.argmax(hi - lo) in (0, 1) and hi[1] > 0.5  # y-up, about 0.6 across


def test_bunny_and_the_default_command_need_neither_pymeshlab_nor_matplotlib(tmp_path) -> None:
    """`import geomtex` imports no matplotlib; with pymeshlab and matplotlib unimportable,
    gt.data.bunny() loads and `python -m geomtex` converts it, writing bunny.png and bunny.gtex."""
    script = f"""
import sys
import geomtex as gt
assert "matplotlib" not in sys.modules and "pymeshlab" not in sys.modules, "imported by geomtex"
sys.modules["pymeshlab"] = None
sys.modules["matplotlib"] = None
assert gt.data.bunny().faces.shape == (56172, 3)
from geomtex.__main__ import main
assert main(["--quiet", "--max-resolution", "64", "-o", {str(tmp_path)!r}]) == 0
"""
    result = _fresh(script)
    assert result.returncode == 0, result.stderr
    assert "bunny.npz ->" in result.stdout
    assert (tmp_path / "bunny.png").stat().st_size > 0 and (tmp_path / "bunny.gtex").stat().st_size > 0


def test_colormapped_properties_without_matplotlib_name_the_install() -> None:
    script = """
import sys
sys.modules["matplotlib"] = None
import numpy as np
import geomtex as gt
try:
    gt.GeometryTextureSet.from_heightmaps(np.zeros((4, 4)), (0, 1, 0, 1), properties=np.zeros((4, 4)))
except ImportError as e:
    print(e)
else:
    raise SystemExit("no ImportError")
"""
    result = _fresh(script)
    assert result.returncode == 0, result.stderr
    assert "pip install matplotlib" in result.stdout and "geomtex[notebook]" in result.stdout
