"""Type stubs for the Rust extension module geomtex._core."""

import os
from collections.abc import Sequence
from typing import Any, Callable, Literal, final

import numpy as np
import numpy.typing as npt
from typing_extensions import disjoint_base

__all__ = [
    "Mesh", "GeometryTextureSet", "Surfels", "convert", "load", "load_surfels", "__version__", "Camera", "Scene",
    "Renderer", "Frame",
    "GeomtexError", "MeshError", "ParameterError", "FormatError", "FileError", "CancelledError",
    "DeviceError", "InternalError",
]
__version__: str

_ErrorScope = Literal["set", "chart"]
_Partition = Literal["cone", "vsa"]
_InPlane = Literal["min_area", "pca"]
_NormalSource = Literal["crease", "smooth", "flat"]
_HeightBits = Literal[8, 16]
_Quality = Literal["fast", "balanced", "exact"]
_Method = Literal["linear_binary", "maxmip"]
_MapFilter = Literal["gaussian", "high_pass"]
# Arguments are converted once at the boundary: any array-like of a real dtype (lists, tuples,
# float32/int arrays) where a vector or matrix is taken, numpy scalars where a number is.
_Vec3 = npt.ArrayLike
_Matrix = npt.ArrayLike
_Int = int | np.integer[Any]
_Real = float | np.floating[Any] | _Int

class GeomtexError(Exception): ...
class MeshError(GeomtexError, ValueError): ...
class ParameterError(GeomtexError, ValueError): ...
class FormatError(GeomtexError, ValueError): ...
class FileError(GeomtexError, OSError): ...
class CancelledError(GeomtexError): ...
class DeviceError(GeomtexError, RuntimeError): ...
class InternalError(GeomtexError, RuntimeError): ...

@disjoint_base
class Mesh:
    def __new__(
        cls,
        vertices: npt.NDArray[np.float64],
        faces: npt.NDArray[np.int64],
        vertex_colors: npt.NDArray[np.uint8] | None = None,
        face_colors: npt.NDArray[np.uint8] | None = None,
        uv: npt.NDArray[np.float64] | None = None,
        texture: npt.NDArray[np.uint8] | None = None,
    ) -> Mesh: ...
    @property
    def vertices(self) -> npt.NDArray[np.float64]: ...
    @property
    def faces(self) -> npt.NDArray[np.uint32]: ...
    @property
    def vertex_colors(self) -> npt.NDArray[np.uint8] | None: ...
    @property
    def face_colors(self) -> npt.NDArray[np.uint8] | None: ...
    @property
    def uv(self) -> npt.NDArray[np.float64] | None: ...
    @property
    def textured(self) -> bool: ...
    @property
    def texture(self) -> npt.NDArray[np.uint8] | None: ...
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
        cmap: Any = "viridis",
        property_range: tuple[float, float] | None = None,
        max_resolution: _Int | None = None,
        height_bits: _HeightBits | None = None,
    ) -> GeometryTextureSet: ...
    @staticmethod
    def _from_prepared_grids(
        prepared: Sequence[
            tuple[npt.NDArray[np.float64], tuple[float, float, float, float], npt.NDArray[np.uint8] | None]
        ],
        *,
        max_resolution: _Int | None = None,
        height_bits: _Int | None = None,
    ) -> GeometryTextureSet: ...
    def __len__(self) -> int: ...
    def filtered(self, kind: _MapFilter, sigma: _Real, *, gain: _Real | None = None) -> GeometryTextureSet: ...
    def seam_gaps(self, mesh: Any) -> npt.NDArray[np.float64]: ...
    def seam_normal_steps(self, mesh: Any) -> npt.NDArray[np.float64]: ...
    @property
    def stats(self) -> dict[str, Any]: ...
    @property
    def texel_size(self) -> float: ...
    @property
    def world_from_patch(self) -> npt.NDArray[np.float64]: ...
    def face_patch(self) -> npt.NDArray[np.int32]: ...
    def patch(self, index: _Int) -> dict[str, Any]: ...
    def to_points(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float32]]: ...
    def to_surfels(self, tile: _Int | None = None) -> Surfels: ...
    def first_hits(
        self, origins: _Matrix, directions: _Matrix
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int32]]: ...
    def save(self, path: str | os.PathLike[str]) -> None: ...
    def to_bytes(self) -> bytes: ...
    @staticmethod
    def from_bytes(data: bytes) -> GeometryTextureSet: ...
    def _repr_png_(self) -> bytes: ...
    def intersects_first(
        self, origins: npt.ArrayLike, directions: npt.ArrayLike, *, quality: _Quality | None = None,
        method: _Method | None = None,
    ) -> Any: ...
    def intersects_location(
        self, ray_origins: npt.ArrayLike, ray_directions: npt.ArrayLike, multiple_hits: bool = False,
        **options: Any,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int32]]: ...
    def intersects_any(
        self, ray_origins: npt.ArrayLike, ray_directions: npt.ArrayLike, **options: Any
    ) -> npt.NDArray[np.bool_]: ...

def convert(
    mesh: Mesh,
    *,
    max_resolution: int | None = None,
    texel_size: float | None = None,
    max_error: float | None = None,
    max_error_rel: float | None = None,
    error_scope: _ErrorScope | None = None,
    partition: _Partition | None = None,
    cone_angle: float | None = None,
    chart_size: float | None = None,
    charts: int | None = None,
    chart_error: float | None = None,
    max_charts: int | None = None,
    compactness: float | None = None,
    lloyd_iterations: int | None = None,
    overlap_rings: int | None = None,
    dilation: int | None = None,
    frame: _InPlane | None = None,
    normals: _NormalSource | None = None,
    crease_angle: float | None = None,
    height_bits: int | None = None,
    max_bytes: int | None = None,
    progress: Callable[[str, float], bool | None] | None = None,
) -> GeometryTextureSet: ...
def load(path: str | os.PathLike[str]) -> GeometryTextureSet: ...

