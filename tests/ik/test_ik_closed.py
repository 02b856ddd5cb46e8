"""rr.ik with the closed form (redres.ik.closed): taken before iterating, exact, within the
limits, the nearest to q0 at q0's q7 (or at the nearest other q7 tried that has one, as
at_q7 at each says); skipped with analytic=False, with a preference, for position-only
targets and on arms without a closed form."""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest

import redres as rr
from redres.ik.analytic import at_q7

closed_module = importlib.import_module("redres.ik.closed")
NO_TIMEOUT = 60.0


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_the_closed_form_answers_before_iterating(name: str) -> None:
    """Even with one iteration per attempt (the first attempt would fail) the answer comes
    from the closed form, with no iteration: converged, exact, within the limits."""
    robot = rr.models.load(name)
    rng = np.random.default_rng(5)
    kw = {"max_iterations": 1, "timeout_s": NO_TIMEOUT, "seed": 0}
    taken = 0
    for _ in range(20):
        T = robot.fk(robot.random_configuration(rng))
        q0 = robot.random_configuration(rng)
        result = rr.ik(robot, T, q0=q0, **kw)
        assert robot.within_limits(result.q)
        if "closed form" in result.message:  # else: none within limits at the 49 q7s tried
            taken += 1
            assert result.converged
            np.testing.assert_allclose(robot.fk(result.q), T, atol=1e-9)
            assert result.restarts == 0 and result.iterations == 0
            assert result.position_error < 1e-10 and result.orientation_error < 1e-10
        without = rr.ik(robot, T, q0=q0, analytic=False, **kw)
        assert "closed form" not in without.message
    print(f"\n{name}: the closed form answered {taken} of 20")
    assert taken >= 12


def test_the_answer_is_at_the_first_q7_tried_with_one_within_limits() -> None:
    """Where q0[6] has none within the limits, the kernel's answer is the nearest at the
    first of the other values (nearest q0[6] first) that has one, as at_q7 says."""
    robot = rr.models.panda()
    _, others, _ = closed_module._arm(robot, None)
    rng = np.random.default_rng(8)
    checked = 0
    for _ in range(60):
        T = robot.fk(robot.random_configuration(rng))
        q0 = robot.random_configuration(rng)
        if at_q7(robot, T, q7=float(q0[6])).within_limits.any():
            continue
        expected = None
        for value in others[np.argsort(np.abs(others - q0[6]))]:
            found = at_q7(robot, T, q7=float(value))
            within = found.q[found.within_limits]
            if len(within):
                expected = within[np.argmin(((within - q0) ** 2).sum(axis=1))]
                break
        answer = closed_module.closed_form_solution(robot, None, T, q0, 1e-6, 1e-5, 0.0)
        if expected is None:
            assert answer is None
            continue
        assert answer is not None
        np.testing.assert_allclose(answer.q, np.clip(expected, robot.q_min, robot.q_max))
        checked += 1
    assert checked >= 5


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


def test_targets_no_q7_tried_answers_are_answered_by_the_arm_angle() -> None:
    """The benchmark's iiwa14 targets (benchmarks/ik_compare.py: seed 7, the flange) that
    none of the 49 values of q7 tried answers from the neutral configuration (q7's range
    within the limits is a few hundredths of a radian there) have arm angles within the
    limits: rr.ik answers them by the S-R-S closed form, with no iteration, exact and
    within the limits, the nearest to q0 of those on the arm-angle grid."""
    robot = rr.models.iiwa14()
    rng = np.random.default_rng(7)
    targets = [robot.fk(robot.random_configuration(rng), "flange") for _ in range(300)]
    q0 = robot.neutral()
    _, others, _ = closed_module._arm(robot, "flange")
    kw = {"max_iterations": 1, "max_restarts": 0, "timeout_s": None, "seed": 0}
    missed = []
    for k, T in enumerate(targets):
        if any(at_q7(robot, T, q7=float(x), frame="flange").within_limits.any()
               for x in [q0[6], *others]):  # fmt: skip
            continue
        missed.append(k)
        result = rr.ik(robot, T, "flange", q0=q0, **kw)
        assert result.converged and "arm angle" in result.message, (k, result.message)
        assert result.iterations == 0 and robot.within_limits(result.q)
        np.testing.assert_allclose(robot.fk(result.q, "flange"), T, atol=1e-10)
        # the nearest to q0 over the grid, by rr.ik_all at each arm angle (oracle)
        best = math.inf
        for phi in closed_module._GRID:
            found = rr.ik_all(robot, T, arm_angle=phi, frame="flange")
            within = found.q[found.within_limits]
            if len(within):
                best = min(best, float(((within - q0) ** 2).sum(axis=1).min()))
        assert float(((result.q - q0) ** 2).sum()) == pytest.approx(best, abs=1e-9)
    print(f"\niiwa14: targets {missed} of 300 answered by the arm angle")
    assert len(missed) >= 2  # seed 7 has such targets: the test covers the case


def test_no_arm_angle_on_an_arm_that_is_not_srs() -> None:
    robot = rr.models.panda()
    T = robot.fk(robot.random_configuration(np.random.default_rng(3)))
    assert closed_module.by_arm_angle(robot, None, T, robot.neutral()) is None


def test_the_exact_arcs_answer_where_the_arm_angle_grid_misses(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """With no arm angle on the grid (as where every arc within the limits is narrower than
    its step), the middles of the exact arcs of the self-motion answer: exact (Pinocchio
    FK), within the limits, at an arm angle inside an arc of rr.self_motion."""
    robot = rr.models.iiwa14()
    rng = np.random.default_rng(7)
    targets = [robot.fk(robot.random_configuration(rng), "flange") for _ in range(51)]
    T, q0 = targets[50], robot.neutral()  # a target no q7 tried answers (test above)
    monkeypatch.setattr(closed_module, "_GRID", [])
    found = closed_module.by_arm_angle(robot, "flange", T, q0)
    assert found is not None
    q, position, rotation, phi = found
    assert robot.within_limits(q) and max(position, rotation) < 1e-10
    np.testing.assert_allclose(robot.fk(q, "flange"), T, atol=1e-10)
    arcs = rr.self_motion(robot, T, parameter="arm_angle", frame="flange").intervals
    inside = [lo <= phi + 2 * math.pi * k <= hi for b in arcs for lo, hi in b for k in (-1, 0, 1)]
    assert any(inside)
