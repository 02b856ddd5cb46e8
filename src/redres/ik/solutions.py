"""Every IK solution of a 7-DOF arm at a given value of its redundancy parameter, and the
self-motion of a pose: ``rr.ik_all`` and ``rr.self_motion``.

A 7-DOF arm reaches a pose in a one-parameter family of configurations, its *self-motion*.
Two parameters name a member of it:

* ``q7``, the last joint (:mod:`redres.ik.analytic`: arms with a spherical shoulder whose
  axes 5 and 6 meet — the Franka Panda and FR3, S-R-S arms such as the iiwa14 — a compiled
  closed form, microseconds per pose);
* ``arm_angle``, the library's arm angle (:class:`redres.tasks.ArmAngleTask`, the angle
  the augmented-Jacobian scheme controls) on S-R-S arms (:mod:`redres.ik.srs`, Shimizu et
  al., IEEE T-RO 24(5), 2008).

At one parameter value there are up to eight solutions, one per *branch*. Along the
parameter each branch is a continuous curve of configurations; :func:`self_motion` gives,
per branch, the parameter intervals on which it exists within the joint limits.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from .._validate import FloatArray, as_scalar, as_transform
from ..errors import InvalidParameterError, ShapeError
from ..robot.chain import log3
from ..tasks import wrap_angle
from . import _analytic_codes as codes
from . import analytic
from .analytic import (
    AnalyticFlag,
    IKSolutions,
    IKSolutionsBatch,
    NotAnalyticError,
    analytic_arm,
    at_q7,
    at_q7_batch,
)
from .arcs import Arc
from .srs import SRSArm

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["SelfMotion", "at_arm_angle", "ik_all", "self_motion"]

Parameter = Literal["q7", "arm_angle"]
#: Grid of :func:`self_motion` along ``q7`` (points over the joint's range) and the width
#: to which each interval end is then found by bisection, rad.
Q7_GRID, END_TOL = 721, 1e-12
_TWO_PI = 2.0 * math.pi


def ik_all(
    robot: Robot,
    T: Any,
    *,
    q7: Any = None,
    arm_angle: Any = None,
    frame: str | None = None,
) -> IKSolutions | IKSolutionsBatch:
    """Every configuration that puts ``frame`` at ``T`` at one value of the redundancy
    parameter: ``q7`` (rad) or ``arm_angle`` (rad, S-R-S arms), exactly one of them.

    ``T`` of shape ``(4, 4)`` gives an :class:`~redres.ik.analytic.IKSolutions` (``q``
    ``(k, 7)``, ``branch``, ``within_limits``, ``residual``, ``flags``); ``(N, 4, 4)``
    with the parameter one value or ``(N,)`` gives an
    :class:`~redres.ik.analytic.IKSolutionsBatch`, padded to 8 per pose (``q7``: on every
    core, results independent of the thread count).

    The branch code of a ``q7`` solution is ``4 i4 + 2 iφ + is`` (elbow root, the root of
    the joint-5/6 condition, shoulder sign: :mod:`redres.ik.analytic`); of an
    ``arm_angle`` solution, the row of :data:`redres.ik.srs.BRANCHES` (the signs of
    ``θ₂``, ``θ₄``, ``θ₆``: Shimizu's global configuration); there each solution has its
    own ``q7`` (in ``q``), and the result's ``q7`` attribute is NaN.

    Raises:
        NotAnalyticError: the arm has no closed form at ``q7`` (the message says which
            test failed; ``rr.ik`` solves any arm numerically).
        NotSRSError: ``arm_angle`` on an arm that is not S-R-S.
        InvalidParameterError: neither or both of ``q7`` and ``arm_angle``.
        ShapeError, NonFiniteError: a bad pose or parameter (named).
    """
    if (q7 is None) == (arm_angle is None):
        raise InvalidParameterError(
            "give exactly one of q7 (the last joint, rad) and arm_angle (rad, S-R-S arms): "
            "the value of the redundancy parameter that picks the solutions"
        )
    poses = np.asarray(T, dtype=float) if not isinstance(T, np.ndarray) else T
    if poses.ndim == 3:
        if q7 is not None:
            return at_q7_batch(robot, poses, q7, frame=frame)
        return _at_arm_angle(robot, poses, arm_angle, frame)
    if q7 is not None:
        return at_q7(robot, T, q7=q7, frame=frame)
    return at_arm_angle(robot, T, arm_angle=arm_angle, frame=frame)


def at_arm_angle(robot: Robot, T: Any, *, arm_angle: float, frame: str | None = None
                 ) -> IKSolutions:  # fmt: skip
    """Every configuration of an S-R-S arm that puts ``frame`` at ``T`` (4x4) at the arm
    angle ``arm_angle`` (rad), by the compiled closed form of :mod:`redres.ik.srs`
    (``rr.ik_all(robot, T, arm_angle=...)`` for one pose): up to eight, in branch order
    (the row of :data:`redres.ik.srs.BRANCHES`), each joint moved by 2π into its limits
    where that fits; the result's ``q7`` is NaN (each solution has its own, in ``q``);
    FK errors computed on first access.

    Raises:
        NotSRSError: the arm is not S-R-S.
        ShapeError, NonFiniteError: a bad pose or arm angle (named).
    """
    global _LAST_SRS
    ref, last_frame, constants, checker = _LAST_SRS
    if constants is None or ref() is not robot or last_frame != frame:
        srs = _srs(robot, frame)
        assert srs is not None
        constants = srs.constants
        try:
            checker = analytic_arm(robot, frame)
        except NotAnalyticError:  # pragma: no cover - an S-R-S arm has the q7 structure
            checker = None
        _LAST_SRS = (weakref.ref(robot), frame, constants, checker)
    if type(T) is not np.ndarray or T.dtype is not _F64 or T.strides != (32, 8):
        T = np.array(as_transform(T, "T"), dtype=np.float64, order="C")
    phi = arm_angle if type(arm_angle) is float else as_scalar(arm_angle, "arm_angle")
    out = _empty(_BUFFER)
    code = analytic.solve_srs(constants, T, phi, out)
    if code < 0:
        analytic._refused(code, T, phi, "T", "arm_angle")
    count = code & _COUNT_MASK
    found = IKSolutions(count, _FLAGS[code >> _FLAG_SHIFT], _NAN, out, checker)
    if checker is None:  # pragma: no cover
        links, axes, kinds = robot.chain(frame).arrays
        analytic._errors(links, axes, kinds, out, count)
    return found


_F64 = np.dtype(np.float64)
_FLAGS = [AnalyticFlag(i) for i in range(2 * max(AnalyticFlag))]
_BUFFER = (codes.N_ROWS, codes.N_VALUES)
_COUNT_MASK, _FLAG_SHIFT, _NAN = codes.COUNT_MASK, codes.FLAG_SHIFT, math.nan
_empty = np.empty
#: The S-R-S arm of the last call of :func:`at_arm_angle`: (robot, frame, its packed
#: constants, its q7 constants, whose chain gives the FK errors).
_LAST_SRS: tuple[Callable[[], Robot | None], str | None, FloatArray | None, Any] = (
    lambda: None,
    None,
    None,
    None,
)


@dataclass(frozen=True)
class SelfMotion:
    """The self-motion of one pose: per branch, the parameter intervals on which the
    branch exists within the joint limits.

    Attributes:
        parameter: ``"q7"`` or ``"arm_angle"``.
        intervals: per branch code (0 to 7), a tuple of ``(lo, hi)`` intervals, rad. For
            ``q7`` inside the joint's limits, ends found to :data:`END_TOL` by bisection
            from a grid of :data:`Q7_GRID` points (a stretch narrower than the grid step
            can be missed); for ``arm_angle`` the exact arcs of the closed form
            (``lo < hi ≤ lo + 2π``: an arc may pass ±π).
        width: the total width of each branch's intervals, ``(8,)``, rad.
    """

    robot: Robot
    pose: FloatArray
    frame: str | None
    parameter: Parameter
    intervals: tuple[tuple[Arc, ...], ...]

    @property
    def width(self) -> FloatArray:
        return np.array([sum(hi - lo for lo, hi in arcs) for arcs in self.intervals])

    @property
    def empty(self) -> bool:
        """No configuration within the limits reaches the pose."""
        return not any(self.intervals)

    def sample(self, per_radian: float = 20.0) -> tuple[FloatArray, FloatArray, NDArray[np.int64]]:
        """Configurations along the self-motion: on each interval, evenly spaced parameter
        values about ``per_radian`` per rad (at least its two ends moved inward by
        1e-9 rad). Returns ``(values (K,), q (K, 7), branch (K,))``, every ``q`` within
        the limits."""
        per_radian = as_scalar(per_radian, "per_radian", minimum=0.0, strict=True)
        out_v: list[float] = []
        out_q: list[FloatArray] = []
        out_b: list[int] = []
        for b, arcs in enumerate(self.intervals):
            for lo, hi in arcs:
                count = max(2, math.ceil((hi - lo) * per_radian) + 1)
                for x in np.linspace(lo + 1e-9, hi - 1e-9, count):
                    q = self._branch_at(float(x), b)
                    if q is not None:
                        out_v.append(float(x))
                        out_q.append(q)
                        out_b.append(b)
        q_all = np.array(out_q).reshape(-1, 7)
        return np.array(out_v), q_all, np.array(out_b, dtype=np.int64)

    def _branch_at(self, value: float, branch: int) -> FloatArray | None:
        kw = {"q7": value} if self.parameter == "q7" else {"arm_angle": float(wrap_angle(value))}
        found = ik_all(self.robot, self.pose, frame=self.frame, **kw)
        assert isinstance(found, IKSolutions)
        hit = np.flatnonzero((found.branch == branch) & found.within_limits)
        return None if len(hit) == 0 else found.q[int(hit[0])].copy()


def self_motion(
    robot: Robot, T: Any, *, parameter: Parameter | None = None, frame: str | None = None
) -> SelfMotion:
    """The self-motion of pose ``T`` (4x4): per branch, the intervals of the redundancy
    parameter on which the branch exists within the joint limits (:class:`SelfMotion`;
    ``.sample()`` gives configurations along them).

    ``parameter``: ``"q7"`` (any arm :func:`ik_all` solves at ``q7``) or ``"arm_angle"``
    (S-R-S arms: exact arcs); default ``"arm_angle"`` on S-R-S arms, else ``"q7"``.

    Raises:
        NotAnalyticError, NotSRSError: the arm has no closed form for the parameter.
        ShapeError, NonFiniteError: a bad pose.
    """
    pose = as_transform(T, "T")
    if parameter is None:
        parameter = "arm_angle" if _srs(robot, frame, quiet=True) is not None else "q7"
    if parameter == "arm_angle":
        arm = _srs(robot, frame)
        assert arm is not None
        exact = arm.poses(pose[None]).arcs()[0]
        return SelfMotion(robot, pose, frame, "arm_angle", tuple(tuple(a) for a in exact))
    if parameter != "q7":
        raise InvalidParameterError(f"parameter must be 'q7' or 'arm_angle'; got {parameter!r}")
    lo, hi = analytic_arm(robot, frame).bounds[:, 6]
    if not (math.isfinite(lo) and math.isfinite(hi)):
        lo, hi = -math.pi, math.pi
    grid = np.linspace(lo, hi, Q7_GRID)
    found = at_q7_batch(robot, np.broadcast_to(pose, (Q7_GRID, 4, 4)), grid, frame=frame)
    present = np.zeros((8, Q7_GRID), dtype=bool)
    rows, slots = np.nonzero(found.within_limits)
    present[found.branch[rows, slots], rows] = True
    intervals: list[tuple[Arc, ...]] = []
    for b in range(8):
        on = present[b]
        arcs: list[Arc] = []
        starts = np.flatnonzero(on & ~np.concatenate(([False], on[:-1])))
        ends = np.flatnonzero(on & ~np.concatenate((on[1:], [False])))
        for s, e in zip(starts, ends):
            a = grid[s] if s == 0 else _edge(robot, pose, frame, b, grid[s - 1], grid[s])
            z = grid[e] if e == Q7_GRID - 1 else _edge(robot, pose, frame, b, grid[e + 1], grid[e])
            arcs.append((float(a), float(z)))
        intervals.append(tuple(arcs))
    return SelfMotion(robot, pose, frame, "q7", tuple(intervals))


def _edge(robot: Robot, pose: FloatArray, frame: str | None, branch: int, out: float,
          inside: float) -> float:  # fmt: skip
    """The ``q7`` between ``out`` (branch absent) and ``inside`` (present) where the branch
    appears, by bisection to :data:`END_TOL`; the last value where it is present."""
    while abs(inside - out) > END_TOL:
        mid = 0.5 * (out + inside)
        found = at_q7(robot, pose, q7=mid, frame=frame)
        if np.any((found.branch == branch) & found.within_limits):
            inside = mid
        else:
            out = mid
    return inside


_SRS: weakref.WeakKeyDictionary[Robot, dict[str | None, SRSArm | None]] = (
    weakref.WeakKeyDictionary()
)


def _srs(robot: Robot, frame: str | None, quiet: bool = False) -> SRSArm | None:
    """The S-R-S closed form of ``robot`` (cached), None when it has none and ``quiet``."""
    from .srs import NotSRSError

    arms = _SRS.setdefault(robot, {})
    if frame not in arms:
        try:
            arms[frame] = SRSArm.from_robot(robot, frame)
        except NotSRSError:
            arms[frame] = None
    arm = arms[frame]
    if arm is None and not quiet:
        SRSArm.from_robot(robot, frame)  # raises NotSRSError with its reason
    return arm


def _at_arm_angle(robot: Robot, poses: FloatArray, arm_angle: Any, frame: str | None
                  ) -> IKSolutionsBatch:  # fmt: skip
    """Every S-R-S solution of poses ``(N, 4, 4)`` at arm angles (one or ``(N,)``)."""
    arm = _srs(robot, frame)
    assert arm is not None
    if poses.ndim != 3 or poses.shape[1:] != (4, 4):
        raise ShapeError(f"T must have shape (4, 4) or (N, 4, 4); got shape {poses.shape}")
    n = poses.shape[0]
    for i in range(n):
        as_transform(poses[i], f"T[{i}]" if n > 1 else "T")
    phi = np.broadcast_to(np.asarray(arm_angle, dtype=float), (n,))
    for i, x in enumerate(phi):
        as_scalar(x, "arm_angle" if n == 1 else f"arm_angle[{i}]")
    solved = arm.poses(np.ascontiguousarray(poses, dtype=float))
    q = np.zeros((n, 8, 7))
    branch = np.full((n, 8), -1, dtype=np.int64)
    within = np.zeros((n, 8), dtype=bool)
    count = np.zeros(n, dtype=np.int64)
    lo, hi = arm.q_min, arm.q_max
    for b in range(8):
        qb = solved.joints(phi[:, None], b)[:, 0]  # (N, 7), NaN where there is none
        ok = np.isfinite(qb).all(axis=1)
        # as the kernels: into [−π, π), then moved by 2π into the limits where that fits
        qb = qb - _TWO_PI * np.floor(qb * (1.0 / _TWO_PI) + 0.5)
        up, down = (qb < lo) & (qb + _TWO_PI <= hi), (qb > hi) & (qb - _TWO_PI >= lo)
        qb = np.where(up, qb + _TWO_PI, np.where(down, qb - _TWO_PI, qb))
        for i in map(int, np.flatnonzero(ok)):
            k = int(count[i])
            q[i, k], branch[i, k] = qb[i], b
            within[i, k] = bool(np.all((qb[i] >= lo - 1e-12) & (qb[i] <= hi + 1e-12)))
            count[i] += 1
    chain = robot.chain(frame)
    pos_err, rot_err = np.zeros((n, 8)), np.zeros((n, 8))
    for i in range(n):
        for k in range(count[i]):
            F = chain.fk(q[i, k])
            pos_err[i, k] = float(np.linalg.norm(F[:3, 3] - poses[i, :3, 3]))
            rot_err[i, k] = float(np.linalg.norm(log3(F[:3, :3].T @ poses[i, :3, :3])))
    flags = np.where(count == 0, int(AnalyticFlag.UNREACHABLE), 0).astype(np.int64)
    return IKSolutionsBatch(q, branch, within, pos_err, rot_err, np.zeros((n, 8), np.int64),
                            count, flags, np.full((n, 3), np.nan))  # fmt: skip
