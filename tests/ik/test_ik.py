"""Position inverse kinematics: reachable targets, preferences, budgets and bad input.

Every solution is checked independently of the solver: forward kinematics of the returned
configuration against the target, the rotation angle from ``‖R − R_d‖_F`` (not the SO(3)
logarithm the solver uses), the joint limits with zero tolerance. The solver's time budget
is made irrelevant (``timeout_s`` large) so that outcomes do not depend on machine load;
speed is measured in benchmarks/ik.py.
"""

from __future__ import annotations

import dataclasses
import importlib
import math

import numpy as np
import pytest

import redres as rr
from redres.errors import FrameNotFoundError, InvalidParameterError, NonFiniteError, ShapeError
from redres.ik import IKResult, ik
from redres.tasks import ArmAngleTask, wrap_angle

NO_TIMEOUT = 60.0


def pose_errors(robot: rr.Robot, q: np.ndarray, T_target: np.ndarray, frame: str | None = None):
    """Position error (m) and rotation angle (rad) of fk(q) against a target pose."""
    T = robot.fk(q, frame)
    chord = np.linalg.norm(T[:3, :3] - T_target[:3, :3]) / (2.0 * math.sqrt(2.0))
    return float(np.linalg.norm(T[:3, 3] - T_target[:3, 3])), 2.0 * math.asin(min(chord, 1.0))


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_random_reachable_poses(name: str, builtin_robots: dict) -> None:
    """fk of 500 random configurations within the limits: ≥ 99.5 % solved to 1e-6 m and
    1e-5 rad with the solution inside the limits (benchmarks/ik.py runs 1,000)."""
    robot = builtin_robots[name]
    rng = np.random.default_rng(20260707)
    failures = []
    for k in range(500):
        T = robot.fk(robot.random_configuration(rng))
        result = ik(robot, T, seed=k, timeout_s=NO_TIMEOUT)
        ep, eo = pose_errors(robot, result.q, T)
        ok = result.converged and ep <= 1e-6 and eo <= 1e-5 and robot.within_limits(result.q)
        if not ok:
            failures.append((k, result.message, ep, eo))
        if result.converged:  # the reported errors are the true ones
            assert (
                abs(result.position_error - ep) <= 1e-9
                and abs(result.orientation_error - eo) <= 1e-7
            )
    assert len(failures) <= 2, failures  # 99.5 % of 500 is 497.5


def test_position_only_targets(builtin_robots: dict) -> None:
    robot = builtin_robots["panda"]
    rng = np.random.default_rng(3)
    for k in range(60):
        T = robot.fk(robot.random_configuration(rng))
        a = ik(robot, T[:3, 3], seed=k, timeout_s=NO_TIMEOUT)
        b = ik(robot, T, position_only=True, seed=k, timeout_s=NO_TIMEOUT)
        for result in (a, b):
            assert result.converged and robot.within_limits(result.q)
            assert np.linalg.norm(robot.fk(result.q)[:3, 3] - T[:3, 3]) <= 1e-6
            assert result.orientation_error == 0.0
        assert np.array_equal(a.q, b.q)


@pytest.mark.parametrize(
    ("name", "frame"), [("srs7", None), ("planar3", None), ("iiwa14", "wrist")]
)
def test_other_robots_and_frames(name: str, frame: str | None, builtin_robots: dict) -> None:
    robot = builtin_robots[name]
    rng = np.random.default_rng(5)
    for k in range(20):
        T = robot.fk(robot.random_configuration(rng), frame)
        target = T if frame is None else T[:3, 3]
        result = ik(robot, target, frame, seed=k, timeout_s=NO_TIMEOUT)
        assert result.converged, result
        ep, eo = pose_errors(robot, result.q, T, frame)
        assert ep <= 1e-6 and (frame is not None or eo <= 1e-5)


def test_q0_is_used_and_clipped(builtin_robots: dict) -> None:
    robot = builtin_robots["panda"]
    q_true = robot.random_configuration(np.random.default_rng(9), margin=0.2)
    at_solution = ik(robot, robot.fk(q_true), q0=q_true)
    assert (
        at_solution.converged
        and at_solution.iterations == 0
        and np.array_equal(at_solution.q, q_true)
    )
    outside = ik(robot, robot.fk(q_true), q0=robot.q_max + 1.0, seed=1, timeout_s=NO_TIMEOUT)
    assert outside.converged and robot.within_limits(outside.q)


def test_unreachable_target_ends_within_the_budget(builtin_robots: dict) -> None:
    robot = builtin_robots["panda"]
    T = robot.fk(robot.neutral())
    T[:3, 3] = [5.0, 0.0, 0.5]
    result = ik(robot, T, max_iterations=50, max_restarts=5, seed=0, timeout_s=NO_TIMEOUT)
    assert not result.converged and "budget" in result.message
    assert result.iterations <= 50 * 6 and result.restarts == 5
    assert robot.within_limits(result.q)
    reach = np.linalg.norm(robot.fk(result.q)[:3, 3] - T[:3, 3])
    assert abs(result.position_error - reach) < 1e-9 and 3.5 < reach < 5.0
    assert math.isfinite(result.orientation_error)


