"""Arguments checked once at the boundary, for every Python entry point (the extension's own
arguments are checked the same way in src/python/args.rs).

Whatever numpy and trimesh users pass is accepted: lists, tuples, arrays of any real dtype,
numpy scalars. Anything else (a str where a number goes, a bool where a count goes, NaN or inf, a
zero direction, a ragged list, a wrong shape, an absurd size) raises a ParameterError naming the
argument and the value it got, before any work starts, so a bad call changes nothing. A missing
file is a FileError.
"""

from __future__ import annotations

import functools
import inspect
import numbers
import os
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import numpy as np
import numpy.typing as npt

from ._errors import FileError, ParameterError

#: Most rays (or pixels) one call takes: 2^26, as the extension's MAX_RAYS (8192 x 8192).
MAX_RAYS = 1 << 26
#: Longest image side a renderer takes (the extension's MAX_IMAGE_SIDE).
MAX_IMAGE_SIDE = 16384
#: How far the last row of a placement may be from (0, 0, 0, 1) (float32 rounding passes).
AFFINE_TOLERANCE = 1e-6
#: Smallest |det| of a placement's 3x3 part, relative to the cube of its largest entry.
SINGULAR_TOLERANCE = 1e-12

_F = TypeVar("_F", bound=Callable[..., Any])


def keywords(function: _F) -> _F:
    """`function` with its own signature (what help() and editors show), where an unknown or
    misspelled keyword is a ParameterError naming it and the keywords taken, as every other bad
    argument is, rather than Python's TypeError."""
    signature = inspect.signature(function)
    taken = [name for name, p in signature.parameters.items()
             if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY) and name != "self"]

    @functools.wraps(function)
    def checked(*args: Any, **kwargs: Any) -> Any:
        unknown = [name for name in kwargs if name not in signature.parameters]
        if unknown:
            raise ParameterError(f"unknown keyword {unknown[0]!r}: {function.__name__} takes "
                                 f"{', '.join(taken)}")
        return function(*args, **kwargs)

    return checked  # type: ignore[return-value]


def shown(value: Any) -> str:
    """`value` for a message: its repr on one line and shortened, an array by shape and dtype."""
    if isinstance(value, np.ndarray) and value.size > 12:
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    try:
        text = " ".join(repr(value).split())
    except Exception:  # a repr that fails says nothing useful
        text = f"<{type(value).__name__}>"
    return text if len(text) <= 80 else text[:80] + "…"


def fail(name: str, wanted: str, value: Any) -> ParameterError:
    """The ParameterError for `name`: what it must be and what it got."""
    return ParameterError(f"{name} must be {wanted}, got {shown(value)}")


def _is_bool(value: Any) -> bool:
    return isinstance(value, (bool, np.bool_))


def number(name: str, value: Any, kind: type) -> Any:
    """`value` as a Python int or float (None stays None); numpy scalars count as numbers, bools
    and strings do not. Ranges are the caller's (or the extension's) to check."""
    if value is None:
        return None
    wanted = numbers.Integral if kind is int else numbers.Real
    if _is_bool(value) or not isinstance(value, wanted):
        raise ParameterError(f"{name} must be {'a number' if kind is float else 'an integer'}, got {value!r}")
    result = kind(value)
    if kind is int and not -(2**63) <= result < 2**63:  # past what the core's i64 holds
        raise ParameterError(f"{name} is out of range, got {value!r}")
    return result


def _interval(lo: float | None, hi: float | None, lo_open: bool, hi_open: bool) -> str:
    if lo is None and hi is None:
        return ""
    if hi is None:
        return f" {'>' if lo_open else '>='} {lo:g}"
    if lo is None:
        return f" {'<' if hi_open else '<='} {hi:g}"
    return f" in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def real(name: str, value: Any, lo: float | None = None, hi: float | None = None, *,
         lo_open: bool = False, hi_open: bool = False) -> float:
    """A finite real number (int, float or numpy scalar; not bool, not str) within the bounds."""
    if lo == 0 and lo_open and hi is None:
        wanted = "a positive finite number"
    else:
        wanted = "a finite number" + _interval(lo, hi, lo_open, hi_open)
    if _is_bool(value) or not isinstance(value, numbers.Real):
        raise fail(name, wanted, value)
    x = float(value)
    if not np.isfinite(x) or (lo is not None and (x <= lo if lo_open else x < lo)) \
            or (hi is not None and (x >= hi if hi_open else x > hi)):
        raise fail(name, wanted, value)
    return x


