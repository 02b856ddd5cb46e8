"""Collision avoidance as a hard constraint: the velocity damper.

For every pair closer than the influence distance ``d_i`` (Faverjon & Tournassoud 1987;
Kanoun, Lamiraux, Wieber 2011, §IV)::

    ḋ = n̂ᵀ (J_a − J_b) q̇  ≥  −ξ (d − d_s) / (d_i − d_s)

one row linear in ``q̇``: at ``d_i`` the pair may approach at ``ξ`` (m/s), the allowed
approach speed falls linearly to zero at the safety distance ``d_s``, and below ``d_s`` the
row demands separation. Over a period ``dt`` the linearised distance obeys
``d⁺ − d_s ≥ (1 − ξ dt/(d_i − d_s)) (d − d_s)``: a pair never crosses ``d_s`` while
``ξ dt ≤ d_i − d_s`` (checked by the scheme), up to the second-order change of ``d``
over one step, and as long as no pair farther than ``d_i`` closes the gap ``d_i − d_s``
within one period (the joint velocity limits must keep every link point's travel per
period below it: the QP scheme refuses a robot without velocity limits).

References:
    B. Faverjon, P. Tournassoud, "A local based approach for path planning of
    manipulators with a high number of degrees of freedom", ICRA 1987, 1152–1159.
    O. Kanoun, F. Lamiraux, P.-B. Wieber, "Kinematic control of redundant manipulators:
    generalizing the task-priority framework to inequality tasks", IEEE Trans. Robotics
    27(4) (2011) 785–792.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_scalar
from ..errors import InvalidParameterError
from .distances import CollisionModel
from .pairs import Pair

if TYPE_CHECKING:
    from ..robot import Capsule, Robot

#: Default gain ξ of the damper, m/s (:class:`Collisions`).
DEFAULT_GAIN = 0.5
#: A collision row counts as binding when ``ḋ`` is within this of its bound, m/s.
BINDING_TOLERANCE = 1e-7


@dataclass(frozen=True)
class CollisionDetails:
    """The collision part of a QP step's details.

    Attributes:
        active: the pairs closer than ``d_i``, one constraint row each.
        distances: their signed distances, ``(len(active),)``, m.
        closest: the closest pair within the broad phase and its distance (m), or None
            when no pair is within ``d_i`` of the other's bounding sphere.
        binding: the active pairs whose row the answer sits on (``ḋ`` at its bound).
    """

    active: list[Pair]
    distances: FloatArray
    closest: tuple[Pair, float] | None
    binding: list[Pair] = field(default_factory=list)

    @property
    def bound(self) -> bool:
        """Whether a collision row was binding."""
        return bool(self.binding)


class Collisions:
    """Settings of collision avoidance as a hard constraint (:class:`~redres.resolution.QPScheme`).

    Args:
        obstacles: spheres, points, capsules, boxes and half-spaces, world coordinates
            (:mod:`redres.collision.shapes`).
        influence: ``d_i``, m: pairs farther apart are not constrained.
        safety: ``d_s``, m, ``0 ≤ d_s < d_i``: the distance never crossed.
        gain: ``ξ``, m/s: the approach speed allowed at ``d_i``. Default
            :data:`DEFAULT_GAIN` = 0.5 m/s: with the default ``d_i − d_s = 0.09`` m the
            distance's excess over ``d_s`` decays no faster than with a time constant of
            ``(d_i − d_s)/ξ = 0.18`` s, slower than an arm's joint-velocity limits
            allow (a link moves at 1–2 m/s), so the approach is braked over several
            periods rather than stopped in one (which the acceleration limits would
            forbid), and the discrete-time bound ``ξ dt ≤ d_i − d_s`` holds up to
            ``dt = 0.18`` s.
        self_collision: also constrain pairs of link capsules.
        allowed: pairs of names (capsule, link frame or obstacle) never checked.
        srdf: an SRDF (path or XML text) whose ``disable_collisions`` are allowed too.
        capsules: link capsules (default ``robot.capsules``).

    Raises:
        InvalidParameterError: ``safety`` not below ``influence``, a negative value.
    """

    def __init__(
        self,
        obstacles: Sequence[Any] = (),
        *,
        influence: float = 0.10,
        safety: float = 0.01,
        gain: float = DEFAULT_GAIN,
        self_collision: bool = True,
        allowed: Sequence[Sequence[str]] = (),
        srdf: str | Path | None = None,
        capsules: Sequence[Capsule] | None = None,
    ) -> None:
        """The arguments are described in ``help(Collisions)``."""
        self.obstacles = list(obstacles)
        self.influence = as_scalar(influence, "influence", minimum=0.0, strict=True)
        self.safety = as_scalar(safety, "safety", minimum=0.0)
        if self.safety >= self.influence:
            raise InvalidParameterError(
                f"safety (d_s = {self.safety} m) must be below influence (d_i = {self.influence} m)"
            )
        self.gain = as_scalar(gain, "gain", minimum=0.0, strict=True)
        self.self_collision = bool(self_collision)
        self.allowed = [tuple(p) for p in allowed]
        self.srdf = srdf
        self.capsules = None if capsules is None else list(capsules)
        self._model: CollisionModel | None = None

    def __repr__(self) -> str:
        return (f"Collisions({len(self.obstacles)} obstacles, influence={self.influence}, "
                f"safety={self.safety}, gain={self.gain}, self={self.self_collision})")  # fmt: skip

    @property
    def rate(self) -> float:
        """The damper's slope ``−ξ/(d_i − d_s)``, 1/s."""
        return -self.gain / (self.influence - self.safety)

    def bound(self, distance: Any) -> Any:
        """The damper's bound on ``ḋ`` at ``distance`` (m): ``−ξ (d − d_s)/(d_i − d_s)``,
        m/s (a row holds when ``ḋ`` is at least this)."""
        return self.rate * (distance - self.safety)

    def check_period(self, dt: float) -> None:
        """Refuse a period over which the damper could step past ``d_s``
        (``ξ dt > d_i − d_s``, module docstring).

        Raises:
            InvalidParameterError: the period is too long for the gain.
        """
        if self.gain * dt > self.influence - self.safety:
            raise InvalidParameterError(
                f"collisions: gain·dt = {self.gain * dt:.3g} m exceeds influence − safety = "
                f"{self.influence - self.safety:.3g} m: a pair could cross the safety "
                "distance in one step; lower the gain or the period"
            )

    def model(self, robot: Robot) -> CollisionModel:
        """The :class:`CollisionModel` of ``robot`` (built once per robot)."""
        if self._model is None or self._model.robot is not robot:
            self._model = CollisionModel(
                robot, self.obstacles, capsules=self.capsules,
                self_collision=self.self_collision, allowed=self.allowed, srdf=self.srdf,
                safety=self.safety,
            )  # fmt: skip
        return self._model

    def damper(self, robot: Robot, G: FloatArray, lower: FloatArray) -> DamperRows:
        """The rows ``G q̇ ≥ lower`` of ``robot``'s pairs, written into ``G`` ``(P, n)``
        and ``lower`` ``(P,)`` (C-contiguous float arrays the caller owns, e.g. views
        into a QP's matrices) at each :meth:`DamperRows.update`."""
        return DamperRows(self, self.model(robot), G, lower)


