"""Bad input to the entry points beyond `convert` (inverse geometric textures, displacement maps,
surfels, ray queries, lights, placements, the viewer and batch jobs) raises a GeomtexError
subclass whose message names the argument, before any work is done and without changing
anything; the array-likes numpy and trimesh users pass are accepted. `gt.show` draws every kind a
Scene takes. One table per rule; every object is tiny (an 8 x 8-cell sheet, a 16 x 16 x 8 tile).
"""

from __future__ import annotations

import os
import pathlib
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Callable

import numpy as np
import pytest
import trimesh

import geomtex as gt
from geomtex import batch, gdm
from geomtex.testing import look_from
from geomtex.testing.shapes import wavy_sheet

NAN3 = (np.nan, 0.0, 0.0)
# Zero-strided arrays: absurd sizes that cost no memory, so a check that copies first would show.
HUGE_RAYS = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (2**26 + 1, 3))
HUGE_GRID = np.broadcast_to(np.array(True), (1000, 1000, 1000))
SKEW = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0.5, 1.0]])


class Objects:
    """Everything the cases call, made once and on first use."""

    @cached_property
    def mesh(self) -> gt.Mesh:
        return wavy_sheet(8)

    @cached_property
    def gts(self) -> gt.GeometryTextureSet:
        return gt.convert(self.mesh, max_resolution=16)

    @cached_property
    def surfels(self) -> gt.Surfels:
        return self.gts.to_surfels()

    @cached_property
    def igt(self) -> gt.igt.InverseGeometricTexture:
        return gt.igt.build(self.mesh, resolution=32)

    @cached_property
    def low(self) -> gt.igt.IgtMesh:
        return gt.igt.attach(self.igt, self.igt.vertices, self.igt.faces)

    @cached_property
    def volume(self) -> gdm.Volume:
        return gdm.Volume.procedural("chain", (16, 16, 8))

    @cached_property
    def table(self) -> gdm.DistanceFunction:
        return self.volume.distance_function((2, 4))

    @cached_property
    def torus(self) -> tuple[Any, Any]:
        return gdm.uv_torus(sections=(8, 6))

    @cached_property
    def shell(self) -> gdm.Shell:
        base, uv = self.torus
        return gdm.Shell(base, self.volume, 0.05, uv=uv)

    @cached_property
    def camera(self) -> gt.Camera:
        return look_from(self.mesh, (0.3, 0.2, 1.0))

    @cached_property
    def renderer(self) -> gt.Renderer:
        return gt.Renderer(16, 16)

    @cached_property
    def viewer(self) -> Any:
        return gt.show(self.gts, width=32, height=32)

    @cached_property
    def ray(self) -> tuple[np.ndarray, np.ndarray]:
        return np.array([[0.1, 0.2, 2.0]]), np.array([[0.0, 0.0, -1.0]])


@pytest.fixture(scope="module")
def o() -> Objects:
    return Objects()


@dataclass
class Bad:
    name: str
    call: Callable[[Objects], Any]
    raises: type[gt.GeomtexError]
    fragment: str  # must appear in the message: the argument's name, and often the value


P, FILE, FORMAT, MESH = gt.ParameterError, gt.FileError, gt.FormatError, gt.MeshError

