"""Hard joint limits over one control step: the joint-velocity box of the QP and SNS schemes.

A rate-control loop applies ``q̇`` for one period ``dt`` (``q ← q + q̇ dt``). Three limits
must hold after every step, for every joint:

* position: ``q_min ≤ q + q̇ dt ≤ q_max``;
* velocity: ``|q̇| ≤ q̇_max``;
* acceleration: ``|q̇ − q̇_prev| ≤ q̈_max dt`` (``q̇_prev`` the velocity of the previous step).

Each is a bound on ``q̇`` alone, so they intersect into a box ``lower ≤ q̇ ≤ upper``
(Flacco, De Luca, Khatib 2012, eq. 11; 2015, §II). The one-step position bound
``(q_max − q)/dt`` is not enough: a joint running toward its limit at speed may be unable
to brake in time with ``|q̈| ≤ q̈_max``, and the box of a later step is then empty. Flacco
et al. add the continuous-time braking bound ``√(2 q̈_max (q_max − q))``; it is not quite
enough in discrete time (a joint braking by ``a = q̈_max dt`` per step travels
``dt·(v + (v − a) + (v − 2a) + …)``, more than ``v²/(2 q̈_max)``). Here the bound is the
exact discrete one. With ``x = (q_max − q)/dt`` the distance in "velocity × step" units and

    S(v) = Σ_{i ≥ 0} max(v − i a, 0) = (k + 1)(v − a k / 2),   k = ⌈v/a⌉ − 1,

the total travel (in the same units) of a joint that moves at ``v`` this step and then brakes
as hard as allowed, the upper position bound is the largest ``v`` with ``S(v) ≤ x``:

    v_max(x) = x/(k + 1) + a k / 2,   k the largest integer with a k (k + 1) / 2 ≤ x.

``v_max(x) ≤ x`` (the one-step bound) and ``v_max(x) → √(2 q̈_max (q_max − q))`` for small
``a``. Because ``S(v) = v + S(v − a)``, a velocity that obeys it this step leaves the
deceleration ``v − a`` admissible at the next step: if the state starts inside the limits
with a velocity admissible for it (e.g. at rest), the box is never empty again, and
position, velocity and acceleration limits all hold at every step (tests check this on
long random sequences and against a brute-force braking simulation). Infinite limits are
allowed (``inf`` means no limit).

When the state is not viable (a caller-supplied ``q̇_prev`` that cannot be stopped in time,
or ``q`` outside its range) the box is made non-empty by giving up, in this order:

1. the acceleration limit: the velocity is the point of the position/velocity box nearest
   to the acceleration box (so the acceleration limit is violated as little as possible);
2. the position limit, only while ``q`` is already outside its range: the joint returns at
   its velocity limit. The velocity limit is never given up.

``VelocityBounds.relaxed`` marks such joints.

References:
    F. Flacco, A. De Luca, O. Khatib, "Motion control of redundant robots under joint
    constraints: saturation in the null space", Proc. IEEE ICRA 2012, 285–292.
    F. Flacco, A. De Luca, O. Khatib, "Control of redundant robots under hard joint
    constraints: saturation in the null space", IEEE Trans. Robotics 31(3) (2015) 637–654.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..._validate import FloatArray, as_scalar, as_vector, real_array
from ...errors import InvalidParameterError, JointLimitError, NonFiniteError, ShapeError
from ._codes import BOUND_KINDS
from ._compiled import kernels

if TYPE_CHECKING:
    from ...robot import Robot


IntArray = NDArray[np.int8]


def _limit_array(value: Any, name: str, n: int, *, positive: bool) -> FloatArray:
    arr = real_array(value, name, "a number or a vector")
    arr = np.full(n, arr, dtype=float) if arr.ndim == 0 else np.array(arr, dtype=float)
    if arr.shape != (n,):
        raise ShapeError(f"{name} must have shape ({n},) or be a scalar; got shape {arr.shape}")
    if np.isnan(arr).any():
        raise NonFiniteError(f"{name} contains NaN: {arr}")
    if positive and np.any(arr <= 0.0):
        raise InvalidParameterError(f"{name} must be > 0 (inf for no limit); got {arr}")
    return arr


@dataclass(frozen=True)
class JointLimits:
    """Position, velocity and acceleration limits of ``n`` joints (``inf``: no limit).

    Attributes:
        q_min, q_max: position limits, shape ``(n,)``, rad (m for prismatic joints).
        qd_max: velocity limits (symmetric), shape ``(n,)``, rad/s, > 0.
        qdd_max: acceleration limits (symmetric), shape ``(n,)``, rad/s², > 0.
    """

    q_min: FloatArray
    q_max: FloatArray
    qd_max: FloatArray
    qdd_max: FloatArray

    def __post_init__(self) -> None:
        n = np.asarray(self.q_min).shape[0] if np.ndim(self.q_min) == 1 else 0
        if n == 0:
            raise ShapeError("q_min must be a non-empty vector")
        for name, positive in (("q_min", False), ("q_max", False), ("qd_max", True),
                               ("qdd_max", True)):  # fmt: skip
            object.__setattr__(
                self, name, _limit_array(getattr(self, name), name, n, positive=positive)
            )
        if np.any(self.q_min > self.q_max):
            j = int(np.argmax(self.q_min > self.q_max))
            raise JointLimitError(
                f"q_min[{j}] = {self.q_min[j]:.6g} > q_max[{j}] = {self.q_max[j]:.6g}"
            )

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.q_min.shape[0])

    @classmethod
    def from_robot(
        cls, robot: Robot, *, qd_max: ArrayLike | None = None, qdd_max: ArrayLike | None = None
    ) -> JointLimits:
        """The robot's limits, with optional velocity/acceleration limits instead of its own.

        Args:
            robot: the robot (``q_min``, ``q_max``, ``qd_max``, ``qdd_max``).
            qd_max: replaces ``robot.qd_max`` (scalar or ``(n,)``, rad/s).
            qdd_max: replaces ``robot.qdd_max`` (scalar or ``(n,)``, rad/s²); useful for
                models without acceleration limits (``inf``).
        """
        return cls(
            robot.q_min,
            robot.q_max,
            robot.qd_max if qd_max is None else real_array(qd_max, "qd_max"),
            robot.qdd_max if qdd_max is None else real_array(qdd_max, "qdd_max"),
        )  # validated by __post_init__


@dataclass(frozen=True)
class VelocityBounds:
    """The joint-velocity box of one step and what defines each side.

    Attributes:
        lower, upper: bounds, shape ``(n,)``, rad/s (``±inf`` where nothing limits).
        lower_kind, upper_kind: which limit defines each bound, codes into
            :data:`BOUND_KINDS` (0 none, 1 position, 2 velocity, 3 acceleration).
        relaxed: per joint, bit 1 = position limit given up (``q`` outside its range),
            bit 2 = acceleration limit given up (module docstring); 0 for a viable state.
    """

    lower: FloatArray
    upper: FloatArray
    lower_kind: IntArray
    upper_kind: IntArray
    relaxed: IntArray

    @property
    def viable(self) -> bool:
        """True when no limit had to be given up (every limit holds for any ``q̇`` in the box)."""
        return not bool(self.relaxed.any())

    def kind(self, joint: int, side: str) -> str:
        """Name of the limit that defines ``side`` (``"lower"``/``"upper"``) of ``joint``."""
        codes = self.upper_kind if side == "upper" else self.lower_kind
        return BOUND_KINDS[int(codes[joint])]


def braking_velocity(distance: ArrayLike, dt: float, qdd_max: ArrayLike) -> FloatArray:
    """Largest velocity toward a limit ``distance`` away from which the joint can still stop.

    The discrete bound ``v_max(x)`` of the module docstring, ``x = distance/dt`` and
    ``a = qdd_max·dt``; ``x`` where ``distance ≤ 0`` or ``qdd_max = inf``. Beyond
    ``k = 2⁵⁰`` braking steps (distances far beyond any robot's, or ``qdd_max·dt``
    underflowing) it is the continuous bound ``√(2 q̈_max·distance)``, which the discrete
    one equals there to 1e-15: every step ends in a bounded number of operations.

    Args:
        distance: distance to the limit, shape ``(n,)`` or scalar, rad (``inf`` allowed).
        dt: control period, s (> 0).
        qdd_max: acceleration limit, same shape or scalar, rad/s² (> 0, ``inf`` allowed).

    Returns:
        The bound, rad/s, shape of the broadcast inputs.
    """
    dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
    d, acc = np.broadcast_arrays(real_array(distance, "distance"), real_array(qdd_max, "qdd_max"))
    if np.isnan(d).any() or np.isnan(acc).any() or np.any(acc <= 0.0):
        raise InvalidParameterError("distance must not be NaN and qdd_max must be > 0")
    braking = kernels().braking
    out = np.array([braking(float(x), dt, float(a)) for x, a in zip(d.ravel(), acc.ravel())])
    return out.reshape(d.shape)


def velocity_bounds(
    limits: JointLimits, q: ArrayLike, qd_prev: ArrayLike | None, dt: float
) -> VelocityBounds:
    """The box of joint velocities that keeps every limit after one step of ``dt``.

    Args:
        limits: the joint limits.
        q: joint positions now, shape ``(n,)``, rad.
        qd_prev: velocity applied at the previous step, shape ``(n,)``, rad/s (``None``:
            at rest).
        dt: control period, s (> 0); must be the loop's period.

    Returns:
        The :class:`VelocityBounds` (module docstring for the formulas and relaxation).
    """
    n = limits.n
    q = as_vector(q, "q", n)
    qd_prev = np.zeros(n) if qd_prev is None else as_vector(qd_prev, "qd_prev", n)
    dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
    lo, hi = np.empty(n), np.empty(n)
    kl, ku, rel = np.empty(n, np.int8), np.empty(n, np.int8), np.empty(n, np.int8)
    kernels().bounds(q, qd_prev, dt, limits.q_min, limits.q_max, limits.qd_max,
                     limits.qdd_max, lo, hi, kl, ku, rel)  # fmt: skip
    return VelocityBounds(lo, hi, kl, ku, rel)


@dataclass(frozen=True)
class Violation:
    """By how much a step (or a run) breaks each limit; 0 where it does not.

    Attributes:
        position: largest excursion of ``q + q̇ dt`` beyond ``[q_min, q_max]``, rad.
        velocity: largest ``|q̇| − q̇_max``, rad/s.
        acceleration: largest ``|q̇ − q̇_prev| − q̈_max dt``, rad/s (a velocity change).
    """

    position: float
    velocity: float
    acceleration: float

    @property
    def worst(self) -> float:
        """The largest of the three (mixed units; for "is it ≤ 1e-9" checks)."""
        return max(self.position, self.velocity, self.acceleration)


def _excess(values: FloatArray, limit: FloatArray) -> float:
    with np.errstate(invalid="ignore"):
        over = np.where(np.isinf(limit), 0.0, values - limit)
    return float(max(0.0, over.max())) if over.size else 0.0


def step_violation(
    limits: JointLimits, q: ArrayLike, qd: ArrayLike, qd_prev: ArrayLike | None, dt: float
) -> Violation:
    """How much applying ``qd`` for ``dt`` at ``q`` (after ``qd_prev``) breaks the limits."""
    q_arr = np.atleast_2d(as_vector(q, "q", limits.n))
    qd_arr = np.atleast_2d(as_vector(qd, "qd", limits.n))
    prev = np.zeros(limits.n) if qd_prev is None else as_vector(qd_prev, "qd_prev", limits.n)
    return run_violation(limits, q_arr, qd_arr, dt, qd_initial=prev)


def run_violation(
    limits: JointLimits,
    q: ArrayLike,
    qd: ArrayLike,
    dt: float,
    *,
    qd_initial: ArrayLike | None = None,
) -> Violation:
    """Worst violation over a run: ``q[k]`` positions, ``qd[k]`` velocities applied after them.

    Args:
        limits: the joint limits.
        q: positions before each step, shape ``(K, n)``, rad (a :class:`RunLog`'s ``q``).
        qd: velocities applied at each step, shape ``(K, n)``, rad/s (``RunLog.qd``).
        dt: control period, s.
        qd_initial: velocity before the first step (default: at rest).
    """
    q_arr, qd_arr = np.asarray(q, float), np.asarray(qd, float)
    if q_arr.ndim != 2 or q_arr.shape != qd_arr.shape or q_arr.shape[1] != limits.n:
        raise ShapeError(
            f"q and qd must both have shape (K, {limits.n}); got {q_arr.shape}, {qd_arr.shape}"
        )
    dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
    prev0 = np.zeros(limits.n) if qd_initial is None else as_vector(qd_initial, "qd_initial",
                                                                    limits.n)  # fmt: skip
    q_next = q_arr + qd_arr * dt
    position = max(_excess(q_next, limits.q_max), _excess(-q_next, -limits.q_min))
    velocity = _excess(np.abs(qd_arr), limits.qd_max)
    change = np.abs(np.diff(np.vstack([prev0, qd_arr]), axis=0))
    acceleration = _excess(change, limits.qdd_max * dt)
    return Violation(position, velocity, acceleration)


class Binding(NamedTuple):
    """One joint-velocity bound that a step's solution sits on.

    Attributes:
        joint: joint index.
        side: ``"lower"`` or ``"upper"``.
        kind: the limit behind the bound: ``"position"``, ``"velocity"`` or
            ``"acceleration"``.
        relaxed: true when the box had to give up a limit at this joint (module docstring).
    """

    joint: int
    side: str
    kind: str
    relaxed: bool = False


def binding_bounds(
    qd: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    lower_kind: IntArray,
    upper_kind: IntArray,
    relaxed: IntArray,
    tol: float = 1e-9,
) -> list[Binding]:
    """The bounds ``qd`` sits on (within ``tol``, rad/s), one :class:`Binding` per side."""
    out = []
    for j in np.flatnonzero((qd >= upper - tol) | (qd <= lower + tol)).tolist():
        if qd[j] >= upper[j] - tol:
            out.append(Binding(j, "upper", BOUND_KINDS[upper_kind[j]], bool(relaxed[j])))
        if qd[j] <= lower[j] + tol:
            out.append(Binding(j, "lower", BOUND_KINDS[lower_kind[j]], bool(relaxed[j])))
    return out
