"""Strict task priorities: each level resolved in the null space of all higher levels.

Levels ``k = 1..K`` have Jacobians ``J_k`` (``m_k x n``) and task velocities ``ẋ_k``.
``P_k`` is the orthogonal projector onto the null space of the augmented Jacobian
``[J_1; …; J_k]`` (``P_0 = I``). Three methods:

``"exact"`` — the recursion of Nakamura, Hanafusa & Yoshikawa (1987) in the form of
Siciliano & Slotine (1991), with exact (truncated SVD) pseudo-inverses::

    q̇_k = q̇_{k−1} + (J_k P_{k−1})⁺ (ẋ_k − J_k q̇_{k−1}),      q̇_0 = 0
    P_k = P_{k−1} − (J_k P_{k−1})⁺ (J_k P_{k−1})

Level ``k`` is met exactly whenever ``J_k P_{k−1}`` has full row rank, and in the least-
squares sense within the freedom left by the higher levels otherwise; lower levels never
change what higher levels achieve. Where ``J_k P_{k−1}`` loses rank while ``J_k`` does not
(an *algorithmic singularity*) the inverse, and the joint speed, grow without bound.

``"robust"`` — the singularity-robust scheme of Chiaverini (1997, eq. 34), extended to any
number of levels as in Antonelli (2009)::

    q̇ = J_1^# ẋ_1 + P_1 J_2^# ẋ_2 + P_2 J_3^# ẋ_3 + …

Each level is inverted *alone* (``J_k^#``, the adaptively damped least-squares inverse of
:mod:`redres.linalg`), then projected; the coupling term ``−J_k q̇_{k−1}`` is dropped. The
projected Jacobians are never inverted, so algorithmic singularities cannot make the
speed blow up, and the damped inverses bound it at kinematic singularities of each
``J_k``. The price: lower levels are met only approximately, even away from singularities
(closed-loop errors still converge, Antonelli 2009). Higher levels are still never
disturbed by lower ones: ``J_i P_{k−1} = 0`` for ``i < k`` exactly, because ``P`` are the
orthogonal projectors of the augmented Jacobians (Antonelli 2009), not projectors built
from the damped inverses. They change discontinuously only where an augmented Jacobian
changes rank exactly.

``"damped"`` — the exact recursion with the adaptively damped inverse of ``J_k P_{k−1}``
(exact away from algorithmic singularities, bounded at them; the usual practice, e.g.
Baerlocher & Boulic 2004).

Computation. One exact inverse of ``A = J_k P_{k−1}`` per level (from
:func:`redres.linalg.damped_pinv` with zero damping) gives the increment of ``"exact"``,
the rank and ``σ_min`` of the diagnostics and the projector update above; increments are
multiplied by ``P_{k−1}`` so that they lie in the null space of the higher levels to
rounding error whatever inverse produced them. Singular values of ``A`` below about
``rcond·‖J_k‖`` count as zero: at an algorithmic singularity *all* of them may be tiny, so
a cut relative to ``A``'s own largest one would invert rounding noise.

References:
    Y. Nakamura, H. Hanafusa, T. Yoshikawa, "Task-priority based redundancy control of
    robot manipulators", Int. J. Robotics Research 6(2) (1987) 3–15.
    B. Siciliano, J.-J. Slotine, "A general framework for managing multiple tasks in highly
    redundant robotic systems", Proc. ICAR 1991, 1211–1216.
    S. Chiaverini, "Singularity-robust task-priority redundancy resolution for real-time
    kinematic control of robot manipulators", IEEE Trans. Robot. Autom. 13(3) (1997)
    398–410.
    G. Antonelli, "Stability analysis for prioritized closed-loop inverse kinematic
    algorithms for redundant robotic systems", IEEE Trans. Robot. 25(5) (2009) 985–994.
    P. Baerlocher, R. Boulic, "An inverse kinematics architecture enforcing an arbitrary
    number of strict priority levels", The Visual Computer 20 (2004) 402–417.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from .._validate import FloatArray, as_matrix, as_scalar, as_vector, checked_keywords
from ..errors import InvalidParameterError, ShapeError
from ..linalg import (
    RCOND,
    AdaptiveDamping,
    InverseInfo,
    damped_pinv,
    sigma_min,
    singular_values,
)
from ..tasks import Task, stack
from .base import Inverse, Scheme, StepResult, make_inverse

if TYPE_CHECKING:
    from .._toml import ScenarioParams
    from ..robot import Robot

PriorityMethod = Literal["exact", "robust", "damped"]
Damping = float | AdaptiveDamping
METHODS: tuple[str, ...] = ("exact", "robust", "damped")

#: Default damping of the ``"robust"`` and ``"damped"`` methods (units of the Jacobian).
DEFAULT_DAMPING = AdaptiveDamping(max_damping=0.05, threshold=0.05)


class LevelInfo(NamedTuple):
    """Diagnostics of one priority level.

    Attributes:
        level: 1 for the highest priority.
        rows: number of task rows ``m_k``.
        freedom: dimension of the null space left by the higher levels (``n`` for level 1).
        rank: rank of the projected Jacobian ``J_k P_{k−1}``.
        full_rank: ``rank == min(rows, freedom)``.
        sigma_min: smallest of the ``min(rows, freedom)`` singular values of
            ``J_k P_{k−1}`` (units of ``J_k``; 0 when no freedom is left). Small while ``J_k``
            itself is well conditioned: an algorithmic singularity.
        damping: damping of the inverse this level used (0 for exact inverses).
        requested: task velocity asked for, ``ẋ_k``, shape ``(m_k,)``.
        achieved: task velocity obtained, ``J_k q̇``, shape ``(m_k,)``.
        contribution: joint velocity this level added, shape ``(n,)``, rad/s.
        algorithmic_singularity: ``sigma_min < threshold`` while ``σ_min(J_k) ≥ threshold``
            (level 1 never: it has no higher level).
        inverse: :class:`~redres.linalg.InverseInfo` of the matrix this level inverted
            (``J_k P_{k−1}`` for ``"exact"``/``"damped"``, ``J_k`` for ``"robust"``).
    """

    level: int
    rows: int
    freedom: int
    rank: int
    full_rank: bool
    sigma_min: float
    damping: float
    requested: FloatArray
    achieved: FloatArray
    contribution: FloatArray
    algorithmic_singularity: bool
    inverse: InverseInfo

    @property
    def residual(self) -> float:
        """``‖J_k q̇ − ẋ_k‖``, units of the task velocity."""
        return float(np.linalg.norm(self.achieved - self.requested))


class PriorityResult(NamedTuple):
    """The result of :func:`prioritized_velocity`.

    Attributes:
        qd: joint velocity of the whole hierarchy, shape ``(n,)``, rad/s.
        levels: one :class:`LevelInfo` per level, highest priority first.
    """

    qd: FloatArray
    levels: list[LevelInfo]


def prioritized_velocity(
    jacobians: Sequence[ArrayLike],
    velocities: Sequence[ArrayLike],
    *,
    method: PriorityMethod = "exact",
    damping: Damping | Sequence[Damping] = DEFAULT_DAMPING,
    rcond: float = RCOND,
    threshold: float = 1e-2,
) -> PriorityResult:
    """Joint velocity of a strict priority hierarchy (module docstring for the formulas).

    Args:
        jacobians: ``J_k`` per level, highest priority first, shapes ``(m_k, n)``.
        velocities: ``ẋ_k`` per level, shapes ``(m_k,)`` (m/s, rad/s, or the CLIK command
            ``ẋ_d + K e``).
        method: ``"exact"`` (Siciliano–Slotine recursion), ``"robust"`` (Chiaverini 1997)
            or ``"damped"`` (the recursion with damped inverses).
        damping: damping of ``"robust"`` and ``"damped"`` (a λ in the units of ``J`` or an
            :class:`~redres.linalg.AdaptiveDamping`), or a list with one per level;
            unused by ``"exact"``.
        rcond: relative rank tolerance of the exact inverses and of the null-space bases.
        threshold: smallest singular value (units of ``J``) below which a level is
            reported singular (:attr:`LevelInfo.algorithmic_singularity`).

    Returns:
        A :class:`PriorityResult` ``(qd, levels)``: joint velocity, shape ``(n,)``, rad/s,
        and one :class:`LevelInfo` per level.

    Raises:
        ShapeError: a Jacobian or velocity has the wrong shape, or the levels disagree on
            ``n``.
        NonFiniteError: an input contains NaN or infinity.
        InvalidParameterError: no levels, unknown ``method``, bad ``damping``/``rcond``.
    """
    Js, xs = _validate(jacobians, velocities)
    _check_method(method)
    rcond = as_scalar(rcond, "rcond", minimum=0.0)
    threshold = as_scalar(threshold, "threshold", minimum=0.0)
    return _resolve(Js, xs, method, _per_level(damping, len(Js)), rcond, threshold)


def _check_method(method: str) -> None:
    if method not in METHODS:
        raise InvalidParameterError(f"method must be one of {', '.join(METHODS)}; got {method!r}")


def _resolve(
    Js: list[FloatArray],
    xs: list[FloatArray],
    method: str,
    dampings: list[Damping],
    rcond: float,
    threshold: float,
) -> PriorityResult:
    """:func:`prioritized_velocity` on validated input."""
    n = Js[0].shape[1]
    qd = np.zeros(n)
    P: FloatArray | None = None  # projector onto the null space of the higher levels
    freedom, levels = n, []
    for k, (J, x) in enumerate(zip(Js, xs)):
        m = J.shape[0]
        if freedom == 0:
            levels.append(LevelInfo(k + 1, m, 0, 0, True, 0.0, 0.0, x, x, np.zeros(n), False,
                                    _NO_FREEDOM))  # fmt: skip
            continue
        A = J if P is None else J @ P
        A_pinv, exact = damped_pinv(A, 0.0, rcond=_projected_rcond(J, A, rcond), return_info=True)
        if method == "exact":
            part, info = A_pinv @ (x - J @ qd), exact
        elif method == "damped":
            A_damped, info = damped_pinv(
                A, dampings[k], rcond=_projected_rcond(J, A, rcond), return_info=True
            )
            part = A_damped @ (x - J @ qd)
        else:
            J_damped, info = damped_pinv(J, dampings[k], rcond=rcond, return_info=True)
            part = J_damped @ x
        if P is not None:  # in the null space of the higher levels to rounding error
            part = P @ part
        qd = qd + part
        smin = exact.sigma_min if m <= freedom else singular_values(A)[freedom - 1]
        singular = P is not None and smin < threshold
        if singular:  # algorithmic only if J_k alone is well conditioned
            singular = (info.sigma_min if method == "robust" else sigma_min(J)) >= threshold
        full = exact.rank == min(m, freedom)
        levels.append(LevelInfo(k + 1, m, freedom, exact.rank, full, float(smin), info.damping,
                                x, x, part, bool(singular), info))  # fmt: skip
        if k + 1 < len(Js):
            P = (np.eye(n) if P is None else P) - A_pinv @ A
            freedom = max(freedom - exact.rank, 0)
    # achieved = J_k q̇ of the final q̇ (the loop above held a placeholder)
    return PriorityResult(qd, [lv._replace(achieved=J @ qd) for lv, J in zip(levels, Js)])


_NO_FREEDOM = InverseInfo(0, False, 0.0, 0.0, 0.0, "none")


def _per_level(value: Any, levels: int, name: str = "damping") -> list[Any]:
    """``value`` for every level, or its list of one per level."""
    if isinstance(value, AdaptiveDamping) or np.ndim(value) == 0:
        return [value] * levels
    out = list(value)
    if len(out) != levels:
        raise InvalidParameterError(f"give one {name}, or one per level ({levels}); got {out}")
    return out


def _projected_rcond(J: FloatArray, A: FloatArray, rcond: float) -> float:
    """Relative tolerance for ``A = J_k P_{k−1}`` that cuts at about ``rcond·‖J_k‖`` (why:
    module docstring, "Computation"; ``‖A‖_F ≤ ‖J_k‖_F`` as ``P`` is an orthogonal
    projector). Once the higher levels use ``r`` joints, ``n − r`` singular values of
    ``A`` are rounding noise."""
    if A is J:
        return rcond
    norm_a = float(np.vdot(A, A))
    if norm_a == 0.0:
        return rcond
    return max(rcond, min(1.0, rcond * math.sqrt(float(np.vdot(J, J)) / norm_a)))


def _validate(
    jacobians: Sequence[ArrayLike], velocities: Sequence[ArrayLike]
) -> tuple[list[FloatArray], list[FloatArray]]:
    if isinstance(jacobians, np.ndarray) or isinstance(velocities, np.ndarray):
        raise ShapeError("jacobians and velocities must be lists with one entry per level")
    if len(jacobians) == 0:
        raise InvalidParameterError("give at least one level (jacobians is empty)")
    if len(jacobians) != len(velocities):
        raise ShapeError(
            f"one velocity per level: {len(jacobians)} Jacobians, {len(velocities)} velocities"
        )
    Js = [as_matrix(J, f"jacobians[{k}]") for k, J in enumerate(jacobians)]
    n = Js[0].shape[1]
    for k, J in enumerate(Js):
        if J.shape[1] != n or J.shape[0] == 0 or n == 0:
            raise ShapeError(
                f"jacobians[{k}] must have shape (m, {n}) with m >= 1 (n from jacobians[0]); "
                f"got {J.shape}"
            )
    xs = [
        as_vector(x, f"velocities[{k}]", J.shape[0]) for k, (x, J) in enumerate(zip(velocities, Js))
    ]
    return Js, xs


@dataclass(frozen=True)
class PriorityDetails:
    """What a priority step adds to its :class:`StepResult`.

    Attributes:
        levels: one :class:`LevelInfo` per level, the loop's task first.
        level_errors: the task errors of the scheme's own levels (level 2 on).
    """

    levels: list[LevelInfo]
    level_errors: list[FloatArray]


class PriorityScheme(Scheme):
    """Strict priorities in :func:`redres.control.run`: the loop's task first, then levels.

    ``step(robot, q, J, xd)`` takes ``(J, xd)`` from the loop as level 1 and the scheme's
    own ``levels`` (each a task or a list of tasks, stacked; evaluated at ``q``, command
    ``ẋ_d + gain·e``) as levels 2, 3, … and resolves them with
    :func:`prioritized_velocity`.

    Args:
        levels: lower-priority levels, highest first.
        method: ``"exact"``, ``"robust"`` or ``"damped"`` (module docstring).
        gain: CLIK gain of the scheme's own levels, 1/s (one for all, or one per level).
        inverse, damping, rcond: the inverse of every level, as for
            :class:`~redres.resolution.PseudoInverseScheme`. ``"exact"`` takes an exact
            inverse only (its ``rcond`` is also the projectors' rank tolerance); ``"robust"``
            and ``"damped"`` default to ``AdaptiveDamping(0.05, 0.05)``.
        threshold: singular value below which a level is reported singular.

    Identifier ``priority``. ``StepResult.info`` is the inverse of level 1,
    ``null_term`` what the lower levels add, ``algorithmic_singularity`` whether any level
    is at one, and ``details`` a :class:`PriorityDetails`.

    Raises:
        InvalidParameterError: an unknown method, a damping with ``method="exact"``, bad
            levels or gains.
        UnknownParameterError: a misspelt keyword (the message names the valid ones).
    """

    name = "priority"

    @checked_keywords
    def __init__(
        self,
        levels: Sequence[Task | Sequence[Task]] = (),
        *,
        method: PriorityMethod = "exact",
        gain: float | Sequence[float] = 10.0,
        inverse: Inverse | None = None,
        damping: Damping | None = None,
        rcond: float | None = None,
        threshold: float = 1e-2,
    ) -> None:
        """The arguments are described in ``help(PriorityScheme)``."""
        _check_method(method)
        self.levels = [[lv] if isinstance(lv, Task) else list(lv) for lv in levels]
        if any(not level or not all(isinstance(t, Task) for t in level) for level in self.levels):
            raise InvalidParameterError("each level must be a Task or a non-empty list of Tasks")
        gains = _per_level(gain, len(self.levels), "gain")
        self.gains = [as_scalar(g, "gain", minimum=0.0) for g in gains]
        self.method: PriorityMethod = method
        if method != "exact" and inverse is None and damping is None and rcond is None:
            damping = DEFAULT_DAMPING
        self.inverse = make_inverse(inverse, damping, rcond)
        if method == "exact" and self.inverse.kind != "exact":
            raise InvalidParameterError(
                f"method 'exact' inverts every level exactly and does not use damping = "
                f"{self.inverse.damping!r}: choose method='damped' or 'robust', or drop it"
            )
        self.threshold = as_scalar(threshold, "threshold", minimum=0.0)
        self.tasks = tuple(t for level in self.levels for t in level)
        self._dampings = [self.inverse.damping] * (len(self.levels) + 1)

    @classmethod
    def from_scenario(cls, params: ScenarioParams) -> PriorityScheme:
        """The scheme of a scenario table: ``levels``, ``method``, ``gain``, the inverse."""
        method = params.string("method", "exact")
        gain = params.nonnegative("gain", 10.0)
        return cls(params.levels(), method=method, gain=gain, inverse=params.inverse())  # type: ignore[arg-type]

    def _step(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> StepResult:
        jacobians = [J]
        velocities = [xd]
        errors = []
        for level, gain in zip(self.levels, self.gains):
            states = [task.compute(robot, q) for task in level]
            state = states[0] if len(states) == 1 else stack(states)
            jacobians.append(state.jacobian)
            velocities.append(state.command(gain))
            errors.append(state.error)
        qd, infos = _resolve(
            jacobians, velocities, self.method, self._dampings, self.inverse.rcond, self.threshold
        )
        return StepResult(
            qd,
            infos[0].inverse,
            qd - infos[0].contribution,
            algorithmic_singularity=any(i.algorithmic_singularity for i in infos),
            details=PriorityDetails(infos, errors),
        )