IGT = [
    Bad("build_resolution_str", lambda o: gt.igt.build(o.mesh, resolution="64"), P, "resolution"),
    Bad("build_resolution_huge", lambda o: gt.igt.build(o.mesh, resolution=10**9), P, "resolution"),
    Bad("build_resolution_negative", lambda o: gt.igt.build(o.mesh, resolution=-1), P, "resolution"),
    Bad("build_primary", lambda o: gt.igt.build(o.mesh, primary="octahedral"), P, "primary"),
    Bad("build_attributes_number", lambda o: gt.igt.build(o.mesh, attributes=5), P, "attributes"),
    Bad("build_attributes_unknown", lambda o: gt.igt.build(o.mesh, attributes=["ambient"]), P, "attributes"),
    Bad("build_crease_nan", lambda o: gt.igt.build(o.mesh, crease_angle=float("nan")), P, "crease_angle"),
    Bad("build_ao_rays_huge", lambda o: gt.igt.build(o.mesh, attributes=["ao"], ao_rays=10**12), P, "ao_rays"),
    Bad("build_ao_distance_nan", lambda o: gt.igt.build(o.mesh, attributes=["ao"], ao_distance=np.nan), P,
        "ao_distance"),
    Bad("build_charts_huge", lambda o: gt.igt.build(o.mesh, charts=10**9), P, "charts"),
    Bad("build_progress_str", lambda o: gt.igt.build(o.mesh, progress="yes"), P, "progress"),
    Bad("build_not_a_mesh", lambda o: gt.igt.build(42), MESH, "expected a geomtex.Mesh"),
    Bad("load_missing", lambda o: gt.igt.load("/nonexistent/x.gtigt"), FILE, "no such file"),
    Bad("load_folder", lambda o: gt.igt.load(os.getcwd()), FILE, "folder"),
    Bad("load_number", lambda o: gt.igt.load(5), P, "path"),
    Bad("load_not_igt", lambda o: gt.igt.load(__file__), FORMAT, "not a .gtigt"),
    Bad("simplify_target_str", lambda o: gt.igt.simplify(o.igt, "50"), P, "target_faces"),
    Bad("simplify_target_huge", lambda o: gt.igt.simplify(o.igt, 10**9), P, "target_faces"),
    Bad("simplify_not_igt", lambda o: gt.igt.simplify(o.gts, 50), P, "igt must be"),
    Bad("simplify_lookup", lambda o: gt.igt.simplify(o.igt, 50, lookup="nearest"), P, "lookup"),
    Bad("simplify_samples", lambda o: gt.igt.simplify(o.igt, 50, samples=3), P, "samples"),
    Bad("simplify_lod_nan", lambda o: gt.igt.simplify(o.igt, 50, lod=float("nan")), P, "lod"),
    Bad("attach_nan_vertex", lambda o: gt.igt.attach(o.igt, np.where(o.igt.vertices > 0.9, np.nan, o.igt.vertices),
                                                     o.igt.faces), P, "vertices must be finite"),
    Bad("attach_empty", lambda o: gt.igt.attach(o.igt, np.zeros((0, 3)), np.zeros((0, 3), int)), P, "vertices"),
    Bad("attach_no_faces", lambda o: gt.igt.attach(o.igt, o.igt.vertices, np.zeros((0, 3), int)), P, "faces"),
    Bad("attach_str", lambda o: gt.igt.attach(o.igt, "vertices", o.igt.faces), P, "vertices"),
    Bad("attach_ragged", lambda o: gt.igt.attach(o.igt, [[0, 0, 0], [1, 0]], o.igt.faces), P, "vertices"),
    Bad("attach_shape", lambda o: gt.igt.attach(o.igt, o.igt.vertices[:, :2], o.igt.faces), P, "(V, 3)"),
    Bad("attach_fractional_faces", lambda o: gt.igt.attach(o.igt, o.igt.vertices, o.igt.faces + 0.5), P,
        "faces must hold integer indices"),
    Bad("attach_face_past_end", lambda o: gt.igt.attach(o.igt, o.igt.vertices, o.igt.faces + 1000), P,
        "faces reference vertices"),
    Bad("attach_negative_face", lambda o: gt.igt.attach(o.igt, o.igt.vertices, o.igt.faces - 1000), P,
        "faces reference vertices"),
    Bad("attach_bool_faces", lambda o: gt.igt.attach(o.igt, o.igt.vertices, o.igt.faces > 3), P, "faces"),
    Bad("attach_not_igt", lambda o: gt.igt.attach(None, o.igt.vertices, o.igt.faces), P, "igt must be"),
    Bad("attach_lookup_number", lambda o: gt.igt.attach(o.igt, o.igt.vertices, o.igt.faces, lookup=5), P, "lookup"),
    Bad("attach_samples_str", lambda o: gt.igt.attach(o.igt, o.igt.vertices, o.igt.faces, samples="1"), P,
        "samples"),
    Bad("attach_samples_bool", lambda o: gt.igt.attach(o.igt, o.igt.vertices, o.igt.faces, samples=True), P,
        "samples"),
    Bad("lookup_nan", lambda o: o.igt.lookup(np.full((1, 3), np.nan), [0]), P, "points must be finite"),
    Bad("lookup_shape", lambda o: o.igt.lookup(np.zeros((2, 2)), [0, 0]), P, "points"),
    Bad("lookup_grids_str", lambda o: o.igt.lookup(np.zeros((1, 3)), "a"), P, "grids"),
    Bad("lookup_grids_fraction", lambda o: o.igt.lookup(np.zeros((1, 3)), [0.5]), P, "grids"),
    Bad("lookup_grids_count", lambda o: o.igt.lookup(np.zeros((2, 3)), [0]), P, "grids"),
    Bad("lookup_grid_past_end", lambda o: o.igt.lookup(np.zeros((1, 3)), [10**6]), P, "grid id"),
    Bad("shade_grid_negative", lambda o: o.igt.shade(o.igt.vertices, o.igt.faces, [-3] * len(o.igt.faces)), P,
        "grid -3"),
    Bad("shade_grid_count", lambda o: o.igt.shade(o.igt.vertices, o.igt.faces, [0]), P, "face_grid"),
    Bad("shade_nan", lambda o: o.igt.shade(np.full((3, 3), np.nan), [[0, 1, 2]], [0]), P, "vertices"),
    Bad("igt_save_number", lambda o: o.igt.save(5), P, "path"),
    Bad("igt_save_no_folder", lambda o: o.igt.save("/nonexistent/x.gtigt"), FILE, "/nonexistent"),
    Bad("igt_from_bytes_str", lambda o: gt.igt.InverseGeometricTexture.from_bytes("data"), P, "data"),
    Bad("igt_from_bytes_junk", lambda o: gt.igt.InverseGeometricTexture.from_bytes(b"junk"), FORMAT, "not a .gtigt"),
]

