"""Acceleration-level redundancy resolution and computed-torque control (Khatib 1987).

Differentiating ``ẋ = J q̇`` gives ``ẍ − J̇ q̇ = J q̈`` (Khatib 1987); resolving it with
a generalised inverse ``J#`` and adding a null-space acceleration::

    q̈ = J# (ẍ − J̇ q̇) + (I − J# J) q̈₀           J# = J̄ = M⁻¹ Jᵀ Λ   ("dynamic", Khatib 1987)
                                                J# = J⁺              ("kinematic")

and the torque follows from inverse dynamics, ``τ = M q̈ + C q̇ + g`` (RNEA).

With ``J# = J̄`` and ``τ₀ = M q̈₀`` this is exactly the operational-space law of
:mod:`redres.dynamics.osc` with joint-space compensation, since ``M J̄ = Jᵀ Λ`` and
``M (I − J̄ J) = (I − Jᵀ J̄ᵀ) M`` — a test checks the two torques agree. At the acceleration
level both inverses leave the task untouched (``J (I − J# J) = 0`` for either); the
choice only changes *which* null-space motion a given ``q̈₀`` produces: ``J̄`` gives the
kinetic-energy-weighted projection of ``q̈₀``, ``J⁺`` the Euclidean one.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, get_args

from numpy.typing import ArrayLike

from .._validate import FloatArray, as_matrix, as_vector
from ..errors import InvalidParameterError
from ..linalg import RCOND, AdaptiveDamping, InverseInfo, generalized_inverse
from ..tasks import FrameTask
from ._servo import ServoLaw, ServoSettings, ServoState
from .base import ControlStep
from .osc import check_choice, dynamic_inverse

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from ..robot import Robot

InverseKind = Literal["dynamic", "kinematic"]
_INVERSES: tuple[str, ...] = get_args(InverseKind)


def _inverse(
    J: FloatArray,
    M: FloatArray | None,
    inverse: str,
    damping: float | AdaptiveDamping,
    rcond: float,
) -> tuple[FloatArray, InverseInfo]:
    if inverse == "dynamic":
        if M is None:
            raise InvalidParameterError("the dynamically consistent inverse needs M")
        return dynamic_inverse(J, M, damping, rcond)
    return generalized_inverse(J, damping=damping, rcond=rcond, return_info=True)


def resolve_acceleration(
    J: ArrayLike,
    M: ArrayLike | None,
    xdd: ArrayLike,
    jdot_qd: ArrayLike,
    qdd0: ArrayLike | None = None,
    *,
    inverse: InverseKind = "dynamic",
    damping: float | AdaptiveDamping = 0.0,
    rcond: float = RCOND,
) -> tuple[FloatArray, InverseInfo]:
    """Joint accelerations ``q̈ = J# (ẍ − J̇ q̇) + (I − J# J) q̈₀`` (Khatib 1987).

    Args:
        J: task Jacobian, ``(m, n)``.
        M: joint-space inertia, SPD, ``(n, n)`` (may be ``None`` for ``"kinematic"``).
        xdd: desired task acceleration ``ẍ``, ``(m,)``, m/s² and rad/s².
        jdot_qd: ``J̇ q̇``, ``(m,)``, same units.
        qdd0: null-space acceleration before projection, ``(n,)``, rad/s².
        inverse: ``"dynamic"`` (``J̄``, Khatib 1987) or ``"kinematic"`` (``J⁺``).
        damping: ``λ ≥ 0`` or :class:`~redres.linalg.AdaptiveDamping`.
        rcond: relative rank tolerance when undamped.

    Returns:
        ``(qdd, info)``: ``(n,)`` joint accelerations, rad/s², and the inverse's diagnostics.

    Raises:
        ShapeError, NonFiniteError: wrong shapes or NaN/inf input (named).
        NotPositiveDefiniteError: ``M`` is not symmetric positive definite.
        InvalidParameterError: unknown ``inverse``, or ``"dynamic"`` without ``M``.
    """
    check_choice(inverse, "inverse", _INVERSES)
    Jm = as_matrix(J, "J")
    m, n = Jm.shape
    a = as_vector(xdd, "xdd", m) - as_vector(jdot_qd, "jdot_qd", m)
    Mm = None if M is None else as_matrix(M, "M", (n, n))
    J_hash, info = _inverse(Jm, Mm, inverse, damping, rcond)
    qdd = J_hash @ a
    if qdd0 is not None:
        q0 = as_vector(qdd0, "qdd0", n)
        qdd = qdd + (q0 - J_hash @ (Jm @ q0))
    return qdd, info


class AccelerationController(ServoLaw):
    """Computed torque from acceleration-level resolution: ``τ = RNEA(q, q̇, q̈)``.

    ``q̈ = J# (ẍ* − J̇ q̇) + (I − J# J) q̈₀`` with the task servo ``ẍ*`` and the null-space
    law ``q̈₀ = −k_p,0 ∇D − k_d,0 q̇`` of :class:`~redres.dynamics.OperationalSpaceController`
    (same arguments and units).

    Args:
        task, kp, kd, objectives, null_kp, null_kd: the task servo and null-space law.
        inverse: ``"dynamic"`` or ``"kinematic"``.
        damping, rcond: as for :func:`resolve_acceleration`.
        name: identifier in run logs (default ``acceleration_<inverse>``).
    """

    def __init__(
        self,
        task: FrameTask | None = None,
        *,
        inverse: InverseKind = "dynamic",
        **settings: Unpack[ServoSettings],
    ) -> None:
        """The arguments are described in ``help(AccelerationController)``."""
        self.inverse = check_choice(inverse, "inverse", _INVERSES)
        self.name = f"acceleration_{inverse}"
        super().__init__(task, **settings)

    def _step(
        self, robot: Robot, q: FloatArray, qd: FloatArray, s: ServoState, M: FloatArray
    ) -> ControlStep:
        qdd0 = self.null_law.acceleration(robot, q, qd)
        J_hash, info = _inverse(s.jacobian, M, self.inverse, self.damping, self.rcond)
        qdd_task = J_hash @ s.command
        qdd_null = qdd0 - J_hash @ (s.jacobian @ qdd0)
        tau = robot.inverse_dynamics(q, qd, qdd_task + qdd_null) + robot.joint_damping * qd
        extra = {"qdd": qdd_task + qdd_null}
        return ControlStep(tau, info, s.error, s.pose, self.task.target, M @ qdd_null, extra)
