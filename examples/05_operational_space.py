"""
Operational-space torque control
================================

Operational-space torque control, and why the projector must be J̄ (Khatib 1987).

The Panda's TCP follows a 10 cm circle under Khatib's operational-space controller while a
posture task acts in the null space, simulated with forward dynamics at 1 kHz. With the
dynamically consistent projector ``I − Jᵀ J̄ᵀ`` the null-space torque causes no task
acceleration at all; with the kinematic ``I − Jᵀ J⁺ᵀ`` it does, and the tracking error
grows. Then the same with a 2 kg load the controller does not know about, and a numerical
check of Featherstone & Khatib's load independence of J̄.

Run: python examples/05_operational_space.py [--full]
(``--full``: the whole circle, 4250 steps per run — the table in docs/dynamics.md;
``REDRES_EXAMPLE_STEPS=N`` sets the number of steps.)
"""

from __future__ import annotations

import os
import sys

import numpy as np

import redres as rr
from redres.control import Circle
from redres.dynamics import (
    OperationalSpaceController,
    Payload,
    dynamics_summary,
    simulate,
    with_payload,
)
from redres.linalg import dynamically_consistent_pinv
from redres.objectives import PostureObjective
from redres.tasks import FrameTask

DT = 1e-3


def steps_to_run(full_circle: int) -> int:
    if "REDRES_EXAMPLE_STEPS" in os.environ:
        return max(1, int(os.environ["REDRES_EXAMPLE_STEPS"]))
    return full_circle if "--full" in sys.argv else 800


def row(label: str, s: dict) -> str:
    return (
        f"| {label:28s} | {1e3 * s['max_position_error_m']:9.4f} | "
        f"{1e3 * s['rms_position_error_m']:9.4f} | {s['max_orientation_error_rad']:.2e} | "
        f"{s['max_torque_ratio']:5.3f} | {s['max_task_disturbance']:.2e} | "
        f"{s['rms_task_disturbance']:.2e} |"
    )


HEADER = (
    "| run                          | max err mm | rms err mm | max rot rad | "
    "τ/τmax | max dist m/s² | rms dist m/s² |\n|---|---|---|---|---|---|---|"
)


def circle_table(robot: rr.Robot) -> None:
    q0 = robot.neutral()
    circle = Circle(robot.fk(q0), 0.10, 4.0, ramp=0.5)
    steps = steps_to_run(round(circle.duration / DT))
    print(
        f"Panda, 10 cm circle (4 s/turn, 0.5 s ramp), posture in the null space, "
        f"{steps} steps at dt = {DT} s:"
    )
    print(HEADER)
    for projector in ("dynamic", "kinematic"):
        law = OperationalSpaceController(projector=projector, objectives=[PostureObjective(q0)])
        log = simulate(robot, law, circle, dt=DT, duration=steps * DT, q0=q0)
        print(row(f"projector {projector}", dynamics_summary(log)))
    payload = Payload(2.0, com=(0.0, 0.0, 0.05), inertia=np.diag([0.01, 0.01, 0.005]))
    short = min(steps, 600 if "--full" in sys.argv else 300)
    for rows, label in ((None, "2 kg unknown, 6-D task"), ("xyz", "2 kg unknown, xyz task")):
        law = OperationalSpaceController(FrameTask(rows=rows), objectives=[PostureObjective(q0)])
        log = simulate(robot, law, circle, dt=DT, duration=short * DT, q0=q0, payload=payload)
        print(row(label, dynamics_summary(log)))
    print(
        "(dist = ‖J M⁻¹ τ_null‖ on the simulated plant: the task acceleration caused by the "
        "null-space torque)\n"
    )


def load_independence(robot: rr.Robot, configurations: int = 5) -> None:
    """Relative change of J̄ when a load is fixed to the TCP, for several tasks and loads."""
    rng = np.random.default_rng(4)
    rigid = Payload(2.0, com=(0.03, -0.02, 0.05), inertia=np.diag([0.010, 0.020, 0.015]))
    cases = [
        ("rigid load, 6-D TCP task", rigid, robot.tip, slice(0, 6), 0.0),
        ("rigid load, 6-D task of another frame of link 7", rigid, "flange", slice(0, 6), 0.0),
        ("rigid load, 6-D task of the wrist (link 6)", rigid, "wrist", slice(0, 6), 0.0),
        ("rigid load, position task", rigid, robot.tip, slice(0, 3), 0.0),
        ("point mass at the TCP, position task", Payload(2.0), robot.tip, slice(0, 3), 0.0),
        ("rigid load, 6-D TCP task, damped J̄ (λ = 0.05)", rigid, robot.tip, slice(0, 6), 0.05),
    ]
    print(
        f"Load independence of J̄ (Featherstone & Khatib 1997), {robot.name}, max over "
        f"{configurations} random configurations of ‖J̄_loaded − J̄‖ / ‖J̄‖:"
    )
    qs = [robot.random_configuration(rng, margin=0.1) for _ in range(configurations)]
    for label, payload, frame, rows, damping in cases:
        loaded = with_payload(robot, payload)
        change = 0.0
        for q in qs:
            J = robot.jacobian(q, frame)[rows]
            J_bar = dynamically_consistent_pinv(J, robot.mass_matrix(q), damping=damping)
            J_bar_l = dynamically_consistent_pinv(J, loaded.mass_matrix(q), damping=damping)
            change = max(change, np.linalg.norm(J_bar_l - J_bar) / np.linalg.norm(J_bar))
        verdict = "invariant" if change < 1e-9 else "changes"
        print(f"  {label:50s} {change:8.1e}  {verdict}")


def main() -> None:
    robot = rr.models.panda()
    circle_table(robot)
    load_independence(robot)


if __name__ == "__main__":
    main()
