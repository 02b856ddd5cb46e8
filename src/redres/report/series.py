"""Thinning long time series for display without hiding their extremes."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .._validate import FloatArray
from ..errors import InvalidParameterError

IntArray = NDArray[np.int64]


def envelope_indices(values: FloatArray, max_points: int = 2000) -> IntArray:
    """Indices of a min/max envelope of ``values`` with at most ``max_points`` samples.

    The series is cut into ``(max_points − 2) // 2`` consecutive buckets and the smallest
    and largest sample of each are kept (with the first and last samples), so a spike of a
    single step survives the thinning, unlike a fixed stride. Non-finite samples are
    treated as zero for the choice.

    Args:
        values: the series, shape ``(K,)``.
        max_points: upper bound on the number of indices returned (≥ 4).

    Returns:
        Sorted unique indices into ``values``; all of ``0 … K−1`` when ``K ≤ max_points``.
    """
    if max_points < 4:
        raise InvalidParameterError(f"max_points must be at least 4; got {max_points}")
    y = np.asarray(values, dtype=float).reshape(-1)
    count = y.shape[0]
    if count <= max_points:
        return np.arange(count, dtype=np.int64)
    buckets = (max_points - 2) // 2
    size = -(-count // buckets)
    padded = np.where(np.isfinite(y), y, 0.0)
    padded = np.concatenate([padded, np.full(buckets * size - count, padded[-1])])
    blocks = padded.reshape(buckets, size)
    start = np.arange(buckets, dtype=np.int64) * size
    chosen = np.concatenate(
        [[0, count - 1], start + np.argmin(blocks, axis=1), start + np.argmax(blocks, axis=1)]
    )
    return np.unique(np.minimum(chosen, count - 1)).astype(np.int64)


def even_indices(count: int, samples: int) -> IntArray:
    """At most ``samples`` indices spread evenly over ``0 … count−1``, both ends included.

    Args:
        count: length of the series (≥ 1).
        samples: how many indices are wanted (≥ 2).
    """
    if count < 1 or samples < 2:
        raise InvalidParameterError(f"need count ≥ 1 and samples ≥ 2; got {count}, {samples}")
    raw = np.rint(np.linspace(0, count - 1, min(count, samples)))
    return np.unique(raw.astype(np.int64))
