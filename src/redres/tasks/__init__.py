"""Tasks: each gives an error and a Jacobian (docs/conventions.md)."""

from .arm_angle import ArmAngle, ArmAngleTask, arm_angle_from_points
from .base import Task, TaskState, stack, wrap_angle
from .frame import FrameTask, OrientationTask, PlanarTask, PositionTask

__all__ = [
    "ArmAngle",
    "ArmAngleTask",
    "FrameTask",
    "OrientationTask",
    "PlanarTask",
    "PositionTask",
    "Task",
    "TaskState",
    "arm_angle_from_points",
    "stack",
    "wrap_angle",
]
