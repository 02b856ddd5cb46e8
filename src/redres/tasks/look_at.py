"""Look-at task: point a frame's z axis (a camera's optical axis) at a world point."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_vector
from ..errors import InvalidParameterError
from .base import Task, TaskState

if TYPE_CHECKING:
    from ..robot import Robot


class LookAtTask(Task):
    """Point a frame's z axis (a camera's optical axis) at a world point: 2 rows.

    With ``u = (p_t − p)/ρ`` the unit vector from the frame origin ``p`` to the target
    ``p_t`` (``ρ = ‖p_t − p‖``) and ``s = Rᵀu`` the same direction in frame axes, the task
    value is the log map of ``s`` at the optical axis ``z = (0, 0, 1)``::

        v = θ (s_x, s_y) / r,    r = ‖(s_x, s_y)‖,    θ = atan2(r, s_z)

    so ``‖v‖ = θ`` is the angle (rad) between the axis and the line of sight, and
    ``v ≈ (s_x, s_y)`` near the goal. Desired ``v = 0``: ``e = −v``. The Jacobian follows
    from ``ṡ = Rᵀ([u]× J_ω − (I − uuᵀ) J_v / ρ) q̇ + Rᵀ (I − uuᵀ) ṗ_t / ρ`` (world-aligned
    ``J_v``, ``J_ω``; the last term gives the feedforward of a moving target). Unlike
    ``(s_x, s_y)`` alone, whose norm ``sin θ`` is also minimal when the axis points *away*,
    ``θ`` has a single minimum. ``v`` is undefined where the axis points exactly away
    (``θ = π``) or the target is at the frame origin; there the output stays finite.

    Args:
        frame: frame whose z axis points (``None``: the tip).
        target: world point, shape ``(3,)``, m (``None``: set it with :meth:`set_target`).
        name: name for logs.
    """

    dim = 2

    def __init__(self, frame: str | None = None, target: Any = None, *, name: str | None = None):
        """The arguments are described in ``help(LookAtTask)``."""
        self.frame = frame
        self.name = name or f"look_at:{frame or 'tip'}"
        self.point = np.zeros(3)
        self.velocity = np.zeros(3)
        self._has_target = False
        if target is not None:
            self.set_target(target)

    def set_target(self, point: Any, velocity: Any = None) -> None:
        """World point to look at (m) and its velocity (m/s, default zero)."""
        self.point = as_vector(point, "point", 3).copy()
        self.velocity = np.zeros(3) if velocity is None else as_vector(velocity, "velocity", 3)
        self._has_target = True

    def evaluate(self, robot: Robot, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(v, ∂v/∂q, ∂v/∂p_t)``: shapes ``(2,)`` rad, ``(2, n)``, ``(2, 3)`` rad/m."""
        if not self._has_target:
            raise InvalidParameterError(f"{self.name}: call set_target(point) first")
        T, J = robot.kinematics(q, self.frame)
        R, d = T[:3, :3], self.point - T[:3, 3]
        rho = float(np.linalg.norm(d))
        if rho < 1e-12:
            return np.zeros(2), np.zeros((2, robot.n)), np.zeros((2, 3))
        u = d / rho
        s = R.T @ u
        v, dv_ds = _log_map_at_z(s)
        tangent = (np.eye(3) - np.outer(u, u)) / rho
        ux = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
        ds_dq = R.T @ (ux @ J[3:] - tangent @ J[:3])
        return v, dv_ds @ ds_dq, dv_ds @ (R.T @ tangent)

    def angle(self, robot: Robot, q: FloatArray) -> float:
        """Angle between the frame's z axis and the line of sight, rad."""
        return float(np.linalg.norm(self.evaluate(robot, q)[0]))

    def compute(self, robot: Robot, q: FloatArray) -> TaskState:
        v, J, D = self.evaluate(robot, q)
        return TaskState(-v, J, -(D @ self.velocity))


def _log_map_at_z(s: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``v = θ s_xy / r`` and ``∂v/∂s`` (2x3) for a unit ``s`` (see :class:`LookAtTask`)."""
    sx, sy, sz = float(s[0]), float(s[1]), float(s[2])
    r = math.hypot(sx, sy)
    if sz > 0.0 and r < 1e-4 * sz:
        t2 = (r / sz) ** 2  # series of atan(t)/r and its derivative, error O(t⁴)
        g = (1.0 - t2 / 3.0) / sz
        dg_r_over_r = (-2.0 / 3.0 + 0.8 * t2) / sz**3
    else:
        if r < 1e-9:  # axis pointing exactly away: any direction of rotation will do
            sx, sy, r = 1e-9, 0.0, 1e-9
        theta = math.atan2(r, sz)
        g = theta / r
        dg_r_over_r = (r * sz / (r * r + sz * sz) - theta) / r**3
    dg_dz = -1.0 / (r * r + sz * sz)
    v = np.array([g * sx, g * sy])
    D = np.array(
        [
            [g + dg_r_over_r * sx * sx, dg_r_over_r * sx * sy, sx * dg_dz],
            [dg_r_over_r * sx * sy, g + dg_r_over_r * sy * sy, sy * dg_dz],
        ]
    )
    return v, D
