"""Compiled FK check of closed-form solutions (internal): each solution's position and
rotation error against the pose it solves, by the chain's own FK.

Entry point and its call tree::

    errors(links, axes, kinds, out, count)
        robot._chain_kernels.fk, _pose_dot

``out`` is a solution buffer of :mod:`._analytic_codes` (rows of joints, the pose in row
``POSE``), filled by :mod:`._q7_kernels` or :mod:`._arm_angle_kernels`.
"""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel
from ..robot._chain_kernels import fk
from ._analytic_codes import (
    POSE,
    POSITION_ERROR,
    ROTATION_ERROR,
)


@kernel(nogil=False)  # called from Python, under a microsecond per solution
def errors(links, axes, kinds, out, count):
    """The FK errors of solutions ``0 … count − 1`` of ``out`` against its pose row:
    position (m) and rotation angle (rad) into their columns (the chain's own FK)."""
    F = np.empty((4, 4))
    P = out[POSE]
    for r in range(count):
        row = out[r]
        fk(links, axes, kinds, row, F)
        dx, dy, dz = F[0, 3] - P[3], F[1, 3] - P[7], F[2, 3] - P[11]
        row[POSITION_ERROR] = math.sqrt(dx * dx + dy * dy + dz * dz)
        # the angle of E = R_Tᵀ R: atan2(|vee(E − Eᵀ)| / 2, (tr E − 1) / 2), accurate at
        # every angle
        wx = _pose_dot(P, F, 2, 1) - _pose_dot(P, F, 1, 2)
        wy = _pose_dot(P, F, 0, 2) - _pose_dot(P, F, 2, 0)
        wz = _pose_dot(P, F, 1, 0) - _pose_dot(P, F, 0, 1)
        trace = _pose_dot(P, F, 0, 0) + _pose_dot(P, F, 1, 1) + _pose_dot(P, F, 2, 2)
        half_sine = 0.5 * math.sqrt(wx * wx + wy * wy + wz * wz)
        row[ROTATION_ERROR] = math.atan2(half_sine, 0.5 * (trace - 1.0))


@kernel(inline=True)
def _pose_dot(P, F, i, j):
    """Column ``i`` of the pose row's rotation (``P``: ``T[:3, :4]`` row by row) dotted
    with column ``j`` of ``F[:3, :3]``: ``(R_Tᵀ R_F)[i, j]``."""
    return P[i] * F[0, j] + P[4 + i] * F[1, j] + P[8 + i] * F[2, j]
