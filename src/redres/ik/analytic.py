"""Every inverse-kinematics solution of a 7R arm at a given ``q7``, in closed form.

``at_q7(robot, T, q7=...)`` returns all joint configurations (up to eight) that put the
frame at pose ``T`` with the last joint at ``q7``, computed by a compiled kernel
(:mod:`redres.ik._q7_kernels`) in microseconds. Covered: arms whose first three
axes meet at one point ``S`` (a spherical shoulder) and whose axes 5 and 6 meet at a
point ``W`` (the Franka Panda and FR3, whose axis 7 is offset; S-R-S arms such as the
iiwa14). With ``q7`` fixed the arm is a 6R chain with a spherical shoulder, the geometry
of He & Liu, "Analytical inverse kinematics for Franka Emika Panda – a geometrical
solver for 7-DOF manipulators with unconventional design", ICCCR 2021, solved here for
any such chain with Paden–Kahan subproblems (Murray, Li & Sastry, *A Mathematical
Introduction to Robotic Manipulation*, 1994, §3.3; Elias & Wen, "IK-Geo", 2022).

Derivation (joints 1-based, ``Rot(a, θ)`` the rotation about the unit ``a``; frame ``j``
is the frame after joint ``j``; ``X_j`` the placement of joint ``j + 1`` in it):

1. **Frame 6.** ``T = F6 · X6 · Rot(a7, q7) · X7`` gives ``F6``, hence the point
   ``W = F6 ∘ w6`` (fixed in link 6: on axes 5 and 6) and the joint-6 axis ``z6``.
2. **Elbow.** ``S`` and ``W`` are fixed in links 3 and 4, so ``|W − S|`` depends on
   ``q4`` alone: with ``s'`` the point ``S`` in joint 4's placement frame and ``w4``
   the point ``W`` in frame 4, ``|W − S|² = |w4|² + |s'|² − 2 s'·Rot(a4, q4) w4
   = K − 2 (P + A cos q4 + B sin q4)`` (Rodrigues), two roots ``q4 = atan2(B, A) ±
   acos(x)``.
3. **Shoulder orientation.** For each ``q4``, the vector ``S → W`` in frame 3 (``v3``)
   and the joint-5 axis there (``u3``) are known. Every frame-3 orientation ``R3`` with
   ``R3 v3 = W − S`` is ``Rot(ŵ, φ) R3⁰``; the joint-5 axis ``z5 = R3 u3`` must make with
   ``z6`` the fixed angle ``γ`` of link 5 (``cos γ = a5 · R(X5) a6``, 0 for the
   Panda). Taking ``R3⁰`` that turns the part of ``u3`` normal to the line onto the part
   of ``z6`` normal to it, ``z5·z6 = (z6·ŵ)(u3·v̂3) + |u3⊥||z6⊥| cos φ = cos γ``: two
   roots ``φ = ± acos(...)``.
4. **Joints.** ``R3`` gives ``q1, q2, q3`` (subproblem 2 on axis 3, two signs: the
   shoulder branches), and ``(R4 R(X4))ᵀ R6 = Rot(a5, q5) R(X5) Rot(a6, q6)`` gives
   ``q5, q6`` uniquely (subproblem 1 twice; its solvability is step 3's condition).

Branch code ``4 i4 + 2 iφ + is``: ``i4`` 0 for ``q4 = atan2(B, A) + acos(x)``, 1 for
``−``; ``iφ`` 0 for ``φ = +acos``, 1 for ``−`` (``φ`` turns ``z5`` about ``S → W``
away from its position closest to ``z6``); ``is`` 0 for ``+`` in subproblem 2, 1 for
``−``. Each is intrinsic to the arm's geometry (no arbitrary frame enters it).

Singular and boundary cases are flagged (:class:`~redres.ik._analytic_codes.AnalyticFlag`),
never NaN: a shoulder with axes 1 and 3 aligned (one solution, ``q1 ± q3`` split
evenly), a stretched elbow and merged roots of step 3 (one solution each), a free
rotation about ``S → W`` (one of the continuum), an unreachable pose (no solution,
``UNREACHABLE``). Each joint is moved by 2π into its limits where that fits;
``within_limits`` tells which solutions lie inside them (to 1e-12 rad).

**Speed.** What depends on the arm alone is computed once per arm
(:func:`analytic_arm`, in ``redres.ik.structure``):
frame 6 as a fixed combination of three matrices in ``cos q7``, ``sin q7``; ``S → W``,
the joint-5 axis and ``q5``'s reference vectors in frame 3 as ``c0 + cos q4 cc + sin q4
cs``. ``cos q4``, ``sin q4`` and ``cos φ``, ``sin φ`` come from the sum formulas and
``√(1 − x²)``, ``q5`` and ``q6`` as ``atan2`` of dot products linear in ``cos φ``,
``sin φ``. Where axes 1 and 2 are perpendicular and axes 1 and 3 parallel at the zero
configuration (to :data:`~redres.ik._analytic_codes.TWIN_TOL`: the Panda, FR3, iiwa14,
srs7), the second shoulder solution is the first turned: ``Rot(k1, q1 + π) Rot(k2, −q2)
Rot(k3, q3 + π) = Rot(k1, q1) Rot(k2, q2) Rot(k1, π) Rot(k3, π) Rot(k3, q3)`` because
``Rot(k1, π) Rot(k2, θ) = Rot(k2, −θ) Rot(k1, π)`` for ``k1 ⊥ k2``, and ``Rot(k1, π)
Rot(k3, π) = I`` for ``k3 = ±k1`` (tested against the general subproblem 2). A single
call's FK errors are computed on first access (:class:`IKSolutions`), the batch's in
its kernel (or not at all: ``residuals=False``).

The structure is detected from the robot's serial chain to the frame
(:func:`analytic_arm`, ``redres.ik.structure``) to :data:`STRUCTURE_TOL`; an arm
without it raises :class:`NotAnalyticError` naming the failed test (``rr.ik`` solves any
arm numerically).
"""

