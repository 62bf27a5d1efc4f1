"""Type stubs for the Rust extension module geomtex._core."""

import os
from collections.abc import Sequence
from typing import Any, Callable, final

from typing_extensions import disjoint_base

import numpy as np
import numpy.typing as npt

__all__ = ["Mesh", "GeometryTextureSet", "convert", "load", "__version__", "Camera", "Scene", "Renderer", "Frame"]
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
    @staticmethod
    def from_heightmaps(
        grids: npt.ArrayLike | Sequence[npt.ArrayLike],
        extent: Sequence[float] | Sequence[Sequence[float]] | npt.ArrayLike,
        *,
        properties: npt.ArrayLike | Sequence[npt.ArrayLike] | None = None,
        cmap: str = "viridis",
        property_range: tuple[float, float] | None = None,
        max_resolution: int = 256,
        height_bits: int = 16,
    ) -> GeometryTextureSet: ...
    def __len__(self) -> int: ...
    def filtered(self, kind: str, sigma: float, *, gain: float = 1.0) -> GeometryTextureSet: ...
    def seam_gaps(self, mesh: Mesh) -> npt.NDArray[np.float64]: ...
    @property
    def stats(self) -> dict[str, Any]: ...
    @property
    def texel_size(self) -> float: ...
    @property
    def world_from_patch(self) -> npt.NDArray[np.float64]: ...
    def face_patch(self) -> npt.NDArray[np.int32]: ...
    def patch(self, index: int) -> dict[str, Any]: ...
    def to_points(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float32]]: ...
    def first_hits(
        self, origins: npt.NDArray[np.float64], directions: npt.NDArray[np.float64]
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]: ...
    def save(self, path: str | os.PathLike[str]) -> None: ...
    def _repr_png_(self) -> bytes: ...

def convert(
    mesh: Mesh,
    *,
    max_resolution: int | None = None,
    texel_size: float | None = None,
    max_error: float | None = None,
    max_error_rel: float | None = None,
    error_scope: str = "set",
    charts: int | None = None,
    chart_error: float | None = None,
    max_charts: int = 4096,
    compactness: float = 1.0,
    lloyd_iterations: int = 6,
    overlap_rings: int = 1,
    dilation: int = 2,
    frame: str = "min_area",
    normals: str = "smooth",
    height_bits: int = 16,
    progress: Callable[[str, float], bool | None] | None = None,
) -> GeometryTextureSet: ...
def load(path: str | os.PathLike[str]) -> GeometryTextureSet: ...

@final
class Camera:
    @staticmethod
    def look_at(
        eye: Any,
        target: Any,
        up: tuple[float, float, float] = (0.0, 1.0, 0.0),
        yfov_deg: float = 45.0,
        near: float | None = None,
    ) -> Camera: ...
    @staticmethod
    def from_intrinsics(
        K: npt.NDArray[np.float64],
        world_from_camera: npt.NDArray[np.float64],
        width: int,
        height: int,
        near: float | None = None,
    ) -> Camera: ...
    @staticmethod
    def orthographic(
        world_from_camera: npt.NDArray[np.float64], ymag: float, near: float | None = None
    ) -> Camera: ...
    @property
    def world_from_camera(self) -> npt.NDArray[np.float64]: ...
    @property
    def kind(self) -> str: ...
    @property
    def forward(self) -> list[float]: ...
    def rays(
        self, width: int, height: int
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...

@final
class Scene:
    def __new__(cls) -> Scene: ...
    def add(self, obj: Any, world_from_object: npt.NDArray[np.float64] | None = None) -> int: ...
    def __len__(self) -> int: ...

@final
class Frame:
    @property
    def color(self) -> npt.NDArray[np.uint8]: ...
    @property
    def depth(self) -> npt.NDArray[np.float32]: ...
    @property
    def normal(self) -> npt.NDArray[np.float32]: ...
    @property
    def patch_id(self) -> npt.NDArray[np.int32]: ...
    @property
    def stats(self) -> dict[str, Any]: ...
    def _repr_png_(self) -> bytes: ...
    def save(self, path: str | os.PathLike[str]) -> None: ...

@final
class Renderer:
    def __new__(cls, width: int, height: int) -> Renderer: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def adapter_info(self) -> dict[str, str]: ...
    def render(
        self,
        obj: Any,
        camera: Camera,
        *,
        quality: str | None = None,
        method: str | None = None,
        steps_per_texel: float | None = None,
        min_linear_steps: int | None = None,
        max_linear_steps: int | None = None,
        binary_steps: int | None = None,
        max_traversal_steps: int | None = None,
        count_fetches: bool = False,
        lod: bool = False,
        background: tuple[int, int, int, int] = (255, 255, 255, 0),
    ) -> Frame: ...
