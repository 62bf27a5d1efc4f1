"""Type stubs for the Rust extension module geomtex._core."""

import os
from typing import Any, Callable, final

from typing_extensions import disjoint_base

import numpy as np
import numpy.typing as npt

__all__ = ["Mesh", "GeometryTextureSet", "convert", "load", "__version__"]
__version__: str

@disjoint_base
class Mesh:
    def __new__(
        cls,
        vertices: npt.NDArray[np.float64],
        faces: npt.NDArray[np.int64],
        vertex_colors: npt.NDArray[np.uint8] | None = None,
    ) -> Mesh: ...
    @property
    def vertices(self) -> npt.NDArray[np.float64]: ...
    @property
    def faces(self) -> npt.NDArray[np.uint32]: ...
    @property
    def vertex_colors(self) -> npt.NDArray[np.uint8] | None: ...
    @property
    def n_vertices(self) -> int: ...
    @property
    def n_faces(self) -> int: ...
    @property
    def diagonal(self) -> float: ...
    @property
    def bounds(self) -> npt.NDArray[np.float64]: ...

@final
class GeometryTextureSet:
    def __len__(self) -> int: ...
    @property
    def stats(self) -> dict[str, Any]: ...
    @property
    def texel_size(self) -> float: ...
    @property
    def world_from_patch(self) -> npt.NDArray[np.float64]: ...
    def face_patch(self) -> npt.NDArray[np.int32]: ...
    def patch(self, index: int) -> dict[str, npt.NDArray[Any]]: ...
    def to_points(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float32]]: ...
    def save(self, path: str | os.PathLike[str]) -> None: ...
    def _repr_png_(self) -> bytes: ...

def convert(
    mesh: Mesh,
    *,
    max_resolution: int = 256,
    texel_size: float | None = None,
    charts: int | None = None,
    chart_error: float = 0.1,
    max_charts: int = 4096,
    compactness: float = 1.0,
    lloyd_iterations: int = 6,
    overlap_rings: int = 1,
    dilation: int = 2,
    frame: str = "min_area",
    normals: str = "smooth",
    progress: Callable[[str, float], bool | None] | None = None,
) -> GeometryTextureSet: ...
def load(path: str | os.PathLike[str]) -> GeometryTextureSet: ...
