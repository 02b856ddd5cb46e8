"""The finite-difference helper is itself checked: it must reject a wrong Jacobian."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.testing import (
    assert_jacobian_close,
    frame_jacobian_fd,
    numerical_gradient,
    numerical_jacobian,
)


def test_numerical_jacobian_of_a_known_function() -> None:
    q = np.array([0.3, -1.2])
    J = numerical_jacobian(lambda x: np.array([np.sin(x[0]) * x[1], x[1] ** 2]), q)
    exact = np.array([[np.cos(0.3) * -1.2, np.sin(0.3)], [0.0, -2.4]])
    assert_jacobian_close(J, exact, atol=1e-9)


def test_numerical_gradient_of_a_quadratic() -> None:
    A = np.array([[2.0, 0.5], [0.5, 1.0]])
    q = np.array([0.7, -0.2])
    assert np.allclose(numerical_gradient(lambda x: 0.5 * x @ A @ x, q), A @ q, atol=1e-9)


@pytest.mark.parametrize("reference", ["world", "local"])
def test_fd_helper_rejects_a_wrong_jacobian(reference: str, rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    q = robot.random_configuration(rng)
    J = robot.jacobian(q, reference=reference)  # type: ignore[arg-type]
    J_fd = frame_jacobian_fd(robot, q, reference=reference)  # type: ignore[arg-type]
    assert_jacobian_close(J, J_fd, atol=1e-7)
    wrong_columns = J[:, [1, 0, 2, 3, 4, 5, 6]]
    with pytest.raises(AssertionError, match="differs"):
        assert_jacobian_close(wrong_columns, J_fd, atol=1e-7)
    wrong_order = np.vstack([J[3:], J[:3]])  # [w; v] instead of [v; w]
    with pytest.raises(AssertionError):
        assert_jacobian_close(wrong_order, J_fd, atol=1e-7)
    slightly_off = J.copy()
    slightly_off[2, 4] += 1e-4
    with pytest.raises(AssertionError):
        assert_jacobian_close(slightly_off, J_fd, atol=1e-7)


def test_fd_helper_distinguishes_the_two_references(rng: np.random.Generator) -> None:
    robot = rr.models.iiwa14()
    q = robot.random_configuration(rng)
    with pytest.raises(AssertionError):
        assert_jacobian_close(robot.jacobian(q, reference="local"), frame_jacobian_fd(robot, q))
