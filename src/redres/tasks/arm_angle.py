"""The arm (elbow) angle of a 7-DOF arm and its analytic Jacobian (Kreutz-Delgado et al. 1992).

With shoulder, elbow and wrist points ``s``, ``e_pt``, ``w_pt``, a reference vector ``v``
and ``w = w_pt − s``, ``e = e_pt − s``:

* ``p = (I − ŵŵᵀ) e`` is the elbow's offset from the shoulder–wrist line;
* ``l = (w × v) × w`` lies in the reference plane (spanned by ``w`` and ``v``), normal
  to ``w``;
* ``φ`` is the angle from ``l`` to ``p`` about ``ŵ``:
  ``tan φ = ŵᵀ(l × p) / (l · p)``.

Expanding ``l`` gives the form used here, ``φ = atan2(S, C)`` with
``S = |w| wᵀ(v × e)`` and ``C = |w|²(vᵀe) − (wᵀv)(wᵀe)``; both are polynomial in the
points, so their gradients are exact and cheap, and
``∂φ = (C ∂S − S ∂C) / (S² + C²)``. The row Jacobian follows from the point Jacobians:
``J_φ = ∂φ/∂w (J_w − J_s) + ∂φ/∂e (J_e − J_s)``.

:func:`arm_angles` is this formula on arrays, for many configurations at once (the
sweeps' redundancy maps, through :func:`arm_angles` of batch poses, and
:meth:`ArmAngleTask.value` for one); :func:`arm_angle_from_points` evaluates it on one
configuration's scalars with its gradients, for the control step, where NumPy's
per-call overhead on 3-vectors would dominate.

``S² + C² = |l|² |p|²`` vanishes when the arm is stretched (``p = 0``: the elbow on the
shoulder–wrist line) or when ``w`` is parallel to ``v``: there ``φ`` is undefined. The
functions then return a zero gradient and report ``conditioning = |l||p| = 0``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_scalar, as_vector, real_array
from ..errors import InvalidParameterError, ShapeError
from .base import Task, TaskState, wrap_angle

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["ArmAngle", "ArmAngleTask", "arm_angle_from_points", "arm_angles"]


@dataclass(frozen=True)
class ArmAngle:
    """Arm angle and its gradients with respect to the three points.

    Attributes:
        phi: arm angle, rad, in ``(-π, π]``.
        d_shoulder, d_elbow, d_wrist: ``∂φ/∂point``, each shape ``(3,)``, rad/m.
        conditioning: ``sqrt(S² + C²) = |l| |p|``, m⁴ scale; 0 where ``φ`` is undefined.
    """

    phi: float
    d_shoulder: FloatArray
    d_elbow: FloatArray
    d_wrist: FloatArray
    conditioning: float


def arm_angles(
    shoulder: FloatArray, elbow: FloatArray, wrist: FloatArray, reference: FloatArray
) -> FloatArray:
    """Arm angles of many point triples at once: ``φ = atan2(S, C)`` (module docstring).

    Args:
        shoulder, elbow, wrist: points, ``(..., 3)``, m (broadcast against each other).
        reference: the reference vector ``v``, ``(3,)`` or ``(..., 3)``.

    Returns:
        ``(...)``, rad in ``(-π, π]``; where the angle is undefined (a stretched arm,
        ``w`` parallel to ``v``) ``atan2`` of (near) zeros, a finite value.

    Raises:
        InvalidParameterError: a complex input (refused, not made real).
        ShapeError: inputs whose last axis is not 3 or that do not broadcast.
    """
    given = {"shoulder": shoulder, "elbow": elbow, "wrist": wrist, "reference": reference}
    points = {name: real_array(value, name) for name, value in given.items()}
    try:
        shape = np.broadcast_shapes(*(a.shape for a in points.values()))
    except ValueError:
        shape = ()
    if not shape or shape[-1] != 3:
        shapes = ", ".join(f"{k} {a.shape}" for k, a in points.items())
        raise ShapeError(f"the points must be 3-vectors that broadcast together; got {shapes}")
    w = points["wrist"] - points["shoulder"]
    e = points["elbow"] - points["shoulder"]
    v = np.broadcast_to(points["reference"], shape)
    ww = np.sum(w * w, axis=-1)
    S = np.sqrt(ww) * np.sum(w * np.cross(v, e), axis=-1)
    C = ww * np.sum(v * e, axis=-1) - np.sum(w * v, axis=-1) * np.sum(w * e, axis=-1)
    return np.asarray(np.arctan2(S, C))


def arm_angle_from_points(shoulder: Any, elbow: Any, wrist: Any, reference: Any) -> ArmAngle:
    """Arm angle of three points about the shoulder–wrist line (module docstring).

    Args:
        shoulder, elbow, wrist: the three points, shape ``(3,)``, m (world).
        reference: the reference direction, shape ``(3,)``.

    Raises:
        ShapeError, NonFiniteError, InvalidParameterError: a point that is not a finite
            real 3-vector (complex values are refused, not made real).
    """
    return _arm_angle(
        as_vector(shoulder, "shoulder", 3),
        as_vector(elbow, "elbow", 3),
        as_vector(wrist, "wrist", 3),
        as_vector(reference, "reference", 3),
    )


def _arm_angle(
    shoulder: FloatArray, elbow: FloatArray, wrist: FloatArray, reference: FloatArray
) -> ArmAngle:
    """:func:`arm_angle_from_points` on checked points (the task's hot path).

    Written on scalars: on 3-vectors, NumPy's per-call overhead would dominate.
    """
    sx, sy, sz = float(shoulder[0]), float(shoulder[1]), float(shoulder[2])
    wx, wy, wz = float(wrist[0]) - sx, float(wrist[1]) - sy, float(wrist[2]) - sz
    ex, ey, ez = float(elbow[0]) - sx, float(elbow[1]) - sy, float(elbow[2]) - sz
    vx, vy, vz = float(reference[0]), float(reference[1]), float(reference[2])
    ww = wx * wx + wy * wy + wz * wz
    nw = math.sqrt(ww)
    # v × e and w × v
    cx, cy, cz = vy * ez - vz * ey, vz * ex - vx * ez, vx * ey - vy * ex
    det = wx * cx + wy * cy + wz * cz  # wᵀ(v × e)
    wv, we, ve = (
        wx * vx + wy * vy + wz * vz,
        wx * ex + wy * ey + wz * ez,
        vx * ex + vy * ey + vz * ez,
    )
    S = nw * det
    C = ww * ve - wv * we
    r2 = S * S + C * C
    scale = max(nw, 1e-12) ** 4 * max(vx * vx + vy * vy + vz * vz, 1e-12)
    scale *= max(ex * ex + ey * ey + ez * ez, 1e-12)
    if r2 <= 1e-24 * scale:
        zero = np.zeros(3)
        return ArmAngle(math.atan2(S, C), zero, zero, zero, 0.0)
    a, b = C / r2, S / r2
    # ∂φ/∂e = a ∂S/∂e − b ∂C/∂e with ∂S/∂e = |w| (w × v), ∂C/∂e = |w|² v − (wᵀv) w
    px, py, pz = wy * vz - wz * vy, wz * vx - wx * vz, wx * vy - wy * vx
    d_e = np.array(
        [
            a * nw * px - b * (ww * vx - wv * wx),
            a * nw * py - b * (ww * vy - wv * wy),
            a * nw * pz - b * (ww * vz - wv * wz),
        ]
    )
    # ∂S/∂w = ŵ wᵀ(v × e) + |w| (v × e); ∂C/∂w = 2 w (vᵀe) − v (wᵀe) − (wᵀv) e
    k = det / nw
    d_w = np.array(
        [
            a * (k * wx + nw * cx) - b * (2 * wx * ve - vx * we - wv * ex),
            a * (k * wy + nw * cy) - b * (2 * wy * ve - vy * we - wv * ey),
            a * (k * wz + nw * cz) - b * (2 * wz * ve - vz * we - wv * ez),
        ]
    )
    return ArmAngle(math.atan2(S, C), -(d_e + d_w), d_e, d_w, math.sqrt(r2))


class ArmAngleTask(Task):
    """Hold or track the arm angle ``φ`` of a 7-DOF arm (one row).

    Args:
        shoulder, elbow, wrist: frame names of the three points (the built-in 7-DOF arms
            define frames with these names).
        reference: reference vector ``v`` in world coordinates (default: world z); the
            reference plane contains ``v`` and the shoulder–wrist line.
        target: desired ``φ``, rad; ``None``: the angle at the first call is held.
        name: name for logs.

    The error is ``wrap(φ_d − φ)``; the Jacobian is the analytic row of the module
    docstring. On the Panda, whose elbow and wrist are offset, ``φ`` is defined from its
    ``shoulder``, ``elbow`` and ``wrist`` frames (docs/models.md) with the same formula.
    """

    dim = 1

    def __init__(
        self,
        shoulder: str = "shoulder",
        elbow: str = "elbow",
        wrist: str = "wrist",
        reference: Any = (0.0, 0.0, 1.0),
        *,
        target: float | None = None,
        name: str = "arm_angle",
    ) -> None:
        """The arguments are described in ``help(ArmAngleTask)``."""
        self.shoulder, self.elbow, self.wrist = shoulder, elbow, wrist
        v = as_vector(reference, "reference", 3)
        if np.linalg.norm(v) < 1e-9:
            raise InvalidParameterError("reference must be a non-zero 3-vector")
        self.reference = v / np.linalg.norm(v)
        self.target = None if target is None else as_scalar(target, "target")
        self._initial_target = self.target
        self.rate = 0.0
        self.name = name
        self.last: ArmAngle | None = None

    def reset(self) -> None:
        """Back to the target given at construction (``None``: hold the next first angle)."""
        self.target, self.rate, self.last = self._initial_target, 0.0, None

    def set_target(self, phi: float, rate: float = 0.0) -> None:
        """Desired arm angle (rad) and its rate (rad/s)."""
        self.target, self.rate = as_scalar(phi, "phi"), as_scalar(rate, "rate")

    def evaluate(self, robot: Robot, q: FloatArray) -> tuple[ArmAngle, FloatArray]:
        """Arm angle with its point gradients, and the Jacobian row, shape ``(n,)``."""
        points, jacobians = robot.point_jacobians(q, (self.shoulder, self.elbow, self.wrist))
        angle = _arm_angle(points[0], points[1], points[2], self.reference)
        row = angle.d_shoulder @ jacobians[0] + angle.d_elbow @ jacobians[1]
        row = row + angle.d_wrist @ jacobians[2]
        return angle, row

    def value(self, robot: Robot, q: FloatArray) -> float:
        """The arm angle ``φ(q)``, rad: :func:`arm_angles` of the three frames' origins."""
        points = [robot.fk(q, f)[:3, 3] for f in (self.shoulder, self.elbow, self.wrist)]
        return float(arm_angles(points[0], points[1], points[2], self.reference))

    def values(self, robot: Robot, q: FloatArray) -> FloatArray:
        """The arm angles of configurations ``q`` ``(N, n)`` (rad), ``(N,)``, rad:
        :meth:`value` of each row. For many rows on all cores, give :func:`arm_angles`
        the frames' origins from :func:`redres.batch.fk` (as the self-motion sweeps do)."""
        return np.array([self.value(robot, qi) for qi in np.asarray(q, dtype=np.float64)])

    def compute(self, robot: Robot, q: FloatArray) -> TaskState:
        angle, row = self.evaluate(robot, q)
        self.last = angle
        if self.target is None:
            self.target = angle.phi
        error = np.array([wrap_angle(self.target - angle.phi)])
        return TaskState(error, row[None, :], np.array([self.rate]))
