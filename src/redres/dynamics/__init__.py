"""Dynamics: the dynamically consistent inverse at work (Khatib 1987): operational-space and
acceleration-level torque laws and their forward-dynamics :func:`simulate`. See
docs/dynamics.md."""

from __future__ import annotations

from .acceleration import AccelerationController, resolve_acceleration
from .base import ControlStep, GravityCompensation, TaskGains, TorqueFunction, TorqueLaw, ZeroTorque
from .osc import (
    OperationalSpaceController,
    OperationalSpaceTorque,
    operational_space_torque,
    task_disturbance,
)
from .payload import Payload, payload_spatial_inertia, with_gravity, with_payload
from .simulate import dynamics_summary, simulate

__all__ = [
    "AccelerationController",
    "ControlStep",
    "GravityCompensation",
    "OperationalSpaceController",
    "OperationalSpaceTorque",
    "Payload",
    "TaskGains",
    "TorqueFunction",
    "TorqueLaw",
    "ZeroTorque",
    "dynamics_summary",
    "operational_space_torque",
    "payload_spatial_inertia",
    "resolve_acceleration",
    "simulate",
    "task_disturbance",
    "with_gravity",
    "with_payload",
]
