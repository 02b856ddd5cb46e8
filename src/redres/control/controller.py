"""The controller: closed-loop inverse kinematics (CLIK), one step per control period.

A task gives its error ``e`` (m, rad) and Jacobian ``J`` (``m x n``) at ``q``; driving
``e`` to zero at the rate ``ė = −K e`` (``K`` the gain, 1/s) asks for the task velocity

    ẋ = ẋ_d + K e                                   (ė ≈ ẋ_d − J q̇ for ẋ = J q̇)

and the redundancy-resolution scheme turns it into a joint velocity, e.g. for gradient
projection (Liégeois 1977; Siciliano et al., *Robotics*, 2009, §3.5.1)

    q̇ = J# ẋ − k (I − J# J) Σ wᵢ ∇Dᵢ(q).

If a joint would exceed its velocity limit, the whole ``q̇`` is divided by one factor,
which keeps its direction (and so the task direction)::

    q̇ ← q̇ / max(1, maxⱼ |q̇ⱼ| / q̇_max,j)          (not for hard-limit schemes: theirs hold)
    q ← q + q̇ dt                                   (explicit Euler, Δq = q̇ Δt)

When the scheme tracks exactly, ``e`` decays as ``(1 − K dt)^k`` per step, ``exp(−K t)``
in the limit; ``K dt`` must stay well below 2 for the discrete loop to be stable. For a
frame task ``e = [p_d − p; log(R_d Rᵀ)]``, world-aligned (docs/conventions.md; Siciliano
et al., *Robotics*, 2009, §3.7.3).

:meth:`Controller.step` is the only body of this loop in the library: :func:`redres.run`
drives a controller along a trajectory and records it. It takes one of three paths,
chosen at construction (:attr:`Controller.path`), all computing the same step:

* ``"fused"``: a plain frame task with a :class:`~redres.resolution.PseudoInverseScheme`
  or a :class:`~redres.resolution.GradientProjectionScheme` whose costs are diagonal
  quadratics (joint-limit mid-range, posture): one compiled kernel per step (the frame's
  placement and Jacobian, pose error, inverse, null-space term, scaling, integration);
* ``"frame"``: a plain frame task with any other scheme: the kernel's front end gives the
  task rows of ``J`` and ``ẋ``, the scheme's ``_step`` resolves them;
* ``"composed"``: any other task (or no compiled kernels): ``task.compute`` and the
  scheme's ``step``.

On the first two the kernel computes the frame's placement and Jacobian itself from the
robot's serial chain (:meth:`redres.Robot.chain`, equal to Pinocchio's to rounding) when
the robot is one up to the frame (:attr:`Controller.kinematics` ``"chain"``), else one
Pinocchio call gives them to it (``"pinocchio"``: a tree, a joint the chain kernels do
not take).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np

from .._validate import FloatArray, as_gains, as_scalar, checked_keywords, real_array
from ..errors import InvalidParameterError, NonFiniteError, ShapeError, SimulationError
from ..linalg import InverseInfo
from ..linalg import _backend as be
from ..linalg._codes import CFG_MODE, FIXED, LAZY
from ..resolution import Scheme, StepResult
from ..tasks import FrameTask, Task
from ._box_path import BoxStep, box_step
from ._fused import (
    ENTRIES,
    TARGET,
    Path,
    adopt_target,
    block_size,
    choose_path,
    fused_config,
    fused_info,
    kernel_for,
    native,
    raise_for_status,
    ready,
    serial_chain,
)
from .shaping import CommandShaper, as_shaper

if TYPE_CHECKING:
    from ..robot import Robot
    from ..robot.chain import SerialChain


_F64 = np.float64
_F64_TYPE = np.dtype(np.float64)  # the native float64 dtype: `is` tells it in one step
_UNIT_STRIDE = (8,)  # the strides of a one-dimensional C-contiguous float64 array
_ndarray = np.ndarray
_empty = np.empty
_contiguous = np.ascontiguousarray
_abs, _max = np.abs, np.max


class Controller:
    """Closed-loop inverse kinematics: a task, a scheme, a gain and a period.

    Args:
        robot: the robot.
        task: the primary task (any :class:`~redres.tasks.Task`). A
            :class:`~redres.tasks.FrameTask` takes its target from ``task.set_target(pose,
            twist)`` (e.g. a trajectory sample each period); until one is set, the pose at
            the first step (hold still). Other tasks compute their own error.
        scheme: the redundancy-resolution scheme (any :class:`~redres.resolution.Scheme`).
        gain: CLIK gain ``K`` in 1/s (≥ 0), a scalar or one value per task row.
        dt: control period in s (> 0); a scheme that plans over a period
            (``scheme.dt``, the hard-limit schemes) must have this one.
        limit_velocity: scale each command uniformly down to the joint velocity limits
            (never for ``scheme.hard_limits``: those schemes keep every limit already).
        shaping: end each step in command shaping (:mod:`redres.control.shaping`): the
            applied velocity keeps the robot's ``qd_max``, ``qdd_max`` and ``qddd_max`` as
            a robot checks them, from the first cycle. ``True``: a
            :class:`~redres.control.shaping.CommandShaper` of the robot's limits at
            rest; or a shaper of your own (:attr:`shaper`; ``shaper.reset(qd, qdd)`` with
            the measured state before the first step).

    ``q = controller.step(q)`` each period; then :attr:`qd`, :attr:`error`, :attr:`info`,
    :attr:`speed_ratio`, :attr:`scaled`, :attr:`pose` and :attr:`result` report the step.

    The path (:attr:`path`) and the scheme's settings are read once, at construction.
    On the compiled paths the controller keeps a frame task's target in its kernel's
    settings (``task.set_target`` writes there), and the task's ``last_pose`` and
    ``last_error`` are not updated: read :attr:`pose` and :attr:`error`. At an orientation
    error of exactly 180° both rotation axes are valid logarithms; the kernel and the
    composed path (:func:`redres.robot.chain.log3`, the same formula on a product rounded
    differently) may pick opposite ones. Anywhere else the paths agree to rounding.

    Raises:
        InvalidParameterError: a bad gain or period, a task or scheme of the wrong type,
            or a scheme planned for another period.
        UnknownParameterError: a misspelt keyword.
    """

    @checked_keywords
    def __init__(
        self,
        robot: Robot,
        task: Task,
        scheme: Scheme,
        *,
        gain: float | Any = 50.0,
        dt: float = 1e-3,
        limit_velocity: bool = True,
        shaping: bool | CommandShaper = False,
    ) -> None:
        """A CLIK step of ``task`` on ``robot`` resolved by ``scheme``, gain in 1/s, period in s."""
        if not isinstance(task, Task):
            raise InvalidParameterError(f"task must be a redres Task; got {task!r}")
        if not isinstance(scheme, Scheme):
            raise InvalidParameterError(f"scheme must be a redres Scheme; got {scheme!r}")
        self._dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
        if scheme.dt is not None and scheme.dt != self._dt:
            raise InvalidParameterError(
                f"the {scheme.name} scheme plans over dt = {scheme.dt} s but the controller "
                f"runs at dt = {self._dt} s: its limits hold only at its own period; build "
                f"both with the same dt"
            )
        self._robot, self._task, self._scheme, self._n = robot, task, scheme, robot.n
        self._hard = scheme.hard_limits
        self._limit = bool(limit_velocity)
        frame = task if isinstance(task, FrameTask) else None
        rows = frame.rows if frame is not None else list(range(task.dim))
        self._gain = as_gains(gain, "gain", len(rows))
        path, fused = choose_path(robot, task, scheme)
        self._path: Path = path
        self._fid = robot.frame_id(frame.frame) if frame is not None else -1
        self._rows = np.array(rows, dtype=np.int64)
        self._size = block_size(self._n)
        self._shape = (self._n,)
        self._kernel: Any = None
        self._front: Any = None
        self._integrate: Any = None
        self._chain: SerialChain | None = None  # the frame's, when the robot is one up to it
        self._box: BoxStep | bool = False  # the hard-limit one-call step (True: compiling)
        self._config = self._block = _empty(0)
        if path != "composed":
            assert frame is not None
            self._chain = serial_chain(robot, frame.frame)
            self._config = fused_config(
                robot, self._rows, self._gain, self._dt, self._limit, fused, self._chain
            )
            self._block = self._config[TARGET]  # the task's target, from the first step on
        self._pending = False
        self._entry = ""  # the kernel whose readiness the compiled path waits for
        self._bind()
        # What the last step did. The fused kernel writes its output block into the spare
        # of two, which becomes the last step's once the step succeeded: the block of a
        # step that raised is never reported, and no step allocates one.
        self._out: FloatArray = np.full(self._size, np.nan)  # the last step's block
        self._spare: FloatArray = _empty(self._size)
        self._qd: FloatArray = self._out[:0]
        self._error: FloatArray = self._out[:0]
        self._pose: Any = None
        self._result: StepResult | Callable[[], StepResult] | None = None
        self._speed: float | None = 0.0
        self._scaled = False
        self._shaper = as_shaper(shaping, robot, self._dt)
        self._shaped: FloatArray = self._out[:0]
        if self._shaper is None:  # no shaping: `step` is the step itself (no extra call)
            self.step = self._step  # type: ignore[method-assign]

    # -- settings (fixed at construction) ---------------------------------------------

    @property
    def robot(self) -> Robot:
        """The robot."""
        return self._robot

    @property
    def task(self) -> Task:
        """The primary task."""
        return self._task

    @property
    def scheme(self) -> Scheme:
        """The redundancy-resolution scheme."""
        return self._scheme

    @property
    def gain(self) -> float | FloatArray:
        """CLIK gain ``K``, 1/s: a float, or one value per task row (a copy)."""
        return self._gain if isinstance(self._gain, float) else self._gain.copy()

    @property
    def dt(self) -> float:
        """Control period, s."""
        return self._dt

    @property
    def shaper(self) -> CommandShaper | None:
        """The command shaper each step ends in (``shaping``), or None."""
        return self._shaper

    @property
    def limit_velocity(self) -> bool:
        """Whether commands are scaled down to the joint velocity limits (never for a
        hard-limit scheme)."""
        return self._limit and not self._hard

    @property
    def path(self) -> Path:
        """``"fused"``, ``"frame"`` or ``"composed"`` (see the module documentation)."""
        return self._path

    @property
    def kinematics(self) -> str:
        """Where the compiled paths get the frame's placement and Jacobian: ``"chain"``
        (the robot's serial chain, inside the kernel), ``"pinocchio"`` (one Pinocchio
        call per step), or ``"task"`` on the composed path (``task.compute``)."""
        if self._path == "composed":
            return "task"
        return "pinocchio" if self._chain is None else "chain"

    @property
    def compiled(self) -> bool:
        """Whether the step runs compiled code now: False while the kernels of a cold cache
        compile behind and the step takes their reference path (docs/architecture.md)."""
        if self._path == "composed":
            return be.kernels() is not None
        return not self._pending

    def _bind(self) -> None:
        """The path's kernels: compiled, or their plain-Python twins while they compile
        behind (then bound again, compiled, at the first step after they are ready)."""
        front, step = ENTRIES[self._chain is not None]  # the kernels' two forms
        if self._path == "fused":
            self._kernel = kernel_for(self._robot, self._fid, step)
        elif self._path == "frame":
            self._front = kernel_for(self._robot, self._fid, front)
            self._integrate = native("integrate")
            self._box = box_step(self._robot, self._scheme, self._config)
        self._entry = step if self._path == "fused" else front
        self._pending = self._path != "composed" and (not ready(self._entry) or self._box is True)

    def _stepped(self) -> bool:
        """Whether the fused path has made a step: the damping slot of its block, NaN
        until then, holds the damping (finite, ≥ 0) of every step that succeeded."""
        return not math.isnan(self._out[self._n + 3])

    # -- the step -----------------------------------------------------------------------

    def step(self, q: Any) -> FloatArray:
        """The next configuration ``q + q̇ dt``, shape ``(n,)``, rad (``q̇`` shaped, with
        :attr:`shaper`).

        Args:
            q: joint positions, shape ``(n,)``, rad.

        Raises:
            ShapeError: ``q`` does not have shape ``(n,)``.
            NonFiniteError: ``q`` contains NaN or infinity.
            SimulationError: the scheme returned a non-finite joint velocity.
        """
        self._step(q)  # (without a shaper, ``step`` is ``_step``: see __init__)
        self._shaped = qd = self._shaper(self.qd_wanted)  # type: ignore[misc]
        return np.asarray(q, dtype=_F64) + qd * self._dt  # q: checked by _step

    def _step(self, q: Any) -> FloatArray:
        n = self._n
        if type(q) is _ndarray and q.dtype is _F64_TYPE and q.strides == _UNIT_STRIDE:
            qa = q  # a one-dimensional C-contiguous float64 array: its length is checked
            # where it matters, by the kernels (status Q_SHAPE) and before Pinocchio
        else:  # complex q is refused by name (real_array), never made real
            qa = _contiguous(real_array(q, "q", f"an array of {n}"))
            if qa.shape != self._shape:
                raise ShapeError(f"q must have shape ({n},); got {qa.shape}")
        if self._pending and ready(self._entry):
            self._bind()
        kernel = self._kernel
        if kernel is None:
            return self._resolved_step(qa)
        if self._task._target is not self._block:  # type: ignore[attr-defined]
            adopt_target(self._task, self._block, qa, self._robot, self._fid, self._chain)
        q_next, out = _empty(n), self._spare
        if self._chain is None:
            if qa.shape != self._shape:
                raise ShapeError(f"q must have shape ({n},); got {qa.shape}")
            placement, J = self._robot.placement_jacobian(qa, self._fid)
            status = kernel(J, placement.homogeneous, qa, self._config, q_next, out)
        else:
            status = kernel(self._config, qa, q_next, out)
        if status:
            if qa.shape != self._shape:
                raise ShapeError(f"q must have shape ({n},); got {qa.shape}")
            raise_for_status(status, n)
        self._spare, self._out = self._out, out
        return q_next

    def _resolved_step(self, q: FloatArray) -> FloatArray:
        """The ``"frame"`` and ``"composed"`` paths: task rows, the scheme, then scaling."""
        robot, scheme, n = self._robot, self._scheme, self._n
        front = self._front
        if front is not None:
            if self._task._target is not self._block:  # type: ignore[attr-defined]
                adopt_target(self._task, self._block, q, self._robot, self._fid, self._chain)
            box, m = self._box, self._rows.shape[0]
            if box:  # front end, scheme and integration in one compiled call
                q_next, self._result, self._qd, self._error, self._pose = box(q)  # type: ignore[operator]
                self._speed, self._scaled = None, False
                return q_next
            Jm, xd = _empty((m, n)), _empty(m)
            if self._chain is None:
                placement, J = robot.placement_jacobian(q, self._fid)
                e, H = _empty(6), placement.homogeneous
                status = front(J, H, q, self._config, Jm, xd, e)
            else:
                block = _empty(6 * n + 22)  # [e | H | J], the fused block's tail
                status = front(self._config, q, block, Jm, xd)
                e, H = block[:6], block[6:22].reshape(4, 4)
            if status:
                raise_for_status(status, n)
            self._error, self._pose = e, H
            result = scheme._step(robot, q, Jm, xd)  # the kernel's own arrays
        else:
            result = scheme.step(robot, q, *self._compose(q))
        self._result = result
        qd = result.qd
        if type(qd) is not _ndarray or qd.dtype != _F64 or not qd.flags.c_contiguous:
            qd = _contiguous(qd, _F64)
        if qd.shape != (n,):
            raise ShapeError(
                f"the {scheme.name} scheme returned a joint velocity of shape {qd.shape}; "
                f"expected ({n},)"
            )
        speed: float | None = None  # read on demand where nothing is scaled
        scaled = False
        if self._limit and not self._hard:
            speed = float(_max(_abs(qd) / robot.qd_max))
            if not speed < math.inf:  # NaN and inf both fail
                self._non_finite(qd)
            if speed > 1.0:
                qd, scaled = qd / speed, True
        self._qd, self._speed, self._scaled = qd, speed, scaled
        integrate = self._integrate
        if integrate is None:
            q_next = q + qd * self._dt
            if speed is None and not math.isfinite(q_next @ q_next):
                self._non_finite(qd)  # (or astronomically large: as bad)
            return q_next
        q_next = _empty(n)
        if not integrate(q, qd, self._dt, q_next) and speed is None:
            self._non_finite(qd)
        return q_next

    def _eager_info(self) -> None:
        """Have the kernel report the singular values at every step, as :attr:`info` is
        then read every step (``rr.run`` logs them); by default a fixed-damping fused
        step skips them and :attr:`info` computes them when asked."""
        if self._config.shape[0] and self._config[CFG_MODE] == LAZY:
            self._config[CFG_MODE] = FIXED

    def _non_finite(self, qd: FloatArray) -> NoReturn:
        raise SimulationError(
            f"the {self._scheme.name} scheme returned a non-finite joint velocity {qd}"
        )

    def _compose(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """``(J, ẋ_d + K e)`` from ``task.compute``; keeps the error and pose to report."""
        if not math.isfinite(q @ q):  # one reduction: NaN or inf anywhere shows
            raise NonFiniteError("q contains NaN or infinity")
        task = self._task
        state = task.compute(self._robot, q)
        self._error, self._pose = state.error, None
        if isinstance(task, FrameTask) and task.last_error is not None:
            self._error, self._pose = task.last_error, task.last_pose
        return state.jacobian, state.feedforward + self._gain * state.error

    # -- what the last step did ---------------------------------------------------------

    @property
    def qd(self) -> FloatArray:
        """Joint velocity applied at the last step (after velocity scaling and shaping),
        ``(n,)``, rad/s."""
        if self._shaper is not None:
            return self._shaped.copy()
        return self.qd_wanted

    @property
    def qd_wanted(self) -> FloatArray:
        """The joint velocity of the last step before shaping (:attr:`qd` without a
        :attr:`shaper`), ``(n,)``, rad/s."""
        if self._kernel is None:
            return self._qd
        return self._out[: self._n].copy() if self._stepped() else self._out[:0]

    @property
    def error(self) -> FloatArray:
        """Task error at the last step: for a frame task the six rows
        ``[p_d − p; log(R_d Rᵀ)]`` whatever rows it controls (m, rad), else the task's
        error ``(m,)``."""
        if self._kernel is None:
            return self._error
        k = self._n + 5
        return self._out[k : k + 6].copy() if self._stepped() else self._out[:0]

    @property
    def pose(self) -> FloatArray | None:
        """The frame task's frame pose at the last step (4x4, world), else None."""
        if self._kernel is not None:
            if not self._stepped():
                return None
            k = self._n + 11
            return self._out[k : k + 16].reshape(4, 4).copy()
        pose = self._pose
        if pose is None or isinstance(pose, _ndarray):
            return pose
        return pose.homogeneous  # type: ignore[no-any-return]

    @property
    def speed_ratio(self) -> float:
        """``maxⱼ |q̇ⱼ| / q̇_max,j`` of the scheme's joint velocity at the last step, before
        any scaling (> 1: it was scaled down, if :attr:`limit_velocity`)."""
        if self._kernel is None:
            if self._speed is None:  # nothing was scaled: the applied velocity's ratio
                self._speed = float(_max(_abs(self._qd) / self._robot.qd_max))
            return self._speed
        if not self._stepped():
            return 0.0
        if self._limit:
            return float(self._out[self._n + 4])
        return float(_max(_abs(self.qd_wanted) / self._robot.qd_max))

    @property
    def scaled(self) -> bool:
        """Whether the last command was scaled down to the velocity limits."""
        if self._kernel is None:
            return self._scaled
        return self._stepped() and bool(self._out[self._n + 4] > 1.0)

    @property
    def info(self) -> InverseInfo:
        """Diagnostics of the inverse at the last step (rank, σ_min, σ_max, damping)."""
        result = self.result
        if self._kernel is None:
            if result is None:
                raise InvalidParameterError("the controller has not made a step yet")
            return result.info
        if not self._stepped():
            raise InvalidParameterError("the controller has not made a step yet")
        return fused_info(self._out, self._n, self._rows, self._config)

    @property
    def result(self) -> StepResult | None:
        """The scheme's :class:`~redres.resolution.StepResult` of the last step (its
        ``qd`` before scaling); None before a step and on the ``"fused"`` path, whose
        schemes report nothing more than the attributes above (no bounds, no algorithmic
        singularity)."""
        result = self._result
        if callable(result):  # the one-call hard-limit step builds it when read
            result = self._result = result()
        return result

    def __repr__(self) -> str:
        return (
            f"Controller(robot={self._robot.name!r}, task={self._task.name!r}, "
            f"scheme={self._scheme.name!r}, path={self._path!r}, dt={self._dt})"
        )
