"""The geomtex exception tree. The classes are created by the extension (src/python/errors.rs), so
every error the Rust core raises is one of them; this module re-exports them.

    GeomtexError
    ├── MeshError (ValueError)        the input mesh is unusable
    ├── ParameterError (ValueError)   a keyword is out of range, of the wrong type, or contradictory
    ├── FormatError (ValueError)      a file is not an intact .gtex (or mesh) file
    ├── FileError (OSError)           a file could not be read or written
    ├── CancelledError                the progress callback returned False
    ├── DeviceError (RuntimeError)    no usable GPU adapter, or the GPU refused a resource
    └── InternalError (RuntimeError)  a bug: a panic caught at the boundary

Warnings (the call goes on): ``AppearanceWarning`` (geomtex._mesh, a color source that cannot be
carried) and ``CapWarning`` (a conversion cap was hit: the result is not what was asked for).
"""

from __future__ import annotations

from ._core import (
    CancelledError,
    DeviceError,
    FileError,
    FormatError,
    GeomtexError,
    InternalError,
    MeshError,
    ParameterError,
)


class CapWarning(UserWarning):
    """A conversion hit a cap: VSA stopped at ``max_charts`` above its chart-error target
    (``stats["charts_capped"]``), or the maps still exceed ``max_bytes`` after the texel was
    coarsened (``stats["max_bytes_exceeded"]``)."""


__all__ = [
    "CancelledError",
    "CapWarning",
    "DeviceError",
    "FileError",
    "FormatError",
    "GeomtexError",
    "InternalError",
    "MeshError",
    "ParameterError",
]
