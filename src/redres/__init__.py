"""redres: redundancy resolution for robot manipulators.

Quick start::

    import redres as rr

    robot = rr.models.panda()
    q = robot.neutral()
    T = robot.fk(q)                      # 4x4 pose of the tip frame
    J = robot.jacobian(q)                # 6 x 7, rows [v; w], world-aligned axes
    qd = rr.linalg.damped_pinv(J, 0.01) @ [0.1, 0, 0, 0, 0, 0]
"""

from __future__ import annotations

from . import batch, control, dynamics, errors, linalg, models, objectives, resolution, tasks
from ._warmup import warmup
from .control import Controller, run
from .errors import RedresError
from .ik import IKResult, ik
from .robot import DHLink, Robot
from .viewer import Viewer, view

__version__ = "0.1.0.dev0"

__all__ = [
    "Controller",
    "DHLink",
    "IKResult",
    "RedresError",
    "Robot",
    "Viewer",
    "__version__",
    "batch",
    "control",
    "dynamics",
    "errors",
    "ik",
    "linalg",
    "models",
    "objectives",
    "resolution",
    "run",
    "tasks",
    "view",
    "warmup",
]
