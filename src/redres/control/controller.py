"""A compiled CLIK controller for one frame task: a whole control step in two calls.

:class:`ClikController` does, for a :class:`~redres.tasks.FrameTask` and diagonal quadratic
secondary costs (joint-limit mid-range, posture), what one iteration of
:func:`redres.control.run` does with :class:`~redres.resolution.GradientProjectionScheme`
(or :class:`~redres.resolution.PseudoInverseScheme` without costs)::

    e   = [p_d − p; log(R_d Rᵀ)]                       (world-aligned, docs/conventions.md)
    q̇   = J# (ẋ_d + K e) − k (I − J# J) Σ wᵢ ∇Dᵢ(q)     (seed 000 eq. 6, seed 003)
    q̇  ← q̇ / max(1, maxⱼ |q̇ⱼ| / q̇_max,j)               (one factor: keeps the direction)
    q  ← q + q̇ dt

in one Pinocchio call (frame placement and Jacobian, one forward pass) and one compiled
kernel (pose error, inverse, null-space term, scaling, integration) writing one fresh
output array per step. It is the loop for a 1 kHz controller; :func:`run` stays the
general path (any task, scheme and objective, with a full run log).

The costs must declare :meth:`~redres.objectives.Objective.quadratic_form` (their gradient
is ``a ∘ (q − r)``); a cost without one (manipulability, obstacles) is refused with a
pointer to the general path.

With ``scheme=`` (any :class:`~redres.resolution.Scheme`, e.g. the hard-limit
:class:`~redres.resolution.SNSScheme` and :class:`~redres.resolution.QPScheme`), the
compiled kernel computes the task error and command only and the scheme's
:meth:`~redres.resolution.Scheme._step` (without the input checks of ``step``: the
kernel's arrays are known good) resolves them; the step is then that of :func:`run` with
that scheme.

Without the compiled kernels (numba missing or disabled) the same step runs through
:class:`~redres.tasks.FrameTask` and :func:`redres.linalg.rate_step` (or the scheme).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from .._validate import FloatArray, as_scalar, as_transform, as_vector
from ..errors import InvalidParameterError, NonFiniteError, ShapeError
from ..linalg import InverseInfo, rate_step
from ..linalg import _backend as be
from ..linalg import _codes as codes
from ..objectives import Objective
from ..resolution.base import InverseChoice, Scheme, StepResult, as_inverse
from ..resolution.gradient_projection import WeightedObjective, weighted_objectives
from ..tasks import FrameTask
from ._fused import fused_config, kernel_for, quadratic_coefficients, raise_for_status, row_gains

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["ClikController", "FrameCommand"]

_F64 = np.float64
_ndarray = np.ndarray
_empty = np.empty
_contiguous = np.ascontiguousarray
_LABELS = ("pinv", "damped", "adaptive", "selective")  # by damping mode, as rate_step
_new_info = tuple.__new__
_PENDING = object()  # a kernel not loaded yet


class FrameCommand(NamedTuple):
    """A frame task evaluated for a solver (:meth:`ClikController.command`).

    Attributes:
        jacobian: the task rows of the world-aligned Jacobian, ``(m, n)``.
        command: ``ẋ_d + K e`` on those rows, ``(m,)`` (m/s, rad/s).
        error: the six-row error ``[p_d − p; log(R_d Rᵀ)]`` (m, rad).
        pose: the frame's pose, 4x4.
    """

    jacobian: FloatArray
    command: FloatArray
    error: FloatArray
    pose: FloatArray


class ClikController:
    """Closed-loop inverse kinematics of one frame, compiled into a single kernel call.

    Args:
        robot: the robot.
        frame: task frame (``None``: the robot's tip).
        rows: task rows of ``[x, y, z, rx, ry, rz]``, indices or names (default: all six).
        gain: CLIK gain ``K`` in 1/s, a scalar or one value per task row (≥ 0).
        objectives: diagonal quadratic costs, each optionally with a weight:
            ``[JointLimitObjective(), (PostureObjective(q_ref), 0.1)]``.
        k_null: gain ``k`` of the null-space term ``−k N ∇D`` (≥ 0).
        inverse: ``"exact"``, ``"svd"``, ``"damped"``, ``"adaptive"`` or an
            :class:`~redres.resolution.InverseChoice`; its parameters (``damping``,
            ``max_damping``, ``threshold``, ``rcond``) as keywords, as for the schemes.
        dt: control period in s (> 0).
        limit_velocity: scale each command uniformly down to the joint velocity limits
            (schemes that enforce hard limits already keep them).
        scheme: resolve the task with this scheme instead (then ``objectives``,
            ``k_null`` and ``inverse`` belong to the scheme; a hard-limit scheme must have
            the same ``dt``).

    Use :meth:`set_target` (pose and twist, e.g. from a trajectory sample), then
    ``q = controller.step(q)`` each period. After a step, :attr:`qd` (after velocity
    scaling), :attr:`error`, :attr:`info` and :attr:`speed_ratio` describe it. Until a
    target is set, the target is the pose at the first step (hold still). The settings are
    fixed at construction (read-only attributes), and so is the choice between the compiled
    kernels and the NumPy path.

    At an orientation error of exactly 180° both rotation axes are valid logarithms; the
    kernel and Pinocchio's ``log3`` (used by :class:`~redres.tasks.FrameTask`) may pick
    opposite ones, and the two paths then part ways. Anywhere else they agree to rounding.

    Raises:
        InvalidParameterError: a bad gain, period, inverse, a cost without a quadratic
            form, or objectives given next to a scheme.
    """

    def __init__(
        self,
        robot: Robot,
        frame: str | None = None,
        rows: Sequence[int] | Sequence[str] | None = None,
        *,
        gain: float | Sequence[float] | FloatArray = 50.0,
        objectives: Sequence[WeightedObjective] = (),
        k_null: float = 1.0,
        inverse: InverseChoice | str = "exact",
        dt: float = 1e-3,
        limit_velocity: bool = True,
        scheme: Scheme | None = None,
        **inverse_params: Any,
    ) -> None:
        n = robot.n
        # Settings are fixed at construction (the kernel's config vector holds them): the
        # public names below are read-only properties.
        self._robot, self._n = robot, n
        self.task = FrameTask(frame, rows)
        self.frame_id = robot.frame_id(frame)
        self.rows = np.array(self.task.rows, dtype=np.int64)
        self._dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
        self._k_null = as_scalar(k_null, "k_null", minimum=0.0)
        self._limit_velocity = bool(limit_velocity)
        self._inverse = as_inverse(inverse, **inverse_params)
        self._objectives = tuple(weighted_objectives(objectives))
        self._gain = row_gains(gain, self.task.rows)
        self._scheme = scheme
        if scheme is not None:
            given = inverse != "exact" or inverse_params or k_null != 1.0
            self._check_scheme(scheme, bool(given))
        a, b = quadratic_coefficients(robot, self._objectives)
        self._rate_kwargs = self._inverse.rate_kwargs()
        quadratic = (a, b) if self._objectives else None
        config, mode = fused_config(robot, self._gain, self._k_null, self._rate_kwargs,
                                    self._dt, self._limit_velocity, quadratic)  # fmt: skip
        self._config = config
        # Views of the target's slots in config, written in place by set_target.
        self._rotation = config[codes.CFG_ROTATION : codes.CFG_ROTATION + 9].reshape(3, 3)
        self._position = config[codes.CFG_POSITION : codes.CFG_POSITION + 3]
        self._twist = config[codes.CFG_TWIST : codes.CFG_TWIST + 6]
        self._mode = mode
        self._a, self._b = a, b
        self._has_target = False
        self._size = 2 * n + 6
        self._out: FloatArray | None = np.zeros(self._size)
        self._diag: tuple[int, float, float, float, float] = (0, 0.0, 0.0, 0.0, 0.0)
        self._front = kernel_for(robot, self.frame_id, be.fused_frame_command, "frame_command")
        # The fused step's kernel is loaded at the first fused step (rr.run, which only
        # uses command(), never compiles it); None then means the NumPy path.
        self._kernel: Any = _PENDING if scheme is None and self._front is not None else None
        self._integrate: Any = be.fused_integrate() if scheme is not None else None
        self._qd = self._e = self._out[:0]
        self._result: StepResult | None = None

    def _check_scheme(self, scheme: Scheme, inverse_given: bool) -> None:
        if not isinstance(scheme, Scheme):
            raise InvalidParameterError(f"scheme must be a redres Scheme; got {scheme!r}")
        if self.objectives or inverse_given:
            raise InvalidParameterError(
                "give the objectives, k_null and the inverse to the scheme, not to the "
                "controller, when a scheme resolves the task"
            )
        dt = getattr(scheme, "dt", None)
        if scheme.hard_limits and dt is not None and dt != self.dt:
            raise InvalidParameterError(
                f"the {scheme.name} scheme was built for dt = {dt}, the controller runs at "
                f"dt = {self.dt}: its limits hold only at its own period"
            )

    # -- settings (read-only: the compiled step holds them) ------------------------------

    @property
    def robot(self) -> Robot:
        """The robot."""
        return self._robot

    @property
    def dt(self) -> float:
        """Control period, s."""
        return self._dt

    @property
    def k_null(self) -> float:
        """Gain of the null-space term."""
        return self._k_null

    @property
    def limit_velocity(self) -> bool:
        """Whether commands are scaled down to the joint velocity limits."""
        return self._limit_velocity

    @property
    def inverse(self) -> InverseChoice:
        """The inverse of the fused step."""
        return self._inverse

    @property
    def objectives(self) -> tuple[tuple[Objective, float], ...]:
        """The weighted secondary costs of the fused step."""
        return self._objectives

    @property
    def scheme(self) -> Scheme | None:
        """The scheme resolving the task (``None``: the fused step)."""
        return self._scheme

    # -- target -------------------------------------------------------------------------

    def set_target(self, pose: Any, twist: Any = None, *, validate: bool = True) -> None:
        """Target pose (4x4, world) and feedforward twist ``[v; ω]`` (6,), m/s and rad/s.

        ``validate=False`` skips the checks (finite, homogeneous, a rotation block), for
        loops that feed trajectory samples already checked.
        """
        if validate:
            pose = as_transform(pose, "pose")
            twist = None if twist is None else as_vector(twist, "twist", 6)
        self._rotation[...] = pose[:3, :3]
        self._position[...] = pose[:3, 3]
        self._twist[...] = 0.0 if twist is None else twist
        self._has_target = True

    @property
    def twist(self) -> FloatArray:
        """The target's feedforward twist ``[v; ω]`` (a copy)."""
        return self._twist.copy()

    @property
    def target_position(self) -> FloatArray:
        """The target's position (a copy; zeros before the first target)."""
        return self._position.copy()

    @property
    def compiled(self) -> bool:
        """Whether the step runs in the compiled kernels (else through NumPy)."""
        return self._front is not None

    @property
    def target(self) -> FloatArray | None:
        """The target pose (4x4), ``None`` before the first target or step."""
        if not self._has_target:
            return None
        T = np.eye(4)
        T[:3, :3] = self._rotation
        T[:3, 3] = self._position
        return T

    # -- the step -----------------------------------------------------------------------

    def step(self, q: Any) -> FloatArray:
        """The next configuration ``q + q̇ dt``, shape ``(n,)``.

        Raises:
            ShapeError: ``q`` does not have shape ``(n,)``.
            NonFiniteError: ``q`` contains NaN or infinity.
        """
        n = self._n
        qa = self._checked(q)
        if self._scheme is not None:
            return self._scheme_step(qa)
        kernel = self._kernel
        if kernel is _PENDING:
            kernel = self._kernel = kernel_for(
                self._robot, self.frame_id, be.fused_clik_step, "clik_step"
            )
        if kernel is None:
            return self._composed_step(qa)
        J, H = self._frame(qa)
        out = _empty(self._size)
        status, rank, smin, smax, used, speed = kernel(J, H, qa, self.rows, self._config, out)
        if status:
            raise_for_status(status, n)
        self._out = out
        self._diag = (rank, smin, smax, used, speed)
        return out[:n]

    def _frame(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The frame's world-aligned Jacobian and pose at ``q`` (one Pinocchio pass); the
        pose becomes the target at the first call without one (hold still)."""
        placement, J = self._robot.placement_jacobian(q, self.frame_id)
        H = placement.homogeneous
        if not self._has_target:
            if not np.all(np.isfinite(q)):
                raise NonFiniteError("q contains NaN or infinity")
            self.set_target(H, validate=False)
        return J, H

    def command(self, q: Any) -> FrameCommand:
        """The frame task at ``q`` without resolving it: its Jacobian rows, the command
        ``ẋ_d + K e``, the six-row error and the frame's pose, from the compiled front end
        (for a solver of your own; :meth:`step` with ``scheme=`` uses the same).

        Raises:
            ShapeError, NonFiniteError: as :meth:`step`.
        """
        return self._command(self._checked(q))

    def _checked(self, q: Any) -> FloatArray:
        n = self._n
        try:
            qa = _contiguous(q, _F64)
        except (TypeError, ValueError) as exc:
            raise ShapeError(f"q must be an array of {n} numbers: {exc}") from exc
        if qa.ndim != 1 or qa.shape[0] != n:
            raise ShapeError(f"q must have shape ({n},); got {qa.shape}")
        return qa

    def _command(self, q: FloatArray) -> FrameCommand:
        """:meth:`command` for a checked ``q``: the kernel, or FrameTask without numba."""
        n, front = self._n, self._front
        if front is None:
            return self._task_command(q)
        J, H = self._frame(q)
        m = self.rows.shape[0]
        Jm, xd, e = _empty((m, n)), _empty(m), _empty(6)
        status = front(J, H, q, self.rows, self._config, Jm, xd, e)
        if status:
            raise_for_status(status, n)
        return FrameCommand(Jm, xd, e, H)

    def _task_command(self, q: FloatArray) -> FrameCommand:
        """:meth:`command` through :class:`~redres.tasks.FrameTask` (NumPy and Pinocchio's
        ``log3``: the path without compiled kernels)."""
        if not np.all(np.isfinite(q)):
            raise NonFiniteError("q contains NaN or infinity")
        task = self.task
        if not self._has_target:
            self.set_target(self._robot.fk(q, task.frame), validate=False)
        task.set_target(self.target, self._twist.copy(), validate=False)
        state = task.compute(self._robot, q)
        xd = state.feedforward + self._gain[task.rows] * state.error
        assert task.last_error is not None and task.last_pose is not None
        return FrameCommand(state.jacobian, xd, task.last_error, task.last_pose.homogeneous)

    def _scheme_step(self, q: FloatArray) -> FloatArray:
        """Task command by the kernel (or FrameTask), joint velocity by the scheme."""
        robot, scheme, n = self._robot, self._scheme, self._n
        assert scheme is not None
        Jm, xd, e, _ = self._command(q)
        if self._front is None:
            result = scheme.step(robot, q, Jm, xd)
        else:  # the kernel's own arrays: no re-check
            result = scheme._step(robot, q, Jm, xd)
        self._result = result
        qd = result.qd
        if type(qd) is not _ndarray or qd.dtype != _F64 or not qd.flags.c_contiguous:
            qd = np.ascontiguousarray(qd, dtype=_F64)
        if qd.shape != (n,):
            raise ShapeError(
                f"the {scheme.name} scheme returned a joint velocity of shape {qd.shape}; "
                f"expected ({n},)"
            )
        speed = 0.0
        if self._limit_velocity and not scheme.hard_limits:
            speed = float(np.max(np.abs(qd) / robot.qd_max))
            if speed > 1.0:
                qd = qd / speed
        self._out, self._qd, self._e = None, qd, e
        self._diag = (0, 0.0, 0.0, 0.0, speed)
        integrate = self._integrate
        if integrate is None:
            return q + qd * self._dt
        q_next = _empty(n)
        integrate(q, qd, self._dt, q_next)
        return q_next

    def _composed_step(self, q: FloatArray) -> FloatArray:
        """The same step through FrameTask and rate_step (no compiled kernels)."""
        n = self._n
        J, xd, error, _ = self._task_command(q)
        grad = self._a * q - self._b if self._objectives else None
        qd, info, _ = rate_step(J, xd, grad, k_null=self._k_null, **self._rate_kwargs)
        speed = float(np.max(np.abs(qd) / self._robot.qd_max)) if self._limit_velocity else 0.0
        if speed > 1.0:
            qd = qd / speed
        out = np.empty(self._size)
        out[:n] = q + qd * self._dt
        out[n : 2 * n] = qd
        out[2 * n :] = error
        self._out = out
        self._diag = (info.rank, info.sigma_min, info.sigma_max, info.damping, speed)
        return out[:n]

    # -- what the last step did -----------------------------------------------------------

    @property
    def qd(self) -> FloatArray:
        """Joint velocity of the last step (after velocity scaling), rad/s."""
        if self._out is None:
            return self._qd
        n = self.robot.n
        return self._out[n : 2 * n]

    @property
    def error(self) -> FloatArray:
        """Six-row pose error ``[p_d − p; log(R_d Rᵀ)]`` at the last step (m, rad)."""
        if self._out is None:
            return self._e
        return self._out[2 * self.robot.n :]

    @property
    def speed_ratio(self) -> float:
        """``maxⱼ |q̇ⱼ| / q̇_max,j`` of the last step before scaling (0 if limits are off
        or a hard-limit scheme kept them)."""
        return self._diag[4]

    @property
    def scaled(self) -> bool:
        """Whether the last command was scaled down to the velocity limits."""
        return self._diag[4] > 1.0

    @property
    def info(self) -> InverseInfo:
        """Diagnostics of the inverse at the last step (rank, σ_min, σ_max, damping)."""
        if self.scheme is not None:
            return self.last_result().info
        rank, smin, smax, used, _ = self._diag
        full = rank == min(len(self.rows), self.robot.n)
        return _new_info(InverseInfo, (rank, full, smin, smax, used, _LABELS[self._mode]))

    def last_result(self) -> StepResult:
        """The scheme's full :class:`~redres.resolution.StepResult` of the last step (only
        with ``scheme=``; the fused step has :attr:`qd` and :attr:`info`)."""
        result = self._result
        if result is None:
            raise InvalidParameterError(
                "last_result() needs a controller built with scheme=, after a step"
            )
        return result

    def __repr__(self) -> str:
        return (
            f"ClikController(robot={self.robot.name!r}, frame={self.task.frame!r}, "
            f"rows={self.task.rows}, inverse={self.inverse.kind!r}, "
            f"objectives={[obj.name for obj, _ in self.objectives]})"
        )
