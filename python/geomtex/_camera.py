"""`Camera`: where a frame or a batch of rays is seen from."""

from __future__ import annotations

from typing import Any, Literal, Sequence

import numpy as np
import numpy.typing as npt

from . import _core
from ._bridge import Int, Real, Wrapped, forward

CameraState = tuple[str, npt.NDArray[np.float64], list[float], "float | None"]


class Camera(Wrapped, core=_core.Camera,
             made_by="Camera.look_at, Camera.from_intrinsics or Camera.orthographic"):
    """A camera: OpenGL-style pose (looks down -Z, +Y up) as pyrender and trimesh use.

    Made by `look_at`, `from_intrinsics` (OpenCV) or `orthographic`; ``Camera(...)`` is a
    ParameterError. ``near`` (every constructor): a fixed near plane distance, or None to choose
    one from the scene's bounds at render time. Invalid poses, fields of view and intrinsics
    raise :class:`ParameterError`. Cameras pickle.
    """

    _core: _core.Camera

    def __reduce__(self) -> tuple[Any, ...]:
        from ._pickle import restore_camera

        return restore_camera, self._state()

    @staticmethod
    def look_at(eye: npt.ArrayLike, target: npt.ArrayLike, up: npt.ArrayLike | None = None,
                yfov_deg: Real | None = None, near: Real | None = None) -> Camera:
        """A perspective camera at `eye` looking at `target`.

        Parameters
        ----------
        eye, target : (3,) array-like
            World positions; they must differ.
        up : (3,) array-like, optional
            The world direction that is up in the image (default +Y); not along the view.
        yfov_deg : float, optional
            Vertical field of view in degrees, in (0, 180) (default 45).
        near : float, optional
            A fixed near plane distance (default: chosen from the scene's bounds).

        Returns
        -------
        Camera
        """
        return Camera._wrap(_core.Camera.look_at(eye, target, up, yfov_deg, near))

    @staticmethod
    def from_intrinsics(K: npt.ArrayLike, world_from_camera: npt.ArrayLike, width: Int, height: Int,
                        near: Real | None = None) -> Camera:
        """A camera from OpenCV intrinsics and pose, for an image of `width` x `height`.

        Parameters
        ----------
        K : (3, 3) array-like
            OpenCV intrinsics (fx, fy, cx, cy in pixels).
        world_from_camera : (4, 4) array-like
            OpenCV camera-to-world pose (looks down +Z, +Y down).
        width, height : int
            The image size the intrinsics are for; render at this size.
        near : float, optional
            A fixed near plane distance (default: chosen from the scene's bounds).

        Returns
        -------
        Camera
        """
        return Camera._wrap(_core.Camera.from_intrinsics(K, world_from_camera, width, height, near))

    @staticmethod
    def orthographic(world_from_camera: npt.ArrayLike, ymag: Real, near: Real | None = None) -> Camera:
        """An orthographic camera.

        Parameters
        ----------
        world_from_camera : (4, 4) array-like
            OpenGL camera-to-world pose (looks down -Z, +Y up).
        ymag : float
            Half the view's height in world units (the width follows the image's aspect).
        near : float, optional
            A fixed near plane distance (default: chosen from the scene's bounds).

        Returns
        -------
        Camera
        """
        return Camera._wrap(_core.Camera.orthographic(world_from_camera, ymag, near))

    @staticmethod
    def _from_state(kind: str, world_from_camera: npt.ArrayLike, numbers: Sequence[float],
                    near: float | None) -> Camera:
        """The camera `_state` described, checked as the constructors check their arguments."""
        return Camera._wrap(_core.Camera._from_state(kind, world_from_camera, numbers, near))

    world_from_camera = forward[npt.NDArray[np.float64]]("(4, 4) float64 OpenGL-style camera-to-world pose.")
    kind = forward[Literal["perspective", "intrinsics", "orthographic"]](
        '"perspective", "intrinsics" or "orthographic".')

    @property
    def forward(self) -> list[float]:
        """The unit vector the camera looks along (its -Z axis in world space); z-depth is measured
        along it."""
        return self._core.forward

    def rays(self, width: Int, height: Int) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """World rays through every pixel centre of a width x height image: origins and unit
        directions, each (height, width, 3) float64, row 0 at the top. The renderer's own rays.
        At most 2^26 rays (8192 x 8192) per call."""
        return self._core.rays(width, height)

    def _state(self) -> CameraState:
        """What the camera is made of, as pickling stores it: (kind, world_from_camera (4, 4)
        OpenGL pose, projection numbers, near or None); `_from_state` makes it again."""
        return self._core._state()
