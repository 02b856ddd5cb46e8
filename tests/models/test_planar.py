"""Seed 002: the geometric Jacobians of the planar RR and RRR arms with unit links."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr

ROWS = [0, 1, 5]  # (ẋ, ẏ, ω_z) of the 6-row Jacobian
DEG = np.pi / 180


def rr_jacobian(q: np.ndarray) -> np.ndarray:
    s1, c1 = np.sin(q[0]), np.cos(q[0])
    s12, c12 = np.sin(q.sum()), np.cos(q.sum())
    return np.array([[-s1 - s12, -s12], [c1 + c12, c12], [1.0, 1.0]])


def rrr_jacobian(q: np.ndarray) -> np.ndarray:
    s = [np.sin(q[: i + 1].sum()) for i in range(3)]
    c = [np.cos(q[: i + 1].sum()) for i in range(3)]
    return np.array(
        [
            [-s[0] - s[1] - s[2], -s[1] - s[2], -s[2]],
            [c[0] + c[1] + c[2], c[1] + c[2], c[2]],
            [1.0, 1.0, 1.0],
        ]
    )


def test_rr_jacobian_is_the_symbolic_one(rng: np.random.Generator) -> None:
    robot = rr.models.planar([1.0, 1.0])
    for _ in range(20):
        q = rng.uniform(-np.pi, np.pi, 2)
        J = robot.jacobian(q)
        assert np.allclose(J[ROWS], rr_jacobian(q), atol=1e-14)
        assert np.allclose(J[[2, 3, 4]], 0.0, atol=1e-14)  # no z motion, no tilt


def test_rrr_jacobian_is_the_symbolic_one(rng: np.random.Generator) -> None:
    robot = rr.models.planar([1.0, 1.0, 1.0])
    for _ in range(20):
        q = rng.uniform(-np.pi, np.pi, 3)
        assert np.allclose(robot.jacobian(q)[ROWS], rrr_jacobian(q), atol=1e-14)


def test_rrr_jacobian_at_the_printed_configuration() -> None:
    """Seed 002, weighted example: q = (60°, −30°, 15°), position rows, two decimals."""
    J = rr.models.planar([1.0, 1.0, 1.0]).jacobian(np.array([60, -30, 15]) * DEG)
    printed = [[-2.07, -1.21, -0.71], [2.07, 1.57, 0.71]]
    assert np.allclose(J[:2], printed, atol=0.005)


def test_rr_jacobian_at_the_printed_configurations() -> None:
    robot = rr.models.planar([1.0, 1.0])
    J = robot.jacobian(np.array([30, 30]) * DEG)[ROWS]  # left pseudo-inverse example
    assert np.allclose(J, [[-1.366, -0.866], [1.366, 0.5], [1.0, 1.0]], atol=5e-4)
    J = robot.jacobian(np.array([30, 0]) * DEG)[:2]  # singular SVD example
    assert np.allclose(J, [[-1.0, -0.5], [np.sqrt(3), np.sqrt(3) / 2]], atol=1e-14)
    assert np.linalg.matrix_rank(J) == 1


def test_planar_tip_position_is_the_sum_of_links() -> None:
    robot = rr.models.planar([0.5, 0.3])
    T = robot.fk([np.pi / 2, -np.pi / 2])
    assert np.allclose(T[:3, 3], [0.3, 0.5, 0.0], atol=1e-15)


@pytest.mark.parametrize("lengths", [[], [1.0, -1.0], [np.nan], [[1.0, 2.0]]])
def test_planar_rejects_bad_lengths(lengths: list) -> None:
    with pytest.raises(rr.errors.InvalidParameterError, match="lengths"):
        rr.models.planar(lengths)
