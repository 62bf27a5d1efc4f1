"""geomtex.reference, what the tests compare with: its ray casts keep their memory bounded on
trimesh's numpy intersector (no embreex), casting in chunks of rays, and chunks change nothing
but memory."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import geomtex as gt
from geomtex import reference
from geomtex.testing import look_from

from conftest import pymeshlab_bunny_path


@pytest.fixture(scope="module")
def bunny_mesh() -> gt.Mesh:
    return gt.load_mesh(pymeshlab_bunny_path())


@pytest.mark.parametrize("intersector", ["numpy", "auto"])
def test_chunked_casts_equal_one_call(bunny_mesh: gt.Mesh, intersector: str) -> None:
    camera = look_from(bunny_mesh, (0.3, 0.5, 1.0))
    whole = reference.RayCaster(bunny_mesh, intersector=intersector, chunk_rays=10**9)
    chunked = reference.RayCaster(bunny_mesh, intersector=intersector, chunk_rays=37)
    a, b = whole.cast(camera, 32, 24), chunked.cast(camera, 32, 24)
    assert a["hit"].sum() == 95  # of 768 pixels
    for name in ("depth", "normal", "hit", "triangle", "point"):
        assert a[name].dtype == b[name].dtype and np.array_equal(a[name], b[name]), name
    # first_hits: the same hits, ray indices counted over all the rays.
    origins, directions = camera.rays(32, 24)
    (la, ra, ta), (lb, rb, tb) = whole.first_hits(origins, directions), chunked.first_hits(origins, directions)
    oa, ob = np.argsort(ra), np.argsort(rb)
    assert np.array_equal(ra[oa], rb[ob]) and np.array_equal(ta[oa], tb[ob]) and np.array_equal(la[oa], lb[ob])
    # The default chunk for numpy: 2M pairs over 56,172 faces.
    assert reference.RayCaster(bunny_mesh, intersector="numpy").chunk_rays == 2_000_000 // len(bunny_mesh.faces)
    with pytest.raises(ValueError, match="chunk_rays"):
        reference.RayCaster(bunny_mesh, chunk_rays=0)
    with pytest.raises(ValueError, match="intersector"):
        reference.RayCaster(bunny_mesh, intersector="optix")  # type: ignore[arg-type]


def test_a_numpy_cast_keeps_its_memory_bounded(bunny_mesh: gt.Mesh) -> None:
    """The numpy intersector's memory goes as the (ray, candidate triangle) pairs of one call:
    a 48² view of pymeshlab's bunny in one call took +1,269 MB of peak RSS (6.0 s), in the
    default chunks (35 rays) +67 MB (2.6 s); a 128² view of the Stanford bunny +147 MB (37 s;
    in one call about 11 GB: 25M pairs, 440 bytes each; 256² was killed at 24 GB). Measured in
    a fresh interpreter, the r-tree built before the count starts."""
    script = f"""
import resource, numpy as np, geomtex as gt
from geomtex import reference
from geomtex.testing import look_from
mesh = gt.load_mesh({str(pymeshlab_bunny_path())!r})
caster = reference.RayCaster(mesh, intersector="numpy")
caster.first_hits(np.zeros((1, 3)), np.ones((1, 3)))
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
hits = caster.cast(look_from(mesh, (0.3, 0.5, 1.0)), 48, 48)["hit"].sum()
print(hits, (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024)
"""
    out = subprocess.run([sys.executable, "-c", script], check=True, capture_output=True, text=True, timeout=300)
    hits, grown_mb = out.stdout.split()[-2:]
    assert int(hits) == 401
    assert float(grown_mb) < 200, grown_mb  # measured 67 (one call: 1,269)
