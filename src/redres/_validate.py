"""Input checks shared by the public entry points (internal).

Each check raises an error from :mod:`redres.errors` that names the argument, says what
was expected and what was given. They are written to be cheap: they run on every call of
the public API, including inside control loops.
"""

from __future__ import annotations

import difflib
import functools
import inspect
import math
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from .errors import InvalidParameterError, NonFiniteError, ShapeError, UnknownParameterError

FloatArray = NDArray[np.float64]

#: Bound on a model's or an obstacle's lengths, m (link lengths and offsets, centres of
#: mass, obstacle coordinates and radii). Robots and workcells are metres across, so a
#: kilometre is a unit slip; the bound also keeps products of lengths (lever arms squared
#: in the mass matrix, squared distances) far from overflowing.
MAX_LENGTH = 1e3
#: Bound on a link's mass, kg (the heaviest industrial arms' links weigh about a tonne).
MAX_MASS = 1e6
_F = TypeVar("_F", bound=Callable[..., Any])
_EYE3 = np.eye(3)


def as_vector(
    value: Any, name: str, size: int | None = None, *, limit: float | None = None
) -> FloatArray:
    """Return ``value`` as a finite float64 vector, optionally of a given size and with
    every entry within ``±limit``."""
    if type(value) is np.ndarray and value.dtype == np.float64:
        arr = value  # the common case in control loops: no conversion
    else:
        arr = _real_array(value, name, "a vector")
    if arr.ndim != 1 or (size is not None and arr.shape[0] != size):
        expected = f"({size},)" if size is not None else "a 1-D vector"
        raise ShapeError(f"{name} must have shape {expected}; got shape {arr.shape}")
    # isfinite().all(), not the cheaper isfinite(sum()): summing inf and -inf, or entries
    # near 1e308, raises a RuntimeWarning before the error (an exception under -W error).
    if not np.isfinite(arr).all():
        raise NonFiniteError(f"{name} contains NaN or infinity: {arr}")
    if limit is not None and arr.size and np.abs(arr).max() > limit:
        raise InvalidParameterError(f"{name} must lie within ±{limit:g}; got {arr}")
    return arr


def real_array(value: Any, name: str, what: str = "an array") -> FloatArray:
    """``value`` as a float64 array of any shape (no copy when it is one already), its
    values unchecked; a complex array is an :class:`~redres.errors.InvalidParameterError`
    naming ``name``, never made real; non-numbers a :class:`~redres.errors.ShapeError`."""
    if type(value) is np.ndarray and value.dtype == np.float64:
        return value
    return _real_array(value, name, what)


def _real_array(value: Any, name: str, what: str) -> FloatArray:
    """``value`` as a float64 array; complex values are refused, not made real."""
    try:
        raw = value if isinstance(value, np.ndarray) else np.asarray(value)
        if raw.dtype.kind in "bSUV":  # astype would read "1.5", b"1" and True as numbers
            raise TypeError(f"{raw.dtype} is not a number type")
        arr = None if raw.dtype.kind == "c" else raw.astype(np.float64, copy=False)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ShapeError(f"{name} must be {what} of numbers; got {short_repr(value)}") from exc
    if arr is None:
        raise InvalidParameterError(
            f"{name} must be real; got a complex array (dtype {raw.dtype}): pass {name}.real "
            "if the imaginary part is meant to be dropped"
        )
    return arr


