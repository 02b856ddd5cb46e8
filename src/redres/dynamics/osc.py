"""Operational-space torque control with a null-space torque (Khatib 1987).

The law, with ``M`` the joint-space inertia, ``b = C(q, q̇) q̇ + g(q)`` the bias torques,
``J`` the task Jacobian (world-aligned rows of the task frame), ``Λ = (J M⁻¹ Jᵀ)⁻¹`` and
``J̄ = M⁻¹ Jᵀ Λ`` the dynamically consistent inverse::

    ẍ*  = ẍ_d + K_d (ẋ_d − J q̇) + K_p e                    task servo (1/s², 1/s)
    τ   = Jᵀ Λ (ẍ* − J̇ q̇)  +  b  +  (I − Jᵀ J#ᵀ) τ₀         J# = J̄  ("dynamic")
                                                          J# = J⁺  ("kinematic")
    τ₀  = M (−k_p,0 ∇D(q) − k_d,0 q̇)  [+ any user torque]

Why this form:

* **Full bias in joint space** (``compensation="joint"``). Khatib writes the task force
  as ``F = Λ ẍ* + μ + p`` with ``μ + p = J̄ᵀ b − Λ J̇ q̇``, i.e. ``τ = Jᵀ F = Jᵀ Λ (ẍ* −
  J̇ q̇) + Jᵀ J̄ᵀ b`` (``compensation="task"``). Both give the same task acceleration, but
  the task form leaves ``(I − Jᵀ J̄ᵀ) b`` uncompensated: gravity and Coriolis torques then
  act on the self-motion and the posture sags. Adding ``b`` whole costs the same (one
  RNEA) and makes the closed loop ``M q̈ = Jᵀ Λ (ẍ* − J̇ q̇) + (I − Jᵀ J̄ᵀ) τ₀``, whence
  ``ẍ = J q̈ + J̇ q̇ = ẍ*`` exactly: every task row obeys ``ë + K_d ė + K_p e = 0``. The
  controller's ``b`` includes the viscous joint damping ``d ∘ q̇`` its model's file gives
  (:attr:`redres.Robot.joint_damping`), which the plant dissipates otherwise.
* **``Jᵀ Λ = M J̄``** (from ``J̄ = M⁻¹ Jᵀ Λ``), so the task torque needs only ``J̄`` — one
  factorisation per step, no separate ``Λ``.
* **Null-space torque from an acceleration**: ``τ₀ = M q̈₀`` gives, with the dynamic
  projector, the joint acceleration ``M⁻¹ (I − Jᵀ J̄ᵀ) M q̈₀ = (I − J̄ J) q̈₀``: the posture
  PD acts with gains in 1/s² and 1/s whatever the link inertias, and its motion is the
  projection of ``q̈₀`` onto the null space of ``J``.
* **Dynamic consistency**: ``J M⁻¹ (I − Jᵀ J̄ᵀ) = J M⁻¹ − Λ⁻¹ Λ J M⁻¹ = 0`` (Khatib
  1987), so ``τ₀`` never accelerates the task. With the kinematic ``J⁺`` the same
  product is ``J M⁻¹ − J M⁻¹ Jᵀ J⁺ᵀ ≠ 0`` in general: the null-space torque disturbs the
  task, and only the task's feedback rejects it. :func:`task_disturbance` measures it.
* With ``damping = λ > 0`` the inverse is ``J̄_λ = M⁻¹ Jᵀ (J M⁻¹ Jᵀ + λ² I)⁻¹``: bounded
  near singularities, but consistency is then only approximate:
  ``J M⁻¹ (I − Jᵀ J̄_λᵀ) = λ² (J M⁻¹ Jᵀ + λ² I)⁻¹ J M⁻¹``.

References:
    O. Khatib, "A unified approach for motion and force control of robot manipulators:
    the operational space formulation", IEEE J. Robotics and Automation 3(1), 1987.
    O. Khatib, "Inertial properties in robotic manipulation: an object-level framework",
    Int. J. Robotics Research 14(1), 1995.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Literal, NamedTuple, TypeVar, get_args

import numpy as np
from numpy.typing import ArrayLike

from .._validate import FloatArray, as_matrix, as_vector
from ..errors import InvalidParameterError, NotPositiveDefiniteError
from ..linalg import RCOND, AdaptiveDamping, InverseInfo, generalized_inverse
from ..linalg._backend import parse_damping
from ..linalg._engine import method_label
from ..linalg._status import raise_status
from ..linalg.dynamics import mass_matrix_factor
from ..objectives import PostureObjective, quadratic_coefficients
from ..tasks import FrameTask
from ._codes import OUT_EXTRA, OUT_STATS
from ._servo import ServoLaw, ServoSettings, ServoState
from .base import ControlStep
from .chain import KERNELS as CHAIN_KERNELS
from .chain import ChainDynamics, KernelControlStep, chain_dynamics
from .consistent import consistent_torques

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from .._toml import ScenarioParams
    from ..control import Sample
    from ..robot import Robot

Projector = Literal["dynamic", "kinematic"]
Compensation = Literal["joint", "task"]
_PROJECTORS: tuple[str, ...] = get_args(Projector)
_COMPENSATIONS: tuple[str, ...] = get_args(Compensation)
_S = TypeVar("_S", bound=str)
_F64 = np.dtype(np.float64)


def check_choice(value: _S, name: str, choices: tuple[str, ...]) -> _S:
    """``value`` if it is one of ``choices``, else an error listing them."""
    if value not in choices:
        raise InvalidParameterError(f"{name} must be one of {', '.join(choices)}; got {value!r}")
    return value


def dynamic_inverse(
    J: FloatArray, M: ArrayLike, damping: float | AdaptiveDamping, rcond: float
) -> tuple[FloatArray, InverseInfo]:
    """``J̄ = M⁻¹ Jᵀ (J M⁻¹ Jᵀ + λ² I)⁻¹`` and its info, errors naming ``M``.

    This is :func:`redres.linalg.weighted_pinv` with ``W = M`` (Khatib 1987: the
    dynamically consistent inverse is the inertia-weighted one), the compiled path of
    :func:`redres.linalg.dynamically_consistent_pinv`; tests check the two agree.
    """
    try:
        return generalized_inverse(J, weights=M, damping=damping, rcond=rcond, return_info=True)
    except NotPositiveDefiniteError as exc:
        raise NotPositiveDefiniteError(
            f"M must be a symmetric positive definite mass matrix ({exc})"
        ) from exc


class OperationalSpaceTorque(NamedTuple):
    """The parts of one operational-space torque, each shape ``(n,)``, N·m.

    Attributes:
        tau: total ``task + compensation + null``.
        task: ``Jᵀ Λ (ẍ* − J̇ q̇)``.
        compensation: ``b`` (joint) or ``Jᵀ J̄ᵀ b`` (task).
        null: ``(I − Jᵀ J#ᵀ) τ₀``.
        info: diagnostics of ``J̄`` (singular values of ``J M^{-1/2}``).
    """

    tau: FloatArray
    task: FloatArray
    compensation: FloatArray
    null: FloatArray
    info: InverseInfo


def operational_space_torque(
    J: ArrayLike,
    M: ArrayLike,
    bias: ArrayLike,
    command: ArrayLike,
    tau0: ArrayLike | None = None,
    *,
    projector: Projector = "dynamic",
    compensation: Compensation = "joint",
    damping: float | AdaptiveDamping = 0.0,
    rcond: float = RCOND,
) -> OperationalSpaceTorque:
    """One operational-space torque on bare arrays (module docstring; Khatib 1987).

    ``τ = M J̄ a + b + (I − Jᵀ J#ᵀ) τ₀`` with ``a = ẍ* − J̇ q̇`` (``M J̄ = Jᵀ Λ``).

    Args:
        J: task Jacobian, shape ``(m, n)``.
        M: joint-space inertia, symmetric positive definite, ``(n, n)``, kg·m².
        bias: ``C q̇ + g``, ``(n,)``, N·m.
        command: ``ẍ* − J̇ q̇``, ``(m,)``, m/s² and rad/s².
        tau0: null-space torque before projection, ``(n,)``, N·m (``None``: none).
        projector: ``"dynamic"`` (``J# = J̄``, consistent) or ``"kinematic"`` (``J# = J⁺``).
        compensation: ``"joint"`` (add ``b``) or ``"task"`` (add ``Jᵀ J̄ᵀ b``, Khatib's
            ``Jᵀ (μ + p)``).
        damping: ``λ ≥ 0`` or :class:`~redres.linalg.AdaptiveDamping`, used by both
            inverses.
        rcond: relative rank tolerance when undamped.

    Raises:
        ShapeError, NonFiniteError: wrong shapes or NaN/inf input (named).
        NotPositiveDefiniteError: ``M`` is not symmetric positive definite.
        InvalidParameterError: unknown ``projector`` or ``compensation``.
    """
    check_choice(projector, "projector", _PROJECTORS)
    check_choice(compensation, "compensation", _COMPENSATIONS)
    Jm = as_matrix(J, "J")
    m, n = Jm.shape
    Mm = as_matrix(M, "M", (n, n))
    b = as_vector(bias, "bias", n)
    a = as_vector(command, "command", m)
    t0 = None if tau0 is None else as_vector(tau0, "tau0", n)
    return _torque(Jm, Mm, b, a, t0, projector, compensation, damping, rcond)


def _torque(
    J: FloatArray,
    M: FloatArray,
    b: FloatArray,
    a: FloatArray,
    tau0: FloatArray | None,
    projector: str,
    compensation: str,
    damping: float | AdaptiveDamping,
    rcond: float,
) -> OperationalSpaceTorque:
    """:func:`operational_space_torque` on validated arrays (the controller's hot path)."""
    J_bar, info = dynamic_inverse(J, M, damping, rcond)
    # The same inverse in every direction: both torques by QR, accurate to κ(J M^{-1/2}) ε
    # rather than its square (redres.dynamics.consistent); a truncated or selectively
    # damped J̄ is used as it is.
    selective = isinstance(damping, AdaptiveDamping) and damping.selective
    n = M.shape[0]
    t0 = np.zeros(n) if tau0 is None else tau0
    tau_comp = b
    if selective or (info.rank < J.shape[0] and info.damping == 0.0):
        tau_task = M @ (J_bar @ a)
        proj = J.T @ (J_bar.T @ t0)
        if compensation != "joint":
            tau_comp = J.T @ (J_bar.T @ b)
    else:
        tau_task, proj = consistent_torques(J, M, info.damping, a, t0)
        if compensation != "joint":
            tau_comp = consistent_torques(J, M, info.damping, a, b)[1]
    if tau0 is None:
        tau_null = np.zeros(n)
    elif projector == "dynamic":
        tau_null = tau0 - proj
    else:
        J_hash = generalized_inverse(J, damping=damping, rcond=rcond)
        tau_null = tau0 - J.T @ (J_hash.T @ tau0)
    return OperationalSpaceTorque(
        tau_task + tau_comp + tau_null, tau_task, tau_comp, tau_null, info
    )


def task_disturbance(J: ArrayLike, M: ArrayLike, tau: ArrayLike) -> FloatArray:
    """Task acceleration ``J M⁻¹ τ`` that a torque ``τ`` causes on its own, ``(m,)``.

    Zero for ``τ = (I − Jᵀ J̄ᵀ) τ₀`` (dynamic consistency, Khatib 1987).

    Args:
        J: task Jacobian, ``(m, n)``.
        M: joint-space inertia, SPD, ``(n, n)``.
        tau: joint torque, ``(n,)``, N·m.
    """
    Jm = as_matrix(J, "J")
    n = Jm.shape[1]
    L = mass_matrix_factor(M, n)
    t = as_vector(tau, "tau", n)
    from scipy.linalg import cho_solve  # on first use: 0.2 s of import

    return Jm @ cho_solve((L, True), t)


class OperationalSpaceController(ServoLaw):
    """Khatib's operational-space controller with a null-space posture (module docstring).

    Args:
        task: the frame task (default: the robot's tip, all six rows); its ``rows`` select
            the controlled directions.
        kp: task stiffness ``K_p``, 1/s² (scalar or per row), ≥ 0.
        kd: task damping ``K_d``, 1/s (default ``2√K_p``: critically damped), ≥ 0.
        objectives: secondary costs for ``τ₀``, e.g. ``[PostureObjective(q_ref)]``.
        null_kp: ``k_p,0`` of ``q̈₀ = −k_p,0 ∇D − k_d,0 q̇``, 1/s², ≥ 0.
        null_kd: ``k_d,0``, 1/s, ≥ 0 (damps the self-motion).
        null_torque: optional ``f(robot, q, qd) -> (n,)`` added to ``τ₀`` (N·m), for any
            other secondary torque.
        projector: ``"dynamic"`` (``I − Jᵀ J̄ᵀ``) or ``"kinematic"`` (``I − Jᵀ J⁺ᵀ``).
        compensation: ``"joint"`` or ``"task"`` bias compensation.
        damping: ``λ`` of the inverses near singularities (0: exact), or
            :class:`~redres.linalg.AdaptiveDamping`.
        rcond: relative rank tolerance when undamped.
        name: identifier in run logs (default ``osc_<projector>``).
    """

    #: Scenario ``type`` name.
    scenario_types = ("osc",)

    def __init__(
        self,
        task: FrameTask | None = None,
        *,
        null_torque: Callable[[Robot, FloatArray, FloatArray], Any] | None = None,
        projector: Projector = "dynamic",
        compensation: Compensation = "joint",
        **settings: Unpack[ServoSettings],
    ) -> None:
        """The arguments are described in ``help(OperationalSpaceController)``."""
        if null_torque is not None and not callable(null_torque):
            raise InvalidParameterError(f"null_torque must be callable; got {null_torque!r}")
        self.null_torque = null_torque
        self.projector = check_choice(projector, "projector", _PROJECTORS)
        self.compensation = check_choice(compensation, "compensation", _COMPENSATIONS)
        self.name = f"osc_{projector}"
        super().__init__(task, **settings)
        self._compiled: tuple[Robot, _CompiledStep | None] | None = None
        self._fast: tuple[Robot, _CompiledStep] | None = None  # once it runs compiled

    @classmethod
    def from_scenario(cls, params: ScenarioParams) -> OperationalSpaceController:
        """The law of a scenario table: ``kp``, ``kd``, ``projector``, ``null_kp``,
        ``null_kd`` and ``objectives`` (default: a posture cost); identifier ``osc``."""
        kp = params.positive("kp", 400.0)
        kd = params.positive("kd", 2.0 * float(np.sqrt(kp)))
        projector = params.string("projector", "dynamic")
        if projector not in _PROJECTORS:
            raise params.fail("projector", f"use 'dynamic' or 'kinematic'; got {projector!r}")
        return cls(
            kp=kp,
            kd=kd,
            objectives=params.objectives() or [(PostureObjective(), 1.0)],
            null_kp=params.number("null_kp", 25.0),
            null_kd=params.number("null_kd", 10.0),
            projector=projector,  # type: ignore[arg-type]
            name="osc",
        )

    def null_space_torque(
        self, robot: Robot, q: FloatArray, qd: FloatArray, M: FloatArray
    ) -> FloatArray:
        """``τ₀ = M q̈₀`` (+ the user's ``null_torque``), before projection, ``(n,)``."""
        tau0 = M @ self.null_law.acceleration(robot, q, qd)
        if self.null_torque is not None:
            tau0 = tau0 + as_vector(self.null_torque(robot, q, qd), "null_torque()", robot.n)
        return tau0

    def reset(self) -> None:
        """Forget the reference, and the compiled step's copy of the settings (gains,
        damping, objectives: it reads them again at the next step)."""
        super().reset()
        self._compiled = self._fast = None

    def step(
        self, robot: Robot, q: FloatArray, qd: FloatArray, sample: Sample | None = None
    ) -> ControlStep:
        """Torques for state ``(q, q̇)`` tracking ``sample`` (``None``: hold the target).

        On a robot whose joints form one serial chain to the task frame, with the dynamic
        projector, joint-space compensation, no ``null_torque`` and quadratic objectives
        (posture, joint limits), the step is one compiled call
        (:mod:`redres.dynamics.chain`); otherwise, and while that compiles behind,
        Pinocchio's algorithms and NumPy compute the same torque. The compiled step copies
        the law's settings when it is built (first step on a robot, and after
        :meth:`reset`): change them between runs, not within one."""
        fast = self._fast
        if fast is not None and fast[0] is robot:  # the compiled step, ready
            if sample is not None:
                self.servo.update(sample)
            return fast[1].step(self, q, qd)
        if self._compiled is None or self._compiled[0] is not robot:
            self._compiled = (robot, _CompiledStep.build(self, robot))
        compiled = self._compiled[1]
        if compiled is None or not compiled.ready():
            return super().step(robot, q, qd, sample)
        self._fast = (robot, compiled)
        self.servo.update(sample)
        return compiled.step(self, q, qd)

    def _step(
        self, robot: Robot, q: FloatArray, qd: FloatArray, s: ServoState, M: FloatArray
    ) -> ControlStep:
        tau0 = self.null_space_torque(robot, q, qd, M)
        out = _torque(
            s.jacobian,
            M,
            robot.bias(q, qd) + robot.joint_damping * qd,  # the file's damping as well
            s.command,
            tau0,
            self.projector,
            self.compensation,
            self.damping,
            self.rcond,
        )
        return ControlStep(
            out.tau, out.info, s.error, s.pose, self.task.target, out.null, {"tau0": tau0}
        )


class _CompiledStep:
    """The arrays of :func:`redres.dynamics._kernels.osc_step` for one controller and robot
    (built when the law allows it, :meth:`OperationalSpaceController.step`), checked and
    filled here once: a step copies ``q``, ``q̇`` (and a new reference) in, calls the kernel
    and hands its output to a :class:`~redres.dynamics.chain.KernelControlStep`."""

    def __init__(self, law: OperationalSpaceController, dynamics: ChainDynamics) -> None:
        n, rows = dynamics.n, law.servo.rows
        self.dynamics = dynamics
        self.n = n
        self.rows = np.array(rows, dtype=np.int64)
        self.gains = np.array([law.servo.gains.kp, law.servo.gains.kd])
        mode, lam, lam_max, eps = parse_damping(law.damping)
        self.settings = np.array([law.null_law.kp, law.null_law.kd, 0.0, mode, lam, lam_max, eps,
                                  law.rcond])  # fmt: skip
        self.quad = np.zeros((2, n))
        self.method = method_label(mode, True, "")
        self.feed = np.zeros(12)  # the reference twist and acceleration
        self.out = np.empty(4 * n + OUT_EXTRA)
        self._shape, self._strides = (n,), (8,)
        self._feed: tuple[Any, Any] = (None, None)  # the servo's arrays copied into feed
        self._target = law.task.target_block
        self.args = self._arguments()
        self._entry: Any = None

    @classmethod
    def build(cls, law: OperationalSpaceController, robot: Robot) -> _CompiledStep | None:
        """The compiled step of ``law`` on ``robot``, or None where it does not apply."""
        if law.projector != "dynamic" or law.compensation != "joint" or law.null_torque:
            return None
        dynamics = chain_dynamics(robot, law.task.frame)
        if dynamics is None:
            return None
        quadratic = quadratic_coefficients(robot, law.null_law.objectives)
        if law.null_law.objectives and quadratic is None:
            return None
        step = cls(law, dynamics)
        if quadratic is not None:
            step.quad[:] = quadratic
            step.settings[2] = 1.0
        return step

    def _arguments(self) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
        """The kernel's arguments before ``q, q̇`` and after them."""
        d = self.dynamics
        return (*d.arrays, d.damping), (self.feed, self._target, self.gains, self.rows, self.quad,
                                        self.settings, self.out)  # fmt: skip

    def ready(self) -> bool:
        """Whether the kernel runs compiled (it compiles behind until then)."""
        if self._entry is None and CHAIN_KERNELS.ready():
            q = np.zeros(self.n)
            self._entry = CHAIN_KERNELS.entry("osc_step", (*self.args[0], q, q, *self.args[1]))
        return self._entry is not None

    def step(self, law: OperationalSpaceController, q: Any, qd: Any) -> ControlStep:
        """The torque at ``(q, q̇)`` with the servo's reference."""
        n = self.n
        # The kernel takes q and q̇ as they are when they are contiguous float64 vectors
        # of length n (its entry point's types; their finiteness is the kernel's check).
        if not (type(q) is np.ndarray and type(qd) is np.ndarray and q.dtype is _F64
                and qd.dtype is _F64 and q.shape == self._shape == qd.shape
                and q.strides == self._strides == qd.strides):  # fmt: skip
            q, qd = as_vector(q, "q", n).copy(), as_vector(qd, "qd", n).copy()
        servo = law.servo
        if not servo.has_target:
            servo.hold(self.dynamics.pose(as_vector(q, "q", n)))
        feed = (servo.twist, servo.acceleration)
        if feed[0] is not self._feed[0] or feed[1] is not self._feed[1]:  # a new reference
            self.feed[:6], self.feed[6:] = self._feed = feed
        if servo.task.target_block is not self._target:  # the task was given another block
            self._target = servo.task.target_block
            self.args = self._arguments()
        head, tail = self.args
        status = self._entry(*head, q, qd, *tail)
        if status:
            as_vector(q, "q", n), as_vector(qd, "qd", n)  # names the non-finite one
            raise_status(status, {"J": "the task Jacobian", "W": "M"})
        return KernelControlStep(self.out.copy(), self)

    def info(self, out: FloatArray) -> InverseInfo:
        """The inverse's diagnostics in the output ``out`` of one step."""
        n, m = self.n, len(self.rows)
        rank, smin, smax, used = out[4 * n + OUT_STATS : 4 * n + OUT_EXTRA].tolist()
        return InverseInfo(int(rank), rank == min(m, n), smin, smax, used, self.method)
