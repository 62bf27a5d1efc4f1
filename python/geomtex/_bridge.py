"""How the package talks to its extension, ``geomtex._core``: one style for every class.

Every public class is a Python class holding an extension object as ``self._core`` (the way
polars holds its Rust frames): its methods are typed, documented here and forward to the handle.
The extension's classes are used as they are, never subclassed and never given methods at import,
so ``geomtex._core`` is exactly what ``_core.pyi`` describes and importing geomtex changes nothing
in it. Two helpers cross the boundary: `wrap` turns what the extension returns into the public
object, `unwrap` turns a public object back into what the extension takes.
"""

from __future__ import annotations

import dataclasses
import inspect
import typing
from typing import Any, Callable, ClassVar, Generic, TypeVar, overload

import numpy as np

from ._errors import InternalError, ParameterError

T = TypeVar("T")
W = TypeVar("W", bound="Wrapped")

# Numbers as the extension takes them (numpy scalars too), for the public signatures.
Int = int | np.integer[Any]
Real = float | np.floating[Any] | Int
Flag = bool | np.bool_


class Wrapped:
    """Base of the public classes that hold an extension object. ``class X(Wrapped,
    core=_core.X)`` also makes `wrap` turn a ``_core.X`` into an X; ``made_by="..."`` says how one
    is made, for a class users do not construct (``X(...)`` is then a ParameterError saying so)."""

    _core: Any
    _made_by: ClassVar[str | None] = None
    #: The public class of each extension class `wrap` meets.
    _public: ClassVar[dict[type, type[Wrapped]]] = {}

    def __init_subclass__(cls, core: type | None = None, made_by: str | None = None, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if core is not None:
            Wrapped._public[core] = cls
        if made_by is not None:
            #: How one is made, for the API reference (which then shows no constructor).
            cls._made_by = made_by

            def refuse(cls: type, *args: Any, **kwargs: Any) -> Any:
                name = cls.__name__
                article = "an" if name[0] in "AEIOU" else "a"
                raise ParameterError(f"{article} {name} is made by {made_by}, not by {name}(...)")

            cls.__new__ = refuse  # type: ignore[method-assign, assignment]

    @classmethod
    def _wrap(cls: type[W], handle: Any) -> W:
        """An instance around an extension object, without running ``__init__`` (which builds a
        new one from user arguments)."""
        obj = object.__new__(cls)
        obj._core = handle
        return obj

    def __repr__(self) -> str:
        return repr(self._core)


def wrap(handle: Any) -> Any:
    """The public object for an extension object (`Wrapped` subclasses name their extension
    class); anything else (arrays, numbers, None) as it is."""
    cls = Wrapped._public.get(type(handle))
    if cls is not None:
        return cls._wrap(handle)
    if type(handle).__module__ == "geomtex._core":  # a class with no public face: a bug here
        raise InternalError(f"geomtex has no public class for the extension's {type(handle).__name__}")
    return handle


def unwrap(obj: Any) -> Any:
    """What the extension takes for `obj`: a public object's handle, anything else as it is (the
    extension then says what it expected)."""
    return obj._core if isinstance(obj, Wrapped) else obj


class forward(Generic[T]):
    """A read-only attribute read from the handle under the same name:
    ``positions = forward[NDArray[np.float64]]("(N, 3) float64 world positions.")``. One line
    per attribute, typed for mypy and documented for ``help()``, instead of a property each."""

    def __init__(self, doc: str) -> None:
        self.__doc__ = doc
        self.name = ""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> forward[T]: ...
    @overload
    def __get__(self, obj: object, owner: type | None = None) -> T: ...

    def __get__(self, obj: object | None, owner: type | None = None) -> T | forward[T]:
        if obj is None:
            return self
        return getattr(obj._core, self.name)  # type: ignore[attr-defined, no-any-return]

    def __set__(self, obj: object, value: Any) -> None:
        raise AttributeError(f"{self.name} is read-only")


class _Unchanged:
    """The default shown for a keyword whose absence leaves a setting as it is."""

    def __repr__(self) -> str:
        return "<unchanged>"


#: Shown as the default of a keyword that, left out, changes nothing (``Viewer.set``).
UNCHANGED: Any = _Unchanged()


def _written(annotation: Any) -> Any:
    """An annotation as the source wrote it (a TypedDict holds its keys' as ForwardRefs)."""
    return annotation.__forward_arg__ if isinstance(annotation, typing.ForwardRef) else annotation


def keyword_parameters(source: Any, *, default: Any = None, drop: tuple[str, ...] = ()) -> list[inspect.Parameter]:
    """Keyword-only parameters named after `source`: a TypedDict (its keys, each with `default`),
    a dataclass (its fields that have defaults, with those) or a function (its keyword-only
    parameters as they are); names in `drop` are left out. Annotations stay as written (strings
    under ``from __future__ import annotations``): ``help()`` shows ``Real | None``, not the union
    it stands for."""
    if isinstance(source, type) and hasattr(source, "__total__"):  # a TypedDict
        return [inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=default, annotation=_written(hint))
                for name, hint in source.__annotations__.items() if name not in drop]
    if dataclasses.is_dataclass(source):
        return [inspect.Parameter(f.name, inspect.Parameter.KEYWORD_ONLY, annotation=_written(f.type),
                                  default=f.default if default is None else default)
                for f in dataclasses.fields(source) if f.name not in drop and f.default is not dataclasses.MISSING]
    return [p for p in inspect.signature(source).parameters.values()
            if p.kind is inspect.Parameter.KEYWORD_ONLY and p.name not in drop]


F = TypeVar("F", bound=Callable[..., Any])


def spelled_out(*keywords: inspect.Parameter) -> Callable[[F], F]:
    """Gives a function that takes its keywords as ``**options`` (to check them itself: an
    unknown one is a ParameterError naming it, not a TypeError) a ``__signature__`` naming them,
    so ``help()``, ``inspect.signature``, IPython and the API reference show the real keywords.
    The ``**`` parameter is replaced by `keywords` (see `keyword_parameters`); type checkers see
    the function as written (``**options: Unpack[SomeTypedDict]`` types them there)."""

    def decorate(func: F) -> F:
        sig = inspect.signature(func)
        params = [p for p in sig.parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
        taken = {p.name for p in params}
        params += [p for p in keywords if p.name not in taken]
        func.__signature__ = sig.replace(parameters=params)  # type: ignore[attr-defined]
        return func

    return decorate
