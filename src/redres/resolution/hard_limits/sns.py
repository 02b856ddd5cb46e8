"""Saturation in the null space (SNS): hard joint limits without a QP solver.

Flacco, De Luca and Khatib (2015, Algorithm 1) solve ``J q̇ = ẋ`` inside the joint-velocity
box ``lower ≤ q̇ ≤ upper`` of :mod:`~redres.resolution.hard_limits.box` as follows. Start with every
joint free (``W = I``) and the null-space velocity ``q̇_N`` equal to the secondary velocity
``q̇_0`` (zero without objectives); repeat:

1. ``q̇ = q̇_N + (J W)⁺ (ẋ − J q̇_N)`` — the task solved with the free joints only (``W``
   selects them; ``(J W)⁺ = W Jᵀ (J W Jᵀ)⁻¹``, computed by a Cholesky solve with one step
   of iterative refinement). If ``q̇`` is inside the box, stop: the task is met exactly.
2. Otherwise write ``q̇(s) = s a + b`` with ``a = (J W)⁺ ẋ``, ``b = q̇ − a`` and find the
   largest ``s ∈ [0, 1]`` that keeps the free joints in the box (Algorithm 2, the task
   scaling factor); remember the best ``(s, W, q̇_N)`` seen.
3. Saturate the *most critical joint* (the first to reach its bound as ``s`` grows; the
   worst violator if none limits ``s``): ``W_jj = 0``, ``q̇_N,j`` = the bound it crosses.
4. When the task leaves the range of ``J W`` (the residual of step 1 is not at rounding
   level), it cannot be met: return the best remembered solution with the task scaled by
   ``s`` (``J q̇ = s ẋ``, same direction). A rank-deficient ``J W`` alone does not end the
   loop: ``(J W)⁺`` then comes from ``J W Jᵀ + δ I`` (``δ = 1e-12 ×`` its largest
   diagonal), refined to the least-squares solution, so that a task in the range of an
   exactly singular ``J`` is still met (issue 18, item 3).

The greedy choice of saturated joints does not always find the largest feasible scale
(nor a feasible solution whenever one exists; on random boxes it misses in about one
case in four). So when step 4 is reached, this implementation also solves the linear
program of :mod:`.lp` exactly and keeps the SNS solution if its scale is that maximum,
the simplex vertex otherwise: the returned scale is the largest feasible one (tests check
it against a brute-force line search). If no scale in ``[0, 1]`` is feasible (the joints
cannot change their velocities fast enough to move along ``ẋ`` at all), the result is
the LP's nearest velocity, reported as infeasible.

With objectives the secondary velocity is ``q̇_0 = −k_null Σ wᵢ ∇Dᵢ(q)`` (DESIGN.md convention);
on the free joints SNS then gives the gradient projection ``q̇_0 + (J W)⁺(ẋ − J q̇_N)``. If
the task cannot be met with ``q̇_0``, SNS is rerun without it (the secondary goal gives way
first).

References:
    F. Flacco, A. De Luca, O. Khatib, "Control of redundant robots under hard joint
    constraints: saturation in the null space", IEEE Trans. Robotics 31(3) (2015) 637–654.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ... import _compile
from ..._validate import FloatArray, as_scalar, checked_keywords
from ...linalg._status import raise_status
from ..base import StepResult
from ..gradient_projection import WeightedObjective
from ._codes import FEASIBLE, LP_SCALED, METHODS, NEAREST, SCALED
from ._compiled import kernels, pending
from ._solvers import orthonormal_rows
from .base import STEP_NAMES, BoxScheme, Workspace, box_details, task_met

if TYPE_CHECKING:
    from ...robot import Robot


@dataclass(frozen=True)
class SNSDetails:
    """What an SNS step adds to its :class:`~redres.resolution.StepResult`.

    Attributes:
        scale: ``s`` with ``J q̇ = s ẋ`` (1: the task is met; 0 when no scale is feasible).
        method: the outcome (a result, not an error): ``"sns"`` (Algorithm 1 met the
            task), ``"sns-scaled"`` (its scaled solution has the largest scale), ``"lp"``
            (the simplex vertex, when the greedy saturation missed the largest scale),
            ``"nearest"`` (no scale in ``[0, 1]`` is feasible) or ``"failed"``.
        bounds: the joint-velocity box ``(lower, upper)``, two ``(n,)`` arrays, rad/s.
        relaxed: joints whose box had to give up a limit.
    """

    scale: float
    method: str
    bounds: tuple[FloatArray, FloatArray]
    relaxed: list[int]


class SNSScheme(BoxScheme):
    """Saturation in the null space (Flacco, De Luca, Khatib 2015) within hard limits.

    Each step solves the task inside the box of
    :func:`~redres.resolution.hard_limits.velocity_bounds` (module docstring), so a run
    through :func:`redres.control.run` at the period ``dt`` keeps every limit, to rounding.

    Args:
        dt: control period, s; must equal the ``dt`` of the loop that applies ``q̇``.
        objectives: optional secondary costs (each ``obj`` or ``(obj, weight)``); their
            velocity ``−k_null Σ wᵢ ∇Dᵢ`` is used on the free joints while the task allows.
        k_null: null-space gain of the secondary velocity, 1/s (per unit of cost gradient).
        qd_max, qdd_max: velocity / acceleration limits replacing the robot's (scalar or
            ``(n,)``; e.g. ``qdd_max`` for a model without acceleration limits).
        tolerance: slack of the box tests inside the algorithm, rad/s (the output is
            clipped into the exact box).

    Identifier ``sns``. State: the previous joint velocity ``qd_prev`` (``None`` = at
    rest; :meth:`reset` clears it, so a run starts at rest). ``StepResult.feasible``:
    ``s = 1``, the task is met exactly; ``binding``: the
    :class:`~redres.resolution.hard_limits.Binding` bounds ``q̇`` sits on; ``details``: an
    :class:`SNSDetails` (scale, method, box, relaxed joints). ``null_term`` is the
    component of ``q̇`` in the null space of ``J``; ``info`` gives the singular values and
    rank of ``J`` (:mod:`redres.linalg`'s rule, ``σ > RCOND·σ_max``).
    """

    name = "sns"

    @checked_keywords
    def __init__(
        self,
        dt: float = 1e-3,
        *,
        objectives: Sequence[WeightedObjective] = (),
        k_null: float = 1.0,
        qd_max: ArrayLike | None = None,
        qdd_max: ArrayLike | None = None,
        tolerance: float = 1e-12,
    ) -> None:
        """The arguments are described in ``help(SNSScheme)``."""
        self._init_box(dt, objectives, k_null, qd_max, qdd_max)
        self.tolerance = as_scalar(tolerance, "tolerance", minimum=0.0)

    def _prepare(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> None:
        ws = Workspace(self.limits(robot), J.shape[0])
        args = (q, ws.zero, self.dt, ws.lim, J, xd, ws.zero, False, self.tolerance,
                *ws.outputs(), ws.M, ws.wm, ws.wn, ws.wb)  # fmt: skip
        self._kernel = _compile.entry_point(kernels().sns_step, args)
        self._finish = _compile.entry_point(kernels().epilogue, (J, xd, ws.outputs()[0], ws.wm))
        self._ws, self._robot, self._pending = ws, robot, pending("_kernels")

    @staticmethod
    def _orthonormal_lp(
        J: FloatArray, xd: FloatArray, out: FloatArray, method: int, s: float
    ) -> tuple[int, float]:
        """Near a singularity the simplex on ``J``'s nearly dependent rows may miss the
        largest scale: the LP again on the orthonormal rows ``Vᵀ q̇ = s S⁻¹Uᵀ ẋ``
        (:func:`._solvers.orthonormal_rows`), taken when its scale is larger (writes
        ``out[0]``). Returns ``(method, scale)``."""
        rows = orthonormal_rows(J, xd)
        if rows is None or not np.all(np.isfinite(rows[1])) or rows[0].shape[0] == 0:
            return method, s
        lo, hi = out[2], out[3]
        qd = np.empty(J.shape[1])
        found, scale = kernels("_lp_kernels").largest_scale(rows[0], rows[1], lo, hi, qd,
                                                            False, 0.0)  # fmt: skip
        if found == LP_SCALED and scale > s:
            out[0] = np.minimum(np.maximum(qd, lo), hi)
            return LP_SCALED, float(scale)
        return method, s

    def _step(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> StepResult:
        ws, qd0, prev = self._inputs(robot, q, J, xd)
        out, codes, Jc = ws.outputs()
        status, *outcome = self._kernel(
            q, prev, self.dt, ws.lim, J, xd, qd0, bool(self.objectives), self.tolerance,
            out, codes, Jc, ws.M, ws.wm, ws.wn, ws.wb,
        )  # fmt: skip
        if status:  # an input is not finite (redres.linalg's status codes)
            raise_status(status, STEP_NAMES)
        return self._finished(J, xd, out, codes, Jc, *outcome)

    def _finished(
        self, J: FloatArray, xd: FloatArray, out: FloatArray, codes: NDArray[np.int8],
        Jc: FloatArray, method: int, s: float, relaxed: int, active: int, met: bool,
        ill: bool, full: bool, keep: bool = True,
    ) -> StepResult:  # fmt: skip
        """The step's result from the SNS kernel's outcome (``sns_step``'s tuple past its
        status, for ``out``, ``codes``, ``Jc``), after the LP on orthonormal rows where
        ``J`` may be ill-conditioned (then ``out[0]`` changes); ``q̇`` becomes
        :attr:`qd_prev` when ``keep``. Shared with the controller's compiled step
        (:mod:`redres.control._box_kernels`)."""
        ws = self._ws
        s = 0.0 if method == NEAREST else s
        if ill and (method != LP_SCALED or s == 1.0):  # the LP may have missed the task
            s = 0.0 if s == 1.0 else s  # a scale the answer does not achieve
            method, s = self._orthonormal_lp(J, xd, out, method, s)
            active, _ = self._finish(J, xd, out, ws.wm)  # the new q̇'s
            met = task_met(J, xd, out[0])
        if method != FEASIBLE and method != SCALED:  # the flag and scale mean "task met"
            s = 1.0 if met else min(s, 1.0 - 1e-16)
        return self._result(
            out, codes, Jc, met, active,
            lambda: SNSDetails(s, METHODS[method], *box_details(out, codes, relaxed)), keep,
        )  # fmt: skip