def integer(name: str, value: Any, lo: int | None = None, hi: int | None = None) -> int:
    """An integer (Python or numpy; not bool, not a float) within [lo, hi]."""
    wanted = "an integer" + _interval(lo, hi, False, False)
    if _is_bool(value) or not isinstance(value, numbers.Integral):
        raise fail(name, wanted, value)
    n = int(value)
    if (lo is not None and n < lo) or (hi is not None and n > hi):
        raise fail(name, wanted, value)
    return n


def flag(name: str, value: Any) -> bool:
    """True or False (Python or numpy bool), nothing merely truthy."""
    if not _is_bool(value):
        raise fail(name, "True or False", value)
    return bool(value)


def choice(name: str, value: Any, choices: Sequence[str]) -> str:
    """One of `choices` (strings)."""
    if not isinstance(value, str) or value not in choices:
        raise fail(name, "one of " + ", ".join(repr(c) for c in choices), value)
    return value


def callback(name: str, value: Any) -> Callable[..., Any] | None:
    """None or a callable."""
    if value is not None and not callable(value):
        raise fail(name, "None or a callable", value)
    return value


def counts(name: str, value: Any, lo: int, highs: Sequence[int], wanted: str) -> tuple[int, ...]:
    """len(highs) integers (a tuple, list or array of them), the i-th in [lo, highs[i]];
    `wanted` says what they are, e.g. "three voxel counts (nx, ny, nz), each 2 to 512"."""
    try:
        sized = not isinstance(value, (str, bytes)) and len(value) == len(highs)
    except TypeError:  # no length: a number, a 0-d array
        sized = False
    if not sized:
        raise fail(name, wanted, value)
    try:
        return tuple(integer(name, v, lo, h) for v, h in zip(value, highs))
    except ParameterError:
        raise fail(name, wanted, value) from None


_KINDS = {"iu": "integers", "iuf": "real numbers", "biuf": "bools or real numbers"}


def array(name: str, value: Any, kinds: str = "iuf", shape: str = "") -> npt.NDArray[Any]:
    """`value` as a numpy array whose dtype kind is one of `kinds` ("iu" integers, "iuf" real
    numbers, "biuf" also bools); a ragged list, strings, None entries or objects are refused.
    `shape` ("(N, 3)") names the shape wanted in the message. No copy is made."""
    held = _KINDS.get(kinds, "real numbers")
    wanted = f"an {shape} array-like of {held}" if shape else f"an array-like of {held}"
    if isinstance(value, (str, bytes)):
        raise ParameterError(f"{name} must be {wanted}, got {type(value).__name__} {shown(value)}")
    try:
        a = np.asarray(value)
    except (ValueError, TypeError):  # a ragged list
        raise fail(name, wanted + " (not ragged)", value) from None
    if a.dtype.kind not in kinds:
        got = shown(value)
        got = got if got.startswith("an array of shape") else f"{got} of dtype {a.dtype}"
        raise ParameterError(f"{name} must be {wanted}, got {got}")
    return a


def _first_bad_row(ok: npt.NDArray[np.bool_]) -> int:
    return int(np.flatnonzero(~ok.reshape(len(ok), -1).all(axis=1))[0])


def vector(name: str, value: Any, n: int = 3) -> npt.NDArray[np.float64]:
    """A finite float64 vector of `n` reals from any array-like."""
    a = array(name, value)
    if a.shape != (n,):
        raise fail(name, f"{n} finite numbers", value)
    if not np.isfinite(a).all():
        raise fail(name, f"{n} finite numbers (no NaN or inf)", value)
    return np.array(a, dtype=np.float64)


def direction(name: str, value: Any) -> npt.NDArray[np.float64]:
    """A finite, non-zero 3-vector (not normalized)."""
    v = vector(name, value)
    if not np.linalg.norm(v) > 0:
        raise fail(name, "a non-zero direction", value)
    return v


def rows(name: str, value: Any, columns: int = 3, *, label: str = "N", min_rows: int = 0,
         max_rows: int = MAX_RAYS, finite: bool = True) -> npt.NDArray[np.float64]:
    """An (N, columns) C-contiguous float64 array from any array-like of reals, with
    min_rows <= N <= max_rows (checked before any copy) and, with `finite`, no NaN or inf."""
    shape = f"({label}, {columns})"
    a = array(name, value, shape=shape)
    if a.ndim != 2 or a.shape[1] != columns:
        raise ParameterError(f"{name} must be an {shape} array of real numbers, got shape {a.shape}")
    if len(a) < min_rows:
        raise ParameterError(f"{name} must have at least {min_rows} rows, got {len(a)}")
    if len(a) > max_rows:
        raise ParameterError(f"{name} has {len(a)} rows, more than the limit of {max_rows}")
    out = np.ascontiguousarray(a, dtype=np.float64)
    if finite and not np.isfinite(out).all():
        bad = _first_bad_row(np.isfinite(out))
        raise ParameterError(f"{name} must be finite: row {bad} is {out[bad].tolist()}")
    return out


