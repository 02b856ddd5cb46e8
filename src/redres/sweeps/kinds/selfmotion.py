"""Tracing the self-motion manifold of a 7-DOF arm: the arm angles one IK solution can
reach within the joint limits without leaving its pose.

For a pose ``T`` of a 7-joint arm the configurations placing the frame at ``T`` form
curves in joint space (the self-motion manifolds; Burdick, "On the inverse kinematics of
redundant manipulators: characterization of the self-motion manifolds", ICRA 1989). From a
solution ``q₀`` the curve is followed by predictor–corrector continuation (Allgower &
Georg, *Numerical Continuation Methods*, 1990): the predictor steps ``h`` (rad, joint
space) along the unit null vector ``n`` of the 6×7 task Jacobian (the last right singular
vector, its sign kept from step to step), the corrector applies Newton steps ``Δq =
Jᵀ(JJᵀ)⁻¹ e`` on the pose error ``e = [p_d − p; log(R_d Rᵀ)]`` until ``‖e‖ < 1e-10``. Each
point's arm angle (:func:`redres.tasks.arm_angle.arm_angles` of batch poses) is unwrapped
along the curve. The trace runs in both directions until a joint leaves its limits — the
crossing is then located by bisection of the last step (to 1e-6 of it) — or the curve
returns to ``q₀`` (a closed loop inside the limits); the arm angles visited are one arc,
``[min, max]`` of the unwrapped angle (the whole circle when it spans ``2π``). Between
steps the angle's extremes are the samples', so an arm angle that turns back inside a step
is missed by at most its curvature times ``h²``; where the augmented Jacobian is regular
(the S-R-S arms) it does not turn back.

All items advance together: every step is one batch of compiled kinematics
(:func:`redres.batch.jacobian`) over the items still running.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ... import batch
from ...ik.arcs import TWO_PI, Arc
from ...robot.chain import log3
from ...tasks.arm_angle import ArmAngleTask, arm_angles

if TYPE_CHECKING:
    from ...robot import Robot

__all__ = ["BUDGET", "CLOSED", "LIMIT", "LOST", "Trace", "trace"]

#: How a direction of a trace ended: a joint met its limit, the loop closed, the step
#: budget ran out, the corrector failed (a singular task Jacobian).
LIMIT, CLOSED, BUDGET, LOST = 0, 1, 2, 3
_CORRECTED = 1e-10  # pose error (m, rad) the corrector reaches
_BISECTIONS = 16  # the crossing to 2**-16 of a step
_SMALL = 256  # items below which one thread is faster than a parallel launch


@dataclass(frozen=True)
class Trace:
    """Traced self-motion arcs, one per start.

    Attributes:
        lo, hi: extremes of the unwrapped arm angle visited, rad, ``(N,)``.
        ends: how each direction ended (:data:`LIMIT`, ...), ``(N, 2)``.
        steps: predictor steps taken, ``(N,)``.
        full: the curve closed with the arm angle once around the circle, ``(N,)`` (a
            closed curve whose arm angle comes back without a turn is the arc
            ``[lo, hi]``).
        q_ends: the last configuration of each direction, ``(N, 2, 7)``, rad (at a
            joint limit where that direction ended at one).
    """

    lo: np.ndarray
    hi: np.ndarray
    ends: np.ndarray
    steps: np.ndarray
    full: np.ndarray
    q_ends: np.ndarray

    def arc(self, i: int) -> Arc:
        """Item ``i``'s arc (``lo`` in ``[-π, π)``; ``(-π, π)`` for the whole circle)."""
        lo, hi = float(self.lo[i]), float(self.hi[i])
        if self.full[i] or hi - lo >= TWO_PI - 1e-12:
            return (-math.pi, math.pi)
        shift = TWO_PI * math.floor((lo + math.pi) / TWO_PI)
        return (lo - shift, hi - shift)