def test_time_budget(builtin_robots: dict) -> None:
    robot = builtin_robots["iiwa14"]
    T = robot.fk(robot.neutral())
    T[:3, 3] += [3.0, 0.0, 0.0]
    result = ik(robot, T, timeout_s=1e-9, max_restarts=1000, seed=0)
    assert not result.converged and "time budget" in result.message and result.restarts == 0


def test_a_budget_that_changes_on_every_call_is_still_checked_and_cached(
    builtin_robots: dict,
) -> None:
    """A caller that passes the time left of its own budget gives a new ``timeout_s`` on
    every call: the other options stay validated once (one cache entry), the budget is
    checked on each call."""
    ik_module = importlib.import_module("redres.ik.solve")  # rr.ik is the function
    robot = builtin_robots["panda"]
    T = robot.fk(robot.random_configuration(np.random.default_rng(3)))
    ik(robot, T, seed=0, timeout_s=1.0, max_iterations=77)
    entries = len(ik_module._OPTIONS)
    results = [ik(robot, T, seed=0, timeout_s=1.0 + k / 7, max_iterations=77) for k in range(5)]
    assert len(ik_module._OPTIONS) == entries
    assert all(r.converged and np.array_equal(r.q, results[0].q) for r in results)
    for bad in (-1.0, 0.0, math.inf, math.nan, "one", np.array([1.0, 2.0])):
        with pytest.raises((InvalidParameterError, NonFiniteError)):
            ik(robot, T, seed=0, timeout_s=bad, max_iterations=77)  # type: ignore[arg-type]


def test_non_finite_target_is_a_result_not_an_exception(builtin_robots: dict) -> None:
    robot = builtin_robots["panda"]
    T = robot.fk(robot.neutral())
    T[0, 3] = np.nan
    for target in (T, np.array([0.3, np.inf, 0.2])):
        result = ik(robot, target)
        assert not result.converged and result.iterations == 0 and "NaN" in result.message
        assert robot.within_limits(result.q) and result.position_error == math.inf


def test_programming_errors_raise(builtin_robots: dict) -> None:
    robot = builtin_robots["panda"]
    T = robot.fk(robot.neutral())
    with pytest.raises(ShapeError):
        ik(robot, np.zeros(4))
    with pytest.raises(ShapeError):
        ik(robot, np.eye(3))
    with pytest.raises(ShapeError):
        ik(robot, 2.0 * np.eye(4))  # not a rotation
    with pytest.raises(ShapeError):
        ik(robot, "tcp")
    with pytest.raises(FrameNotFoundError):
        ik(robot, T, "nose")
    with pytest.raises(ShapeError):
        ik(robot, T, q0=np.zeros(3))
    with pytest.raises(NonFiniteError):
        ik(robot, T, q0=np.full(7, np.nan))
    for bad in ({"max_iterations": 0}, {"max_restarts": -1}, {"tol_position": 0.0},
                {"timeout_s": -1.0}, {"patience": 0}, {"damping": 0.1},
                {"q_preferred": robot.neutral(), "arm_angle": 0.0}):  # fmt: skip
        with pytest.raises(InvalidParameterError):
            ik(robot, T, **bad)


def test_seeded_restarts_are_reproducible(builtin_robots: dict) -> None:
    robot = builtin_robots["panda"]
    T = robot.fk(robot.random_configuration(np.random.default_rng(11)))
    kw = {"max_iterations": 4, "timeout_s": NO_TIMEOUT, "analytic": False}  # restarts
    runs = [ik(robot, T, seed=s, **kw) for s in (7, 7)]
    gens = [ik(robot, T, seed=np.random.default_rng(7), **kw) for _ in range(2)]
    other = ik(robot, T, seed=8, **kw)
    assert runs[0].restarts > 0  # four iterations per attempt force restarts
    assert np.array_equal(runs[0].q, runs[1].q) and np.array_equal(gens[0].q, gens[1].q)
    assert runs[0].iterations == runs[1].iterations and gens[0].iterations == gens[1].iterations
    assert not np.array_equal(runs[0].q, other.q)  # the seed is the restarts' key


@pytest.mark.parametrize("seed", [-1, 1.5, True, "7", [1, 2]])
def test_a_bad_seed_is_refused_by_name(builtin_robots: dict, seed: object) -> None:
    robot = builtin_robots["iiwa14"]
    with pytest.raises(InvalidParameterError, match="seed must be"):
        ik(robot, robot.fk(robot.neutral()), seed=seed)