def indices(name: str, value: Any, columns: int, count: int, *, label: str = "N", min_rows: int = 0,
            refers: str = "vertices") -> npt.NDArray[np.int64]:
    """An (N, columns) int64 array of indices into `count` items: integers, or floats holding
    whole numbers; each in [0, count); at least `min_rows` rows."""
    a = array(name, value, shape=f"({label}, {columns})")
    if a.ndim != 2 or a.shape[1] != columns:
        raise ParameterError(f"{name} must be an ({label}, {columns}) array of integers, got shape {a.shape}")
    if len(a) < min_rows:
        raise ParameterError(f"{name} must have at least {min_rows} rows, got {len(a)}")
    if a.dtype.kind == "f":
        whole = np.isfinite(a) & (a == np.round(a))
        if not whole.all():
            bad = _first_bad_row(whole)
            raise ParameterError(f"{name} must hold integer indices: row {bad} is {a[bad].tolist()}")
    inside = (a >= 0) & (a < count)
    if not inside.all():
        bad = _first_bad_row(inside)
        raise ParameterError(f"{name} reference {refers} outside 0..{count - 1}: row {bad} is {a[bad].tolist()}")
    return np.ascontiguousarray(a, dtype=np.int64)


def path(name: str, value: Any, *, exists: bool = False) -> str:
    """A str or os.PathLike as a str; with `exists`, a FileError if nothing is there or it is a
    folder."""
    if not isinstance(value, (str, os.PathLike)):
        raise fail(name, "a str or os.PathLike", value)
    p = os.fspath(value)
    if not isinstance(p, str):  # a PathLike of bytes
        raise fail(name, "a str or os.PathLike", value)
    if exists:
        if not os.path.exists(p):
            raise FileError(f"no such file: {p}")
        if os.path.isdir(p):
            raise FileError(f"{name} {p} is a folder, not a file")
    return p


def affine(name: str, value: Any) -> npt.NDArray[np.float64]:
    """A 4x4 placement: finite, its last row (0, 0, 0, 1) within AFFINE_TOLERANCE and its 3x3
    part invertible (mirrors are allowed)."""
    a = array(name, value, shape="(4, 4)")
    if a.shape != (4, 4):
        raise fail(name, "an array of real numbers of shape (4, 4)", value)
    m = np.array(a, dtype=np.float64)
    if not np.isfinite(m).all():
        raise fail(name, "finite (no NaN or inf)", value)
    if np.abs(m[3] - (0.0, 0.0, 0.0, 1.0)).max() > AFFINE_TOLERANCE:
        raise ParameterError(f"{name} must be affine (last row 0, 0, 0, 1), got last row {m[3].tolist()}")
    linear = m[:3, :3]
    scale = float(np.abs(linear).max())
    if scale == 0.0 or abs(float(np.linalg.det(linear / scale))) < SINGULAR_TOLERANCE:
        raise ParameterError(f"{name} must be invertible, but its 3x3 part is singular: {linear.tolist()}")
    return m


def image_size(width: Any, height: Any, lo: int = 1, hi: int = MAX_IMAGE_SIDE) -> tuple[int, int]:
    """(width, height): integers in [lo, hi], at most MAX_RAYS pixels."""
    w, h = integer("width", width, lo, hi), integer("height", height, lo, hi)
    if w * h > MAX_RAYS:
        raise ParameterError(f"width x height = {w} x {h} pixels is more than the limit of {MAX_RAYS}")
    return w, h


def rgba(name: str, value: Any) -> tuple[int, int, int, int]:
    """Four integers in [0, 255] (R, G, B, A) from any array-like of integers."""
    wanted = "four integers in [0, 255] (R, G, B, A)"
    try:
        a = array(name, value, "iu")
    except ParameterError:
        raise fail(name, wanted, value) from None
    if a.shape != (4,) or (a < 0).any() or (a > 255).any():
        raise fail(name, wanted, value)
    return (int(a[0]), int(a[1]), int(a[2]), int(a[3]))