from __future__ import annotations

import dataclasses
import math
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .. import _compile
from .._validate import FloatArray, as_scalar, as_transform
from ..errors import (
    InvalidParameterError,
    NonFiniteError,
    ShapeError,
)
from . import _analytic_codes as codes
from ._analytic_codes import AnalyticFlag
from .structure import STRUCTURE_TOL, AnalyticArm, NotAnalyticError, analytic_arm

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = [
    "STRUCTURE_TOL",
    "AnalyticArm",
    "AnalyticFlag",
    "IKSolutions",
    "IKSolutionsBatch",
    "NotAnalyticError",
    "analytic_arm",
    "at_q7",
    "at_q7_batch",
]

#: The analytic kernels: the closed form at ``q7`` (first), at the arm angle (S-R-S arms),
#: the solutions' FK errors, the geometry the first two share (compiled into them), and
#: ``rr.ik``'s closed-form answer (the nearest solution within the limits).
#: Cold (2026-12-07, 2 shared cores, load 3.1, empty cache, foreground): a first ``at_q7``
#: 6.6 s (no chain kernel on its path), its first FK errors 2.4 s more (with the chain's
#: FK), the batch form 1.7 s more, the arm-angle form (``at_arm_angle``) 3.0 s more; warm
#: 0.6 s.
KERNELS = _compile.KernelGroup(
    "analytic ik",
    (
        "redres.ik._q7_kernels",
        "redres.ik._arm_angle_kernels",
        "redres.ik._residual_kernels",
        "redres.ik._geometry_kernels",
        "redres.ik._nearest_kernels",
    ),
    cold_seconds=8.3,
    others={"redres.ik._arm_angle_kernels": 3.0, "redres.ik._residual_kernels": 2.4},
)


