"""Plain arrays of a Mesh, for the builders in this package."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .._mesh import Mesh


def arrays(mesh: Mesh) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """(vertices float64, faces int64) of `mesh`."""
    return np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
