"""Shared fixtures: real meshes (the shared scans, pymeshlab's bundled bunny) and generated ones,
each converted once per session."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

import geomtex as gt
from geomtex.testing import GENERATED

from bounds import write_recorded

# Property tests: CI (CI set, as .ci/run does) replays a fixed, derandomized set of examples;
# locally each run draws new ones. GEOMTEX_HYPOTHESIS=ci|dev|thorough picks a profile by name.
_PROPERTY = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
settings.register_profile("ci", max_examples=10, derandomize=True, database=None, print_blob=True, **_PROPERTY)
settings.register_profile("dev", max_examples=10, **_PROPERTY)
settings.register_profile("thorough", max_examples=200, **_PROPERTY)
settings.load_profile(os.environ.get("GEOMTEX_HYPOTHESIS", "ci" if os.environ.get("CI") else "dev"))

# The classic scans beside the checkout (../shared/meshes), where a developer has them; a user's
# clone has none, and .ci/run sets GEOMTEX_SHARED_MESHES=none so that CI runs the suite as a plain
# clone would (generated meshes and the bunny inside the pymeshlab wheel only).
_shared = os.environ.get("GEOMTEX_SHARED_MESHES", "")
SHARED_MESHES = (Path("/nonexistent-shared-meshes") if _shared == "none" else
                 Path(_shared) if _shared else Path(__file__).resolve().parents[2] / "shared" / "meshes")
SHARED_NAMES = ["stanford-bunny", "fandisk", "rocker-arm", "spot", "homer", "teapot"]


def shared_mesh_path(name: str) -> Path:
    path = SHARED_MESHES / f"{name}.obj"
    if not path.exists():
        pytest.skip(f"{path} is absent: the shared reference meshes are not beside this checkout")
    return path


def pymeshlab_bunny_path() -> Path:
    import pymeshlab

    return Path(pymeshlab.__file__).parent / "tests" / "sample_meshes" / "bunny.obj"


class Converted:
    def __init__(self, name: str, mesh: gt.Mesh, gts: gt.GeometryTextureSet) -> None:
        self.name = name
        self.mesh = mesh
        self.gts = gts
        self.points, self.normals = gts.to_points()


_cache: dict[str, Converted] = {}


def converted(name: str) -> Converted:
    """Converts a named mesh once per session at a fixed 256 texels (`max_resolution=256`, the
    default before error-driven conversion was; the bounds of the tests that share these sets
    were measured on them). tests/test_economy.py checks the default, error-driven sets."""
    if name not in _cache:
        if name in GENERATED:
            mesh = GENERATED[name]()
        elif name == "pymeshlab-bunny":
            mesh = gt.load_mesh(pymeshlab_bunny_path())
        else:
            mesh = gt.load_mesh(shared_mesh_path(name))
        _cache[name] = Converted(name, mesh, gt.convert(mesh, max_resolution=256))
    return _cache[name]


@pytest.fixture(scope="session")
def bunny() -> Converted:
    """The Stanford scan (69,451 faces) if the shared meshes are here, else pymeshlab's bunny."""
    if (SHARED_MESHES / "stanford-bunny.obj").exists():
        return converted("stanford-bunny")
    return converted("pymeshlab-bunny")


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    write_recorded()