GDM = [
    Bad("procedural_pattern", lambda o: gdm.Volume.procedural("chainmail", (16, 16, 8)), P, "pattern"),
    Bad("procedural_size_huge", lambda o: gdm.Volume.procedural("chain", (1000, 1000, 1000)), P, "size"),
    Bad("procedural_size_negative", lambda o: gdm.Volume.procedural("chain", (-16, 16, 8)), P, "size"),
    Bad("procedural_size_fraction", lambda o: gdm.Volume.procedural("chain", (16.5, 16, 8)), P, "size"),
    Bad("procedural_size_nan", lambda o: gdm.Volume.procedural("chain", (np.nan, 16, 8)), P, "size"),
    Bad("procedural_size_str", lambda o: gdm.Volume.procedural("chain", "16x16x8"), P, "size"),
    Bad("procedural_size_two", lambda o: gdm.Volume.procedural("chain", (16, 16)), P, "size"),
    Bad("volume_huge", lambda o: gdm.Volume(HUGE_GRID), P, "occupancy"),
    Bad("volume_empty_array", lambda o: gdm.Volume(np.zeros((0, 0, 0))), P, "occupancy"),
    Bad("volume_flat", lambda o: gdm.Volume(np.ones((8, 8))), P, "occupancy"),
    Bad("volume_str", lambda o: gdm.Volume("solid"), P, "occupancy"),
    Bad("volume_nan", lambda o: gdm.Volume(np.full((8, 8, 4), np.nan)), P, "occupancy"),
    Bad("volume_colors_300", lambda o: gdm.Volume(o.volume.occupancy, colors=np.full((16, 16, 8, 4), 300)), P,
        "colors"),
    Bad("volume_colors_negative", lambda o: gdm.Volume(o.volume.occupancy, colors=np.full((16, 16, 8, 4), -3)), P,
        "colors"),
    Bad("volume_colors_float", lambda o: gdm.Volume(o.volume.occupancy, colors=np.zeros((16, 16, 8, 4))), P,
        "colors must be an array-like of integers"),
    Bad("volume_colors_shape", lambda o: gdm.Volume(o.volume.occupancy, colors=np.zeros((2, 4), np.uint8)), P,
        "colors"),
    Bad("volume_check_seams_str", lambda o: gdm.Volume(o.volume.occupancy, check_seams="no"), P, "check_seams"),
    Bad("from_mesh_size_huge", lambda o: gdm.Volume.from_mesh(trimesh.creation.box(), (1000, 1000, 1000)), P,
        "size"),
    Bad("from_mesh_not_a_mesh", lambda o: gdm.Volume.from_mesh(42), MESH, "expected a geomtex.Mesh"),
    Bad("march_nan_origin", lambda o: o.volume.march([NAN3], [[0, 0, 1]]), P, "origins must be finite"),
    Bad("march_zero_direction", lambda o: o.volume.march([[1, 1, 1]], [[0, 0, 0]]), P, "directions must be non-zero"),
    Bad("march_shapes", lambda o: o.volume.march([[1, 1, 1]], [[0, 0, 1], [0, 0, 1]]), P, "origins and directions"),
    Bad("march_two_columns", lambda o: o.volume.march([[1, 1]], [[0, 1]]), P, "origins"),
    Bad("march_str", lambda o: o.volume.march("origin", [[0, 0, 1]]), P, "origins"),
    Bad("march_huge", lambda o: o.volume.march(HUGE_RAYS, HUGE_RAYS), P, "rows, more than the limit"),
    Bad("march_max_t_nan", lambda o: o.volume.march([[1, 1, 1]], [[0, 0, 1]], max_t=float("nan")), P, "max_t"),
    Bad("march_max_t_negative", lambda o: o.volume.march([[1, 1, 1]], [[0, 0, 1]], max_t=-1.0), P, "max_t"),
    Bad("directions_huge", lambda o: o.volume.distance_function((10**5, 10**5)), P, "directions"),
    Bad("directions_negative", lambda o: o.volume.distance_function((-2, 4)), P, "directions"),
    Bad("directions_fraction", lambda o: o.volume.distance_function((2.5, 4)), P, "directions"),
    Bad("directions_str", lambda o: o.volume.distance_function("16x32"), P, "directions"),
    Bad("distance_progress_str", lambda o: o.volume.distance_function((2, 4), progress="yes"), P, "progress"),
    Bad("distance_lower_bound_int", lambda o: o.volume.distance_function((2, 4), lower_bound=1), P, "lower_bound"),
    Bad("compress_zero", lambda o: o.table.compress(0), P, "k must be"),
    Bad("compress_past_rank", lambda o: o.table.compress(10**6), P, "k must be"),
    Bad("compress_float", lambda o: o.table.compress(2.0), P, "k must be"),
    Bad("compress_str", lambda o: o.table.compress("2"), P, "k must be"),
    Bad("shell_thickness_nan", lambda o: gdm.Shell(o.torus[0], o.volume, float("nan")), P, "thickness"),
    Bad("shell_thickness_inf", lambda o: gdm.Shell(o.torus[0], o.volume, np.inf), P, "thickness"),
    Bad("shell_thickness_huge", lambda o: gdm.Shell(o.torus[0], o.volume, 1e300), P, "thickness"),
    Bad("shell_thickness_zero", lambda o: gdm.Shell(o.torus[0], o.volume, 0.0), P, "thickness"),
    Bad("shell_thickness_str", lambda o: gdm.Shell(o.torus[0], o.volume, "0.1"), P, "thickness"),
    Bad("shell_thickness_bool", lambda o: gdm.Shell(o.torus[0], o.volume, True), P, "thickness"),
    Bad("shell_tiles_nan", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, tiles=(np.nan, 1)), P, "tiles"),
    Bad("shell_tiles_huge", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, tiles=(1e300, 1)), P, "tiles"),
    Bad("shell_tiles_three", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, tiles=(1, 2, 3)), P, "tiles"),
    Bad("shell_uv_nan", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, uv=np.full_like(o.torus[1], np.nan)), P,
        "uv must be finite"),
    Bad("shell_uv_str", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, uv="box"), P, "uv"),
    Bad("shell_uv_ragged", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, uv=[[0, 0], [1]]), P, "uv"),
    Bad("shell_uv_shape", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, uv=np.zeros((3, 2))), P, "uv"),
    Bad("shell_color_float", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, color=(0.5, 0.5, 0.5, 1.0)), P,
        "color"),
    Bad("shell_color_str", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, color="red"), P, "color"),
    Bad("shell_pieces", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, pieces=0), P, "pieces"),
    Bad("shell_refine_nan", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, refine=np.nan), P, "refine"),
    Bad("shell_lookup", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, lookup=5), P, "lookup"),
    Bad("shell_volume", lambda o: gdm.Shell(o.torus[0], 5, 0.05), P, "volume"),
    Bad("shell_count_steps", lambda o: gdm.Shell(o.torus[0], o.volume, 0.05, count_steps="yes"), P, "count_steps"),
    Bad("shell_base", lambda o: gdm.Shell(42, o.volume, 0.05), MESH, "expected a geomtex.Mesh"),
    Bad("torus_major_nan", lambda o: gdm.uv_torus(np.nan), P, "major"),
    Bad("torus_major_str", lambda o: gdm.uv_torus("1"), P, "major"),
    Bad("torus_minor_past_major", lambda o: gdm.uv_torus(1.0, 2.0), P, "minor"),
    Bad("torus_minor_negative", lambda o: gdm.uv_torus(1.0, -0.3), P, "minor"),
    Bad("torus_sections_huge", lambda o: gdm.uv_torus(sections=(10**5, 10**5)), P, "sections"),
    Bad("torus_sections_zero", lambda o: gdm.uv_torus(sections=(0, 3)), P, "sections"),
    Bad("torus_sections_str", lambda o: gdm.uv_torus(sections="ab"), P, "sections"),
]

