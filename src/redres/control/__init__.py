"""Rate-control loops, trajectories and run logs."""

from .clik import final_configuration, run
from .runlog import RunLog
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
    "RunLog",
    "Sample",
    "Trajectory",
    "final_configuration",
    "minimum_jerk",
    "run",
]
