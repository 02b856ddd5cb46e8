"""rr.ik with the closed form (redres.ik.closed): taken when the first attempt fails, exact,
within the limits, the nearest to q0 at q0's q7; skipped with analytic=False, with a
preference, for position-only targets and on arms without a closed form."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import redres as rr
from redres.ik.analytic import at_q7

closed_module = importlib.import_module("redres.ik.closed")
NO_TIMEOUT = 60.0


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_failed_first_attempt_is_finished_by_the_closed_form(name: str) -> None:
    """With one iteration per attempt the first attempt fails; the answer then comes from
    the closed form, before any restart: converged, exact, within the limits."""
    robot = rr.models.load(name)
    rng = np.random.default_rng(5)
    kw = {"max_iterations": 1, "timeout_s": NO_TIMEOUT, "seed": 0}
    taken = 0
    for _ in range(20):
        T = robot.fk(robot.random_configuration(rng))
        q0 = robot.random_configuration(rng)
        result = rr.ik(robot, T, q0=q0, **kw)
        assert robot.within_limits(result.q)
        if "closed form" in result.message:  # else: none within limits at the 13 q7s tried
            taken += 1
            assert result.converged
            np.testing.assert_allclose(robot.fk(result.q), T, atol=1e-9)
            assert result.restarts == 0 and result.iterations == 1
            assert result.position_error < 1e-10 and result.orientation_error < 1e-10
        without = rr.ik(robot, T, q0=q0, analytic=False, **kw)
        assert "closed form" not in without.message
    print(f"\n{name}: the closed form finished {taken} of 20 failed first attempts")
    assert taken >= 12


def test_the_answer_is_the_nearest_within_limits_at_q0s_q7() -> None:
    robot = rr.models.iiwa14()
    rng = np.random.default_rng(6)
    checked = 0
    for _ in range(30):
        T = robot.fk(robot.random_configuration(rng))
        q0 = robot.random_configuration(rng)
        found = at_q7(robot, T, q7=float(q0[6]))
        within = found.q[found.within_limits]
        if not len(within):
            continue
        answer = closed_module.closed_form_solution(robot, None, T, q0, 1e-6, 1e-5, 0.0)
        assert answer is not None and answer.q[6] == pytest.approx(q0[6], abs=1e-12)
        nearest = within[np.argmin(((within - q0) ** 2).sum(axis=1))]
        np.testing.assert_allclose(answer.q, np.clip(nearest, robot.q_min, robot.q_max))
        checked += 1
    assert checked >= 10


def test_skipped_where_it_does_not_apply() -> None:
    robot = rr.models.panda()
    T = robot.fk(robot.random_configuration(np.random.default_rng(7)))
    kw = {"max_iterations": 1, "max_restarts": 0, "timeout_s": NO_TIMEOUT, "seed": 0}
    q0 = robot.neutral()
    assert "closed form" in rr.ik(robot, T, q0=q0, **kw).message
    for extra in ({"analytic": False}, {"position_only": True},
                  {"q_preferred": robot.neutral()}):  # fmt: skip
        assert "closed form" not in rr.ik(robot, T, q0=q0, **{**kw, **extra}).message
    planar = rr.models.planar([1.0, 1.0, 1.0])
    result = rr.ik(planar, planar.fk(np.array([0.3, 0.2, 0.1])), timeout_s=NO_TIMEOUT, seed=0)
    assert result.converged and "closed form" not in result.message


def test_a_bad_target_still_says_why() -> None:
    robot = rr.models.iiwa14()
    nan = np.full((4, 4), np.nan)
    result = rr.ik(robot, nan, max_iterations=1)
    assert not result.converged and "NaN" in result.message
