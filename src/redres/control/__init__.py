"""The controller, command shaping, rate-control runs, trajectories and run logs."""

from .analysis import analyse_run, progress_bar
from .closed_loop import LiveView, final_configuration, run
from .controller import Controller
from .log import RunLog, RunWarning
from .shaping import CommandShaper
from .trajectories import (
    Chain,
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
    "Chain",
    "Circle",
    "CommandShaper",
    "Controller",
    "FigureEight",
    "Hold",
    "Line",
    "LiveView",
    "MinimumJerk",
    "RunLog",
    "RunWarning",
    "Sample",
    "Trajectory",
    "analyse_run",
    "final_configuration",
    "minimum_jerk",
    "progress_bar",
    "run",
]
