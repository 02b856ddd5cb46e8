"""Frame tasks: pose (6D), position (3D), orientation (3D), planar (x, y, φ), any rows.

Error (docs/conventions.md): ``e = [p_d − p; log(R_d Rᵀ)]`` in world-aligned axes, so
that with the world-aligned geometric Jacobian ``J``, ``ė ≈ ẋ_d − J q̇`` and the CLIK law
``q̇ = J#(ẋ_d + K e)`` makes ``e`` decay as ``exp(−K t)`` near the target
(Siciliano, Sciavicco, Villani, Oriolo, *Robotics*, 2009, §3.7.3: angle-axis error).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from .._validate import FloatArray, as_transform, as_vector
from ..errors import InvalidParameterError
from ..robot.chain import log3
from .base import Task, TaskState

if TYPE_CHECKING:
    from ..robot import Robot

_ROW_NAMES = {"x": 0, "y": 1, "z": 2, "rx": 3, "ry": 4, "rz": 5}


def _parse_rows(rows: Sequence[int] | Sequence[str] | None) -> list[int]:
    if rows is None:
        return list(range(6))
    out = []
    for r in rows:
        idx = _ROW_NAMES.get(r) if isinstance(r, str) else r
        if not isinstance(idx, (int, np.integer)) or not 0 <= idx < 6:
            raise InvalidParameterError(
                f"task rows must be indices 0..5 or names {sorted(_ROW_NAMES)}; got {r!r}"
            )
        out.append(int(idx))
    if len(set(out)) != len(out) or not out:
        raise InvalidParameterError(f"task rows must be distinct and non-empty; got {rows}")
    return out


class FrameTask(Task):
    """Drive a frame to a target pose, on any subset of the six rows.

    Args:
        frame: frame name (``None``: the robot's tip).
        rows: which rows of ``[x, y, z, rx, ry, rz]`` to control, as indices or names
            (default: all six).
        name: name for logs.

    Set the target with :meth:`set_target` (a 4x4 pose and optionally a twist
    ``[v; ω]``, world-aligned). Until then the target is the pose at the first call.
    """

    def __init__(
        self,
        frame: str | None = None,
        rows: Sequence[int] | Sequence[str] | None = None,
        *,
        name: str | None = None,
    ) -> None:
        """The arguments are described in ``help(FrameTask)``."""
        self.frame = frame
        self.rows = _parse_rows(rows)
        self.dim = len(self.rows)
        self.name = name or f"frame:{frame or 'tip'}"
        self._has_target = False
        self._share_target(np.zeros(18))
        self._R_target[...] = np.eye(3)
        self._all_rows = self.rows == list(range(6))
        #: Placement (Pinocchio SE3) of the frame and six-row error at the last compute.
        self.last_pose: pin.SE3 | None = None
        self.last_error: FloatArray | None = None

    def set_target(self, T_target: Any, twist: Any = None, *, validate: bool = True) -> None:
        """Target pose (4x4, world) and desired twist ``[v; ω]`` (6,), m/s and rad/s.

        Both are copied. ``validate=False`` skips the checks (finite, homogeneous, a
        rotation block), for loops that feed trajectory samples already checked.
        """
        if validate:
            T_target = as_transform(T_target, "T_target")
            twist = None if twist is None else as_vector(twist, "twist", 6)
        self._R_target[...] = T_target[:3, :3]
        self._p_target[...] = T_target[:3, 3]
        self._twist[...] = 0.0 if twist is None else twist
        self._has_target = True

    def _share_target(self, block: FloatArray) -> None:
        """Keep the target in ``block`` (18 floats, written in place from now on): the
        rotation row-major, the position, the twist. The controller passes a slice of its
        compiled kernel's settings, so that :meth:`set_target` writes straight into them."""
        old = getattr(self, "_target", None)
        if old is not None:
            block[:] = old
        self._target = block
        self._R_target = block[0:9].reshape(3, 3)
        self._p_target = block[9:12]
        self._twist = block[12:18]

    def __getstate__(self) -> dict[str, Any]:
        # Copies and pickles would turn the views into arrays of their own: keep the block.
        state = self.__dict__.copy()
        for view in ("_R_target", "_p_target", "_twist"):
            del state[view]
        state["_target"] = self._target.copy()
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._share_target(self._target)

    @property
    def target(self) -> FloatArray | None:
        """The current target pose (4x4) or ``None`` before the first target."""
        if not self._has_target:
            return None
        T = np.eye(4)
        T[:3, :3] = self._R_target
        T[:3, 3] = self._p_target
        return T

    @property
    def target_block(self) -> FloatArray:
        """The target as the compiled kernels read it: 18 floats, the rotation row-major,
        the position, the twist (the array itself, written in place by :meth:`set_target`)."""
        return self._target

    @property
    def twist(self) -> FloatArray:
        """The desired twist ``[v; ω]`` of the target (a copy; zeros by default)."""
        return np.array(self._twist, dtype=float)

    def full_error(self, T: FloatArray) -> FloatArray:
        """Six-row error ``[p_d − p; log(R_d Rᵀ)]`` of pose ``T`` against the target."""
        if not self._has_target:
            raise InvalidParameterError(f"task {self.name!r} has no target yet")
        return self._error(T[:3, :3], T[:3, 3])

    def _error(self, R: FloatArray, p: FloatArray) -> FloatArray:
        e = np.empty(6)
        e[:3] = self._p_target - p
        e[3:] = log3(self._R_target @ R.T)
        return e

    def compute(self, robot: Robot, q: FloatArray) -> TaskState:
        qv = as_vector(q, "q", robot.n)
        placement, J = robot.placement_jacobian(qv, robot.frame_id(self.frame))
        if not self._has_target:
            self.set_target(placement.homogeneous, validate=False)
        e = self._error(placement.rotation, placement.translation)
        self.last_pose, self.last_error = placement.copy(), e
        if self._all_rows:
            return TaskState(e, J, self._twist.copy())
        return TaskState(e[self.rows], J[self.rows], self._twist[self.rows])


class PositionTask(FrameTask):
    """Position of a frame's origin (3 rows); orientation free."""

    def __init__(self, frame: str | None = None, *, name: str | None = None) -> None:
        """Track ``frame`` (``None``: the robot's tip); ``name`` labels it in logs."""
        super().__init__(frame, (0, 1, 2), name=name or f"position:{frame or 'tip'}")


class OrientationTask(FrameTask):
    """Orientation of a frame (3 rows, SO(3) logarithm); position free."""

    def __init__(self, frame: str | None = None, *, name: str | None = None) -> None:
        """Track ``frame`` (``None``: the robot's tip); ``name`` labels it in logs."""
        super().__init__(frame, (3, 4, 5), name=name or f"orientation:{frame or 'tip'}")


class PlanarTask(FrameTask):
    """Planar pose ``(x, y, φ)`` of a frame moving in the world x-y plane (Siciliano et al. 2009).

    Set the target with :meth:`set_planar_target`; ``φ`` is the rotation about world z.
    """

    def __init__(self, frame: str | None = None, *, name: str | None = None) -> None:
        """Track ``frame`` (``None``: the robot's tip); ``name`` labels it in logs."""
        super().__init__(frame, (0, 1, 5), name=name or f"planar:{frame or 'tip'}")

    def set_planar_target(self, x: float, y: float, phi: float, velocity: Any = None) -> None:
        """Target ``(x, y)`` in m and ``φ`` in rad; ``velocity`` = ``(ẋ, ẏ, φ̇)``."""
        T = pin.SE3(pin.utils.rotate("z", phi), np.array([x, y, 0.0])).homogeneous
        twist = np.zeros(6)
        if velocity is not None:
            twist[[0, 1, 5]] = as_vector(velocity, "velocity", 3)
        self.set_target(T, twist)
