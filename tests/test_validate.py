"""The shared input checks: complex values are refused by name, not made real (issue 18,
item 10); huge integers and ragged lists are one clear error."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres._validate import as_matrix, as_scalar, as_vector
from redres.errors import InvalidParameterError, RedresError, ShapeError
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme


def test_complex_values_are_refused_by_name() -> None:
    with pytest.raises(InvalidParameterError, match=r"q must be real; got a complex array"):
        as_vector(np.zeros(3) + 0.5j, "q", 3)
    with pytest.raises(InvalidParameterError, match=r"J must be real"):
        as_matrix([[1.0, 2j]], "J")
    with pytest.raises(InvalidParameterError, match=r"damping must be a real number"):
        as_scalar(np.complex128(0.1), "damping")


def test_public_array_entry_points_refuse_complex_input() -> None:
    robot = rr.models.panda()
    q = robot.neutral()
    J = robot.jacobian(q)
    calls = {
        "fk": lambda: robot.fk(q + 0.5j),
        "jacobian": lambda: robot.jacobian(q + 0.5j),
        "mass_matrix": lambda: robot.mass_matrix(q + 0.5j),
        "bias": lambda: robot.bias(q, q + 0.5j),
        "pinv": lambda: rr.linalg.pinv(J + 1j),
        "damped_pinv": lambda: rr.linalg.damped_pinv(J + 1j, 0.1),
        "manipulability": lambda: rr.linalg.manipulability(J + 0j),
        "joint-limit gradient": lambda: JointLimitObjective().gradient(robot, q + 1j),
        "pinv step": lambda: PseudoInverseScheme().step(robot, q, J, np.zeros(6) + 1j),
        "gradient step": lambda: GradientProjectionScheme([JointLimitObjective()]).step(
            robot, q + 1j, J, np.zeros(6)
        ),
    }
    for name, call in calls.items():
        with pytest.raises(RedresError, match="must be real") as info:
            call()
        assert isinstance(info.value, ValueError), name


def test_huge_integers_and_ragged_lists_are_shape_errors() -> None:
    with pytest.raises(ShapeError, match=r"q must be a vector of numbers; got \[1000.*characters"):
        as_vector([10**400, 0, 0], "q", 3)
    with pytest.raises(ShapeError, match=r"J must be a 2-D array of numbers"):
        as_matrix([[1.0, 2.0], [3.0]], "J")
    with pytest.raises(InvalidParameterError, match=r"gain must be a number; got 1000"):
        as_scalar(10**400, "gain")


def test_objectives_check_the_configuration_they_are_given() -> None:
    """JointLimitObjective().gradient(robot, nan_q) returned NaN (issue 18, item 6)."""
    from redres.errors import NonFiniteError
    from redres.objectives import PostureObjective

    robot = rr.models.panda()
    for objective in (JointLimitObjective(), PostureObjective()):
        with pytest.raises(NonFiniteError, match="q contains NaN"):
            objective.gradient(robot, np.full(7, np.nan))
        with pytest.raises(ShapeError, match=r"q must have shape \(7,\)"):
            objective.cost(robot, np.zeros(3))
