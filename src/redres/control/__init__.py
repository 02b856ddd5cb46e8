"""Rate-control loops, trajectories and run logs."""

from .clik import final_configuration, run
from .runlog import RunLog
from .scenarios import SCENARIOS, Scenario, iiwa_arm_angle_eight, panda_joint_limit_circle
from .trajectories import (
    Circle,
    FigureEight,
    Hold,
    Line,
    MinimumJerk,
    Sample,
    Trajectory,
    minimum_jerk,
)

__all__ = [
    "Circle",
    "FigureEight",
    "Hold",
    "Line",
    "MinimumJerk",
    "SCENARIOS",
    "RunLog",
    "Scenario",
    "Sample",
    "Trajectory",
    "final_configuration",
    "iiwa_arm_angle_eight",
    "minimum_jerk",
    "panda_joint_limit_circle",
    "run",
]
