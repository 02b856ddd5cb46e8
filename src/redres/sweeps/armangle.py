"""The arm angle of many configurations at once (what :class:`~redres.tasks.ArmAngleTask` controls).

The same definition as :func:`redres.tasks.arm_angle.arm_angle_from_points`
(Kreutz-Delgado, Long & Seraji, IJRR 11(5), 1992): with shoulder, elbow and wrist points
``s``, ``e_pt``, ``w_pt``, the reference vector ``v``, ``w = w_pt − s`` and
``e = e_pt − s``, ``φ = atan2(S, C)`` with ``S = |w| wᵀ(v × e)`` and
``C = |w|²(vᵀe) − (wᵀv)(wᵀe)``: the angle about ``ŵ`` from ``l = (w × v) × w`` to the
elbow's offset from the shoulder–wrist line. Written on arrays here (the task's version
works on one configuration's scalars); ``tests/sweeps/test_redundancy.py`` checks the
two against each other.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .. import batch

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["arm_angles", "arm_angles_of_points"]


def arm_angles_of_points(
    shoulder: np.ndarray, elbow: np.ndarray, wrist: np.ndarray, reference: np.ndarray
) -> np.ndarray:
    """Arm angles, rad in ``(-π, π]``, of points ``(..., 3)`` (m) about the
    shoulder–wrist line, reference ``(3,)`` (module docstring)."""
    w = wrist - shoulder
    e = elbow - shoulder
    v = np.broadcast_to(reference, w.shape)
    ww = np.sum(w * w, axis=-1)
    S = np.sqrt(ww) * np.sum(w * np.cross(v, e), axis=-1)
    C = ww * np.sum(v * e, axis=-1) - np.sum(w * v, axis=-1) * np.sum(w * e, axis=-1)
    return np.asarray(np.arctan2(S, C))


def arm_angles(
    robot: Robot,
    q: np.ndarray,
    points: tuple[str, str, str] = ("shoulder", "elbow", "wrist"),
    reference: np.ndarray | None = None,
    threads: int | None = None,
) -> np.ndarray:
    """Arm angles of configurations ``q`` ``(N, n)`` (rad), ``(N,)``: the ``points``
    frames' origins by :func:`redres.batch.fk`, reference default world z."""
    v = np.array([0.0, 0.0, 1.0]) if reference is None else np.asarray(reference, float)
    v = v / np.linalg.norm(v)
    s, e, w = (batch.fk(robot, q, f, threads=threads)[:, :3, 3] for f in points)
    return arm_angles_of_points(s, e, w, v)