SURFELS = [
    Bad("constructor", lambda o: gt.Surfels(), P, "to_surfels"),
    Bad("to_surfels_tile_zero", lambda o: o.gts.to_surfels(tile=0), P, "tile"),
    Bad("to_surfels_tile_huge", lambda o: o.gts.to_surfels(tile=10**9), P, "tile"),
    Bad("to_surfels_tile_str", lambda o: o.gts.to_surfels(tile="8"), P, "tile"),
    Bad("save_number", lambda o: o.surfels.save(5), P, "path"),
    Bad("save_no_folder", lambda o: o.surfels.save("/nonexistent/x.gtsurf"), FILE, "/nonexistent"),
    Bad("from_bytes_str", lambda o: gt.Surfels.from_bytes("data"), P, "data"),
    Bad("from_bytes_junk", lambda o: gt.Surfels.from_bytes(b"junk"), FORMAT, "not a surfel file"),
    Bad("load_missing", lambda o: gt.load_surfels("/nonexistent/x.gtsurf"), FILE, "no such file"),
    Bad("load_folder", lambda o: gt.load_surfels(os.getcwd()), FILE, "folder"),
    Bad("load_number", lambda o: gt.load_surfels(3), P, "path"),
    Bad("load_not_surfels", lambda o: gt.load_surfels(__file__), FORMAT, "not a surfel file"),
    Bad("max_pixel_error_nan", lambda o: o.renderer.render(o.surfels, o.camera, max_pixel_error=np.nan), P,
        "max_pixel_error"),
]


def _query(method: str, *args: Any, **kwargs: Any) -> Callable[[Objects], Any]:
    return lambda o: getattr(o.gts, method)(*(a(o) if callable(a) else a for a in args), **kwargs)


def _d(o: Objects) -> np.ndarray:
    return o.ray[1]


def _origin(o: Objects) -> np.ndarray:
    return o.ray[0]


RAYS = [
    *[Bad(f"{m}_nan_origin", _query(m, [NAN3], _d), P, "(origins row 0)") for m in
      ("intersects_first", "intersects_location", "intersects_any")],
    *[Bad(f"{m}_zero_direction", _query(m, _origin, [[0, 0, 0]]), P, "(directions row 0)") for m in
      ("intersects_first", "intersects_location", "intersects_any")],
    *[Bad(f"{m}_inf_direction", _query(m, _origin, [[np.inf, 0, 0]]), P, "non-zero (directions row 0)") for m in
      ("intersects_first", "intersects_location", "intersects_any")],
    *[Bad(f"{m}_huge", _query(m, HUGE_RAYS, HUGE_RAYS), P, "more than the limit") for m in
      ("intersects_first", "intersects_location", "intersects_any")],
    Bad("first_shapes", _query("intersects_first", np.zeros((2, 3)), _d), P, "origins and directions"),
    Bad("first_two_columns", _query("intersects_first", [[0, 0]], [[0, 1]]), P, "directions"),
    Bad("first_str", _query("intersects_first", "origin", _d), P, "origins"),
    Bad("first_ragged", _query("intersects_first", _origin, [[0, 0, 1], [0, 1]]), P, "directions"),
    Bad("first_bool", _query("intersects_first", _origin, np.ones((1, 3), bool)), P, "directions"),
    Bad("first_complex", _query("intersects_first", _origin, np.ones((1, 3), complex)), P, "directions"),
    Bad("first_quality", _query("intersects_first", _origin, _d, quality="best"), P, "quality"),
    Bad("location_multiple_hits_str", _query("intersects_location", _origin, _d, multiple_hits="no"), P,
        "multiple_hits"),
    Bad("any_unknown_keyword", _query("intersects_any", _origin, _d, speed=1), P, "speed"),
    Bad("scene_nan_origin", lambda o: gt.Scene().intersects_first([NAN3], o.ray[1]), P, "origins"),
]

