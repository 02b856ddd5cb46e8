"""Inputs of :mod:`redres.batch` (internal): rows with a leading batch axis, checked and
made the one array type the batch kernels are compiled for, with errors naming the row."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from .._validate import FloatArray, real_array
from ..errors import InvalidParameterError, ShapeError


def _targets(value: Any) -> tuple[FloatArray, int]:
    """Targets as ``(N, 4, 4)`` C-contiguous float64 and the task rows (6, or 3 for
    positions)."""
    array = real_array(value, "targets", "poses (N, 4, 4) or positions (N, 3)")
    if array.ndim == 2 and array.shape[1] == 3:
        _fits_in_memory(array.shape[0] * 16 * 8, "the targets' poses")
        T = np.tile(np.eye(4), (len(array), 1, 1))
        T[:, :3, 3] = array
        return T, 3
    if array.ndim != 3 or array.shape[1:] != (4, 4):
        raise ShapeError(f"targets must have shape (N, 4, 4) or (N, 3); got {array.shape}")
    _fits_in_memory(array.shape[0] * 16 * 8, "the targets' copy")
    return _typed(array), 6


def _keys(keys: Any, seed: Any, count: int) -> Any:
    """The restart keys: ``keys`` checked, or drawn from ``default_rng(seed)``."""
    if keys is None:
        return np.random.default_rng(seed).integers(0, 2**62, count)
    try:
        array = np.asarray(keys)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"keys must be {count} integers, shape ({count},)") from exc
    if array.shape != (count,) or array.dtype.kind not in "iu":
        raise ShapeError(f"keys must be {count} integers, shape ({count},); got {array.shape}")
    if count and (array.min() < 0 or array.max() >= 2**62):
        raise InvalidParameterError("keys must lie in [0, 2**62)")
    return np.array(array, dtype=np.int64)  # a writeable copy: the compiled type


def _is_complex(value: Any) -> bool:
    """Whether ``value`` holds complex numbers (False for ragged input: found below)."""
    try:
        return bool(np.iscomplexobj(value))
    except (TypeError, ValueError):
        return False


def _rows(value: Any, name: str, width: int, count: int | None = None) -> FloatArray:
    """``value`` as a C-contiguous float64 ``(N, width)`` array: ``N`` rows, or, when
    ``count`` is given, ``count`` rows or one ``(width,)`` vector for all (kept as one
    row). Ragged or mis-shaped input raises :class:`ShapeError` naming the row."""
    if _is_complex(value):
        real_array(value, name)  # raises: complex is refused by name, not made real
    try:
        raw = np.asarray(value)
        if raw.dtype.kind in "bSUV":  # astype would read "1.5", b"1" and True as numbers
            raise TypeError(f"{raw.dtype} is not a number type")
    except (TypeError, ValueError) as exc:
        raise _ragged(value, name, width) or ShapeError(
            f"{name} must be an array of numbers of shape (N, {width}): {exc}"
        ) from exc
    if raw.dtype != np.float64:
        _fits_in_memory(raw.size * 8, f"{name}'s copy")
    try:
        array = raw.astype(np.float64, copy=False)
    except (TypeError, ValueError, OverflowError) as exc:  # 10**400, an object
        raise ShapeError(
            f"{name} must be an array of numbers of shape (N, {width}): {exc}"
        ) from exc
    if count is not None and array.shape == (width,):
        return _typed(array[None])
    if not array.flags.c_contiguous:  # a broadcast view of 10**9 rows is copied below
        _fits_in_memory(array.size * 8, f"{name}'s copy")
    expected = f"(N, {width})" if count is None else f"({count}, {width}) or ({width},)"
    if array.ndim != 2 or array.shape[1] != width or count not in (None, len(array)):
        hint = f"; for one item use {name}[None]" if array.shape == (width,) else ""
        raise ShapeError(f"{name} must have shape {expected}; got shape {array.shape}{hint}")
    return _typed(array)


def _typed(array: FloatArray) -> FloatArray:
    """``array`` C-contiguous and writeable: the one array type the kernels are compiled
    (and cached) for; a read-only input would compile them again."""
    out = np.ascontiguousarray(array)
    return out if out.flags.writeable and out.flags.aligned else out.copy()


def _ragged(value: Any, name: str, width: int) -> ShapeError | None:
    """The error naming the first row of ``value`` that is not ``width`` numbers."""
    try:
        rows = list(value)
    except TypeError:
        return None
    for i, row in enumerate(rows):
        try:
            shape = np.asarray(row, dtype=np.float64).shape
        except (TypeError, ValueError) as exc:
            return ShapeError(f"{name}[{i}] is not a vector of {width} numbers: {exc}")
        if shape != (width,):
            return ShapeError(
                f"{name}[{i}] has shape {shape}; every row of {name} must have shape "
                f"({width},) (ragged input)"
            )
    return None


def _fits_in_memory(size: int, what: str) -> None:
    """Refuse a call whose output arrays (``size`` bytes) exceed half the machine's memory
    (a broadcast of 10⁹ targets), before allocating them."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # not POSIX: numpy's own MemoryError
        return
    if size > total // 2:
        raise InvalidParameterError(
            f"{what} would need {size / 2**30:.1f} GiB for its outputs, more than half of this "
            f"machine's {total / 2**30:.0f} GiB: split the targets into chunks, or run a sweep "
            "(redres.sweeps) that stores its shards on disk"
        )
