"""The joint-velocity box of one step: braking bound, viability, relaxation, violations."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import redres as rr
from redres.errors import InvalidParameterError, JointLimitError, NonFiniteError, ShapeError
from redres.resolution.hard_limits import (
    RELAXED_ACCELERATION,
    RELAXED_POSITION,
    JointLimits,
    braking_velocity,
    run_violation,
    step_violation,
    velocity_bounds,
)

DT = 1e-3


def braking_travel(v: float, a: float, dt: float) -> float:
    """Brute force: distance covered moving at v now, then braking by a per step."""
    travel = 0.0
    while v > 0.0:
        travel += v * dt
        v -= a
    return travel


@pytest.mark.parametrize("seed", range(5))
def test_braking_velocity_is_the_largest_that_can_stop(seed: int) -> None:
    """Oracle: step-by-step braking simulation. v stops in time, v(1 + 1e-9) does not."""
    rng = np.random.default_rng(seed)
    for _ in range(200):
        dt = 10 ** rng.uniform(-4, -1.5)
        qdd_max = 10 ** rng.uniform(-1, 2)
        distance = 10 ** rng.uniform(-7, 0.5)
        v = float(braking_velocity(distance, dt, qdd_max))
        a = qdd_max * dt
        assert braking_travel(v, a, dt) <= distance * (1 + 1e-12) + 1e-15
        assert braking_travel(v * (1 + 1e-9) + 1e-15, a, dt) > distance
        assert v <= distance / dt * (1 + 1e-15)  # never more than the one-step bound


def test_braking_velocity_tends_to_the_continuous_bound() -> None:
    """dt -> 0: v_max -> sqrt(2 qdd_max d) (Flacco et al. 2012), from below."""
    distance, qdd_max = 0.3, 12.0
    continuous = math.sqrt(2 * qdd_max * distance)
    for dt in (1e-3, 1e-4, 1e-5):
        v = float(braking_velocity(distance, dt, qdd_max))
        assert v < continuous
        assert continuous - v <= qdd_max * dt  # within one step's velocity change


def test_braking_velocity_special_values() -> None:
    out = braking_velocity([np.inf, 0.0, -0.01, 0.2], DT, [5.0, 5.0, 5.0, np.inf])
    assert out[0] == np.inf and out[1] == 0.0
    assert out[2] == pytest.approx(-10.0)  # outside: return within one step
    assert out[3] == pytest.approx(200.0)  # no acceleration limit: the one-step bound
    with pytest.raises(InvalidParameterError):
        braking_velocity(0.1, DT, 0.0)
    with pytest.raises(InvalidParameterError):
        braking_velocity(0.1, 0.0, 1.0)


def test_the_continuous_braking_bound_alone_is_not_viable() -> None:
    """Why the discrete bound: at v = sqrt(2 A d) the next step cannot decelerate enough
    (closed form: the next continuous bound is sqrt(v² − 2 v a) < v − a)."""
    A, d = 10.0, 0.05
    a = A * DT
    v = math.sqrt(2 * A * d)
    next_bound = math.sqrt(2 * A * (d - v * DT))
    assert next_bound < v - a  # the box of the next step would be empty
    v = float(braking_velocity(d, DT, A))  # the discrete bound leaves room
    assert float(braking_velocity(d - v * DT, DT, A)) >= v - a - 1e-12


def panda_limits() -> tuple[rr.Robot, JointLimits]:
    robot = rr.models.panda()
    return robot, JointLimits.from_robot(robot)


def test_any_velocity_in_the_box_keeps_every_limit(rng: np.random.Generator) -> None:
    robot, lim = panda_limits()
    for _ in range(300):
        q = robot.random_configuration(rng)
        near = rng.random(7) < 0.4
        q = np.where(near, np.where(rng.random(7) < 0.5, lim.q_max, lim.q_min), q)
        q = np.clip(q + rng.uniform(-0.01, 0.01, 7), lim.q_min, lim.q_max)
        prev = np.zeros(7)
        box = velocity_bounds(lim, q, prev, DT)
        assert box.viable and np.all(box.lower <= box.upper)
        for corner in (box.lower, box.upper, rng.uniform(box.lower, box.upper)):
            assert step_violation(lim, q, corner, prev, DT).worst <= 1e-12


@pytest.mark.parametrize("seed", range(3))
def test_box_stays_viable_when_always_pushed_to_its_edge(seed: int) -> None:
    """Recursive feasibility: 3,000 steps at the box's upper or lower edge (the hardest
    driving), from rest inside the limits: never relaxed, no limit broken."""
    rng = np.random.default_rng(seed)
    robot, lim = panda_limits()
    q, prev = robot.random_configuration(rng), np.zeros(7)
    qs, qds = [], []
    for k in range(3000):
        box = velocity_bounds(lim, q, prev, DT)
        assert box.viable, f"step {k}: box relaxed {box.relaxed}"
        push_up = (k // 400 + np.arange(7)) % 2 == 0
        qd = np.where(push_up, box.upper, box.lower)
        qs.append(q)
        qds.append(qd)
        q, prev = q + qd * DT, qd
    assert run_violation(lim, np.array(qs), np.array(qds), DT).worst <= 1e-12
    assert np.min(np.minimum(lim.q_max - q, q - lim.q_min)) >= -1e-12


def test_kinds_name_the_limit_that_binds() -> None:
    robot, lim = panda_limits()
    q = robot.neutral()
    box = velocity_bounds(lim, q, np.zeros(7), DT)  # at rest: acceleration binds
    assert all(box.kind(j, "upper") == "acceleration" for j in range(7))
    box = velocity_bounds(JointLimits.from_robot(robot, qdd_max=np.inf), q, None, DT)
    assert np.allclose(box.upper, lim.qd_max) and box.kind(0, "lower") == "velocity"
    q_edge = q.copy()
    q_edge[3] = lim.q_max[3] - 1e-6  # 1 µrad from the limit: one step of 1 mrad/s
    box = velocity_bounds(lim, q_edge, np.zeros(7), DT)
    assert box.kind(3, "upper") == "position"
    assert box.upper[3] == pytest.approx(1e-6 / DT, rel=1e-9)


def test_too_fast_toward_a_limit_gives_up_acceleration_first() -> None:
    robot, lim = panda_limits()
    q = robot.neutral()
    q[1] = lim.q_max[1] - 1e-3
    prev = np.zeros(7)
    prev[1] = 2.0  # cannot stop within 1 mrad at 7.5 rad/s²
    box = velocity_bounds(lim, q, prev, DT)
    assert box.relaxed[1] == RELAXED_ACCELERATION and box.relaxed.sum() == RELAXED_ACCELERATION
    assert box.lower[1] == box.upper[1]
    assert box.upper[1] == pytest.approx(float(braking_velocity(1e-3, DT, lim.qdd_max[1])))
    v = step_violation(lim, q, box.upper, prev, DT)
    assert v.position == 0.0 and v.velocity == 0.0 and v.acceleration > 0.0


def test_outside_the_range_returns_at_the_velocity_limit() -> None:
    robot = rr.models.panda()
    lim = JointLimits.from_robot(robot, qdd_max=np.inf)
    q = robot.neutral()
    q[0] = lim.q_max[0] + 0.1  # 0.1 rad outside; one step back would need 100 rad/s
    box = velocity_bounds(lim, q, None, DT)
    assert box.relaxed[0] == RELAXED_POSITION
    assert box.lower[0] == box.upper[0] == -lim.qd_max[0]


def test_infinite_limits() -> None:
    n = 3
    lim = JointLimits(np.full(n, -np.inf), np.full(n, np.inf), np.full(n, np.inf),
                      np.full(n, np.inf))  # fmt: skip
    box = velocity_bounds(lim, np.zeros(n), np.ones(n), DT)
    assert np.all(box.lower == -np.inf) and np.all(box.upper == np.inf) and box.viable
    assert box.kind(0, "upper") == "none"
    lim = JointLimits(np.full(n, -np.inf), np.full(n, np.inf), np.full(n, np.inf),
                      np.full(n, 10.0))  # fmt: skip
    box = velocity_bounds(lim, np.zeros(n), np.ones(n), DT)
    assert np.allclose(box.lower, 0.99) and np.allclose(box.upper, 1.01)


def test_run_violation_by_hand() -> None:
    lim = JointLimits(np.array([-1.0]), np.array([1.0]), np.array([2.0]), np.array([100.0]))
    q = np.array([[0.999], [0.5], [0.0]])
    qd = np.array([[2.0], [2.5], [0.0]])
    v = run_violation(lim, q, qd, 0.01)
    assert v.position == pytest.approx(0.999 + 0.02 - 1.0)
    assert v.velocity == pytest.approx(0.5)
    assert v.acceleration == pytest.approx(2.5 - 1.0)  # 0 -> 2 -> 2.5 -> 0, limit 1 per step
    assert v.worst == pytest.approx(1.5)


def test_limits_validation() -> None:
    with pytest.raises(JointLimitError):
        JointLimits(np.array([1.0]), np.array([0.0]), np.array([1.0]), np.array([1.0]))
    with pytest.raises(InvalidParameterError):
        JointLimits(np.array([0.0]), np.array([1.0]), np.array([0.0]), np.array([1.0]))
    with pytest.raises(NonFiniteError):
        JointLimits(np.array([0.0]), np.array([np.nan]), np.array([1.0]), np.array([1.0]))
    with pytest.raises(ShapeError):
        JointLimits(np.zeros(2), np.ones(3), np.ones(2), np.ones(2))
    robot, lim = panda_limits()
    with pytest.raises(ShapeError):
        velocity_bounds(lim, np.zeros(6), None, DT)
    with pytest.raises(InvalidParameterError):
        velocity_bounds(lim, robot.neutral(), None, -1.0)
    assert JointLimits.from_robot(robot, qdd_max=3.0).qdd_max.tolist() == [3.0] * 7


def test_extreme_readings_and_limits_end_in_bounded_time() -> None:
    """Readings of 1e300 rad, a distance of 1e30 rad, dt = 1e-300 s and qdd_max = 5e-324
    used to spin forever in the braking loop (k ± 1 stops changing k beyond 2^53): now
    each ends at once with a finite, non-negative bound. Run in a subprocess so that a
    hang fails the test instead of stalling the suite."""
    code = textwrap.dedent(
        """
        import numpy as np, redres as rr
        from redres.resolution import SNSScheme, QPScheme, braking_velocity
        robot = rr.models.panda()
        q = np.full(7, 1e300)
        J = robot.jacobian(robot.neutral())
        out = [braking_velocity(1e30, 1e-3, 1.0), braking_velocity(1.0, 1e-300, 1.0),
               braking_velocity(1.0, 1e-3, 5e-324)]
        for make in (SNSScheme, QPScheme):
            out.append(make(dt=1e-3).step(robot, q, J, np.zeros(6)).qd)
        print(all(np.all(np.isfinite(v)) and np.all(np.asarray(v) >= -1e300) for v in out))
        print(float(out[0]), float(out[2]))
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=240, check=True
    )
    finite, far, no_acceleration = done.stdout.split()
    assert finite == "True"
    assert float(far) == pytest.approx(math.sqrt(2.0 * 1.0 * 1e30), rel=1e-12)
    assert float(no_acceleration) == pytest.approx(0.0, abs=1e-100)


def test_the_braking_bound_is_continuous_where_it_turns_continuous() -> None:
    """Either side of 2^50 braking steps the discrete bound and √(2 q̈ d) agree."""
    dt, qdd = 1e-3, 2.0
    a = qdd * dt
    for k in (2.0**50 * 0.999, 2.0**50 * 1.001):
        distance = 0.5 * a * k * (k + 1.0) * dt
        v = float(braking_velocity(distance, dt, qdd))
        assert v == pytest.approx(math.sqrt(2.0 * qdd * distance), rel=1e-12)
