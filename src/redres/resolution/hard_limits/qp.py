"""Hard joint limits by quadratic programming (the approach of pink and mink), exact tasks.

Each step the joint-velocity box ``lower ≤ q̇ ≤ upper`` of
:mod:`~redres.resolution.hard_limits.box` (position, velocity and acceleration limits over
one period) is computed, and the task is resolved inside it as a lexicographic sequence of
QPs (Kanoun, Lamiraux, Wieber 2011; Escande, Mansard, Wieber 2014):

1. **Exact** — ``min ½‖q̇ − q̇_0‖²  s.t.  J q̇ = ẋ,  lower ≤ q̇ ≤ upper``.
   ``q̇_0 = −k_null Σ wᵢ ∇Dᵢ`` is the secondary velocity (zero without objectives).
   Without active bounds the solution is ``J⁺ẋ + (I − J⁺J) q̇_0``, gradient projection;
   with active bounds it is the closest velocity to ``q̇_0`` that still meets the task
   exactly.
2. **Least violating**, only when 1 is infeasible (the task cannot be met within the
   limits, or ``J`` is singular) — ``min ½‖J q̇ − ẋ‖²_W + ½λ²‖q̇ − q̇_0‖²  s.t.  the box``: the
   weighted task residual plus a small regularisation ``λ`` (``damping``). The box is
   never empty (see :mod:`~redres.resolution.hard_limits.box`), so this QP is always
   feasible and the step never raises inside a control loop; ``StepResult.binding`` lists
   the bounds the answer sits on. After an infeasible step this QP is tried first, and the
   exact one is skipped when the residual ``r = ẋ − J q̇`` proves the task infeasible
   (Farkas' lemma: ``rᵀẋ > max_box rᵀJ q̇``).

With ``collisions`` (:class:`~redres.collision.Collisions`), every pair of link capsules
and obstacles (or two link capsules) closer than the influence distance ``d_i`` adds the
velocity damper ``n̂ᵀ(J_a − J_b) q̇ ≥ −ξ (d − d_s)/(d_i − d_s)`` (Faverjon & Tournassoud
1987; Kanoun, Lamiraux, Wieber 2011; :mod:`redres.collision.constraint`) to both QPs,
beside the box: the task yields (``feasible=False``), the rows never do. When the box and
the rows admit no velocity together (the acceleration limits cannot brake an approach in
one period), the acceleration limits yield first, then the rest of the box; the rows are
kept in every case (:meth:`QPScheme._collide`).

With ``levels`` (lower-priority tasks, each evaluated at ``q`` by the scheme and commanded
``ẋ_d + gain·e``), level ``k`` is solved by the same two QPs with the velocities achieved by
the levels above held as equality constraints, ``J_i q̇ = J_i q̇*_i`` for ``i < k`` (a
sequence of QPs; a lower level never disturbs a higher one).

The QPs go through qpsolvers' backends (extra ``qp``: ``pip install -e '.[qp]'``).
The default backend, DAQP (Arnström, Bemporad, Axehill 2022, a dual active-set solver for
small dense QPs), is called directly with the dense matrices qpsolvers would build: the
solve takes about a microsecond, qpsolvers' generic conversions about twenty. Any other
qpsolvers backend (``"proxqp"``, ...) is used through :func:`qpsolvers.solve_problem`
(:mod:`._solvers`).

References:
    O. Kanoun, F. Lamiraux, P.-B. Wieber, "Kinematic control of redundant manipulators:
    generalizing the task-priority framework to inequality tasks", IEEE Trans. Robotics
    27(4) (2011) 785–792.
    A. Escande, N. Mansard, P.-B. Wieber, "Hierarchical quadratic programming: fast online
    humanoid-robot motion generation", Int. J. Robotics Research 33(7) (2014) 1006–1028.
    D. Arnström, A. Bemporad, D. Axehill, "A dual active-set solver for embedded quadratic
    programming using recursive LDLᵀ updates", IEEE Trans. Automatic Control 67(8) (2022).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ... import _compile
from ..._validate import FloatArray, as_scalar, as_vector, checked_keywords
from ...collision import CollisionDetails, Collisions
from ...errors import InvalidParameterError, ShapeError
from ...linalg._status import raise_status
from ...tasks import Task, stack
from ..base import StepResult
from ..gradient_projection import WeightedObjective
from ._codes import MET_TOLERANCE
from ._compiled import kernels, pending
from ._solvers import QPSolver, WarmQP, sense, solve_exact, solve_levels
from .base import STEP_NAMES, BoxScheme, Workspace, box_details, task_met

_MET2 = MET_TOLERANCE * MET_TOLERANCE
_INF = 1e30  # DAQP's infinity (an absent bound)

if TYPE_CHECKING:
    from ..._toml import ScenarioParams
    from ...robot import Robot


@dataclass(frozen=True)
class QPDetails:
    """What a QP step adds to its :class:`~redres.resolution.StepResult`.

    Attributes:
        residual: ``‖J q̇ − ẋ‖`` of the loop's task.
        level_residuals: the same for every level, the loop's task first.
        bounds: the joint-velocity box ``(lower, upper)``, two ``(n,)`` arrays, rad/s.
        relaxed: joints whose box had to give up a limit.
        solver: the QP backend.
        collisions: with ``collisions``: the active pairs, the closest pair and the
            binding rows (:class:`~redres.collision.CollisionDetails`); else None.
    """

    residual: float
    level_residuals: list[float]
    bounds: tuple[FloatArray, FloatArray]
    relaxed: list[int]
    solver: str
    collisions: CollisionDetails | None = None


class QPScheme(BoxScheme):
    """Joint velocity by a sequence of QPs inside hard position, velocity, acceleration limits.

    Args:
        dt: control period, s; must equal the ``dt`` of the loop that applies ``q̇``.
        objectives: optional secondary costs (``obj`` or ``(obj, weight)``), giving the
            target velocity ``q̇_0 = −k_null Σ wᵢ ∇Dᵢ``.
        k_null: null-space gain of the secondary velocity, 1/s (per unit of cost gradient).
        levels: lower-priority tasks (each a task or a list of tasks, stacked), highest
            first, evaluated at ``q``; their command is ``ẋ_d + gain·e``.
        gain: CLIK gain of the levels, 1/s.
        task_weights: diagonal weights of the task residual in the least-violating QP,
            shape ``(m,)`` (default ones).
        damping: ``λ`` of the least-violating QP (units of ``J``), > 0.
        solver: qpsolvers backend name (default ``"daqp"``).
        solver_options: keyword settings passed to the backend (e.g. ``{"eps_abs": 1e-9}``
            for ProxQP; DAQP gets ``primal_tol=1e-10`` unless given).
        qd_max, qdd_max: limits replacing the robot's (scalar or ``(n,)``).
        collisions: collision avoidance as a hard constraint (module docstring; DAQP, one
            level).

    Raises:
        MissingDependencyError: qpsolvers or the backend is not installed (names the
            ``qp`` extra).
        InvalidParameterError: ``collisions`` with ``levels`` or another backend than
            DAQP, or a period too long for its gain.

    Identifier ``qp``. State: the previous joint velocity ``qd_prev`` (:meth:`reset`
    clears it). ``StepResult.feasible``: every level met exactly; ``binding``: the bounds
    ``q̇`` sits on; ``details``: a :class:`QPDetails` (residuals, box, relaxed joints,
    solver, collision pairs). ``info`` gives the singular values and rank of ``J``
    (:mod:`redres.linalg`'s rule); ``null_term`` the component of ``q̇`` in its null space.
    """

    name = "qp"

    @checked_keywords
    def __init__(
        self,
        dt: float = 1e-3,
        *,
        objectives: Sequence[WeightedObjective] = (),
        k_null: float = 1.0,
        levels: Sequence[Task | Sequence[Task]] = (),
        gain: float = 10.0,
        task_weights: ArrayLike | None = None,
        damping: float = 1e-3,
        solver: str = "daqp",
        solver_options: dict[str, Any] | None = None,
        qd_max: ArrayLike | None = None,
        qdd_max: ArrayLike | None = None,
        collisions: Collisions | None = None,
    ) -> None:
        """The arguments are described in ``help(QPScheme)``."""
        self._init_box(dt, objectives, k_null, qd_max, qdd_max)
        self.levels = [[lv] if isinstance(lv, Task) else list(lv) for lv in levels]
        if any(not lv or not all(isinstance(t, Task) for t in lv) for lv in self.levels):
            raise InvalidParameterError("each level must be a Task or a non-empty list of Tasks")
        self.tasks = tuple(t for level in self.levels for t in level)
        self.gain = as_scalar(gain, "gain", minimum=0.0)
        self.task_weights = None if task_weights is None else as_vector(task_weights,
                                                                        "task_weights")  # fmt: skip
        if self.task_weights is not None and np.any(self.task_weights <= 0):
            raise InvalidParameterError(f"task_weights must be > 0; got {self.task_weights}")
        self.damping = as_scalar(damping, "damping", minimum=0.0, strict=True)
        self._qp = QPSolver(solver, solver_options)
        self.solver, self.solver_options = self._qp.name, self._qp.options
        self._infeasible_before = self._rows_infeasible = self._rows_bound = False
        if collisions is not None and not isinstance(collisions, Collisions):
            raise InvalidParameterError(
                f"collisions must be a redres.Collisions(...); got {type(collisions).__name__}"
            )
        if collisions is not None and (self.levels or not self._qp.daqp):
            raise InvalidParameterError(
                "collisions work with the DAQP backend and one level (no levels=) today"
            )
        if collisions is not None:
            collisions.check_period(as_scalar(dt, "dt"))
        self.collisions = collisions

    @classmethod
    def from_scenario(cls, params: ScenarioParams) -> QPScheme:
        """The scheme of a scenario table: ``objectives``, ``k_null`` and ``collisions``
        (``{ influence = 0.10, safety = 0.01, self = true }``, optional ``gain``), over
        the run's period ``dt``."""
        return cls(dt=params.dt, objectives=params.objectives(),
                   k_null=params.nonnegative("k_null", 1.0),
                   collisions=params.collisions())  # fmt: skip

    def _reset(self) -> None:
        super()._reset()
        self._infeasible_before = self._rows_infeasible = self._rows_bound = False

    def _prepare(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> None:
        n, m = robot.n, J.shape[0]
        w = np.ones(m) if self.task_weights is None else self.task_weights
        if w.shape != (m,):  # before anything changes: the old workspace stays consistent
            raise ShapeError(f"task_weights must have shape ({m},); got {w.shape}")
        self._robot = None  # rebuilt from scratch on the next call if anything below fails
        limits = self.limits(robot)
        if self.collisions is not None and not np.all(np.isfinite(limits.qd_max)):
            raise InvalidParameterError(
                f"collisions need joint velocity limits (robot {robot.name!r} has qd_max = "
                f"{limits.qd_max}): a pair farther than d_i could cross into contact within "
                "one period; give them with robot.with_limits(qd_max=...) or QPScheme(qd_max=...)"
            )
        ws = Workspace(limits, m)
        # DAQP's bounds: the box, the task rows, then (with collisions) one row per pair
        P = 0 if self.collisions is None else len(self.collisions.model(robot).pairs)
        self._bu_all, self._bl_all = np.full(n + m + P, _INF), np.full(n + m + P, -_INF)
        self._bu, self._bl, self._f = self._bu_all[: n + m], self._bl_all[: n + m], np.empty(n)
        self._P, self._c, self._w = np.empty((n, n)), np.empty(n), w
        kq, out = kernels("_qp_kernels"), ws.outputs()
        k = kernels(plain=not _compile.is_compiled(kq))  # both compiled or both plain (no stall)
        self._begin = _compile.entry_point(kq.qp_begin, (q, ws.zero, self.dt, ws.lim, J, xd,
                                                     ws.zero, *out, ws.M, ws.wm, self._bu,
                                                     self._bl, self._f, w, 1e-6, self._P,
                                                     self._c))  # fmt: skip
        self._end = _compile.entry_point(kq.qp_end, (J, xd, ws.zero, out[0], ws.wm))
        self._finish = _compile.entry_point(k.epilogue, (J, xd, out[0], ws.wm))
        self._normal = _compile.entry_point(kq._qp_normal, (J, xd, w, 1e-6, ws.zero, self._P,
                                                            self._c))  # fmt: skip
        if self._qp.daqp:
            flags, eye, daqp, options = sense(n, m), np.eye(n), self._qp.module, self._qp.options
            self._exact_qp = WarmQP(daqp, options, H=eye, f=self._f, A=J, bupper=self._bu,
                                    blower=self._bl, sense=flags)  # fmt: skip
            self._box_qp = WarmQP(daqp, options, H=eye, f=self._f, A=np.zeros((0, n)),
                                  bupper=self._bu[:n], blower=self._bl[:n],
                                  sense=flags[:n])  # fmt: skip
            if self.collisions is not None:
                self._prepare_rows(robot, J, P)
        self._ws, self._robot, self._pending = ws, robot, pending("_kernels", "_qp_kernels")

    def _step(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> StepResult:
        ws, qd0, prev = self._inputs(robot, q, J, xd)
        out, codes, Jc = ws.outputs()
        status, relaxed, _, inside = self._begin(
            q, prev, self.dt, ws.lim, J, xd, qd0, out, codes, Jc, ws.M, ws.wm, self._bu,
            self._bl, self._f, self._w, self.damping * self.damping, self._P, self._c,
        )  # fmt: skip
        if status:  # an input is not finite (redres.linalg's status codes)
            raise_status(status, STEP_NAMES)
        damper = self._damper if self.collisions is not None else None
        near = damper is not None and damper.update(q) > 0
        finished, single, collided = None, False, False
        if self.levels or not (inside or self._qp.daqp):  # other backends: no warm start
            rows, targets = self._stack(robot, q, J, xd)
            qd, exact, residuals = solve_levels(self._qp, rows, targets, (out[2], out[3]), qd0,
                                                self.task_weights, self.damping)  # fmt: skip
            out[0] = qd
        elif near and self._rows_bound:  # the last answer sat on a row: the rows' QPs at once
            exact, collided = [self._collide(q, J, xd, qd0, out, True, not inside)], True
        elif inside:
            exact = [True]
        else:
            met, finished = self._single(J, xd, qd0, out)
            single = finished is None  # not proved infeasible (Farkas' lemma)
            exact = [met]
        if finished is None:
            finished = self._finish(J, xd, out, ws.wm)
        active, residual = finished
        if single and residual * residual > _MET2 * (xd @ xd):
            exact[0], active, residual = self._refine(J, xd, qd0, out, active, residual)
        contact = None
        if damper is not None:
            if not collided and near and damper.violated(out[0]):
                exact[0] = self._collide(q, J, xd, qd0, out, exact[0], not inside)
                active, residual = self._finish(J, xd, out, ws.wm)
                collided = True
            if collided:
                exact[0] = exact[0] and task_met(J, xd, out[0])
            elif not near:
                self._rows_infeasible = False
            contact = damper.details(out[0])
            self._rows_bound = damper.bound
        return self._finished(out, codes, Jc, all(exact), active, residual, relaxed,
                              residuals if self.levels else None, contact)  # fmt: skip

    def _finished(
        self, out: FloatArray, codes: NDArray[np.int8], Jc: FloatArray, met: bool, active: int,
        residual: float, relaxed: int, levels: list[float] | None = None,
        contact: Callable[[], CollisionDetails] | None = None, keep: bool = True,
    ) -> StepResult:  # fmt: skip
        """The step's result from the kernels' rows (``out``, ``codes``, ``Jc``): the task
        ``met``, ``active`` bounds, the loop task's ``residual``, ``relaxed`` joints, the
        levels' residuals (default: the loop task's alone), the collision pairs' details;
        ``q̇`` becomes :attr:`qd_prev` when ``keep``. Shared with the controller's compiled step
        (:mod:`redres.control._box_kernels`)."""
        levels = [residual] if levels is None else levels
        return self._result(
            out, codes, Jc, met, active,
            lambda: QPDetails(residual, levels, *box_details(out, codes, relaxed), self.solver,
                              None if contact is None else contact()), keep,
        )  # fmt: skip

    def _prepare_rows(self, robot: Robot, J: FloatArray, P: int) -> None:
        """The collision rows' buffers and warm DAQP problems: the exact QP with ``[J; G]``
        (``n + m + P`` bounds: the box, ``ẋ``, the rows) and the least-violating one with
        ``G`` (``n + P``), ``G`` written in place by :class:`~redres.collision.DamperRows`."""
        n, m = robot.n, J.shape[0]
        self._A_all = np.zeros((m + P, n))
        self._damper = self.collisions.damper(robot, self._A_all[m:], self._bl_all[n + m :])  # type: ignore[union-attr]
        self._lv_bu, self._lv_bl = np.full(n + P, _INF), np.full(n + P, -_INF)
        self._lv_sense = np.zeros(n + P, dtype=np.intc)
        flags = np.zeros(n + m + P, dtype=np.intc)
        flags[n : n + m] = 5  # DAQP: equality rows
        daqp, options = self._qp.module, self._qp.options
        self._rows_qp = WarmQP(daqp, options, H=np.eye(n), f=self._f, A=self._A_all,
                               bupper=self._bu_all, blower=self._bl_all, sense=flags)  # fmt: skip
        self._rows_lv = WarmQP(daqp, options, H=np.eye(n), f=self._f, A=self._A_all[m:],
                               bupper=self._lv_bu, blower=self._lv_bl,
                               sense=self._lv_sense)  # fmt: skip

    def _collide(
        self, q: FloatArray, J: FloatArray, xd: FloatArray, qd0: FloatArray, out: FloatArray,
        met: bool, normal: bool,
    ) -> bool:  # fmt: skip
        """The step again with the collision rows ``G q̇ ≥ lower`` (module docstring): the
        exact QP, else the least-violating one, else the same with the acceleration limits
        dropped from the box, else with no box. Writes ``out[0]`` (and the box used into
        ``out[2]``, ``out[3]``: the epilogue clips to them); returns whether the exact QP
        was solved (tried only when the task was ``met`` without the rows: more rows
        cannot make an infeasible QP feasible). The first two are DAQP problems
        warm-started from the previous step's; after a step whose exact QP was infeasible
        the least-violating one comes first, and the exact one is skipped when its answer
        proves it infeasible (:meth:`_rows_proved`). ``normal``: ``qp_begin`` built the
        least-violating QP's ``P``, ``c`` this step (its optimum was not in the box).
        After a step whose answer sat on a row, the step comes here without solving the
        QPs without rows first (``met`` is then only a hint: the exact QP with the rows is
        tried, unless infeasible at the last step)."""
        n, m = J.shape[1], J.shape[0]
        later = met and self._rows_infeasible
        if met and not later:
            self._rows_infeasible = not self._rows_exact(J, out)
            if not self._rows_infeasible:
                return True
        P, c = self._P, self._c
        if not normal:
            self._normal(J, xd, self._w, self.damping * self.damping, qd0, P, c)
        G, lower = self._A_all[m:], self._bl_all[n + m :]
        self._lv_bl[n:] = lower
        self._lv_bu[:n], self._lv_bl[:n] = out[3], out[2]
        x, flag = self._rows_lv.solve(P, c, G, self._lv_bu, self._lv_bl)
        if flag > 0:
            if later and not self._rows_proved(J, xd, qd0, out, x):
                self._rows_infeasible = not self._rows_exact(J, out)
                if not self._rows_infeasible:
                    return True
            out[0] = x
            return False
        lim = self._ws.lim  # fallbacks, solved cold: no acceleration limits, then no box
        lo = np.maximum(-lim[2], (lim[0] - q) / self.dt)
        hi = np.minimum(lim[2], (lim[1] - q) / self.dt)
        for low, up in ((np.minimum(lo, hi), hi), (np.full(n, -_INF), np.full(n, _INF))):
            self._lv_bu[:n], self._lv_bl[:n] = up, low
            x, _, flag, _ = self._qp.module.solve(
                P, c, G, self._lv_bu, self._lv_bl, self._lv_sense, **self._qp.options
            )
            if flag > 0:
                out[0], out[2], out[3] = x, low, up
                return False
        active = lower > -_INF  # the rows contradict each other
        out[0] = np.linalg.lstsq(G[active], lower[active], rcond=None)[0]
        out[2], out[3] = low, up
        return False

    def _rows_exact(self, J: FloatArray, out: FloatArray) -> bool:
        """The exact QP with the rows (``[J; G]``, the box and ``ẋ`` as ``qp_begin`` wrote
        them); writes ``out[0]`` and returns True when it is feasible."""
        self._A_all[: J.shape[0]] = J
        x, flag = self._rows_qp.solve(None, self._f, self._A_all, self._bu_all, self._bl_all)
        if flag > 0:
            out[0] = x
        return bool(flag > 0)

    def _rows_proved(
        self, J: FloatArray, xd: FloatArray, qd0: FloatArray, out: FloatArray, x: FloatArray
    ) -> bool:
        """Whether the least-violating answer ``x`` proves the exact QP with the rows
        infeasible: a feasible ``x_e`` would cost ``½λ²‖x_e − q̇_0‖²`` in the
        least-violating QP, so its optimum has ``‖J x − ẋ‖_W ≤ λ max_box ‖q̇ − q̇_0‖``;
        a larger residual (beyond round-off) rules ``x_e`` out."""
        r = J @ x
        r -= xd
        size2 = float(r @ r) if self.task_weights is None else float(r @ (self._w * r))
        gap = out[2:4] - qd0
        far = max(float(gap.max()), -float(gap.min())) * math.sqrt(len(x))  # ≥ max_box ‖q̇ − q̇_0‖
        return math.sqrt(size2) > 1.001 * self.damping * far + 1e-12

    def _single(
        self, J: FloatArray, xd: FloatArray, qd0: FloatArray, out: FloatArray
    ) -> tuple[bool, tuple[int, float] | None]:
        """One level, bounds active, DAQP: the exact QP, else the least-violating one (writes
        ``out[0]``; after an infeasible step, the latter first: module docstring). Returns
        whether the task is met exactly, and ``(#active, residual)`` when the step is
        already finished (else None: the caller finishes it)."""
        tried = self._infeasible_before
        if tried:
            lv = self._least_violating(out)
            finished = self._proved(J, xd, lv, out)
            if finished is not None:
                return False, finished
        x, flag = self._exact_qp.solve(None, self._f, J, self._bu, self._bl)
        self._infeasible_before = flag <= 0
        if flag > 0:
            out[0] = x
            return True, None
        if not tried:
            lv = self._least_violating(out)
            finished = self._proved(J, xd, lv, out)
            if finished is not None:  # no retry on orthonormal rows needed
                return False, finished
        out[0] = lv if lv is not None else np.clip(qd0, out[2], out[3])
        return False, None

    def _proved(
        self, J: FloatArray, xd: FloatArray, lv: FloatArray | None, out: FloatArray
    ) -> tuple[int, float] | None:
        """When the least-violating answer ``lv`` proves the task infeasible (Farkas'
        lemma, ``qp_end``), the finished step's ``(#active, residual)``; else None."""
        if lv is None:
            return None
        ws = self._ws
        proved, active, residual = self._end(J, xd, lv, out, ws.wm)
        return (active, residual) if proved else None

    def _refine(
        self,
        J: FloatArray,
        xd: FloatArray,
        qd0: FloatArray,
        out: FloatArray,
        active: int,
        residual: float,
    ) -> tuple[bool, int, float]:
        """A single-level step whose ``‖J q̇ − ẋ‖`` exceeds ``1e-9 ‖ẋ‖`` (near a
        singularity the backend's equality rows are nearly dependent): the exact QP again
        on orthonormal rows (:func:`._solvers.solve_exact`), kept if closer to the task.
        Returns ``(task met, #active, residual)``; ``feasible`` means the task is met."""
        kept = out[0].copy()
        x = solve_exact(self._qp, qd0, J, xd, out[2], out[3])
        if x is not None:
            out[0] = x
            ws = self._ws
            again = self._finish(J, xd, out, ws.wm)
            if again[1] < residual:
                active, residual = again
            else:
                out[0] = kept
                active, residual = self._finish(J, xd, out, ws.wm)
        met = bool(residual * residual <= _MET2 * (xd @ xd))
        self._infeasible_before = self._infeasible_before and not met
        return met, active, residual

    def _least_violating(self, out: FloatArray) -> FloatArray | None:
        """The least-violating QP on the normal equations ``P``, ``c`` that ``qp_begin``
        built for this step."""
        x, flag = self._box_qp.solve(self._P, self._c, None, out[3], out[2])
        return x if flag > 0 else None

    def _stack(
        self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray
    ) -> tuple[list[FloatArray], list[FloatArray]]:
        rows, targets = [J], [xd]
        for level in self.levels:
            states = [task.compute(robot, q) for task in level]
            state = states[0] if len(states) == 1 else stack(states)
            rows.append(state.jacobian)
            targets.append(state.command(self.gain))
        return rows, targets