@dataclass(slots=True, eq=False)
class IKSolutions:
    """Every solution of one pose at one ``q7`` (``count`` of them, ``0 ≤ count ≤ 8``).

    The arrays are views of the kernel's buffer, made on access (a call returns before
    slicing them: most callers read two or three). The FK errors are computed on first
    access (the chain's compiled FK of each solution, once). Read-only by convention:
    not frozen, because a frozen dataclass costs a call a fifth more to make.

    Attributes:
        count: how many solutions.
        flags: the union of the solutions' flags, and ``UNREACHABLE`` when there is none.
        q7: the last joint's value, rad.
        q: the configurations, ``(count, 7)``, rad.
        branch: each one's branch code ``4 i4 + 2 iφ + is`` (module docstring).
        within_limits: whether each is within the joint limits.
        position_error: its FK position error (the chain's compiled FK), m.
        rotation_error: its FK rotation error (angle), rad.
        residual: ``max(position_error m, rotation_error rad)``.
        solution_flags: what is special about each (:class:`AnalyticFlag` bits).
        values: the buffer, ``(N_ROWS, N_VALUES)`` (:mod:`redres.ik._analytic_codes`).
        arm: the arm solved, whose chain gives the FK errors on first access; ``None``
            when ``values`` holds them already.
    """

    count: int
    flags: AnalyticFlag
    q7: float
    values: FloatArray = dataclasses.field(repr=False)
    arm: AnalyticArm | None = dataclasses.field(default=None, repr=False)
    _filled: bool = dataclasses.field(default=False, init=False, repr=False)

    @property
    def q(self) -> FloatArray:
        return self.values[_Q_ROWS[self.count]]

    @property
    def branch(self) -> NDArray[np.int64]:
        return self.values[: self.count, codes.BRANCH].astype(np.int64)

    @property
    def within_limits(self) -> NDArray[np.bool_]:
        return self.values[: self.count, codes.WITHIN] == 1.0

    @property
    def position_error(self) -> FloatArray:
        return self._checked()[: self.count, codes.POSITION_ERROR]

    @property
    def rotation_error(self) -> FloatArray:
        return self._checked()[: self.count, codes.ROTATION_ERROR]

    @property
    def residual(self) -> FloatArray:
        values = self._checked()[: self.count]
        return np.maximum(values[:, codes.POSITION_ERROR], values[:, codes.ROTATION_ERROR])

    @property
    def solution_flags(self) -> NDArray[np.int64]:
        return self.values[: self.count, codes.FLAGS].astype(np.int64)

    def __len__(self) -> int:
        return self.count

    def _checked(self) -> FloatArray:
        """The buffer, with the FK errors filled (on the first call; two threads racing
        here write the same values)."""
        arm = self.arm
        if arm is not None and not self._filled:
            _errors(arm.links, arm.axes, arm.kinds, self.values, self.count)
            self._filled = True
        return self.values


@dataclass(frozen=True)
class IKSolutionsBatch:
    """Every solution of ``N`` poses, padded to 8 per pose: row ``j`` of pose ``i`` holds
    a solution when ``j < count[i]`` (padding: zeros, ``branch`` −1, not within limits).

    Attributes:
        q: ``(N, 8, 7)``, rad. branch, solution_flags: ``(N, 8)`` int64.
        within_limits: ``(N, 8)``. position_error, rotation_error: ``(N, 8)``, m, rad.
        count: solutions per pose, ``(N,)``. flags: per pose, ``(N,)`` int64
        (:class:`AnalyticFlag` bits).
        roots: the arguments of the ``acos`` that decide which branches exist, ``(N, 3)``
            (a root exists where its argument lies within ±1): the elbow's ``x`` (step 2
            of the module docstring), then the joint-5/6 condition's ``y`` of each elbow
            root (step 3; NaN where not reached: the elbow out of reach, one elbow root,
            or a condition that does not involve ``φ``; all NaN from the closed form at
            the arm angle).
    """

    q: FloatArray
    branch: NDArray[np.int64]
    within_limits: NDArray[np.bool_]
    position_error: FloatArray
    rotation_error: FloatArray
    solution_flags: NDArray[np.int64]
    count: NDArray[np.int64]
    flags: NDArray[np.int64]
    roots: FloatArray

    @property
    def residual(self) -> FloatArray:
        """``max(position_error, rotation_error)``, ``(N, 8)`` (0 in the padding)."""
        return np.maximum(self.position_error, self.rotation_error)


