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

import importlib
from typing import TYPE_CHECKING, Any

from .ik import IKResult, ik  # eager: the function `ik` must shadow the package `redres.ik`
from .robot import DHLink, Robot

if TYPE_CHECKING:
    from . import (
        batch,
        collision,
        control,
        dynamics,
        errors,
        linalg,
        models,
        objectives,
        resolution,
        tasks,
    )
    from ._warmup import warmup
    from .collision import (
        BoxObstacle,
        CapsuleObstacle,
        Collisions,
        PlaneObstacle,
        PointObstacle,
        SphereObstacle,
    )
    from .control import Controller, run
    from .errors import RedresError
    from .ik.solutions import ik_all, self_motion
    from .plan import PathPlan, plan_path
    from .viewer import Viewer, view

from ._version import __version__

#: Public names loaded on first use, name -> defining module: ``import redres`` pays only
#: for what a program touches (the README example never loads the controller, the
#: torque laws or the viewer). Submodules of ``__all__`` load the same way.
_LAZY: dict[str, str] = dict.fromkeys(("Controller", "run"), ".control") | {
    "RedresError": ".errors", "warmup": "._warmup", "Viewer": ".viewer", "view": ".viewer",
    "ik_all": ".ik.solutions", "self_motion": ".ik.solutions",
    "plan_path": ".plan", "PathPlan": ".plan",
} | dict.fromkeys(("Collisions", "SphereObstacle", "PointObstacle", "CapsuleObstacle",
                   "BoxObstacle", "PlaneObstacle"), ".collision")  # fmt: skip
_SUBMODULES = frozenset(
    {"batch", "collision", "control", "dynamics", "errors", "hardware", "linalg", "models",
     "objectives", "resolution", "sim", "tasks"}
)  # fmt: skip


def __getattr__(name: str) -> Any:
    if name in _SUBMODULES:
        return importlib.import_module(f".{name}", __name__)
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'redres' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = [
    "BoxObstacle",
    "CapsuleObstacle",
    "Collisions",
    "Controller",
    "DHLink",
    "IKResult",
    "PathPlan",
    "PlaneObstacle",
    "PointObstacle",
    "RedresError",
    "Robot",
    "SphereObstacle",
    "Viewer",
    "__version__",
    "batch",
    "collision",
    "control",
    "dynamics",
    "errors",
    "hardware",
    "ik",
    "ik_all",
    "linalg",
    "models",
    "objectives",
    "plan_path",
    "resolution",
    "run",
    "self_motion",
    "sim",
    "tasks",
    "view",
    "warmup",
]