class _Chain:
    """The kinematics a trace needs, on the items given."""

    def __init__(self, robot: Robot, frame: str | None, threads: int | None) -> None:
        self.robot, self.frame, self.threads = robot, frame, threads

    def threads_for(self, count: int) -> int | None:
        return 1 if count < _SMALL else self.threads

    def jacobian(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        T = np.empty((len(q), 4, 4))
        J = batch.jacobian(self.robot, q, self.frame, poses=T, threads=self.threads_for(len(q)))
        return J, T

    def correct(
        self, q: np.ndarray, target: np.ndarray, iterations: int = 6
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Newton steps on the pose error: the corrected ``q``, its error norm and the
        Jacobian of the last evaluation (at ``q`` where the error was reached)."""
        q = q.copy()
        error = np.full(len(q), np.inf)
        J = np.zeros((len(q), 6, q.shape[1]))
        for _ in range(iterations):
            J, T = self.jacobian(q)
            rotation = log3(target[:, :3, :3] @ np.swapaxes(T[:, :3, :3], 1, 2))
            e = np.concatenate((target[:, :3, 3] - T[:, :3, 3], rotation), axis=1)
            error = np.linalg.norm(e, axis=1)
            busy = error > _CORRECTED
            if not busy.any():
                break
            Jb = J[busy]
            gram = Jb @ np.swapaxes(Jb, 1, 2) + 1e-14 * np.eye(6)
            q[busy] += np.einsum(
                "nji,nj->ni", Jb, np.linalg.solve(gram, e[busy][..., None])[..., 0]
            )
        return q, error, J


def _null(J: np.ndarray) -> np.ndarray:
    """Unit null vectors of 6×7 Jacobians ``(N, 6, 7)``: the last right singular vector."""
    return np.asarray(np.linalg.svd(J)[2][:, -1])


def trace(
    robot: Robot,
    T: np.ndarray,
    q_start: np.ndarray,
    *,
    frame: str | None = None,
    points: tuple[str, str, str] = ("shoulder", "elbow", "wrist"),
    reference: np.ndarray | None = None,
    step: float = 0.02,
    max_steps: int = 4000,
    threads: int | None = None,
) -> Trace:
    """Trace the self-motion arcs through the solutions ``q_start`` ``(N, 7)`` of the
    poses ``T`` ``(N, 4, 4)`` (module docstring); ``step`` is ``h``, rad."""
    chain = _Chain(robot, frame, threads)
    q0 = np.asarray(q_start, dtype=np.float64)
    count = len(q0)

    task = ArmAngleTask(*points, reference=(0.0, 0.0, 1.0) if reference is None else reference)

    def angle(q: np.ndarray) -> np.ndarray:
        threads = chain.threads_for(len(q))
        s, e, w = (batch.fk(robot, q, f, threads=threads)[:, :3, 3]
                   for f in (task.shoulder, task.elbow, task.wrist))  # fmt: skip
        return arm_angles(s, e, w, task.reference)

    phi0 = angle(q0)
    lo, hi = phi0.copy(), phi0.copy()
    ends = np.full((count, 2), BUDGET, dtype=np.int64)
    steps = np.zeros(count, dtype=np.int64)
    full = np.zeros(count, dtype=bool)
    q_ends = np.repeat(q0[:, None], 2, axis=1)
    J0 = chain.jacobian(q0)[0]
    n0 = _null(J0)
    for side, sign in enumerate((1.0, -1.0)):
        q, n_prev, Jq = q0.copy(), sign * n0, J0.copy()
        phi, unwrapped = phi0.copy(), phi0.copy()
        left = np.zeros(count, dtype=bool)
        active = ~(ends[:, 0] == CLOSED) if side else np.ones(count, dtype=bool)
        for _ in range(max_steps):
            rows = np.flatnonzero(active)
            if not len(rows):
                break
            n = _null(Jq[rows])
            n *= np.where(np.sum(n * n_prev[rows], axis=1) < 0.0, -1.0, 1.0)[:, None]
            moved, error, Jq[rows] = chain.correct(q[rows] + step * n, T[rows])
            steps[rows] += 1
            lost = error > 1e-8
            out = ((moved < robot.q_min) | (moved > robot.q_max)).any(axis=1) & ~lost
            if out.any():
                hit = rows[out]
                end = _locate(chain, robot, q[hit], n[out], T[hit], step)
                moved[out] = end
            new_phi = angle(moved)
            unwrapped[rows] += np.pi - np.mod(np.pi - (new_phi - phi[rows]), TWO_PI)
            phi[rows] = new_phi
            ok = ~lost
            lo[rows[ok]] = np.minimum(lo[rows[ok]], unwrapped[rows[ok]])
            hi[rows[ok]] = np.maximum(hi[rows[ok]], unwrapped[rows[ok]])
            q[rows], n_prev[rows] = moved, n
            distance = np.linalg.norm(moved - q0[rows], axis=1)
            left[rows] |= distance > 3.0 * step
            closed = left[rows] & (distance < 1.5 * step) & ~out & ~lost
            full[rows[closed]] = np.abs(unwrapped[rows[closed]] - phi0[rows[closed]]) > np.pi
            for flag, code in ((out, LIMIT), (closed, CLOSED), (lost, LOST)):
                ends[rows[flag], side] = code
                active[rows[flag]] = False
        q_ends[:, side] = q
    return Trace(lo, hi, ends, steps, full, q_ends)


def _locate(chain: _Chain, robot: Robot, q: np.ndarray, n: np.ndarray, T: np.ndarray,
            step: float) -> np.ndarray:  # fmt: skip
    """The point of the curve where the step from ``q`` along ``n`` leaves the limits:
    bisection on the step's fraction; the last corrected point within the limits."""
    below, above = np.zeros(len(q)), np.ones(len(q))
    best = q.copy()
    for _ in range(_BISECTIONS):
        mid = (below + above) / 2.0
        trial = chain.correct(q + (mid * step)[:, None] * n, T)[0]
        inside = ((trial >= robot.q_min) & (trial <= robot.q_max)).all(axis=1)
        below, above = np.where(inside, mid, below), np.where(inside, above, mid)
        best[inside] = trial[inside]
    return best