# ---------------------------------------------------------------------- arms
#: The arm of the last single-pose call: (robot, frame, arm) (a weak-dict lookup costs
#: a tenth of a call).
_LAST: tuple[Callable[[], Robot | None], str | None, AnalyticArm | None] = (
    lambda: None,
    None,
    None,
)


# ---------------------------------------------------------------------- solving


def at_q7(robot: Robot, T: Any, *, q7: float, frame: str | None = None) -> IKSolutions:
    """Every configuration that puts ``frame`` at ``T`` with the last joint at ``q7``
    (module docstring).

    Args:
        robot: a 7R arm of the covered structure (:func:`analytic_arm`).
        T: the frame's pose in the world, ``(4, 4)``.
        q7: the last joint's value (the redundancy parameter), rad.
        frame: the frame (default: the robot's tip).

    Returns:
        The :class:`IKSolutions` (none, with ``UNREACHABLE``, when out of reach). Each
        call has its own buffer.

    Raises:
        NotAnalyticError: the arm lacks the structure (the message says why).
        ShapeError: ``T`` is not a 4x4 homogeneous transform with a rotation block.
        NonFiniteError: ``T`` or ``q7`` holds NaN or infinity.
    """
    global _LAST
    ref, last_frame, arm = _LAST
    if arm is None or ref() is not robot or last_frame != frame:
        arm = analytic_arm(robot, frame)
        _LAST = (weakref.ref(robot), frame, arm)
    # the entry point takes a C-contiguous float64 2-D array (its shape: the kernel checks)
    if type(T) is not np.ndarray or T.dtype is not _F64 or T.strides != (32, 8):
        T = np.array(_pose(T, "T"), dtype=np.float64, order="C")
    x = q7 if type(q7) is float else _q7(q7)
    out = _empty(_BUFFER)
    code = _solve(arm.arm, T, x, out)
    if code < 0:
        _refused(code, T, x, "T", "q7")
    return IKSolutions(code & _COUNT_MASK, _FLAGS[code >> _FLAG_SHIFT], x, out, arm)


def at_q7_batch(
    robot: Robot, T: Any, q7: Any, *, frame: str | None = None, residuals: bool = True
) -> IKSolutionsBatch:
    """:func:`at_q7` for ``N`` poses ``T`` ``(N, 4, 4)`` at ``q7`` ``(N,)`` (or one value
    for all), rad, on every core (numba's threads; each pose is independent, so results do
    not depend on the thread count). The FK errors are computed here, for every solution,
    when ``residuals`` (the default); ``residuals=False`` skips them (``position_error``
    and ``rotation_error`` are then NaN for every solution, 0 in the padding) and more
    than halves the kernel's time for callers that do not read them.

    Raises:
        NotAnalyticError, ShapeError, NonFiniteError: as :func:`at_q7` (the message names
            the first bad pose).
    """
    arm = analytic_arm(robot, frame)
    poses = np.ascontiguousarray(T, dtype=np.float64)
    if poses.ndim != 3 or poses.shape[1:] != (4, 4):
        raise ShapeError(f"T must have shape (N, 4, 4); got shape {poses.shape}")
    n = poses.shape[0]
    values = np.ascontiguousarray(np.broadcast_to(np.asarray(q7, dtype=np.float64), (n,)))
    out = np.empty((n, *_BUFFER))
    summary = np.zeros((n, 3), dtype=np.int64)
    _module().solve_many(
        arm.arm, arm.links, arm.axes, arm.kinds, poses, values, out, summary, bool(residuals)
    )
    bad = np.flatnonzero(summary[:, 0] != codes.SOLVED)
    if len(bad):
        i = int(bad[0])
        _refused(int(summary[i, 0]), poses[i], float(values[i]), f"T[{i}]", f"q7[{i}]")
    rows = out[:, : codes.MAX_SOLUTIONS]
    return IKSolutionsBatch(
        q=rows[:, :, : codes.N_JOINTS],
        branch=rows[:, :, codes.BRANCH].astype(np.int64),
        within_limits=rows[:, :, codes.WITHIN] == 1.0,
        position_error=rows[:, :, codes.POSITION_ERROR],
        rotation_error=rows[:, :, codes.ROTATION_ERROR],
        solution_flags=rows[:, :, codes.FLAGS].astype(np.int64),
        count=summary[:, 1].copy(),
        flags=summary[:, 2].copy(),
        roots=out[:, codes.ROOTS, :3],
    )


