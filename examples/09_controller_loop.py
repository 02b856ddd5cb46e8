"""
A 1 kHz control loop with the Controller
========================================

A 1 kHz control loop with the Controller — the whole step in a few µs.

``rr.run`` records everything about a run; a real controller only needs the next joint
command, every millisecond. ``rr.Controller(robot, task, scheme)`` computes it: for a
frame task and gradient projection with a joint-limit cost, in one Pinocchio call
(placement and Jacobian) and one compiled kernel (pose error, inverse, joint-limit
gradient in the null space, velocity scaling, integration); with another scheme (here
the hard-limit SNS and QP schemes) the kernel computes the task command and the scheme
resolves it. ``controller.path`` says which.

The loop below follows the Panda joint-limit circle for a few seconds with three
controllers and prints, for each, the tracking error, the closest approach to a joint
limit and the median time per step measured inside the loop.

Run: python examples/09_controller_loop.py
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable

import numpy as np

import redres as rr
from redres.control import Controller
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme, QPScheme, Scheme, SNSScheme
from redres.scenarios.spec import builtin
from redres.tasks import FrameTask

DT = 1e-3


def controllers(robot: rr.Robot) -> dict[str, tuple[FrameTask, Controller]]:
    """Each loop's frame task (the trajectory sets its target) and its controller."""
    schemes: dict[str, Callable[[], Scheme]] = {
        "gradient projection": lambda: GradientProjectionScheme(
            [JointLimitObjective()], k_null=5.0, damping=0.01
        ),
        "SNS, hard limits": lambda: SNSScheme(dt=DT),
        "QP, hard limits": lambda: QPScheme(dt=DT),
    }
    out = {}
    for name, make in schemes.items():
        try:
            scheme = make()
        except rr.errors.MissingDependencyError as exc:  # the qp extra is not installed
            print(f"({name} skipped: {exc})")
            continue
        task = FrameTask()
        out[name] = (task, Controller(robot, task, scheme, gain=50.0, dt=DT))
    return out


def main() -> None:
    scenario = builtin("panda_joint_limit_circle")
    robot, trajectory = scenario.robot, scenario.trajectory
    assert trajectory is not None
    steps = int(os.environ.get("REDRES_EXAMPLE_STEPS", 6000))
    print(f"{scenario.description}; {steps} steps at 1 kHz")
    print(f"{'controller (path)':<32} | {'max err mm':>10} | {'min margin rad':>14} | "
          f"{'median µs':>9}")  # fmt: skip
    for name, (task, controller) in controllers(robot).items():
        q = scenario.q0.copy()
        errors, margins, times = np.empty(steps), np.empty(steps), np.empty(steps)
        for k in range(steps):
            sample = trajectory.sample(k * DT)
            t0 = time.perf_counter()
            task.set_target(sample.pose, sample.twist, validate=False)
            q = controller.step(q)
            times[k] = time.perf_counter() - t0
            errors[k] = np.linalg.norm(controller.error[:3])
            margins[k] = robot.joint_limit_margin(q).min()
        # The first steps start from rest at full path speed: report the tracking error
        # once the loop has caught up (after 0.1 s).
        settled = errors[min(100, steps - 1) :]
        print(
            f"{f'{name} ({controller.path})':<32} | {1e3 * settled.max():>10.4f} | "
            f"{margins.min():>14.4f} | {1e6 * np.median(times):>9.1f}"
        )
    print("\nFor the sigma_min, damping and rank of the last step: controller.info")


if __name__ == "__main__":
    main()