LIGHTS = [
    Bad("directional_zero", lambda o: gt.DirectionalLight((0, 0, 0)), P, "direction"),
    Bad("directional_nan", lambda o: gt.DirectionalLight(NAN3), P, "direction"),
    Bad("directional_inf", lambda o: gt.DirectionalLight((np.inf, 0, 0)), P, "direction"),
    Bad("directional_str", lambda o: gt.DirectionalLight("down"), P, "direction"),
    Bad("directional_two", lambda o: gt.DirectionalLight((0, 1)), P, "direction"),
    Bad("directional_ragged", lambda o: gt.DirectionalLight([[0, 1], [1]]), P, "direction"),
    Bad("point_nan", lambda o: gt.PointLight(NAN3), P, "position"),
    Bad("point_str", lambda o: gt.PointLight("above"), P, "position"),
    Bad("point_matrix", lambda o: gt.PointLight(np.eye(3)), P, "position"),
    Bad("render_light_number", lambda o: o.renderer.render(o.gts, o.camera, light=5), P, "light"),
    Bad("render_light_zeroed_after", lambda o: o.renderer.render(o.gts, o.camera, light=_zeroed()), P,
        "light.direction"),
    Bad("render_light_object_nan", lambda o: o.renderer.render(o.gts, o.camera, light=_Duck(direction=NAN3)), P,
        "light.direction"),
    Bad("render_light_object_position_nan",
        lambda o: o.renderer.render(o.gts, o.camera, light=_Duck(position=NAN3)), P, "light.position"),
]


class _Duck:
    def __init__(self, **attributes: Any) -> None:
        self.__dict__.update(attributes)


def _zeroed() -> gt.DirectionalLight:
    light = gt.DirectionalLight((0, 0, -1))
    light.direction[:] = 0  # type: ignore[index]  # the array inside a frozen dataclass changed in place
    return light


def _moved(x: float, y: float, z: float, scale: float = 1.0) -> np.ndarray:
    m = np.diag([scale, scale, scale, 1.0])
    m[:3, 3] = x, y, z
    return m


PLACEMENTS = [
    Bad("not_affine", lambda o: gt.Scene().add(o.gts, SKEW), P, "world_from_object must be affine"),
    Bad("projective_w", lambda o: gt.Scene().add(o.gts, np.diag([1, 1, 1, 2.0])), P, "affine"),
    Bad("singular", lambda o: gt.Scene().add(o.gts, np.diag([1, 1, 0, 1.0])), P, "singular"),
    Bad("zero", lambda o: gt.Scene().add(o.gts, np.zeros((4, 4))), P, "world_from_object"),
    Bad("nan", lambda o: gt.Scene().add(o.gts, np.where(np.eye(4) > 0, np.nan, 0)), P, "world_from_object"),
    Bad("inf_translation", lambda o: gt.Scene().add(o.mesh, _moved(np.inf, 0, 0)), P, "world_from_object"),
    Bad("three_by_three", lambda o: gt.Scene().add(o.gts, np.eye(3)), P, "shape (4, 4)"),
    Bad("str", lambda o: gt.Scene().add(o.gts, "identity"), P, "world_from_object"),
    Bad("shell_not_affine", lambda o: gt.Scene().add(o.shell, SKEW), P, "world_from_object"),
    Bad("surfels_singular", lambda o: gt.Scene().add(o.surfels, np.diag([0, 0, 0, 1.0])), P, "singular"),
    Bad("igt_mesh_not_affine", lambda o: gt.Scene().add(o.low, SKEW), P, "affine"),
]

VIEWER = [
    Bad("width_str", lambda o: gt.show(o.gts, width="64"), P, "width"),
    Bad("width_huge", lambda o: gt.show(o.gts, width=10**6, height=10**6), P, "width"),
    Bad("height_small", lambda o: gt.show(o.gts, width=64, height=4), P, "height"),
    Bad("azimuth_nan", lambda o: gt.show(o.gts, width=32, height=32, azimuth_deg=np.nan), P, "azimuth_deg"),
    Bad("azimuth_str", lambda o: gt.show(o.gts, width=32, height=32, azimuth_deg="north"), P, "azimuth_deg"),
    Bad("distance_nan", lambda o: gt.show(o.gts, width=32, height=32, distance=np.nan), P, "distance"),
    Bad("distance_negative", lambda o: gt.show(o.gts, width=32, height=32, distance=-1.0), P, "distance"),
    Bad("yfov_zero", lambda o: gt.show(o.gts, width=32, height=32, yfov_deg=0), P, "yfov_deg"),
    Bad("yfov_huge", lambda o: gt.show(o.gts, width=32, height=32, yfov_deg=500), P, "yfov_deg"),
    Bad("lod_str", lambda o: gt.show(o.gts, width=32, height=32, lod="yes"), P, "lod"),
    Bad("shading", lambda o: gt.show(o.gts, width=32, height=32, shading="toon"), P, "shading"),
    Bad("unknown_setting", lambda o: gt.show(o.gts, width=32, height=32, zoom=2), P, "zoom"),
    Bad("compare_without_mesh", lambda o: gt.show(o.gts, width=32, height=32, compare="beside"), P, "mesh="),
    Bad("not_renderable", lambda o: gt.show(42), MESH, "expected a geomtex.Mesh"),
    Bad("mesh_not_a_mesh", lambda o: gt.show(o.gts, mesh=42, width=32, height=32), MESH, "expected a geomtex.Mesh"),
    Bad("empty_scene", lambda o: gt.show(gt.Scene(), width=32, height=32), P, "empty"),
    Bad("zoom_nan", lambda o: o.viewer.zoom(np.nan), P, "factor"),
    Bad("zoom_zero", lambda o: o.viewer.zoom(0), P, "factor"),
    Bad("zoom_str", lambda o: o.viewer.zoom("in"), P, "factor"),
    Bad("orbit_nan", lambda o: o.viewer.orbit(np.nan, 0), P, "d_azimuth_deg"),
    Bad("orbit_str", lambda o: o.viewer.orbit(0, "up"), P, "d_elevation_deg"),
    Bad("set_distance_str", lambda o: o.viewer.set(distance="far"), P, "distance"),
    Bad("set_quality", lambda o: o.viewer.set(quality="best"), P, "quality"),
]


def _cam(o: Objects) -> list[gt.Camera]:
    return [o.camera]


