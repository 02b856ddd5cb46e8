"""Hard joint limits by quadratic programming (the approach of pink and mink), exact tasks.

Each step the joint-velocity box ``lower ≤ q̇ ≤ upper`` of
:mod:`~redres.resolution.limits` (position, velocity and acceleration limits over one
period) is computed, and the task is resolved inside it as a lexicographic sequence of
QPs (Kanoun, Lamiraux, Wieber 2011; Escande, Mansard, Wieber 2014):

1. **Exact** — ``min ½‖q̇ − q̇_0‖²  s.t.  J q̇ = ẋ,  lower ≤ q̇ ≤ upper``. ``q̇_0 = −k Σ wᵢ ∇Dᵢ``
   is the secondary velocity (zero without objectives). Without active bounds the
   solution is ``J⁺ẋ + (I − J⁺J) q̇_0``, gradient projection; with active bounds it is the
   closest velocity to ``q̇_0`` that still meets the task exactly.
2. **Least violating**, only when 1 is infeasible (the task cannot be met within the
   limits, or ``J`` is singular) — ``min ½‖J q̇ − ẋ‖²_W + ½λ²‖q̇ − q̇_0‖²  s.t.  the box``: the
   weighted task residual plus a small regularisation ``λ`` (``damping``). The box is
   never empty (see :mod:`~redres.resolution.limits`), so this QP is always feasible and
   the step never raises inside a control loop; ``StepResult.binding`` lists the bounds the
   answer sits on. After an infeasible step this QP is tried first, and the exact one is
   skipped when the residual ``r = ẋ − J q̇`` proves the task infeasible (Farkas' lemma:
   ``rᵀẋ > max_box rᵀJ q̇``).

With ``levels`` (lower-priority tasks, each evaluated at ``q`` by the scheme), level ``k``
is solved by the same two QPs with the velocities achieved by the levels above held as
equality constraints, ``J_i q̇ = J_i q̇*_i`` for ``i < k`` (a sequence of QPs; a lower level
never disturbs a higher one).

The QPs go through qpsolvers' backends (extra ``qp``: ``pip install 'redres[qp]'``).
The default backend, DAQP (Arnström, Bemporad, Axehill 2022, a dual active-set solver for
small dense QPs), is called directly with the dense matrices qpsolvers would build: the
solve takes about a microsecond, qpsolvers' generic conversions about twenty. Any other
qpsolvers backend (``"proxqp"``, ...) is used through :func:`qpsolvers.solve_problem`.

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

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import FloatArray, as_scalar, as_vector
from ..errors import InvalidParameterError, MissingDependencyError, ShapeError
from ..tasks import Task, stack
from .base import StepResult
from .gradient_projection import WeightedObjective, weighted_objectives
from .limits import fast_entry, kernel, register_kernels

# Kernels shared with SNS (rebound to their compiled versions by :func:`_kernels`).
from .sns import (
    BoxScheme,
    Workspace,
    _epilogue,
    _min_norm,
    _prologue,
    _solved,
    binding_list,
    gram_info,
    input_error,
    relaxed_joints,
    step_inputs,
)

if TYPE_CHECKING:
    from ..robot import Robot

_EXTRA = "pip install 'redres[qp]'"


def _backend(solver: str) -> Any:
    """The DAQP module for ``"daqp"``, else qpsolvers; clear errors when missing."""
    try:
        import qpsolvers
    except ImportError as exc:
        raise MissingDependencyError(
            f"QPScheme needs qpsolvers and a QP backend (DAQP or ProxQP): {_EXTRA}"
        ) from exc
    available = list(qpsolvers.available_solvers)
    if solver not in available:
        listed = ", ".join(available) or "none"
        raise MissingDependencyError(
            f"QP backend {solver!r} is not installed (available: {listed}); "
            f"{_EXTRA} installs daqp and proxsuite"
        )
    if solver == "daqp":
        import daqp

        return daqp
    return qpsolvers


@dataclass(frozen=True)
class QPDetails:
    """What a QP step adds to its :class:`~redres.resolution.StepResult`.

    Attributes:
        residual: ``‖J q̇ − ẋ‖`` of the loop's task.
        level_residuals: the same for every level, the loop's task first.
        bounds: the joint-velocity box ``(lower, upper)``, two ``(n,)`` arrays, rad/s.
        relaxed: joints whose box had to give up a limit.
        solver: the QP backend.
    """

    residual: float
    level_residuals: list[float]
    bounds: tuple[FloatArray, FloatArray]
    relaxed: list[int]
    solver: str


class QPScheme(BoxScheme):
    """Joint velocity by a sequence of QPs inside hard position, velocity, acceleration limits.

    Args:
        dt: control period, s; must equal the ``dt`` of the loop that applies ``q̇``.
        objectives: optional secondary costs (``obj`` or ``(obj, weight)``), giving the
            target velocity ``q̇_0 = −gain Σ wᵢ ∇Dᵢ``.
        gain: ``k`` of the secondary velocity.
        levels: lower-priority tasks (each a task or a list of tasks, stacked), highest
            first, evaluated at ``q``; their command is ``ẋ_d + level_gain·e``.
        level_gain: CLIK gain of the levels, 1/s.
        task_weights: diagonal weights of the task residual in the least-violating QP,
            shape ``(m,)`` (default ones).
        damping: ``λ`` of the least-violating QP (units of ``J``), > 0.
        solver: qpsolvers backend name (default ``"daqp"``).
        solver_options: keyword settings passed to the backend (e.g. ``{"eps_abs": 1e-9}``
            for ProxQP; DAQP gets ``primal_tol=1e-10`` unless given).
        qd_max, qdd_max: limits replacing the robot's (scalar or ``(n,)``).

    Raises:
        MissingDependencyError: qpsolvers or the backend is not installed (names the
            ``qp`` extra).

    Identifier ``qp``. State: the previous joint velocity :attr:`qd_prev` (:meth:`reset`
    clears it). ``StepResult.feasible``: every level met exactly; ``binding``: the bounds
    ``q̇`` sits on; ``details``: a :class:`QPDetails` (residuals, box, relaxed joints,
    solver). ``info`` gives the
    singular values of ``J``; ``null_term`` the component of ``q̇`` in its null space.
    """

    name = "qp"

    def __init__(
        self,
        dt: float = 1e-3,
        *,
        objectives: Sequence[WeightedObjective] = (),
        gain: float = 1.0,
        levels: Sequence[Task | Sequence[Task]] = (),
        level_gain: float = 10.0,
        task_weights: ArrayLike | None = None,
        damping: float = 1e-3,
        solver: str = "daqp",
        solver_options: dict[str, Any] | None = None,
        qd_max: ArrayLike | None = None,
        qdd_max: ArrayLike | None = None,
    ) -> None:
        self._init_box(dt, qd_max, qdd_max)
        self.objectives = tuple(weighted_objectives(objectives))
        self.gain = as_scalar(gain, "gain", minimum=0.0)
        self.levels = [[lv] if isinstance(lv, Task) else list(lv) for lv in levels]
        if any(not lv or not all(isinstance(t, Task) for t in lv) for lv in self.levels):
            raise InvalidParameterError("each level must be a Task or a non-empty list of Tasks")
        self.tasks = tuple(t for level in self.levels for t in level)
        self.level_gain = as_scalar(level_gain, "level_gain", minimum=0.0)
        self.task_weights = None if task_weights is None else as_vector(task_weights,
                                                                        "task_weights")  # fmt: skip
        if self.task_weights is not None and np.any(self.task_weights <= 0):
            raise InvalidParameterError(f"task_weights must be > 0; got {self.task_weights}")
        self.damping = as_scalar(damping, "damping", minimum=0.0, strict=True)
        self.solver = str(solver)
        self.solver_options = dict(solver_options or {})
        if self.solver == "daqp":
            self.solver_options.setdefault("primal_tol", 1e-10)
        self._module = _backend(self.solver)
        if self.solver == "daqp":
            check_daqp_options(self._module, self.solver_options)
        self._infeasible_before = False

    def _reset(self) -> None:
        super()._reset()
        self._infeasible_before = False

    def _prepare(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> None:
        n, m = robot.n, J.shape[0]
        w = np.ones(m) if self.task_weights is None else self.task_weights
        if w.shape != (m,):  # before anything changes: the old workspace stays consistent
            raise ShapeError(f"task_weights must have shape ({m},); got {w.shape}")
        self._robot = None  # rebuilt from scratch on the next call if anything below fails
        ws = Workspace(self.limits(robot), m)
        self._eye = np.eye(n)
        self._bu, self._bl, self._f = np.empty(n + m), np.empty(n + m), np.empty(n)
        self._P, self._c, self._A0 = np.empty((n, n)), np.empty(n), np.zeros((0, n))
        self._w = w
        k = _kernels()
        out = ws.outputs()
        self._begin = fast_entry(k["_qp_begin"], (q, ws.zero, self.dt, ws.lim, J, xd, ws.zero,
                                                  *out, ws.M, ws.wm, self._bu, self._bl,
                                                  self._f, self._w, 1e-6, self._P,
                                                  self._c))  # fmt: skip
        self._end = fast_entry(k["_qp_end"], (J, xd, ws.zero, *out[:2], ws.M, ws.wm, True))
        self._finish = fast_entry(k["_epilogue"], (J, xd, *out[:2], ws.M, ws.wm, True, False))
        self._sense = np.zeros(n + m, dtype=np.intc)
        self._sense[n:] = 5  # equality rows (DAQP's sense flags)
        if self.solver == "daqp":
            options, daqp = self.solver_options, self._module
            self._exact_qp = WarmQP(daqp, options, H=self._eye, f=self._f, A=J, bupper=self._bu,
                                    blower=self._bl, sense=self._sense)  # fmt: skip
            self._box_qp = WarmQP(daqp, options, H=self._eye, f=self._f, A=self._A0,
                                  bupper=self._bu[:n], blower=self._bl[:n],
                                  sense=self._sense[:n])  # fmt: skip
        self._ws, self._robot = ws, robot

    def _step(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> StepResult:
        ws, qd0, prev = step_inputs(self, robot, q, J, xd)
        out, codes, gram = ws.outputs()
        err, relaxed, full, inside = self._begin(
            q, prev, self.dt, ws.lim, J, xd, qd0, out, codes, gram, ws.M, ws.wm, self._bu,
            self._bl, self._f, self._w, self.damping * self.damping, self._P, self._c,
        )  # fmt: skip
        if err < 0:
            raise input_error(err, (q, J, xd, qd0))
        residuals: list[float] = []
        finished = None
        if self.levels:
            qd, exact, residuals = self._solve(*self._stack(robot, q, J, xd), out[2], out[3], qd0)
            out[0] = qd
        elif inside:
            exact = [True]
        else:
            met, finished = self._single(J, xd, qd0, out, codes, full)
            exact = [met]
        if finished is None:
            finished = self._finish(J, xd, out, codes, ws.M, ws.wm, full, False)
        active, residual = finished
        self.qd_prev = out[0].copy()  # the scheme's own copy
        levels = residuals if self.levels else [residual]
        bounds, gave_up = (out[2], out[3]), relaxed_joints(codes, relaxed)
        details = QPDetails(residual, levels, bounds, gave_up, self.solver)
        return StepResult(
            out[0], lambda: gram_info(gram, "qp"), out[1], feasible=all(exact),
            binding=binding_list(codes, relaxed > 0) if active else (), details=details,
        )  # fmt: skip

    def _single(
        self, J: FloatArray, xd: FloatArray, qd0: FloatArray, out: FloatArray, codes: Any,
        full: bool,
    ) -> tuple[bool, tuple[int, float] | None]:  # fmt: skip
        """One level, bounds active: the exact QP, else the least-violating one (writes
        ``out[0]``). Returns whether the task is met exactly, and ``(#active, residual)``
        when the step is already finished (else None: the caller finishes it).

        After an infeasible step the least-violating QP is solved first: if its residual
        ``r = ẋ − J q̇`` proves the task infeasible (Farkas: ``rᵀẋ > max over the box of
        rᵀJ q̇``), the exact QP is skipped — one QP per step in both steady states.
        """
        if self.solver != "daqp":
            qd, exact, _ = self._solve([J], [xd], out[2], out[3], qd0)
            out[0] = qd
            return exact[0], None
        if self._infeasible_before:
            x = self._least_violating(out)
            if x is not None:
                ws = self._ws
                proved, active, residual = self._end(J, xd, x, out, codes, ws.M, ws.wm, full)
                if proved:
                    return False, (active, residual)
        x, flag = self._exact_qp.solve(None, self._f, J, self._bu, self._bl)
        self._infeasible_before = flag <= 0
        if flag > 0:
            out[0] = x
            return True, None
        x = self._least_violating(out)
        out[0] = x if x is not None else np.clip(qd0, out[2], out[3])
        return False, None

    def _least_violating(self, out: FloatArray) -> FloatArray | None:
        """The least-violating QP on the normal equations ``P``, ``c`` that ``_qp_begin``
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
            targets.append(state.command(self.level_gain))
        return rows, targets

    def _solve(
        self,
        rows: list[FloatArray],
        targets: list[FloatArray],
        lo: FloatArray,
        hi: FloatArray,
        qd0: FloatArray,
    ) -> tuple[FloatArray, list[bool], list[float]]:
        """The sequence of QPs: per level, exact if possible, else least violating."""
        held_rows: list[FloatArray] = []
        held: list[FloatArray] = []
        qd = np.clip(qd0, lo, hi)
        exact, residuals = [], []
        for k, (Jk, xk) in enumerate(zip(rows, targets)):
            A = Jk if not held_rows else np.vstack([*held_rows, Jk])
            b = xk if not held else np.concatenate([*held, xk])
            x = self._qp(self._eye, -qd0, A, b, lo, hi)
            ok = x is not None
            if x is None:
                W = self.task_weights if k == 0 and self.task_weights is not None else None
                JW = Jk if W is None else Jk * W[:, None]
                lam2 = self.damping**2
                P = JW.T @ Jk + lam2 * self._eye
                c = -(JW.T @ xk) - lam2 * qd0
                A_held = np.vstack(held_rows) if held_rows else None
                b_held = np.concatenate(held) if held else None
                x = self._qp(P, c, A_held, b_held, lo, hi)
            if x is not None:
                qd = np.minimum(np.maximum(x, lo), hi)
            achieved = Jk @ qd
            exact.append(ok)
            residuals.append(float(np.linalg.norm(achieved - xk)))
            held_rows.append(Jk)
            held.append(achieved)
        return qd, exact, residuals

    def _qp(
        self,
        P: FloatArray,
        c: FloatArray,
        A: FloatArray | None,
        b: FloatArray | None,
        lo: FloatArray,
        hi: FloatArray,
    ) -> FloatArray | None:
        """``argmin ½xᵀPx + cᵀx  s.t.  A x = b, lo ≤ x ≤ hi``; None if infeasible or failed."""
        n = lo.shape[0]
        if self.solver == "daqp":
            m = 0 if A is None else A.shape[0]
            bu, bl = np.empty(n + m), np.empty(n + m)
            bu[:n], bl[:n] = hi, lo
            if A is not None and b is not None:
                bu[n:], bl[n:] = b, b
                sense = self._sense if m == self._sense.shape[0] - n else _sense(n, m)
            else:
                A, sense = np.zeros((0, n)), self._sense[:n]
            x, _, flag, _ = self._module.solve(P, c, A, bu, bl, sense, **self.solver_options)
            return x if flag > 0 else None
        problem = self._module.Problem(P, c, None, None, A, b, lo, hi)
        solution = self._module.solve_problem(problem, solver=self.solver, **self.solver_options)
        return solution.x if solution.found else None


def check_daqp_options(daqp: Any, options: dict[str, Any]) -> None:
    """Refuse settings DAQP does not know (``daqp.Model`` would ignore them silently)."""
    if not hasattr(daqp, "Model"):
        return  # daqp.solve raises on unknown keywords itself
    known = set(daqp.Model().settings)
    unknown = sorted(set(options) - known)
    if unknown:
        raise InvalidParameterError(
            f"unknown DAQP setting(s) {unknown}; DAQP's settings are {sorted(known)}"
        )


class WarmQP:
    """One DAQP problem of fixed size, solved again and again with new data (internal).

    Through ``daqp.Model`` (DAQP ≥ 0.7): set up once, then each solve updates the data
    and starts from the active set of the previous solve — about two microseconds less
    per call than ``daqp.solve`` and fewer iterations in a control loop, where the
    active set changes little from one step to the next. Falls back to ``daqp.solve``
    when the installed DAQP has no ``Model``.

    Args:
        daqp: the DAQP module.
        options: DAQP settings (``primal_tol``, ...).
        data: the first problem: ``H``, ``f``, ``A``, ``bupper``, ``blower`` and ``sense``
            (DAQP's arguments).
    """

    def __init__(self, daqp: Any, options: dict[str, Any], **data: Any) -> None:
        self._daqp, self._options, self._data = daqp, options, data
        self._model: Any = None
        if hasattr(daqp, "Model"):
            model = daqp.Model()
            if model.setup(*(data[k] for k in _DAQP_ARGS))[0] >= 0:
                check_daqp_options(daqp, options)
                model.settings = dict(options)
                self._model = model

    def solve(
        self,
        H: FloatArray | None = None,
        f: FloatArray | None = None,
        A: FloatArray | None = None,
        bupper: FloatArray | None = None,
        blower: FloatArray | None = None,
    ) -> tuple[FloatArray, int]:
        """``(x, exitflag)`` for the problem with the given data replacing the previous
        values (``None``: unchanged)."""
        model = self._model
        if model is not None and model.update(H, f, A, bupper, blower) >= 0:
            x, _, flag, _ = model.solve()
            return x, flag
        new = {"H": H, "f": f, "A": A, "bupper": bupper, "blower": blower}
        self._data.update({k: v for k, v in new.items() if v is not None})
        args = (self._data[k] for k in _DAQP_ARGS)
        x, _, flag, _ = self._daqp.solve(*args, **self._options)
        return x, flag


_DAQP_ARGS = ("H", "f", "A", "bupper", "blower", "sense")


def _sense(n: int, m: int) -> Any:
    sense = np.zeros(n + m, dtype=np.intc)
    sense[n:] = 5
    return sense


# --------------------------------------------------------------------------- kernels


@kernel
def _qp_begin(q, prev, dt, lim, J, xd, qd0, out, codes, gram, M, wm, bu, bl, f, w, lam2, P, c):  # type: ignore[no-untyped-def]
    """Box, ``G = J Jᵀ`` (into ``gram``) and the unconstrained optimum of the exact QP,
    ``q̇ = q̇_0 + J⁺(ẋ − J q̇_0)`` in ``out[0]``; fills DAQP's ``bu``, ``bl`` (box, then
    ``ẋ``) and ``f = −q̇_0``, and, when that optimum is not in the box, the least-violating
    QP's ``P``, ``c`` (:func:`_qp_normal`). Returns ``(error, #relaxed, full_rank,
    inside)``: ``inside`` means the optimum is in the box, hence the QP's solution."""
    err, relaxed, full = _prologue(q, prev, dt, lim, J, xd, qd0, out, codes, gram, M, wm)
    if err:
        return err, 0, False, False
    m, n = J.shape
    for k in range(n):
        bu[k], bl[k], f[k] = out[3, k], out[2, k], -qd0[k]
    for i in range(m):
        bu[n + i] = bl[n + i] = xd[i]
    inside = False
    if full:
        r = wm[2]
        for i in range(m):
            acc = xd[i]
            for k in range(n):
                acc -= J[i, k] * qd0[k]
            r[i] = acc
        every = np.ones(n, np.bool_)
        _min_norm(J, every, M[1], r, wm[0], wm[1], out[0])
        inside = _solved(r, wm[1])
        for k in range(n):
            out[0, k] += qd0[k]
            inside = inside and out[2, k] <= out[0, k] <= out[3, k]
    if not inside:
        _qp_normal(J, xd, w, lam2, qd0, P, c)
    return 0, relaxed, full, inside


@kernel
def _qp_farkas(J, xd, lo, hi, x):  # type: ignore[no-untyped-def]
    """Whether ``y = ẋ − J x`` proves ``{J q̇ = ẋ, lo ≤ q̇ ≤ hi}`` empty (Farkas' lemma):
    ``yᵀẋ > max_{lo ≤ q̇ ≤ hi} yᵀ J q̇ = Σ_k max(c_k lo_k, c_k hi_k)``, ``c = Jᵀ y``."""
    m, n = J.shape
    y = np.empty(m)
    gap, size = 0.0, 0.0
    for i in range(m):
        acc = xd[i]
        for k in range(n):
            acc -= J[i, k] * x[k]
        y[i] = acc
        gap += acc * xd[i]
        size += abs(acc * xd[i])
    for k in range(n):
        c = 0.0
        for i in range(m):
            c += J[i, k] * y[i]
        if c != 0.0:
            bound = max(c * lo[k], c * hi[k])
            gap -= bound
            size += abs(bound)
    return gap > 1e-12 * size


@kernel
def _qp_end(J, xd, x, out, codes, M, wm, full):  # type: ignore[no-untyped-def]
    """If ``x`` (the least-violating QP's answer) proves the task infeasible
    (:func:`_qp_farkas`), take it as ``q̇`` and finish the step (:func:`_epilogue`).
    Returns ``(proved, #active, ‖J q̇ − ẋ‖)``."""
    if not _qp_farkas(J, xd, out[2], out[3], x):
        return False, 0, 0.0
    for k in range(x.shape[0]):
        out[0, k] = x[k]
    active, residual = _epilogue(J, xd, out, codes, M, wm, full, False)
    return True, active, residual


@kernel
def _qp_normal(J, xd, w, lam2, qd0, P, c):  # type: ignore[no-untyped-def]
    """The least-violating QP: ``P = Jᵀ W J + λ² I``, ``c = −Jᵀ W ẋ − λ² q̇_0``."""
    m, n = J.shape
    for a in range(n):
        acc = 0.0
        for i in range(m):
            acc += J[i, a] * w[i] * xd[i]
        c[a] = -acc - lam2 * qd0[a]
        for b in range(a + 1):
            acc = 0.0
            for i in range(m):
                acc += J[i, a] * w[i] * J[i, b]
            P[a, b] = acc
            P[b, a] = acc
        P[a, a] += lam2


def _kernels() -> dict[str, Any]:
    """This module's compiled kernels (compiles on first use)."""
    from . import sns

    shared = sns.kernels()
    for name in ("_prologue", "_epilogue", "_min_norm", "_solved"):
        globals()[name] = shared[name]
    register_kernels(globals(), ["_qp_farkas", "_qp_normal", "_qp_begin", "_qp_end"])
    return globals()
