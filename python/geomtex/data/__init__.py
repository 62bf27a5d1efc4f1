"""Meshes that ship inside the package, so examples and the command line run with no download.

>>> import geomtex as gt
>>> mesh = gt.data.bunny()
>>> gts = gt.convert(mesh, max_resolution=256)
"""

from __future__ import annotations

from importlib import resources

import numpy as np

from .._mesh import Mesh

__all__ = ["bunny"]


def bunny() -> Mesh:
    """The Stanford bunny: 28,088 vertices, 56,172 faces, closed (watertight) and y-up.

    Returns
    -------
    Mesh
        A new :class:`geomtex.Mesh` on each call. The bounding box runs from about
        ``(0.0, -0.066, 0.066)`` to ``(0.624, 0.549, 0.549)``, with the ears up (+y).

    Notes
    -----
    The scan is the Stanford Computer Graphics Laboratory's, from the Stanford 3D Scanning
    Repository (https://graphics.stanford.edu/data/3Dscanrep/). This copy is the closed, remeshed
    bunny that pymeshlab ships as ``pymeshlab/tests/sample_meshes/bunny.obj``, stored in
    ``geomtex/data/bunny.npz`` (about 560 KB) as float32 vertices and uint32 faces: its vertices
    are the OBJ's rounded to float32, its faces the OBJ's, in the OBJ's order.

    Examples
    --------
    >>> import geomtex as gt
    >>> gt.data.bunny()
    <geomtex.Mesh 28088 vertices, 56172 faces>
    """
    with resources.files(__name__).joinpath("bunny.npz").open("rb") as f, np.load(f) as npz:
        return Mesh(npz["vertices"], npz["faces"])