def test_preferred_configuration_is_locally_closest(builtin_robots: dict) -> None:
    """First-order optimality of min ½‖q − q_pref‖² on the solution set: the gradient
    q − q_pref is orthogonal to the self-motions, (I − J⁺J)(q − q_pref) ≈ 0."""
    robot = builtin_robots["iiwa14"]
    rng = np.random.default_rng(13)
    closer = unsettled = 0
    for k in range(20):
        target = robot.fk(robot.random_configuration(rng, margin=0.3))[:3, 3]
        q_pref = robot.random_configuration(rng, margin=0.3)
        result = ik(robot, target, q_preferred=q_pref, seed=k, timeout_s=NO_TIMEOUT)
        plain = ik(robot, target, q0=q_pref, seed=k, timeout_s=NO_TIMEOUT)
        assert result.converged
        closer += np.linalg.norm(result.q - q_pref) <= np.linalg.norm(plain.q - q_pref) + 1e-9
        settled = "settled" not in result.message
        unsettled += not settled
        if settled and robot.joint_limit_margin(result.q).min() > 1e-9:
            J = robot.jacobian(result.q)[:3]
            N = np.eye(7) - np.linalg.pinv(J) @ J
            assert np.abs(N @ (result.q - q_pref)).max() < 1e-3
    assert closer >= 19 and unsettled <= 1, (closer, unsettled)


def test_preferred_arm_angle(builtin_robots: dict) -> None:
    """Pose first, arm angle second: the requested angle is met, unless a joint limit
    stops the self-motion on the way."""
    robot = builtin_robots["iiwa14"]
    arm = ArmAngleTask()
    rng = np.random.default_rng(11)
    met = 0
    for k in range(30):
        q_true = robot.random_configuration(rng, margin=0.2)
        wanted = arm.value(robot, q_true) + 0.1
        result = ik(
            robot, robot.fk(q_true), arm_angle=wanted, q0=q_true, seed=k, timeout_s=NO_TIMEOUT
        )
        assert result.converged and robot.within_limits(result.q)
        miss = abs(wrap_angle(arm.value(robot, result.q) - wanted))
        met += miss < 1e-3
        assert miss < 1e-3 or robot.joint_limit_margin(result.q).min() < 1e-9, (k, miss)
    assert met >= 25


def test_result_is_frozen(builtin_robots: dict) -> None:
    robot = builtin_robots["panda"]
    result = ik(robot, robot.fk(robot.neutral()))
    assert isinstance(result, IKResult)
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.converged = False  # type: ignore[misc]


_DETERMINISM_SCRIPT = """
import hashlib, sys
import numpy as np
import redres as rr
robot = rr.models.panda()
out = []
for k in range(3):
    T = robot.fk(robot.random_configuration(np.random.default_rng(100 + k)))
    T[:3, 3] *= 1.0 + 0.6 * k  # k = 2: out of reach, every restart used
    r = rr.ik(robot, T, seed=k, max_iterations=6, max_restarts=8, timeout_s=None)
    out.append(r.q.tobytes() + bytes([r.converged]) + r.iterations.to_bytes(4, "little"))
    out.append(np.float64(r.position_error).tobytes())
print(hashlib.sha256(b"".join(out)).hexdigest(), rr.ik.__module__)
"""


@pytest.mark.parametrize("path", ["compiled", "reference"])
def test_iteration_budget_is_deterministic_across_processes(path: str) -> None:
    """Issue 18, item 11: with ``timeout_s=None`` only the iteration budget binds, so two
    fresh processes give bit-identical results (solutions, iteration counts, errors), on
    the compiled path and on the reference path (kernels disabled) alike."""
    import os
    import subprocess
    import sys

    env = dict(os.environ)
    if path == "reference":
        env["REDRES_DISABLE_JIT"] = "1"
    else:  # compiled in the tests' cache, on the caller's path (conftest: foreground)
        env.pop("REDRES_DISABLE_JIT", None)
    digests = [
        subprocess.run(
            [sys.executable, "-c", _DETERMINISM_SCRIPT], env=env, capture_output=True,
            text=True, timeout=1200, check=True,
        ).stdout.split()[0]
        for _ in range(2)
    ]  # fmt: skip
    assert digests[0] == digests[1]


def test_no_wall_clock_budget_is_none(builtin_robots: dict) -> None:
    """``timeout_s=None``: the iteration budget alone (every restart of an unreachable
    target is used, whatever the machine's speed); the default 0.5 s is a wall-clock one."""
    robot = builtin_robots["panda"]
    T = robot.fk(robot.neutral())
    T[:3, 3] *= 3.0
    result = ik(robot, T, max_iterations=5, max_restarts=7, timeout_s=None, seed=0)
    assert not result.converged and result.restarts == 7
    assert "iteration and restart budget" in result.message
    with pytest.raises(NonFiniteError, match="timeout_s must be finite"):
        ik(robot, T, timeout_s=math.inf)