def _render_views(tmp: pathlib.Path, **kw: Any) -> Callable[[Objects], Any]:
    def call(o: Objects) -> Any:
        args = {"objects": [o.gts], "cameras": _cam(o), "out": tmp / "views.zarr", "width": 8, "height": 8,
                "progress": False, **kw}
        args = {k: v(o) if callable(v) and k in ("objects", "cameras") else v for k, v in args.items()}
        return batch.render_views(**args)
    return call


def _convert_many(tmp: pathlib.Path, **kw: Any) -> Callable[[Objects], Any]:
    def call(o: Objects) -> Any:
        args = {"inputs": [o.mesh], "out_dir": tmp / "out", "progress": False, **kw}
        return batch.convert_many(**args)
    return call


def _batch_cases(tmp: pathlib.Path) -> list[Bad]:
    box = trimesh.creation.box()
    return [
        Bad("convert_inputs_one_path", _convert_many(tmp, inputs="mesh.obj"), P, "inputs"),
        Bad("convert_inputs_number", _convert_many(tmp, inputs=5), P, "inputs"),
        Bad("convert_input_missing", _convert_many(tmp, inputs=[tmp / "missing.obj"]), FILE, "cannot read"),
        Bad("convert_input_not_a_mesh", _convert_many(tmp, inputs=[42]), MESH, "expected a geomtex.Mesh"),
        Bad("convert_out_dir_number", _convert_many(tmp, out_dir=5), P, "out_dir"),
        Bad("convert_client_number", _convert_many(tmp, client=3), P, "client"),
        Bad("convert_n_workers_zero", _convert_many(tmp, n_workers=0), P, "n_workers"),
        Bad("convert_n_workers_str", _convert_many(tmp, n_workers="4"), P, "n_workers"),
        Bad("convert_retry_str", _convert_many(tmp, retry_failed="yes"), P, "retry_failed"),
        Bad("convert_progress_str", _convert_many(tmp, progress="yes"), P, "progress"),
        Bad("convert_option_unknown", _convert_many(tmp, resolution=64), P, "resolution"),
        Bad("convert_option_range", _convert_many(tmp, max_resolution=10**6), P, "max_resolution"),
        Bad("convert_option_nan", _convert_many(tmp, texel_size=float("nan")), P, "texel_size"),
        Bad("convert_option_str", _convert_many(tmp, max_resolution="64"), P, "max_resolution"),
        Bad("convert_option_choice", _convert_many(tmp, frame="diagonal"), P, "frame"),
        Bad("render_width_huge", _render_views(tmp, width=10**6, height=10**6), P, "width"),
        Bad("render_width_str", _render_views(tmp, width="8"), P, "width"),
        Bad("render_height_zero", _render_views(tmp, height=0), P, "height"),
        Bad("render_outputs_unknown", _render_views(tmp, outputs=("depth", "face")), P, "outputs"),
        Bad("render_outputs_number", _render_views(tmp, outputs=3), P, "outputs"),
        Bad("render_outputs_empty", _render_views(tmp, outputs=()), P, "outputs"),
        Bad("render_views_per_task_zero", _render_views(tmp, views_per_task=0), P, "views_per_task"),
        Bad("render_views_per_task_fraction", _render_views(tmp, views_per_task=2.5), P, "views_per_task"),
        Bad("render_cameras_number", _render_views(tmp, cameras=5), P, "cameras"),
        Bad("render_cameras_of_strings", _render_views(tmp, cameras=["front"]), P, "cameras"),
        Bad("render_cameras_uneven", _render_views(tmp, objects=[box, box], cameras=lambda o: [[o.camera], []]), P,
            "cameras"),
        Bad("render_objects_one_path", _render_views(tmp, objects="a.gtex"), P, "objects"),
        Bad("render_object_missing", _render_views(tmp, objects=[tmp / "missing.gtex"]), FILE, "missing.gtex"),
        Bad("render_object_not_a_mesh", _render_views(tmp, objects=[42]), MESH, "expected a geomtex.Mesh"),
        Bad("render_out_number", _render_views(tmp, out=5), P, "out"),
        Bad("render_client_number", _render_views(tmp, client=3), P, "client"),
        Bad("render_light_zero", _render_views(tmp, light=_Duck(direction=(0, 0, 0))), P, "light.direction"),
        Bad("render_light_number", _render_views(tmp, light=5), P, "light"),
        Bad("render_option_unknown", _render_views(tmp, speed=2), P, "speed"),
        Bad("render_option_lod_str", _render_views(tmp, lod="yes"), P, "lod"),
        Bad("render_option_background", _render_views(tmp, background=(1.0, 1.0, 1.0)), P, "background"),
        Bad("render_option_quality_number", _render_views(tmp, quality=3), P, "quality"),
        Bad("manifest_out_dir_number", lambda o: batch.read_manifest(5), P, "out_dir"),
        Bad("manifest_not_json", lambda o: _damaged_manifest(tmp, b"{not json"), FORMAT, "manifest.json"),
        Bad("manifest_a_list", lambda o: _damaged_manifest(tmp, b"[1, 2]"), FORMAT, "manifest.json"),
    ]


def _damaged_manifest(tmp: pathlib.Path, data: bytes) -> Any:
    folder = tmp / "damaged"
    folder.mkdir(exist_ok=True)
    (folder / batch.MANIFEST).write_bytes(data)
    return batch.read_manifest(folder)


def _check(case: Bad, o: Objects) -> None:
    with pytest.raises(gt.GeomtexError) as caught:
        case.call(o)
    assert isinstance(caught.value, case.raises), f"{type(caught.value).__name__}: {caught.value}"
    assert case.fragment in str(caught.value), str(caught.value)


