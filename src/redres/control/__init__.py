"""The controller, rate-control runs, trajectories and run logs."""

from .analysis import analyse_run, progress_bar
from .clik import final_configuration, run
from .controller import Controller
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
    "SCENARIOS",
    "Circle",
    "Controller",
    "FigureEight",
    "Hold",
    "Line",
    "MinimumJerk",
    "RunLog",
    "Sample",
    "Scenario",
    "Trajectory",
    "analyse_run",
    "final_configuration",
    "iiwa_arm_angle_eight",
    "minimum_jerk",
    "panda_joint_limit_circle",
    "progress_bar",
    "run",
]
