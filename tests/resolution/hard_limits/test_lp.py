"""The largest task scale in a box (hard_limits.lp): the simplex against SciPy's HiGHS."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

import redres as rr
from redres.errors import ShapeError
from redres.resolution import ScaleResult, largest_scale


def test_largest_scale_matches_highs_on_position_tasks(rng: np.random.Generator) -> None:
    """3-row tasks (a 4-dimensional null space): the simplex against SciPy's HiGHS."""
    robot = rr.models.panda()
    for _ in range(150):
        q = robot.random_configuration(rng)
        J = robot.jacobian(q)[:3]
        xd = rng.normal(size=3) * 10 ** rng.uniform(-2, 0.5)
        centre = rng.normal(size=7) * 0.05
        half = rng.uniform(0.01, 0.3, 7)
        lo, hi = centre - half, centre + half
        result = largest_scale(J, xd, lo, hi)
        s, qd, feasible = result.scale, result.qd, result.feasible
        assert isinstance(result, ScaleResult) and tuple(result) == (s, qd, feasible)
        c = np.zeros(8)
        c[-1] = -1.0
        ref = linprog(c, A_eq=np.hstack([J, -xd[:, None]]), b_eq=np.zeros(3),
                      bounds=[*zip(lo, hi), (0.0, 1.0)], method="highs")  # fmt: skip
        assert feasible == (ref.status == 0)
        if feasible:
            assert s == pytest.approx(ref.x[-1], abs=1e-9)
            assert np.all(qd >= lo) and np.all(qd <= hi)
            assert np.allclose(J @ qd, s * xd, atol=1e-10)


def test_an_infeasible_box_reports_the_nearest_velocity() -> None:
    """Every velocity of the box moves the task backwards: no scale in [0, 1] is feasible,
    and the answer is the box corner nearest (1-norm) to the segment {s ẋ}."""
    J = np.array([[1.0, 1.0]])
    result = largest_scale(J, np.array([1.0]), np.array([-2.0, -2.0]), np.array([-1.0, -1.0]))
    assert not result.feasible
    assert np.allclose(result.qd, [-1.0, -1.0])


def test_bad_boxes_are_refused() -> None:
    J = np.eye(2, 3)
    with pytest.raises(ShapeError):
        largest_scale(J, np.ones(2), np.zeros(2), np.ones(2))
    with pytest.raises(ShapeError):
        largest_scale(J, np.ones(2), np.ones(3), np.zeros(3))
