"""Tasks: each gives an error and a Jacobian (docs/conventions.md)."""

from .arm_angle import ArmAngle, ArmAngleTask, arm_angle_from_points, arm_angles
from .base import Task, TaskState, stack, wrap_angle
from .frame import FrameTask, OrientationTask, PlanarTask, PositionTask
from .joint import PostureTask
from .look_at import LookAtTask

__all__ = [
    "ArmAngle",
    "ArmAngleTask",
    "FrameTask",
    "LookAtTask",
    "OrientationTask",
    "PlanarTask",
    "PositionTask",
    "PostureTask",
    "Task",
    "TaskState",
    "arm_angle_from_points",
    "arm_angles",
    "stack",
    "wrap_angle",
]