@final
class Surfels:
    @property
    def tile(self) -> int: ...
    @property
    def levels(self) -> int: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def normals(self) -> npt.NDArray[np.float32]: ...
    @property
    def radii(self) -> npt.NDArray[np.float64]: ...
    @property
    def colors(self) -> npt.NDArray[np.uint8]: ...
    @property
    def level(self) -> npt.NDArray[np.int32]: ...
    @property
    def parent(self) -> npt.NDArray[np.int64]: ...
    @property
    def tile_of(self) -> npt.NDArray[np.int32]: ...
    @property
    def tile_patch(self) -> npt.NDArray[np.int32]: ...
    @property
    def tile_start(self) -> npt.NDArray[np.int64]: ...
    @property
    def tile_error(self) -> npt.NDArray[np.float64]: ...
    @property
    def tile_cone(self) -> npt.NDArray[np.float64]: ...
    @property
    def stats(self) -> dict[str, Any]: ...
    @property
    def source(self) -> GeometryTextureSet: ...
    def save(self, path: str | os.PathLike[str]) -> None: ...
    def to_bytes(self) -> bytes: ...
    @staticmethod
    def from_bytes(data: bytes) -> Surfels: ...
    def __len__(self) -> int: ...

def load_surfels(path: str | os.PathLike[str]) -> Surfels: ...

@final
class Camera:
    @staticmethod
    def look_at(
        eye: _Vec3,
        target: _Vec3,
        up: _Vec3 | None = None,
        yfov_deg: _Real | None = None,
        near: _Real | None = None,
    ) -> Camera: ...
    @staticmethod
    def from_intrinsics(
        K: _Matrix,
        world_from_camera: _Matrix,
        width: _Int,
        height: _Int,
        near: _Real | None = None,
    ) -> Camera: ...
    @staticmethod
    def orthographic(world_from_camera: _Matrix, ymag: _Real, near: _Real | None = None) -> Camera: ...
    @property
    def world_from_camera(self) -> npt.NDArray[np.float64]: ...
    @property
    def kind(self) -> str: ...
    @property
    def forward(self) -> list[float]: ...
    def rays(
        self, width: _Int, height: _Int
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def _state(self) -> tuple[str, npt.NDArray[np.float64], list[float], float | None]: ...
    @staticmethod
    def _from_state(kind: str, world_from_camera: _Matrix, numbers: Sequence[float], near: float | None) -> Camera: ...

@disjoint_base
class Scene:
    def __new__(cls) -> Scene: ...
    def add(
        self, obj: Any, world_from_object: _Matrix | None = None, *, normals: _NormalSource | None = None,
        crease_angle: float | None = None,
    ) -> int: ...
    def __len__(self) -> int: ...
    def _objects(self) -> list[tuple[Any, npt.NDArray[np.float64], str | None, float | None]]: ...
    def intersects_first(
        self, origins: npt.ArrayLike, directions: npt.ArrayLike, *, quality: _Quality | None = None,
        method: _Method | None = None,
    ) -> Any: ...
    def intersects_location(
        self, ray_origins: npt.ArrayLike, ray_directions: npt.ArrayLike, multiple_hits: bool = False,
        **options: Any,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int32]]: ...
    def intersects_any(
        self, ray_origins: npt.ArrayLike, ray_directions: npt.ArrayLike, **options: Any
    ) -> npt.NDArray[np.bool_]: ...

@final
class Frame:
    @staticmethod
    def _from_arrays(
        color: npt.NDArray[np.uint8],
        albedo: npt.NDArray[np.uint8],
        depth: npt.NDArray[np.float32],
        normal: npt.NDArray[np.float32],
        patch_id: npt.NDArray[np.int32],
        shadow: npt.NDArray[np.bool_] | None,
        stats: dict[str, Any],
    ) -> Frame: ...
    @property
    def shadow(self) -> npt.NDArray[np.bool_] | None: ...
    @property
    def color(self) -> npt.NDArray[np.uint8]: ...
    @property
    def albedo(self) -> npt.NDArray[np.uint8]: ...
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

@disjoint_base
class Renderer:
    def __new__(cls, width: _Int, height: _Int) -> Renderer: ...
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
        quality: _Quality | None = None,
        method: _Method | None = None,
        steps_per_texel: _Real | None = None,
        min_linear_steps: _Int | None = None,
        max_linear_steps: _Int | None = None,
        binary_steps: _Int | None = None,
        max_traversal_steps: _Int | None = None,
        count_fetches: bool | np.bool_ | None = None,
        lod: bool | np.bool_ | None = None,
        background: npt.ArrayLike | None = None,
        light: Any | None = None,
        max_pixel_error: _Real | None = None,
        primary: Literal["tiles", "boxes"] | None = None,
    ) -> Frame: ...
    def intersect(
        self,
        obj: Any,
        origins: npt.ArrayLike,
        directions: npt.ArrayLike,
        *,
        any_hit: bool | None = None,
        quality: _Quality | None = None,
        method: _Method | None = None,
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int32], npt.NDArray[np.float32]]: ...