class DamperRows:
    """The velocity-damper rows of every pair of a :class:`CollisionModel`, one row per
    pair at a fixed position, refreshed in place (:meth:`Collisions.damper`): a pair
    farther than ``d_i`` keeps its row with no bound (``lower = −1e30``), so a QP solver
    warm-started from one step to the next sees the same rows.

    Attributes:
        G: ``∂d/∂q`` of every pair, ``(P, n)``, m/rad (zero for a pair beyond the broad
            phase).
        lower: ``−ξ (d − d_s)/(d_i − d_s)`` for the pairs closer than ``d_i``, m/s;
            ``−1e30`` for the others.
        active: how many pairs are closer than ``d_i`` at the last :meth:`update`.
        bound: whether the answer of the last :meth:`details` call sits on a row.
    """

    def __init__(
        self, collisions: Collisions, model: CollisionModel, G: FloatArray, lower: FloatArray
    ) -> None:
        self.model, self.G, self.lower = model, G, lower
        self.influence, self.safety = collisions.influence, collisions.safety
        self.rate = collisions.rate
        self.active, self.bound = 0, False

    def update(self, q: FloatArray) -> int:
        """The rows at ``q`` (a float vector of size ``n``, checked by the caller), in one
        compiled call; returns :attr:`active`."""
        self.active = self.model.damper(q, self.influence, self.safety, self.rate, self.G,
                                        self.lower)  # fmt: skip
        return self.active

    def violated(self, qd: FloatArray) -> bool:
        """Whether ``qd`` breaks a row (beyond round-off)."""
        if not self.active:
            return False
        slack = self.G @ qd
        slack -= self.lower  # ~1e30 for a row without bound
        return bool(slack.min() < -1e-12)

    def details(self, qd: FloatArray) -> Callable[[], CollisionDetails]:
        """The :class:`CollisionDetails` of a step that answered ``qd``, built on first
        call (what it needs is copied now: the next :meth:`update` overwrites the rows)."""
        found = self.model.last(self.G)
        d = found.distance.copy()
        slack = self.G @ qd - self.lower if self.active else None
        #: whether ``qd`` sits on a row (``ḋ`` within BINDING_TOLERANCE of its bound)
        self.bound = slack is not None and bool(slack.min() <= BINDING_TOLERANCE)
        resolved, pairs_all, influence = found.resolved, found.pairs, self.influence

        def build() -> CollisionDetails:
            active = np.flatnonzero(d < influence)
            pairs = [pairs_all[i] for i in active]
            binding = ([pairs_all[i] for i in active if slack[i] <= BINDING_TOLERANCE]
                       if slack is not None else [])  # fmt: skip
            k = int(np.argmin(d)) if resolved else -1
            closest = (pairs_all[k], float(d[k])) if k >= 0 else None
            return CollisionDetails(pairs, d[active], closest, binding)

        return build
