"""End-effector reference trajectories: pose, twist and acceleration at any time.

Every trajectory returns world-aligned quantities (docs/conventions.md): the pose ``T(t)``
(4x4), the twist ``[v; ω](t)`` and the acceleration ``[a; α](t)``. Position paths keep the
orientation of their start pose; :class:`MinimumJerk` moves both.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from .._validate import FloatArray, as_scalar, as_transform, as_vector
from ..errors import InvalidParameterError
from ..robot.chain import log3

#: Shortest period or duration accepted, s: shorter ones are not physical and overflow the
#: rates they set (a 5e-324 s period).
MIN_SECONDS = 1e-9


def _seconds(value: Any, name: str) -> float:
    """A period or duration in seconds, at least :data:`MIN_SECONDS`."""
    return as_scalar(value, name, minimum=MIN_SECONDS)


@dataclass(frozen=True)
class Sample:
    """A trajectory at one instant: ``pose`` (4x4), ``twist`` (6,), ``acceleration`` (6,)."""

    pose: FloatArray
    twist: FloatArray
    acceleration: FloatArray


def minimum_jerk(tau: float) -> tuple[float, float, float]:
    """Minimum-jerk time scaling ``s = 10τ³ − 15τ⁴ + 6τ⁵`` and its first two derivatives
    with respect to ``τ`` (Flash and Hogan, J. Neuroscience 5(7), 1985); ``τ`` clipped to
    [0, 1]."""
    t = min(max(tau, 0.0), 1.0)
    s = t**3 * (10.0 - 15.0 * t + 6.0 * t * t)
    ds = 30.0 * t * t * (1.0 - t) ** 2
    dds = 60.0 * t * (1.0 - t) * (1.0 - 2.0 * t)
    return s, ds, dds


def ramped_angle(t: float, w: float, r: float) -> tuple[float, float, float]:
    """Angle, rate and acceleration at ``t`` of a rate that rises from 0 to ``w`` (rad/s)
    over ``r`` seconds as ``w·s(t/r)`` (minimum-jerk ``s``), then stays: the angle is its
    integral, ``w·r·(2.5τ⁴ − 3τ⁵ + τ⁶)`` during the ramp, ``w·(t − r/2)`` after."""
    if r > 0.0 and t < r:
        tau = t / r
        s, ds, _ = minimum_jerk(tau)
        return w * r * (2.5 * tau**4 - 3.0 * tau**5 + tau**6), w * s, w * ds / r
    return w * (t - r / 2.0) if r > 0.0 else w * t, w, 0.0


class Trajectory(ABC):
    """A reference for a frame: :meth:`sample` at time ``t`` (s) from 0 to ``duration``."""

    duration: float

    @abstractmethod
    def sample(self, t: float) -> Sample:
        """Pose, twist and acceleration at time ``t``."""

    def then(self, following: Trajectory | Callable[[FloatArray], Trajectory]) -> Chain:
        """This trajectory, then ``following`` (a trajectory that starts where this one
        ends, or a function of this one's end pose that makes it):
        ``Line(T0, p1, 1.0).then(lambda T: Circle(T, 0.05, 2.0))``."""
        return Chain([self]).then(following)


def _plane_axes(normal: Any) -> tuple[FloatArray, FloatArray]:
    """Two orthonormal axes spanning the plane normal to ``normal`` (3 finite numbers, not
    all zero; scaled before normalising, so 1e-200 or 1e300 are directions too)."""
    n = as_vector(normal, "normal", 3)
    scale = float(np.abs(n).max())
    if scale == 0.0:
        raise InvalidParameterError(f"normal must be a non-zero vector; got {n}")
    nrm = n / scale
    nrm /= np.linalg.norm(nrm)
    helper = np.array([1.0, 0.0, 0.0]) if abs(nrm[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(nrm, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(nrm, u)


class _PlanarPath(Trajectory):
    """A periodic path in a plane through the start position, orientation held: the
    arguments :class:`Circle` and :class:`FigureEight` share, and their sampling."""

    def __init__(
        self, start_pose: Any, period: float, normal: Any, turns: float, ramp: float
    ) -> None:
        self.start_pose = as_transform(start_pose, "start_pose")
        self.period = _seconds(period, "period")
        self.ramp = as_scalar(ramp, "ramp", minimum=0.0)
        turns = as_scalar(turns, "turns", minimum=0.0, strict=True)
        self.duration = float(turns) * self.period + self.ramp / 2.0
        self._axes = _plane_axes(normal)

    def _planar(self, origin: FloatArray, coefficients: Any, basis: FloatArray) -> Sample:
        """A sample with ``coefficients`` (3 x 2) the position offset, velocity and
        acceleration in the plane's ``basis`` (2 x 3, rows e₁, e₂) from ``origin``; one
        matrix product gives all three (the per-step cost of a run)."""
        pva = np.array(coefficients) @ basis
        T = self.start_pose.copy()
        T[:3, 3] = origin + pva[0]
        twist, acc = np.zeros(6), np.zeros(6)
        twist[:3], acc[:3] = pva[1], pva[2]
        return Sample(T, twist, acc)


class Circle(_PlanarPath):
    """A circle through the start position at constant speed, orientation held.

    Args:
        start_pose: 4x4 pose where the circle starts (``robot.fk(q0)``).
        radius: m.
        period: time of one turn, s.
        normal: normal of the circle's plane (world), default world z.
        phase: direction from the start point to the centre, as an angle (rad) in the
            plane (0: along the plane's first axis).
        turns: number of turns (sets ``duration``).
        ramp: seconds over which the angular speed rises smoothly from zero (minimum-jerk
            profile of the angle), so the path starts without a velocity jump.
    """

    def __init__(
        self,
        start_pose: Any,
        radius: float,
        period: float,
        *,
        normal: Any = (0.0, 0.0, 1.0),
        phase: float = 0.0,
        turns: float = 1.0,
        ramp: float = 0.0,
    ) -> None:
        """A circle of ``radius`` (m) through ``start_pose``, one turn per ``period`` (s)."""
        super().__init__(start_pose, period, normal, turns, ramp)
        self.radius = as_scalar(radius, "radius", minimum=0.0, strict=True)
        phase = as_scalar(phase, "phase")
        u, v = self._axes
        to_center = np.cos(phase) * u + np.sin(phase) * v
        self.center = self.start_pose[:3, 3] + self.radius * to_center
        e1 = -to_center  # centre -> start
        self._basis = np.vstack([e1, np.cross(np.cross(u, v), e1)])  # u × v: the unit normal
        self.omega = 2.0 * np.pi / self.period

    def sample(self, t: float) -> Sample:
        a, da, dda = ramped_angle(t, self.omega, self.ramp)
        c, s = math.cos(a), math.sin(a)
        r = self.radius
        # radial = c e1 + s e2, tangent = -s e1 + c e2: position r·radial, velocity
        # r·da·tangent, acceleration r·dda·tangent − r·da²·radial.
        v, w = r * da, r * dda
        centripetal = r * da * da
        return self._planar(
            self.center,
            ((r * c, r * s), (-v * s, v * c), (-w * s - centripetal * c, w * c - centripetal * s)),
            self._basis,
        )


class FigureEight(_PlanarPath):
    """A figure eight (Gerono lemniscate) through the start position, orientation held:
    ``p = p₀ + a sin θ e₁ + (b/2) sin 2θ e₂``, ``θ = 2π t / period``.

    Args:
        start_pose: 4x4 start pose (the crossing point of the eight).
        width, height: ``a`` and ``b``, m.
        period: s per eight; ``turns`` sets the duration.
        normal: normal of the plane (world).
        ramp: seconds over which the speed rises smoothly from zero (as for
            :class:`Circle`), so the path starts without a velocity jump.
    """

    def __init__(
        self,
        start_pose: Any,
        width: float,
        height: float,
        period: float,
        *,
        normal: Any = (0.0, 0.0, 1.0),
        turns: float = 1.0,
        ramp: float = 0.0,
    ) -> None:
        """The arguments are described in ``help(FigureEight)``."""
        super().__init__(start_pose, period, normal, turns, ramp)
        self.width = as_scalar(width, "width", minimum=0.0)
        self.height = as_scalar(height, "height", minimum=0.0)
        self._basis = np.vstack(self._axes)
        self._origin = self.start_pose[:3, 3].copy()

    def sample(self, t: float) -> Sample:
        # θ(t), θ' and θ'' (a ramped rate as for Circle); p = (a sin θ, b sin 2θ), so
        # v = p_θ θ' and acc = p_θθ θ'² + p_θ θ''.
        th, dth, ddth = ramped_angle(t, 2.0 * math.pi / self.period, self.ramp)
        a, b = self.width, self.height / 2.0
        s1, c1, s2, c2 = math.sin(th), math.cos(th), math.sin(2.0 * th), math.cos(2.0 * th)
        return self._planar(
            self._origin,
            ((a * s1, b * s2), (a * c1 * dth, 2.0 * b * c2 * dth),
             (-a * s1 * dth**2 + a * c1 * ddth, -4.0 * b * s2 * dth**2 + 2.0 * b * c2 * ddth)),
            self._basis,
        )  # fmt: skip


class MinimumJerk(Trajectory):
    """Point to point in position and orientation with a minimum-jerk time law.

    ``p(t) = p₀ + s (p₁ − p₀)``; ``R(t) = R₀ exp(s [r]×)`` with ``r = log(R₀ᵀ R₁)``; so
    ``v = ṡ (p₁ − p₀)`` and ``ω = ṡ R₀ r`` (world), ``s = s(t / duration)``.
    """

    def __init__(self, start_pose: Any, end_pose: Any, duration: float) -> None:
        """Move from ``start_pose`` to ``end_pose`` (4x4 poses, m) in ``duration`` s."""
        self.start_pose = as_transform(start_pose, "start_pose")
        self.end_pose = as_transform(end_pose, "end_pose")
        self.duration = _seconds(duration, "duration")
        R0 = self.start_pose[:3, :3]
        self._dp = self.end_pose[:3, 3] - self.start_pose[:3, 3]
        self._r = log3(R0.T @ self.end_pose[:3, :3])
        self._r_world = R0 @ self._r

    def sample(self, t: float) -> Sample:
        s, ds, dds = minimum_jerk(t / self.duration)
        ds, dds = ds / self.duration, dds / self.duration**2
        T = np.eye(4)
        T[:3, :3] = self.start_pose[:3, :3] @ pin.exp3(s * self._r)
        T[:3, 3] = self.start_pose[:3, 3] + s * self._dp
        twist = np.concatenate([ds * self._dp, ds * self._r_world])
        accel = np.concatenate([dds * self._dp, dds * self._r_world])
        return Sample(T, twist, accel)


class Line(MinimumJerk):
    """A straight line from the start position to ``end`` (m, world), orientation held,
    with a minimum-jerk time law."""

    def __init__(self, start_pose: Any, end: Any, duration: float) -> None:
        """Move from ``start_pose`` (4x4) to the position ``end`` (m) in ``duration`` s."""
        T0 = as_transform(start_pose, "start_pose")
        T1 = T0.copy()
        T1[:3, 3] = as_vector(end, "end", 3)
        super().__init__(T0, T1, duration)


#: Largest jump, m, between a trajectory's end and the next one's start in a :class:`Chain`.
CHAIN_GAP = 1e-6


class Chain(Trajectory):
    """Trajectories one after the other: the first for its duration, then the next one
    from its own ``t = 0``, and so on. Each must start at the position where the one before
    ends (within :data:`CHAIN_GAP`): a jump would be a step of the reference.

    Args:
        parts: the trajectories, in order (at least one).

    Raises:
        InvalidParameterError: no parts, a part that is not a trajectory, or a jump.
    """

    def __init__(self, parts: Sequence[Trajectory]) -> None:
        self.parts: list[Trajectory] = []
        if not parts:
            raise InvalidParameterError("a Chain needs at least one trajectory")
        for part in parts:
            self._append(part)

    def _append(self, part: Any) -> None:
        if not isinstance(part, Trajectory):
            raise InvalidParameterError(f"a Chain holds trajectories; got {part!r}")
        if self.parts:
            gap = float(np.linalg.norm(part.sample(0.0).pose[:3, 3] - self.end_pose[:3, 3]))
            if gap > CHAIN_GAP:
                raise InvalidParameterError(
                    f"{type(part).__name__} starts {gap:.3g} m from where the chain ends; start "
                    "it at chain.end_pose (or pass a function of the end pose to then())"
                )
        parts = part.parts if isinstance(part, Chain) else [part]
        self.parts.extend(parts)
        self._starts = np.cumsum([0.0] + [p.duration for p in self.parts])
        self.duration = float(self._starts[-1])
        self.start_pose = self.parts[0].sample(0.0).pose

    @property
    def end_pose(self) -> FloatArray:
        """The pose at the chain's end, 4x4."""
        return self.sample(self.duration).pose

    def then(self, following: Trajectory | Callable[[FloatArray], Trajectory]) -> Chain:
        """A new chain: these parts, then ``following`` (see :meth:`Trajectory.then`)."""
        out = Chain(self.parts)
        out._append(following(self.end_pose) if callable(following) and not isinstance(
            following, Trajectory) else following)  # fmt: skip
        return out

    def sample(self, t: float) -> Sample:
        i = int(np.searchsorted(self._starts, t, side="right")) - 1
        i = min(max(i, 0), len(self.parts) - 1)
        return self.parts[i].sample(t - float(self._starts[i]))


class Hold(Trajectory):
    """Stay at one pose for ``duration`` seconds."""

    def __init__(self, pose: Any, duration: float) -> None:
        """Hold ``pose`` (4x4, m) for ``duration`` s."""
        self.start_pose = as_transform(pose, "pose")
        self.duration = _seconds(duration, "duration")

    def sample(self, t: float) -> Sample:
        return Sample(self.start_pose.copy(), np.zeros(6), np.zeros(6))