@pytest.mark.parametrize("case", IGT, ids=lambda c: c.name)
def test_igt(case: Bad, o: Objects) -> None:
    _check(case, o)


@pytest.mark.parametrize("case", GDM, ids=lambda c: c.name)
def test_gdm(case: Bad, o: Objects) -> None:
    _check(case, o)


@pytest.mark.parametrize("case", SURFELS, ids=lambda c: c.name)
def test_surfels(case: Bad, o: Objects) -> None:
    _check(case, o)


@pytest.mark.parametrize("case", RAYS, ids=lambda c: c.name)
def test_ray_queries(case: Bad, o: Objects) -> None:
    _check(case, o)


@pytest.mark.parametrize("case", LIGHTS, ids=lambda c: c.name)
def test_lights(case: Bad, o: Objects) -> None:
    _check(case, o)


@pytest.mark.parametrize("case", PLACEMENTS, ids=lambda c: c.name)
def test_placements(case: Bad, o: Objects) -> None:
    _check(case, o)


@pytest.mark.parametrize("case", VIEWER, ids=lambda c: c.name)
def test_viewer(case: Bad, o: Objects) -> None:
    before = vars(o.viewer.state).copy()
    _check(case, o)
    assert vars(o.viewer.state) == before  # a bad setting changes nothing


@pytest.mark.parametrize("index", range(len(_batch_cases(pathlib.Path("/")))),
                         ids=[c.name for c in _batch_cases(pathlib.Path("/"))])
def test_batch(index: int, o: Objects, tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("dask.distributed")
    pytest.importorskip("zarr")

    def no_workers(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("the job started although an argument was bad")

    monkeypatch.setattr(batch, "_run_conversions", no_workers)
    monkeypatch.setattr(batch, "_run_renders", no_workers)
    case = _batch_cases(tmp_path)[index]
    _check(case, o)
    # Nothing was written: no output folder, no store.
    assert not (tmp_path / "out").exists() and not (tmp_path / "views.zarr").exists()


def test_bad_calls_change_nothing(o: Objects) -> None:
    scene = gt.Scene()
    scene.add(o.gts)
    with pytest.raises(gt.ParameterError):
        scene.add(o.mesh, SKEW)
    assert len(scene) == 1
    light = gt.DirectionalLight((0, 0, -1))
    with pytest.raises(gt.ParameterError):
        gt.DirectionalLight(np.zeros(3))
    assert np.array_equal(light.direction, [0, 0, -1])


# --- ordinary array-likes are accepted, and give what the canonical form gives


def test_ray_queries_take_array_likes(o: Objects) -> None:
    origin, direction = o.ray
    canonical = o.gts.intersects_first(origin, direction)
    assert canonical.hit.all()
    for origins, directions in [(origin.tolist(), direction.tolist()), (tuple(origin[0]), direction.astype(np.float32)),
                                (origin.astype(np.float32), [[0, 0, -2]]), (origin, direction.astype(np.int64))]:
        hits = o.gts.intersects_first(origins, directions)
        assert np.allclose(hits.locations, canonical.locations, atol=1e-5)
        assert o.gts.intersects_any(origins, directions).tolist() == [True]
        assert np.allclose(o.gts.intersects_location(origins, directions)[0], canonical.locations, atol=1e-5)
    # A batch of no rays is no error: it has no hits (as trimesh's intersector answers).
    assert o.gts.intersects_first(np.zeros((0, 3)), np.zeros((0, 3))).hit.shape == (0,)


def test_igt_takes_array_likes(o: Objects) -> None:
    v, f = o.igt.vertices, o.igt.faces
    canonical = gt.igt.attach(o.igt, v, f)
    for vertices, faces in [(v.tolist(), f.tolist()), (v.astype(np.float32), f.astype(np.uint16)),
                            (v, f.astype(np.float64))]:
        low = gt.igt.attach(o.igt, vertices, faces, samples=np.int64(1), lod=np.float32(2.0))
        assert np.array_equal(low.faces, canonical.faces) and np.allclose(low.vertices, canonical.vertices, atol=1e-6)
    points = v[:4] + [0.0, 0.0, 0.0]
    grids = o.igt.face_grid[:4].clip(0)
    face, bary, found = o.igt.lookup(points, grids)
    for p, g in [(points.tolist(), grids.tolist()), (points.astype(np.float32), tuple(grids.astype(np.int32)))]:
        again = o.igt.lookup(p, g)
        assert np.array_equal(again[0], face) and np.array_equal(again[2], found)
    shaded = o.igt.shade(v.tolist(), f.tolist(), np.zeros(len(f), np.int32))
    assert len(shaded) == len(f)
    data = o.igt.to_bytes()
    for raw in (bytearray(data), memoryview(data)):
        assert len(gt.igt.InverseGeometricTexture.from_bytes(raw).faces) == len(f)


def test_igt_files_take_path_objects(o: Objects, tmp_path: pathlib.Path) -> None:
    o.igt.save(tmp_path / "t.gtigt")
    assert len(gt.igt.load(tmp_path / "t.gtigt").faces) == len(o.igt.faces)
    o.surfels.save(tmp_path / "s.gtsurf")
    assert len(gt.load_surfels(tmp_path / "s.gtsurf")) == len(o.surfels)
    assert len(gt.Surfels.from_bytes(bytearray(o.surfels.to_bytes()))) == len(o.surfels)


def test_gdm_takes_array_likes(o: Objects) -> None:
    occupancy = o.volume.occupancy
    assert gdm.Volume(occupancy.astype(np.int8).tolist()).size == (16, 16, 8)
    colored = gdm.Volume(occupancy, colors=np.full((16, 16, 8, 4), 200, np.int64).tolist())
    assert colored.size == (16, 16, 8)
    assert gdm.Volume.procedural("chain", np.array([16, 16, 8])).size == (16, 16, 8)
    assert gdm.Volume.procedural("chain", [np.int64(16), 16, np.uint8(8)]).size == (16, 16, 8)
    t, hit = o.volume.march([[1.5, 1.5, 7.9]], [[0, 0, -1]])
    for origins, directions in [((1.5, 1.5, 7.9), (0, 0, -3)), (np.float32([[1.5, 1.5, 7.9]]), np.int32([[0, 0, -1]]))]:
        again = o.volume.march(origins, directions, max_t=np.float32(100))
        assert np.allclose(again[0], t, atol=1e-5) and np.array_equal(again[1], hit)
    assert o.volume.distance_function(np.array([2, 4])).directions == (2, 4)
    assert o.table.compress(np.int64(2)).k == 2
    base, uv = o.torus
    shell = gdm.Shell(base, o.volume, np.float32(0.05), uv=uv.tolist(), tiles=[np.int64(2), 3.0],
                      color=np.array([200, 100, 100, 255], np.uint8), pieces=np.int32(4), refine=np.float64(0))
    assert shell.thickness == pytest.approx(0.05) and shell.color == (200, 100, 100, 255)
    torus, torus_uv = gdm.uv_torus(np.float64(1.0), np.float32(0.3), sections=np.array([8, 6]))
    assert len(torus.faces) == 96 and torus_uv.shape == (63, 2)


def test_lights_and_placements_take_array_likes(o: Objects) -> None:
    assert np.array_equal(gt.DirectionalLight((0, 0, -1)).direction, [0, 0, -1])
    assert np.array_equal(gt.DirectionalLight(np.float32([0, 0, -2])).direction, [0, 0, -2])
    assert np.array_equal(gt.PointLight([np.int64(1), 2, 3]).position, [1, 2, 3])
    frame = o.renderer.render(o.gts, o.camera, light=gt.DirectionalLight([0.2, 0.1, -1]))
    assert frame.shadow is not None
    scene = gt.Scene()
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0]).astype(np.float32).tolist()  # a mirror is affine
    scene.add(o.gts, mirror)
    nearly = np.eye(4)
    nearly[3, 3] = 1 - 1e-9  # float rounding in the last row
    scene.add(o.mesh, nearly)
    scene.add(o.surfels, np.eye(4, dtype=np.int64) * 2 + np.diag([0, 0, 0, -1]))
    assert len(scene) == 3
    assert np.allclose(scene._objects()[0][1], np.diag([-1.0, 1, 1, 1]))


