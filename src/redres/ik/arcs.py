"""Sets of arm angles as intervals on the circle, and how a redundancy map stores them.

An arc of the circle is ``(lo, hi)`` with ``lo`` in ``[-π, π)`` and ``lo < hi <= lo + 2π``
(``(-π, π)`` is the whole circle). A redundancy map stores a set of arcs as *pieces*
inside ``[-π, π]``: an arc through ``±π`` (``hi > π``) becomes the two pieces
``[lo, π]`` and ``[-π, hi - 2π]``; the pieces are sorted by ``lo``, merged where they
touch, and NaN-padded to a fixed count (:func:`pack`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np

__all__ = ["contains", "from_arcs", "linear_cuts", "merge", "pack", "pieces", "runs", "width"]

TWO_PI = 2.0 * math.pi
Arc = tuple[float, float]


def from_arcs(cuts: np.ndarray, feasible: np.ndarray) -> list[Arc]:
    """The arcs of the circle cut at ``cuts`` (sorted, distinct, in ``[-π, π)``) whose
    flag is set: ``feasible[i]`` for the arc from ``cuts[i]`` to ``cuts[i + 1]`` (the
    last one to ``cuts[0] + 2π``; at least one cut); consecutive feasible arcs are
    joined."""
    count = len(cuts)
    if feasible.all():
        return [(-math.pi, math.pi)]
    if not feasible.any():
        return []
    ext = np.concatenate((cuts, cuts + TWO_PI, [cuts[0] + 2 * TWO_PI]))
    start = int(np.flatnonzero(~feasible)[0])
    out: list[Arc] = []
    begin: int | None = None
    for i in range(start + 1, start + count + 1):
        if feasible[i % count]:
            begin = i if begin is None else begin
        elif begin is not None:
            lo, hi = float(ext[begin]), float(ext[i])
            shift = TWO_PI * math.floor((lo + math.pi) / TWO_PI)
            out.append((lo - shift, hi - shift))
            begin = None
    return out


def pieces(arcs: Iterable[Arc]) -> list[Arc]:
    """The arcs as sorted, merged pieces inside ``[-π, π]`` (module docstring)."""
    out: list[Arc] = []
    for lo, hi in arcs:
        if hi - lo >= TWO_PI:
            out.append((-math.pi, math.pi))
        elif hi > math.pi:
            out += [(lo, math.pi), (-math.pi, hi - TWO_PI)]
        else:
            out.append((lo, hi))
    return merge(out)


def merge(parts: Sequence[Arc]) -> list[Arc]:
    """Pieces inside ``[-π, π]``, sorted by ``lo``, overlapping or touching ones joined."""
    out: list[list[float]] = []
    for lo, hi in sorted(parts):
        if out and lo <= out[-1][1]:
            out[-1][1] = max(out[-1][1], hi)
        else:
            out.append([lo, hi])
    return [(a, b) for a, b in out if b > a]


def width(parts: Iterable[Arc]) -> float:
    """Total length of pieces (disjoint), rad."""
    return float(sum(hi - lo for lo, hi in parts))


def pack(parts: Sequence[Arc], slots: int) -> tuple[np.ndarray, int]:
    """``(slots, 2)`` array of the first ``slots`` pieces, NaN-padded, and the count of
    pieces (more than ``slots`` means the row is truncated)."""
    out = np.full((slots, 2), np.nan)
    for i, (lo, hi) in enumerate(parts[:slots]):
        out[i] = lo, hi
    return out, len(parts)


def contains(intervals: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Whether each angle of ``phi`` (wrapped into ``(-π, π]``) lies in one of the
    stored pieces ``intervals`` (``(..., K, 2)``, NaN-padded; ``phi`` ``(...)`` or
    ``(..., M)`` against the same rows)."""
    phi = np.asarray(phi, dtype=np.float64)
    wrapped = math.pi - np.mod(math.pi - phi, TWO_PI)
    lo, hi = intervals[..., 0], intervals[..., 1]
    if wrapped.ndim == lo.ndim:
        inside = (lo[..., None, :] <= wrapped[..., :, None]) & (
            wrapped[..., :, None] <= hi[..., None, :]
        )
        return np.asarray(inside.any(axis=-1))
    return np.asarray(((lo <= wrapped[..., None]) & (wrapped[..., None] <= hi)).any(axis=-1))


def linear_cuts(cuts: np.ndarray, tol: float = 1e-12) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The circle cut at ``cuts`` (``(..., M)`` in ``[-π, π)``, NaN-padded, any order) and
    at ``-π``, as a segment: arc ``i`` runs from ``start[..., i]`` to ``stop[..., i]``
    (``start`` sorted, cuts closer than ``tol`` merged; the last arc ends at ``π``; arcs
    from ``count`` on are NaN). Returns ``(start, stop, count)``, ``(..., M + 1)`` twice
    and ``(...)``. An arc through ``±π`` is thus always two arcs, as the stored pieces."""
    lead = np.full((*cuts.shape[:-1], 1), -math.pi)
    c = np.sort(np.concatenate((lead, cuts), axis=-1), axis=-1)
    near = np.zeros(c.shape, dtype=bool)
    near[..., 1:] = np.diff(c, axis=-1) <= tol  # NaN differences are False
    c = np.sort(np.where(near, np.nan, c), axis=-1)
    count = np.isfinite(c).sum(axis=-1)
    stop = np.concatenate((c[..., 1:], np.full_like(lead, np.nan)), axis=-1)
    last = np.arange(c.shape[-1]) == (count - 1)[..., None]
    return c, np.where(last, math.pi, stop), count


def runs(
    start: np.ndarray, stop: np.ndarray, feasible: np.ndarray, slots: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The stored pieces of the arcs of :func:`linear_cuts` whose ``feasible`` flag is set
    (``(..., A)``; arcs past the count must be False): runs of consecutive feasible arcs
    joined. Returns ``(pieces (..., slots, 2) NaN-padded, count (...), width (...))``."""
    off = np.zeros((*feasible.shape[:-1], 1), dtype=bool)
    first = feasible & ~np.concatenate((off, feasible[..., :-1]), axis=-1)
    final = feasible & ~np.concatenate((feasible[..., 1:], off), axis=-1)
    index = np.cumsum(first, axis=-1) - 1
    out = np.full((*feasible.shape[:-1], slots, 2), np.nan)
    at_first, at_final = np.nonzero(first), np.nonzero(final)  # paired, in row order
    piece = index[at_first]
    keep = piece < slots
    where: tuple[np.ndarray, ...] = (*(r[keep] for r in at_first[:-1]), piece[keep])
    out[..., 0][where] = start[at_first][keep]
    out[..., 1][where] = stop[at_final][keep]
    widths = np.where(feasible, stop - start, 0.0).sum(axis=-1)
    return out, first.sum(axis=-1), widths
