"""Closest points of segments against a brute-force search."""

from __future__ import annotations

import numpy as np

from redres.collision.geometry import closest_point_on_segment, closest_points_segments


def brute_force(p1, q1, p2, q2, samples: int = 801) -> float:  # type: ignore[no-untyped-def]
    s = np.linspace(0, 1, samples)[:, None]
    a = p1 + s * (q1 - p1)
    b = p2 + s * (q2 - p2)
    return float(np.min(np.linalg.norm(a[:, None] - b[None], axis=2)))


def test_segment_segment_distance_matches_brute_force(rng: np.random.Generator) -> None:
    for _ in range(60):
        p1, q1, p2, q2 = (rng.normal(size=3) for _ in range(4))
        c1, c2 = closest_points_segments(p1, q1, p2, q2)
        exact = float(np.linalg.norm(c1 - c2))
        assert exact <= brute_force(p1, q1, p2, q2) + 1e-12
        assert exact >= brute_force(p1, q1, p2, q2) - 5e-3  # grid resolution


def test_parallel_and_degenerate_segments() -> None:
    a, b = np.array([0.0, 0, 0]), np.array([1.0, 0, 0])
    c1, c2 = closest_points_segments(a, b, a + [0.5, 1, 0], b + [0.5, 1, 0])
    assert np.linalg.norm(c1 - c2) == 1.0
    c1, c2 = closest_points_segments(a, a, b, b)  # two points
    assert np.allclose(c1, a) and np.allclose(c2, b)
    p = closest_point_on_segment(np.array([2.0, 1.0, 0.0]), a, b)
    assert np.allclose(p, b)
    p = closest_point_on_segment(np.array([0.3, 1.0, 0.0]), a, b)
    assert np.allclose(p, [0.3, 0, 0])
