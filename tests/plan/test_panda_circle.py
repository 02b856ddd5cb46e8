"""The demo's Panda joint-limit circle (``panda_joint_limit_circle``): the global plan from
the scenario's start keeps a larger minimum joint-limit margin than every local scheme of
the scenario, is on the path (Pinocchio's FK), within the velocity limits, and a
controller tracks it within 1 mm."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.resolution import PriorityScheme
from redres.scenarios.runner import run_scenario, summarise
from redres.scenarios.spec import builtin
from redres.tasks import PostureTask


@pytest.fixture(scope="module")
def scenario():  # type: ignore[no-untyped-def]
    return builtin("panda_joint_limit_circle")


@pytest.fixture(scope="module")
def plan(scenario):  # type: ignore[no-untyped-def]
    return rr.plan_path(scenario.robot, scenario.trajectory, dt=0.01, parameter="q7",
                        resolution=360, q0=scenario.q0)  # fmt: skip


def test_plan_beats_every_local_scheme(scenario, plan) -> None:  # type: ignore[no-untyped-def]
    assert plan.feasible and np.abs(plan.q[0] - scenario.q0).max() < 1e-9
    margins = {}
    for log in run_scenario(scenario, progress=False):
        margins[log.label or log.scheme] = summarise(scenario.robot, log)[
            "min_joint_limit_margin_rad"
        ]
    assert len(margins) == len(scenario.schemes)
    assert all(plan.objective >= m for m in margins.values()), (plan.objective, margins)
    assert plan.objective > 0.45  # measured 0.4825 rad; the best local scheme 0.38


def test_plan_is_on_the_circle_within_the_velocity_limits(scenario, plan) -> None:  # type: ignore[no-untyped-def]
    robot = scenario.robot
    assert plan.q.shape == (1001, 7)
    worst = max(
        np.abs(robot.fk(q) - scenario.trajectory.sample(float(t)).pose).max()
        for q, t in zip(plan.q, plan.t)
    )
    assert worst < 1e-10
    assert np.all(np.abs(np.diff(plan.q, axis=0)) <= robot.qd_max * 0.01)
    assert np.all((plan.q >= robot.q_min) & (plan.q <= robot.q_max))


def test_controller_tracks_the_plan(scenario, plan) -> None:  # type: ignore[no-untyped-def]
    """The circle as the frame task, the plan's ``q(t)`` as a posture level below it."""
    robot, dt = scenario.robot, 1e-3
    posture = PostureTask(plan.q[0])
    task = scenario.task()
    controller = rr.Controller(robot, task, PriorityScheme([posture], gain=100.0),
                               gain=scenario.gain, dt=dt)  # fmt: skip
    q = scenario.q0.copy()
    steps = round(scenario.duration / dt)
    error, margin = np.zeros(steps), np.zeros(steps)
    for k in range(steps):
        sample = scenario.trajectory.sample(k * dt)
        task.set_target(sample.pose, sample.twist)
        posture.q_ref[:] = plan.at(k * dt)[0]  # type: ignore[index]
        q = controller.step(q)
        error[k] = np.linalg.norm(controller.error[:3])
        margin[k] = robot.joint_limit_margin(q).min()
    assert error.max() < 1e-3  # measured 0.013 mm
    assert margin.min() > plan.objective - 0.01  # measured 0.481 against 0.4825
