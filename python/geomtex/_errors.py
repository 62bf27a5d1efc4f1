"""The geomtex exception tree. The Rust core maps each of its errors onto one of these."""

from __future__ import annotations


class GeomtexError(Exception):
    """Root of every error geomtex raises on purpose."""


class MeshError(GeomtexError, ValueError):
    """The input mesh is unusable: NaN/inf, bad or negative indices, empty, wrong shape/dtype."""


class ParameterError(GeomtexError, ValueError):
    """A keyword is out of range, of the wrong type, or contradicts another."""


class FormatError(GeomtexError, ValueError):
    """A file is not a .gtex (or mesh) file, is truncated, corrupt, or of an unknown version."""


class FileError(GeomtexError, OSError):
    """A file could not be read or written."""


class CancelledError(GeomtexError):
    """The progress callback returned False."""


class DeviceError(GeomtexError, RuntimeError):
    """No usable GPU adapter (reserved for the renderer)."""
