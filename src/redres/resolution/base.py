"""One step of a redundancy-resolution scheme: task Jacobian and velocity in, joint
velocity and diagnostics out."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from .._validate import FloatArray, as_scalar
from ..errors import InvalidParameterError
from ..linalg import AdaptiveDamping, InverseInfo

if TYPE_CHECKING:
    from ..robot import Robot

InverseKind = Literal["exact", "svd", "damped", "adaptive"]
INVERSES: tuple[str, ...] = ("exact", "svd", "damped", "adaptive")


@dataclass(frozen=True)
class StepResult:
    """What a scheme returns for one control step.

    Attributes:
        qd: joint velocity, shape ``(n,)``, rad/s.
        info: diagnostics of the inverse used (``rank``, ``sigma_min``, ``sigma_max``,
            ``damping``, ``method``), from :mod:`redres.linalg`.
        null_term: the secondary (null-space) part of ``qd``, shape ``(n,)`` (zeros when
            the scheme has none).
        extra: scheme-specific diagnostics (joint weights, algorithmic singularity, ...).
    """

    qd: FloatArray
    info: InverseInfo
    null_term: FloatArray
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class InverseChoice:
    """Which inverse of the linear-algebra core a scheme uses.

    Attributes:
        kind: ``"exact"`` (right pseudo-inverse, truncated SVD if rank-deficient),
            ``"svd"`` (SVD pseudo-inverse skipping singular values below
            ``rcond·σ_max``, seed 002), ``"damped"`` (damped least squares with
            ``damping``), ``"adaptive"`` (zero damping while ``σ_min ≥ threshold``, rising to
            ``max_damping`` at the singularity).
        damping: λ of the damped inverse, units of J (m for position rows).
        max_damping, threshold: the adaptive law's λ_max and ε.
        rcond: relative cut of the SVD inverse.
    """

    kind: InverseKind = "exact"
    damping: float = 0.05
    max_damping: float = 0.1
    threshold: float = 0.05
    rcond: float = 1e-10

    def __post_init__(self) -> None:
        if self.kind not in INVERSES:
            raise InvalidParameterError(
                f"inverse must be one of {', '.join(INVERSES)}; got {self.kind!r}"
            )
        as_scalar(self.damping, "damping", minimum=0.0)
        as_scalar(self.max_damping, "max_damping", minimum=0.0)
        as_scalar(self.threshold, "threshold", minimum=0.0, strict=True)
        as_scalar(self.rcond, "rcond", minimum=0.0)

    def rate_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`redres.linalg.rate_step` for this inverse."""
        if self.kind == "damped":
            return {"damping": float(self.damping)}
        if self.kind == "adaptive":
            return {"damping": AdaptiveDamping(self.max_damping, self.threshold)}
        rcond = self.rcond if self.kind == "svd" else 1e-10
        return {"damping": 0.0, "rcond": float(max(rcond, 1e-10))}


def as_inverse(inverse: InverseChoice | str, **kwargs: Any) -> InverseChoice:
    """An :class:`InverseChoice` from a kind name (with parameters) or as given."""
    if isinstance(inverse, InverseChoice):
        return inverse
    return InverseChoice(inverse, **kwargs)  # type: ignore[arg-type]


class Scheme(ABC):
    """A redundancy-resolution scheme: ``step(robot, q, J, xd) -> StepResult``.

    ``J`` (``m x n``) and ``xd`` (``m``, the closed-loop task velocity ``ẋ_d + K e``) come
    from the primary task; the scheme adds what it resolves the redundancy with.
    """

    #: Stable identifier (``pinv``, ``dls``, ``gradient_projection``, ``wln``, ...).
    name: str = "scheme"
    #: Whether every ``q̇`` already respects the joint position, velocity and
    #: acceleration limits (the hard-limit schemes), so a loop need not scale it.
    hard_limits: bool = False

    @abstractmethod
    def step(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> StepResult:
        """Joint velocity for task Jacobian ``J`` and task velocity ``xd`` at ``q``."""

    def velocity(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> FloatArray:
        """Hot-path form of :meth:`step`: the joint velocity only (inputs checked alike).

        :meth:`last_result` gives the full :class:`StepResult` of the call. Schemes with a
        compiled step override this to skip building the result objects until asked; the
        default calls :meth:`step`. The returned array belongs to the caller.
        """
        self._last: StepResult | None = self.step(robot, q, J, xd)
        return self._last.qd

    def _velocity_unchecked(
        self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray
    ) -> FloatArray:
        """:meth:`velocity` for arrays already known to be float64, C-contiguous and of
        matching shapes (``q (n,)``, ``J (m, n)``, ``xd (m,)``), as the package's compiled
        loop (:class:`~redres.control.ClikController`) makes them: the schemes with
        compiled steps skip the checks. Internal (unchecked input); the default calls
        :meth:`velocity`."""
        return self.velocity(robot, q, J, xd)

    def last_result(self) -> StepResult:
        """The :class:`StepResult` of the last :meth:`velocity` call."""
        last: StepResult | None = getattr(self, "_last", None)
        if last is None:
            raise InvalidParameterError(f"{self.name}: no velocity() call yet")
        return last

    def reset(self) -> None:  # noqa: B027 - stateless schemes need nothing
        """Forget any state kept between steps (called at the start of a run)."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r})"


def zeros_like_qd(n: int) -> FloatArray:
    """A zero joint-velocity vector."""
    return np.zeros(n)
