"""Built-in scenarios: a robot, a start configuration, a task and a reference path.

``panda_joint_limit_circle``: a 10 cm circle, four turns in 10 s, placed (by a seeded
search over start configurations and circle planes, recorded here as numbers) so that
minimum-norm pseudo-inverse control drives joint 2 of the Panda past its lower limit
while self-motion schemes keep every joint inside.

``iiwa_arm_angle_eight``: the iiwa14's flange follows a 15 cm x 10 cm figure eight in a
vertical plane; the augmented Jacobian holds the arm angle where the plain
pseudo-inverse lets it drift.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import FloatArray
from ..models import iiwa14, panda
from ..robot import Robot
from ..tasks import FrameTask
from .trajectories import Circle, FigureEight, Trajectory


@dataclass
class Scenario:
    """What a run needs besides the scheme."""

    name: str
    robot: Robot
    q0: FloatArray
    task: FrameTask
    trajectory: Trajectory
    description: str


PANDA_CIRCLE_Q0 = (-0.811, -1.061, 0.515, -2.269, -0.299, 1.036, 0.521)
PANDA_CIRCLE_NORMAL = (-0.404, -0.565, -1.433)
PANDA_CIRCLE_PHASE = 1.851


def panda_joint_limit_circle(*, turns: float = 4.0) -> Scenario:
    """The Panda's TCP on a 10 cm circle (period 2.5 s) that pushes joint 2 to its limit."""
    robot = panda()
    q0 = np.array(PANDA_CIRCLE_Q0)
    circle = Circle(
        robot.fk(q0),
        0.10,
        2.5,
        normal=PANDA_CIRCLE_NORMAL,
        phase=PANDA_CIRCLE_PHASE,
        turns=turns,
    )
    return Scenario(
        "panda_joint_limit_circle",
        robot,
        q0,
        FrameTask(),
        circle,
        "Panda TCP, 10 cm circle, 2.5 s per turn; the minimum-norm solution drives joint 2 "
        "past its lower limit",
    )


def iiwa_arm_angle_eight(*, turns: float = 2.0) -> Scenario:
    """The iiwa14's flange on a figure eight in the world y-z plane, 5 s per eight."""
    robot = iiwa14()
    q0 = robot.neutral()
    eight = FigureEight(robot.fk(q0), 0.15, 0.10, 5.0, normal=(1.0, 0.0, 0.0), turns=turns)
    return Scenario(
        "iiwa_arm_angle_eight",
        robot,
        q0,
        FrameTask(),
        eight,
        "iiwa14 flange, 15 x 10 cm figure eight in a vertical plane, 5 s per eight",
    )


SCENARIOS = {
    "panda_joint_limit_circle": panda_joint_limit_circle,
    "iiwa_arm_angle_eight": iiwa_arm_angle_eight,
}
