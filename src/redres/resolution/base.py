"""One step of a redundancy-resolution scheme: task Jacobian and velocity in, joint
velocity and diagnostics out."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from .._validate import FloatArray, as_scalar
from ..errors import InvalidParameterError, NonFiniteError, ShapeError
from ..linalg import RCOND, AdaptiveDamping, InverseInfo
from ..linalg import _backend as be
from ..linalg._status import check_rate, too_large

if TYPE_CHECKING:
    from ..objectives import Objective
    from ..robot import Robot
    from ..tasks import Task


_new = object.__new__
_isfinite = np.isfinite


class StepResult:
    """What a scheme returns for one control step.

    Attributes:
        qd: joint velocity, shape ``(n,)``, rad/s.
        info: diagnostics of the inverse used (``rank``, ``sigma_min``, ``sigma_max``,
            ``damping``, ``method``), from :mod:`redres.linalg`; the hard-limit schemes
            compute it on first read.
        null_term: the secondary (null-space) part of ``qd``, shape ``(n,)`` (zeros when
            the scheme has none); the hard-limit schemes compute it on first read.
        feasible: whether the task is met exactly within the scheme's constraints (always
            true for schemes without hard limits).
        algorithmic_singularity: whether an added task row (augmented Jacobian, priority
            level) became dependent on the task while the task alone is not singular.
        binding: the joint-velocity bounds ``qd`` sits on
            (:class:`~redres.resolution.hard_limits.Binding`; empty without hard limits).
        details: the scheme's own typed diagnostics (e.g. :class:`SNSDetails`), or None;
            the hard-limit schemes build it on first read.
    """

    __slots__ = ("_details", "_info", "_null", "algorithmic_singularity", "binding",
                 "feasible", "qd")  # fmt: skip

    def __init__(
        self,
        qd: FloatArray,
        info: InverseInfo | Callable[[], InverseInfo],
        null_term: FloatArray | Callable[[], FloatArray],
        *,
        feasible: bool = True,
        algorithmic_singularity: bool = False,
        binding: Sequence[Any] = (),
        details: Any = None,
    ) -> None:
        """Built by the schemes; the arguments are the attributes listed on the class."""
        # details and null_term may be zero-argument callables (built on first read), like info.
        self.qd, self._info, self._null = qd, info, null_term
        self.feasible, self.algorithmic_singularity = feasible, algorithmic_singularity
        self.binding, self._details = binding, details

    def _built(self, slot: str) -> Any:
        """The value in ``slot``, built now if it holds a zero-argument function."""
        value = getattr(self, slot)
        if callable(value):
            value = value()
            setattr(self, slot, value)
        return value

    @property
    def info(self) -> InverseInfo:
        """Diagnostics of the inverse (computed on first read where that is costly)."""
        return self._built("_info")  # type: ignore[no-any-return]

    @property
    def null_term(self) -> FloatArray:
        """The secondary (null-space) part of ``qd`` (computed on first read where costly)."""
        return self._built("_null")  # type: ignore[no-any-return]

    @property
    def details(self) -> Any:
        """The scheme's own typed diagnostics, or None (built on first read where costly)."""
        return self._built("_details")

    @classmethod
    def lazy(
        cls,
        qd: FloatArray,
        info: Callable[[], InverseInfo],
        null_term: FloatArray | Callable[[], FloatArray],
        feasible: bool,
        binding: Sequence[Any],
        details: Callable[[], Any],
    ) -> StepResult:
        """A result whose ``info`` and ``details`` are built on first read (the hard-limit
        schemes' hot path: no keyword parsing, nothing built a loop never reads)."""
        result = _new(cls)
        result.qd, result._info, result._null, result.feasible = qd, info, null_term, feasible
        result.algorithmic_singularity, result.binding, result._details = False, binding, details
        return result

    def __repr__(self) -> str:
        return (
            f"StepResult(qd={self.qd!r}, feasible={self.feasible}, "
            f"algorithmic_singularity={self.algorithmic_singularity}, "
            f"binding={list(self.binding)!r}, details={self.details!r})"
        )