def as_matrix(
    value: Any, name: str, shape: tuple[int | None, int | None] = (None, None)
) -> FloatArray:
    """Return ``value`` as a finite float64 matrix; ``None`` in ``shape`` means any size."""
    arr = _real_array(value, name, "a 2-D array")
    if arr.ndim != 2 or any(s is not None and s != a for s, a in zip(shape, arr.shape)):
        want = "x".join("m" if s is None else str(s) for s in shape)
        raise ShapeError(f"{name} must be a {want} matrix; got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise NonFiniteError(f"{name} contains NaN or infinity")
    return arr


def as_transform(value: Any, name: str) -> FloatArray:
    """Return ``value`` as a 4x4 homogeneous transform with a proper rotation block."""
    T = as_matrix(value, name, (4, 4))
    R = T[:3, :3]
    if abs(T[3, 0]) + abs(T[3, 1]) + abs(T[3, 2]) + abs(T[3, 3] - 1.0) > 1e-9:
        raise ShapeError(f"{name} must be homogeneous: last row [0, 0, 0, 1]; got {T[3]}")
    if np.abs(R @ R.T - _EYE3).max() > 1e-6 or np.linalg.det(R) < 0.0:
        raise ShapeError(f"{name}: the upper-left 3x3 block is not a rotation matrix")
    return T


def as_scalar(
    value: Any,
    name: str,
    *,
    minimum: float | None = None,
    strict: bool = False,
    maximum: float | None = None,
) -> float:
    """Return ``value`` as a finite real float, optionally bounded below (``strict``:
    ``>``) and above (``<=``)."""
    if isinstance(value, (complex, np.complexfloating)):
        raise InvalidParameterError(f"{name} must be a real number; got {value!r}")
    if isinstance(value, (bool, np.bool_, str, bytes)):  # float() takes "1.5", b"1" and True
        raise InvalidParameterError(f"{name} must be a number; got {short_repr(value)}")
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidParameterError(f"{name} must be a number; got {short_repr(value)}") from exc
    if not math.isfinite(x):
        raise NonFiniteError(f"{name} must be finite; got {x}")
    if minimum is not None and (x <= minimum if strict else x < minimum):
        relation = ">" if strict else ">="
        raise InvalidParameterError(f"{name} must be {relation} {minimum}; got {x}")
    if maximum is not None and x > maximum:
        raise InvalidParameterError(f"{name} must be <= {maximum:g}; got {x:g}")
    return x


def as_gains(value: Any, name: str, size: int | None = None) -> float | FloatArray:
    """A nonnegative scalar, or one nonnegative value per row or joint (``(size,)``; any
    length when ``size`` is None): a gain or a weight. Errors name it ``name``."""
    if isinstance(value, (int, float)) or np.ndim(value) == 0:
        return as_scalar(value, name, minimum=0.0)
    values = as_vector(value, name, size).copy()
    if np.any(values < 0.0):
        raise InvalidParameterError(f"{name} must be >= 0 on every entry; got {values}")
    return values


def as_seed(seed: Any, name: str = "seed") -> int | np.integer[Any] | np.random.Generator | None:
    """``seed`` checked to be a generator, a seed (an integer >= 0) or None, as given."""
    if (
        seed is None
        or isinstance(seed, np.random.Generator)
        or (isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0)
    ):
        return seed  # type: ignore[no-any-return]
    raise InvalidParameterError(
        f"{name} must be a numpy.random.Generator, a seed (an integer >= 0) or None; got "
        f"{short_repr(seed)}"
    )


def as_rng(rng: Any, name: str = "rng") -> np.random.Generator:
    """A NumPy generator from a generator, a seed (an integer >= 0) or None (fresh)."""
    rng = as_seed(rng, name)
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


def short_repr(value: Any, limit: int = 80) -> str:
    """``repr(value)`` cut to ``limit`` characters, for a one-line message."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def checked_keywords(func: _F) -> _F:
    """Make a misspelt or unknown keyword argument of ``func`` an
    :class:`~redres.errors.UnknownParameterError` (a ``RedresError`` and a ``TypeError``)
    that lists the valid names and the nearest one, instead of Python's bare ``TypeError``.

    Use on constructors that take settings by keyword (schemes, controllers): only the
    failed call pays for the check.
    """
    signature = inspect.signature(func)
    names = [
        p.name for p in signature.parameters.values()
        if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY) and p.name != "self"
    ]  # fmt: skip

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except TypeError as exc:
            try:
                signature.bind(*args, **kwargs)
            except TypeError:
                raise unknown_keyword(func.__qualname__, names, kwargs, exc) from None
            raise

    return wrapper  # type: ignore[return-value]


def unknown_keyword(
    qualname: str, names: list[str], kwargs: dict[str, Any], exc: TypeError | None = None
) -> UnknownParameterError:
    """The error for the first of ``kwargs`` that is not in ``names`` (the nearest name
    suggested); ``exc`` (Python's own error) when every key is known."""
    owner = qualname.removesuffix(".__init__")
    for key in kwargs:
        if key not in names:
            near = difflib.get_close_matches(key, names, n=1)
            hint = f"; did you mean {near[0]!r}?" if near else ""
            return UnknownParameterError(
                f"{owner}() has no parameter {key!r}{hint} (its parameters: {', '.join(names)})"
            )
    return UnknownParameterError(f"{owner}(): {exc}")
