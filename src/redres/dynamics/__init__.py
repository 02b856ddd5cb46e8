"""Dynamics: the dynamically consistent inverse at work (seed 004).

* :class:`OperationalSpaceController` — Khatib's operational-space torque law with a
  null-space torque projected by ``I − Jᵀ J̄ᵀ`` (or, to compare, ``I − Jᵀ J⁺ᵀ``);
  :func:`operational_space_torque` is the same law on bare arrays.
* :func:`resolve_acceleration` and :class:`AccelerationController` — acceleration-level
  resolution ``q̈ = J̄ (ẍ − J̇ q̇) + (I − J̄ J) q̈₀`` with computed torque.
* :func:`simulate` — forward dynamics (Pinocchio ABA, semi-implicit Euler) of any torque
  law with torque limits and an optional :class:`Payload`, recorded as a
  :class:`~redres.control.RunLog`.

See docs/dynamics.md.
"""

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