_F64 = np.dtype(np.float64)
_BUFFER = (codes.N_ROWS, codes.N_VALUES)
_COUNT_MASK, _FLAG_SHIFT = codes.COUNT_MASK, codes.FLAG_SHIFT
_empty = np.empty
#: ``values[_Q_ROWS[count]]``: the joints of the solutions (a key made once per count).
_Q_ROWS = [(slice(0, k), slice(0, codes.N_JOINTS)) for k in range(codes.MAX_SOLUTIONS + 1)]
_FLAGS = [AnalyticFlag(i) for i in range(2 * max(AnalyticFlag))]


def _pose(T: Any, name: str) -> FloatArray:
    return as_transform(T, name)


def _q7(value: Any) -> float:
    if value is None:
        raise InvalidParameterError(
            "q7 is required: the value of the last joint, rad, that picks the solutions "
            "among the arm's self-motion"
        )
    return as_scalar(value, "q7")


def _refused(status: int, T: FloatArray, q7: float, t_name: str, q_name: str) -> None:
    """Raise the error the kernel's refusal ``status`` stands for, naming the argument."""
    if status == codes.BAD_Q7 or not math.isfinite(q7):
        raise NonFiniteError(f"{q_name} must be finite; got {q7}")
    if not np.isfinite(T).all():
        raise NonFiniteError(f"{t_name} contains NaN or infinity")
    as_transform(T, t_name)  # raises ShapeError with the reason
    raise ShapeError(f"{t_name}: the upper-left 3x3 block is not a rotation matrix")


# ---------------------------------------------------------------------- kernels


def _module(module: str | None = None) -> Any:
    """Kernel module ``module`` of :data:`KERNELS` (default: the closed form at ``q7``)."""
    return KERNELS.required("analytic IK", module)


def _native(module: str, name: str, args: tuple[Any, ...]) -> tuple[Any, Callable[..., Any] | None]:
    """Kernel ``name`` of kernel module ``module`` run on ``args``, and its native entry
    point for these types, made at the first call (:func:`redres._compile.entry_point`);
    no entry point (``None``) while the kernels compile behind: the plain-Python twin
    answers, and the compiled kernel takes over when ready. The kernels are idempotent:
    running one twice writes the same values."""
    found = _module(module)
    kernel = getattr(found, name)
    if not _compile.is_compiled(found):
        return kernel(*args), None
    entry = _compile.entry_point(kernel, args)
    return entry(*args), entry


def _swapping(module: str, name: str, slot: str) -> Callable[..., Any]:
    """A stand-in for kernel ``name`` of kernel module ``module``: it runs the kernel
    (:func:`_native`) and, once an entry point is made, puts it in this module's global
    ``slot``, where callers look it up, in its own place from then on."""

    def first(*args: Any) -> Any:
        result, entry = _native(module, name, args)
        if entry is not None:
            globals()[slot] = entry
        return result

    first.__name__ = first.__qualname__ = f"{name}_first"
    return first


#: ``solve_pose(arm, T, q7, out)``, compiled: the closed form at ``q7``.
_solve: Callable[..., int] = _swapping("_q7_kernels", "solve_pose", "_solve")
#: ``errors(links, axes, kinds, values, count)``, compiled: the solutions' FK errors.
_errors: Callable[..., None] = _swapping("_residual_kernels", "errors", "_errors")
#: ``solve_arm_angle(srs, T, phi, out)`` (for :mod:`.solutions`): the S-R-S closed form
#: at one arm angle, compiled.
solve_srs: Callable[..., int] = _swapping("_arm_angle_kernels", "solve_arm_angle", "solve_srs")