@dataclass(frozen=True)
class Inverse:
    """The inverse a scheme or controller uses, in the vocabulary of :mod:`redres.linalg`.

    Attributes:
        damping: ``0`` for the exact (truncated SVD) pseudo-inverse, ``λ > 0`` for damped
            least squares ``Jᵀ(JJᵀ + λ²I)⁻¹`` (units of ``J``), or an
            :class:`~redres.linalg.AdaptiveDamping` (zero away from singularities).
        rcond: relative rank cut of the exact inverse: singular values at or below
            ``rcond·σ_max`` are skipped (the truncated SVD inverse). Only the exact inverse
            uses it; giving it with a damping is refused.

    Raises:
        InvalidParameterError: a negative or non-finite value, or ``rcond`` with a damping.
    """

    damping: float | AdaptiveDamping = 0.0
    rcond: float = RCOND

    def __post_init__(self) -> None:
        if not isinstance(self.damping, AdaptiveDamping):
            object.__setattr__(self, "damping", as_scalar(self.damping, "damping", minimum=0.0))
        object.__setattr__(self, "rcond", as_scalar(self.rcond, "rcond", minimum=0.0))
        if self.damping != 0.0 and self.rcond != RCOND:
            raise InvalidParameterError(
                f"rcond = {self.rcond} is used only by the exact inverse (damping = 0); "
                f"the damped inverse with damping = {self.damping!r} has no rank cut: drop rcond"
            )

    @property
    def kind(self) -> Literal["exact", "damped", "adaptive", "selective"]:
        """``"exact"``, ``"damped"``, ``"adaptive"`` or ``"selective"``."""
        if isinstance(self.damping, AdaptiveDamping):
            return "selective" if self.damping.selective else "adaptive"
        return "damped" if self.damping > 0.0 else "exact"

    def rate_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`redres.linalg.rate_step` for this inverse."""
        return {"damping": self.damping, "rcond": self.rcond}


def make_inverse(
    inverse: Inverse | None = None,
    damping: float | AdaptiveDamping | None = None,
    rcond: float | None = None,
) -> Inverse:
    """The :class:`Inverse` of a constructor that takes ``inverse=`` or the keywords
    ``damping=`` / ``rcond=`` (not both)."""
    if inverse is None:
        return Inverse(0.0 if damping is None else damping, RCOND if rcond is None else rcond)
    if not isinstance(inverse, Inverse):
        raise InvalidParameterError(
            f"inverse must be a redres.resolution.Inverse, e.g. Inverse(damping=0.05); "
            f"got {inverse!r}"
        )
    if damping is not None or rcond is not None:
        raise InvalidParameterError("give inverse= or damping=/rcond=, not both")
    return inverse


class Scheme(ABC):
    """A redundancy-resolution scheme: ``step(robot, q, J, xd) -> StepResult``.

    ``J`` (``m x n``) and ``xd`` (``m``, the closed-loop task velocity ``ẋ_d + K e``) come
    from the primary task; the scheme adds what it resolves the redundancy with: its
    :attr:`objectives` (secondary costs) and :attr:`tasks` (tasks it evaluates itself, such
    as priority levels or the augmented Jacobian's extra rows).

    :meth:`step` checks its inputs once and calls the scheme's own :meth:`_step`, which a
    subclass implements for arrays known to be good. The controller
    (:class:`~redres.control.Controller`) calls :meth:`_step` directly on the arrays it
    builds itself; that is the one lean path.
    """

    #: Stable identifier (``pinv``, ``dls``, ``gradient_projection``, ``wln``, ...).
    name: str = "scheme"
    #: Whether every ``q̇`` already respects the joint position, velocity and
    #: acceleration limits (the hard-limit schemes), so a loop need not scale it.
    hard_limits: bool = False
    #: The control period the scheme plans over, s (hard-limit schemes), else None: a loop
    #: must run at this period.
    dt: float | None = None
    #: Gain ``k`` of the secondary (null-space) cost term (0: the scheme has none).
    k_null: float = 0.0
    #: Weighted secondary costs ``(objective, weight)`` the scheme descends (empty: none).
    objectives: tuple[tuple[Objective, float], ...] = ()
    #: Tasks the scheme evaluates itself at ``q`` (empty: none); reset with the scheme.
    tasks: tuple[Task, ...] = ()
    #: The ``type`` names of the scheme in scenario files (empty: its :attr:`name`); the
    #: class builds itself from a scenario table with ``from_scenario`` (redres.scenarios.registry).
    scenario_types: tuple[str, ...] = ()

    def step(self, robot: Robot, q: Any, J: Any, xd: Any) -> StepResult:
        """Joint velocity for task Jacobian ``J`` and task velocity ``xd`` at ``q``.

        Args:
            robot: the robot.
            q: joint positions, shape ``(n,)``, rad.
            J: task Jacobian, shape ``(m, n)``.
            xd: task velocity, shape ``(m,)`` (m/s, rad/s).

        Raises:
            ShapeError: the shapes do not match ``robot.n`` and each other.
            NonFiniteError: an input contains NaN or infinity (the message names it).
            InvalidParameterError: an input is complex (its imaginary part would be lost), or
                ``xd`` has an entry beyond ±1e50 (where the joint velocity could overflow).
        """
        q, J, xd = step_arrays(q, J, xd, robot.n)
        return self._step(robot, q, J, xd)

    @abstractmethod
    def _step(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> StepResult:
        """:meth:`step` for float64 C-contiguous ``q (n,)``, ``J (m, n)``, ``xd (m,)``."""

    def reset(self) -> None:
        """Forget any state kept between steps (called at the start of a run), the
        scheme's own (:meth:`_reset`) and that of its :attr:`tasks`."""
        for task in self.tasks:
            task.reset()
        self._reset()

    def _reset(self) -> None:  # noqa: B027 - stateless schemes need nothing
        """The scheme's own part of :meth:`reset`."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r})"


def step_arrays(q: Any, J: Any, xd: Any, n: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``q``, ``J``, ``xd`` as finite, real, C-contiguous float64 arrays of matching shapes
    (the errors of :meth:`Scheme.step`)."""
    arrays = []
    for value, name in ((q, "q"), (J, "J"), (xd, "xd")):
        if type(value) is np.ndarray and value.dtype == np.float64 and value.flags.c_contiguous:
            arrays.append(value)
            continue
        if np.iscomplexobj(value):
            raise InvalidParameterError(f"{name} must be real; got a complex array")
        try:
            arrays.append(np.ascontiguousarray(value, dtype=np.float64))
        except (TypeError, ValueError) as exc:
            raise ShapeError(f"{name} must be an array of numbers; got {value!r}") from exc
    q, J, xd = arrays
    if q.shape != (n,):
        raise ShapeError(f"q must have shape ({n},); got shape {q.shape}")
    if xd.ndim != 1 or xd.shape[0] == 0:
        raise ShapeError(f"xd must be a non-empty vector; got shape {xd.shape}")
    if J.shape != (xd.shape[0], n):
        raise ShapeError(
            f"J must have shape ({xd.shape[0]}, {n}) to match xd and the robot's {n} joints; "
            f"got {J.shape}"
        )
    lane = _finite_lane[0]
    # (not the one to start compiling linalg behind: a hard-limit loop wants its own first)
    if lane is None and be.KERNELS.ready(start=False):
        warm = (np.zeros(1), np.zeros((1, 1)), np.zeros(1))
        lane = _finite_lane[0] = (
            be.kernels() and be.entry(be.KERNELS, "finite_inputs", warm)
        ) or False
    if lane:  # one compiled pass over the three
        bad = lane(q, J, xd)  # type: ignore[operator]
        if bad == 4:
            raise too_large("xd")
        if bad:
            raise NonFiniteError(f"{('q', 'J', 'xd')[bad - 1]} contains NaN or infinity")
        return q, J, xd
    for arr, name in ((q, "q"), (J, "J"), (xd, "xd")):
        if not _isfinite(arr).all():
            raise NonFiniteError(f"{name} contains NaN or infinity")
    check_rate(xd)
    return q, J, xd


# Native entry point of linalg's finite_inputs kernel (None: not looked up yet; False:
# NumPy checks while the kernels are off or compiling behind; reset when that changes).
_finite_lane: list[Callable[..., Any] | bool | None] = [None]
be._on_switch.append(lambda: _finite_lane.__setitem__(0, None))
