"""Feasible tasks near singularities (issue 18, item 3): both hard-limit schemes meet them
and say so, and ``feasible`` means "the task is met" for both.

Oracle: the tasks are feasible by construction, ``ẋ = J q̇_true`` with ``q̇_true`` strictly
inside the step's joint-velocity box, and ``J`` the Jacobian of a random Panda or planar
configuration with its one or two smallest singular values set to 1e-12 … 1e-6.
"""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.resolution import QPScheme, SNSScheme

CASES = 60


def near_singular_tasks(seed: int) -> list[tuple]:
    """``(robot, q, J, xd)``: tasks feasible by construction at near-singular ``J``."""
    rng = np.random.default_rng(seed)
    robots = [rr.models.panda(), rr.models.planar([1.0, 1.0, 1.0])]
    out = []
    for k in range(CASES):
        robot = robots[k % 2]
        q = robot.q_min + (robot.q_max - robot.q_min) * rng.uniform(0.1, 0.9, robot.n)
        J = robot.jacobian(q) if robot.n == 7 else robot.jacobian(q)[[0, 1, 5]]
        U, s, Vt = np.linalg.svd(J, full_matrices=False)
        few = int(rng.integers(1, 3))
        s[-few:] = 10.0 ** rng.uniform(-12, -6, few)
        J = (U * s) @ Vt
        lo, hi = QPScheme(1e-3).step(robot, q, J, np.zeros(J.shape[0])).details.bounds
        qd_true = lo + (hi - lo) * rng.uniform(0.05, 0.95, robot.n)
        out.append((robot, q, J, J @ qd_true))
    return out


@pytest.fixture(scope="module")
def tasks() -> list[tuple]:
    return near_singular_tasks(18)


def relative_residual(J: np.ndarray, xd: np.ndarray, qd: np.ndarray) -> float:
    return float(np.linalg.norm(J @ qd - xd) / np.linalg.norm(xd))


@pytest.mark.parametrize("scheme", [QPScheme, SNSScheme])
def test_feasible_tasks_near_singularities_are_met_and_flagged(tasks: list, scheme) -> None:
    missed = []
    for robot, q, J, xd in tasks:
        r = scheme(1e-3).step(robot, q, J, xd)
        if not (r.feasible and relative_residual(J, xd, r.qd) <= 1e-9):
            missed.append((r.feasible, relative_residual(J, xd, r.qd)))
    assert missed == []


def test_sns_flag_means_the_task_is_met() -> None:
    """Scaled tasks (``ẋ`` made 1.5 times too fast in some cases) and feasible ones: the
    flag is true exactly when ``‖J q̇ − ẋ‖ ≤ 1e-9 ‖ẋ‖``, and ``scale`` is 1 exactly then."""
    rng = np.random.default_rng(5)
    for robot, q, J, xd in near_singular_tasks(7):
        xd = xd * (1.0 if rng.random() < 0.5 else 40.0)
        r = SNSScheme(1e-3).step(robot, q, J, xd)
        met = relative_residual(J, xd, r.qd) <= 1e-9
        assert r.feasible == met
        assert (r.details.scale == 1.0) == met