def test_batch_options_take_numpy_numbers() -> None:
    pytest.importorskip("dask.distributed")
    options = batch._check_convert_options({"max_resolution": np.int64(64), "texel_size": np.float32(0.5)})
    assert options == {"max_resolution": 64, "texel_size": 0.5} and type(options["max_resolution"]) is int


# --- gt.show draws every kind a Scene takes


def _kinds(o: Objects) -> dict[str, Any]:
    scene = gt.Scene()
    scene.add(o.gts)
    scene.add(o.surfels, _moved(3, 0, 0))
    scene.add(o.low, _moved(-3, 0, 0))
    scene.add(o.shell, _moved(0, 3, 0, scale=0.5))
    return {"set": o.gts, "mesh": o.mesh, "trimesh": trimesh.creation.icosphere(2),
            "trimesh_scene": trimesh.Scene([trimesh.creation.box()]), "surfels": o.surfels, "igt_mesh": o.low,
            "igt": o.igt, "shell": o.shell, "scene": scene}


@pytest.mark.parametrize("kind", ["set", "mesh", "trimesh", "trimesh_scene", "surfels", "igt_mesh", "igt", "shell",
                                  "scene"])
def test_show_draws_every_kind(kind: str, o: Objects) -> None:
    viewer = gt.show(_kinds(o)[kind], width=48, height=48)
    drawn = np.any(viewer.image != 255, axis=-1)
    assert 0.01 < drawn.mean() < 0.98, drawn.mean()  # neither blank nor all of it (a chain shell is sparse)
    rows, cols = np.flatnonzero(drawn.any(axis=1)), np.flatnonzero(drawn.any(axis=0))
    span = max(rows[-1] - rows[0], cols[-1] - cols[0]) + 1
    assert span > 0.4 * 48, span  # framed by its bounds: the object spans much of the view
    viewer.orbit(90, 10)
    assert np.any(viewer.image != 255)


def test_show_frames_a_placed_shell(o: Objects) -> None:
    """A shell added to a scene is framed by its own box, placed."""
    scene = gt.Scene()
    scene.add(o.shell, np.diag([2.0, 2.0, 2.0, 1.0]))
    from geomtex.viewer import _bounds

    lo, hi = _bounds(scene)
    assert np.allclose(lo, 2 * o.shell.bounds[0]) and np.allclose(hi, 2 * o.shell.bounds[1])
    assert (o.shell.bounds[1] - o.shell.bounds[0]).min() > 0


def test_render_refuses_an_unknown_keyword_by_name() -> None:
    """A misspelt keyword was the extension's TypeError; it is a ParameterError naming it."""
    mesh = gt.Mesh(np.eye(3), [[0, 1, 2]])
    camera = gt.Camera.look_at((0.0, 0.0, 3.0), (0.0, 0.0, 0.0))
    with pytest.raises(gt.ParameterError, match="unknown render keyword 'qualty'"):
        gt.Renderer(8, 8).render(mesh, camera, qualty="exact")
