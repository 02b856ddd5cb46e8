"""Closest points between segments and points (exact; Ericson, *Real-Time Collision
Detection*, 2005, §5.1.9), the distances of capsules and spheres."""

from __future__ import annotations

import numpy as np

from .._validate import FloatArray

_EPS = 1e-15


def closest_point_on_segment(p: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """The point of segment ``[a, b]`` closest to ``p``."""
    ab = b - a
    denom = float(ab @ ab)
    if denom <= _EPS:
        return a.copy()
    t = float((p - a) @ ab) / denom
    return a + (0.0 if t < 0.0 else 1.0 if t > 1.0 else t) * ab


def closest_points_segments(
    p1: FloatArray, q1: FloatArray, p2: FloatArray, q2: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Closest points ``(c1, c2)`` of segments ``[p1, q1]`` and ``[p2, q2]``."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e, f = float(d1 @ d1), float(d2 @ d2), float(d2 @ r)
    if a <= _EPS and e <= _EPS:
        return p1.copy(), p2.copy()
    if a <= _EPS:
        s, t = 0.0, float(np.clip(f / e, 0.0, 1.0))
    else:
        c = float(d1 @ r)
        if e <= _EPS:
            s, t = float(np.clip(-c / a, 0.0, 1.0)), 0.0
        else:
            b = float(d1 @ d2)
            denom = a * e - b * b
            s = float(np.clip((b * f - c * e) / denom, 0.0, 1.0)) if denom > _EPS * a * e else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t, s = 0.0, float(np.clip(-c / a, 0.0, 1.0))
            elif t > 1.0:
                t, s = 1.0, float(np.clip((b - c) / a, 0.0, 1.0))
    return p1 + s * d1, p2 + t * d2


def segment_point_distances(a: FloatArray, b: FloatArray, p: FloatArray) -> FloatArray:
    """Distances ``(N,)`` from the point ``p`` ``(3,)`` to segments ``[a, b]`` ``(N, 3)``:
    :func:`closest_point_on_segment` row by row."""
    ab = b - a
    denom = np.einsum("ij,ij->i", ab, ab)
    t = np.einsum("ij,ij->i", p - a, ab) / np.where(denom <= _EPS, 1.0, denom)
    t = np.where(denom <= _EPS, 0.0, np.clip(t, 0.0, 1.0))
    gap = a + t[:, None] * ab - p
    return np.sqrt(np.einsum("ij,ij->i", gap, gap))


def segment_segment_distances(
    p1: FloatArray, q1: FloatArray, p2: FloatArray, q2: FloatArray
) -> FloatArray:
    """Distances ``(N,)`` between segments ``[p1, q1]`` ``(N, 3)`` and one segment
    ``[p2, q2]`` ``(3,)``: :func:`closest_points_segments` row by row (the same cases)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.einsum("ij,ij->i", d1, d1)
    e = float(d2 @ d2)
    f = r @ d2
    c = np.einsum("ij,ij->i", d1, r)
    b = d1 @ d2
    safe_a = np.where(a <= _EPS, 1.0, a)
    if e <= _EPS:  # the second segment is a point
        s, t = np.where(a <= _EPS, 0.0, np.clip(-c / safe_a, 0.0, 1.0)), np.zeros_like(a)
    else:
        denom = a * e - b * b
        general = denom > _EPS * a * e
        s = np.where(general, np.clip((b * f - c * e) / np.where(general, denom, 1.0), 0.0, 1.0),
                     0.0)  # fmt: skip
        t = (b * s + f) / e
        low, high = t < 0.0, t > 1.0
        s = np.where(low, np.clip(-c / safe_a, 0.0, 1.0), s)
        s = np.where(high, np.clip((b - c) / safe_a, 0.0, 1.0), s)
        t = np.clip(t, 0.0, 1.0)
        point = a <= _EPS  # the first segment is a point
        s = np.where(point, 0.0, s)
        t = np.where(point, np.clip(f / e, 0.0, 1.0), t)
    gap = (p1 + s[:, None] * d1) - (p2 + t[:, None] * d2)
    return np.sqrt(np.einsum("ij,ij->i", gap, gap))
