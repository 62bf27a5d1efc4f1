"""A missing optional dependency is an ImportError that names the feature, the package and the pip
command (never a bare "No module named …"), and ``import geomtex`` needs none of them."""

from __future__ import annotations

import re
import subprocess
import sys

import numpy as np
import pytest
import trimesh

import geomtex as gt
from geomtex import _optional, batch, gdm


def _hide(monkeypatch: pytest.MonkeyPatch, module: str) -> None:
    """Make `module` (and its parents and loaded children) unimportable for this test."""
    parts = module.split(".")
    for name in [".".join(parts[:i]) for i in range(1, len(parts) + 1)]:
        monkeypatch.setitem(sys.modules, name, None)
    for name in [m for m in list(sys.modules) if m.startswith(parts[0] + ".")]:
        monkeypatch.setitem(sys.modules, name, None)


@pytest.mark.parametrize("module", sorted(_optional.PACKAGES))
def test_each_optional_module_missing_says_how_to_install_it(monkeypatch: pytest.MonkeyPatch, module: str) -> None:
    package, extra = _optional.PACKAGES[module]
    _hide(monkeypatch, module)
    hint = re.escape(f"pip install '{package}'" + (f" (or pip install 'geomtex[{extra}]'" if extra else ""))
    with pytest.raises(ImportError, match=rf"the feature needs .*{hint}") as e:
        _optional.need(module, "the feature")
    assert e.value.name == module


def test_features_name_what_they_need(monkeypatch: pytest.MonkeyPatch, tmp_path) -> None:
    """Through the public calls: gdm's marching cubes without scikit-image, batch without Dask."""
    occupancy = np.zeros((4, 4, 4), bool)
    occupancy[1:3, 1:3, :2] = True
    volume = gdm.Volume(occupancy)
    _hide(monkeypatch, "skimage")
    with pytest.raises(ImportError, match=r"geomtex.gdm .*scikit-image.*pip install"):
        gdm.tile_surface(volume)
    _hide(monkeypatch, "dask")
    with pytest.raises(ImportError, match=r"geomtex.batch needs dask\[distributed\]"):
        batch.convert_many([trimesh.creation.box()], tmp_path)


def test_import_geomtex_loads_no_optional_dependency() -> None:
    code = ("import sys, geomtex; heavy = [m for m in ('dask', 'zarr', 'skimage', 'ipywidgets', 'pymeshlab', "
            "'scipy', 'matplotlib') if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "", f"import geomtex imported {out}"
    assert gt.__version__
