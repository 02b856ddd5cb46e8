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
