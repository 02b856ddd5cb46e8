"""The QP backends of :class:`~redres.resolution.QPScheme` (internal): DAQP called
directly (warm-started through ``daqp.Model``; why: :mod:`.qp`), any other qpsolvers
backend through :func:`qpsolvers.solve_problem`, and the sequence of QPs of the levels.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..._validate import FloatArray
from ...errors import InvalidParameterError, MissingDependencyError, install_hint
from ._codes import MET_TOLERANCE

_DAQP_ARGS = ("H", "f", "A", "bupper", "blower", "sense")
_EQUALITY = 5  # DAQP's sense flag of an equality row


def backend(solver: str) -> Any:
    """The DAQP module for ``"daqp"``, else qpsolvers; clear errors when missing."""
    try:
        import qpsolvers
    except ImportError as exc:
        raise MissingDependencyError(
            "QPScheme needs qpsolvers and a QP backend (DAQP or ProxQP), the qp extra: "
            + install_hint("qp")
        ) from exc
    available = list(qpsolvers.available_solvers)
    if solver not in available:
        listed = ", ".join(available) or "none"
        raise MissingDependencyError(
            f"QP backend {solver!r} is not installed (available: {listed}); "
            f"the qp extra installs daqp and proxsuite: {install_hint('qp')}"
        )
    if solver == "daqp":
        import daqp

        return daqp
    return qpsolvers


def sense(n: int, m: int) -> Any:
    """DAQP's constraint flags for ``n`` bounds then ``m`` equality rows."""
    flags = np.zeros(n + m, dtype=np.intc)
    flags[n:] = _EQUALITY
    return flags


class WarmQP:
    """One DAQP problem of fixed size, solved again and again with new data.

    Through ``daqp.Model`` (DAQP ≥ 0.7): set up once, then each solve updates the data
    and starts from the active set of the previous solve — about two microseconds less
    per call than ``daqp.solve`` and fewer iterations in a control loop, where the
    active set changes little from one step to the next. Falls back to ``daqp.solve``
    when the installed DAQP has no ``Model``.

    Args:
        daqp: the DAQP module.
        options: DAQP settings, already checked (:class:`QPSolver`).
        data: the first problem: DAQP's arguments ``H``, ``f``, ``A``, ``bupper``,
            ``blower`` and ``sense``.
    """

    def __init__(self, daqp: Any, options: dict[str, Any], **data: Any) -> None:
        self._daqp, self._options, self._data = daqp, options, data
        self._model: Any = None
        if hasattr(daqp, "Model"):
            model = daqp.Model()
            if model.setup(*(data[k] for k in _DAQP_ARGS))[0] >= 0:
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


class QPSolver:
    """``argmin ½xᵀPx + cᵀx  s.t.  A x = b, lo ≤ x ≤ hi`` by the chosen backend.

    Args:
        solver: qpsolvers backend name (``"daqp"`` is called directly).
        options: the backend's settings (DAQP gets ``primal_tol=1e-10`` unless given).

    Raises:
        MissingDependencyError: qpsolvers or the backend is not installed.
        InvalidParameterError: a setting DAQP does not know.
    """

    def __init__(self, solver: str, options: dict[str, Any] | None) -> None:
        self.name = str(solver)
        self.options = dict(options or {})
        self.daqp = self.name == "daqp"
        if self.daqp:
            self.options.setdefault("primal_tol", 1e-10)
        self.module = backend(self.name)
        # daqp.Model would ignore unknown settings silently (daqp.solve refuses them itself)
        if self.daqp and hasattr(self.module, "Model"):
            known = set(self.module.Model().settings)
            unknown = sorted(set(self.options) - known)
            if unknown:
                raise InvalidParameterError(
                    f"unknown DAQP setting(s) {unknown}; DAQP's settings are {sorted(known)}"
                )

    def solve(
        self,
        P: FloatArray,
        c: FloatArray,
        A: FloatArray | None,
        b: FloatArray | None,
        lo: FloatArray,
        hi: FloatArray,
    ) -> FloatArray | None:
        """The minimiser, or None if the QP is infeasible or the backend failed."""
        n = lo.shape[0]
        if self.daqp:
            if A is None or b is None:
                A, b = np.zeros((0, n)), np.zeros(0)
            bu, bl, flags = np.concatenate([hi, b]), np.concatenate([lo, b]), sense(n, len(b))
            x, _, flag, _ = self.module.solve(P, c, A, bu, bl, flags, **self.options)
            return x if flag > 0 else None
        problem = self.module.Problem(P, c, None, None, A, b, lo, hi)
        solution = self.module.solve_problem(problem, solver=self.name, **self.options)
        return solution.x if solution.found else None


def orthonormal_rows(A: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray] | None:
    """The equality ``A x = b`` rewritten with orthonormal rows, ``Vᵀ x = S⁻¹ Uᵀ b`` from the
    SVD ``A = U S Vᵀ`` (the same solution set when ``A`` has full row rank): near a
    singularity the rows of ``A`` are nearly dependent and an active-set solver may call
    a feasible equality infeasible, while ``Vᵀ`` is perfectly conditioned (issue 18,
    item 3). Rows with ``σ = 0`` are dropped when ``uᵀb`` is at rounding level (the
    equation is ``0 = 0``); None when such a row is not (no solution)."""
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    ub = U.T @ b
    zero = s <= np.finfo(float).tiny
    if np.any(np.abs(ub[zero]) > 1e-12 * max(float(np.abs(ub).max()), np.finfo(float).tiny)):
        return None
    keep = ~zero
    return np.ascontiguousarray(Vt[keep]), ub[keep] / s[keep]


def solve_exact(
    qp: QPSolver, qd0: FloatArray, A: FloatArray, b: FloatArray, lo: FloatArray, hi: FloatArray
) -> FloatArray | None:
    """``argmin ½‖x − q̇_0‖²  s.t.  A x = b, lo ≤ x ≤ hi`` with :func:`orthonormal_rows`'
    constraints (the retry of an exact QP the backend called infeasible)."""
    rows = orthonormal_rows(A, b)
    if rows is None or not np.all(np.isfinite(rows[1])):
        return None
    V, b = rows
    x = qp.solve(np.eye(lo.shape[0]), -qd0, V, b, lo, hi)
    if x is not None:  # the backend meets Vᵀx = b to its tolerance: one exact projection
        refined = np.minimum(np.maximum(x + V.T @ (b - V @ x), lo), hi)
        if np.linalg.norm(V @ refined - b) <= np.linalg.norm(V @ x - b):
            x = refined
    return x


def solve_levels(
    qp: QPSolver,
    rows: list[FloatArray],
    targets: list[FloatArray],
    box: tuple[FloatArray, FloatArray],
    qd0: FloatArray,
    task_weights: FloatArray | None,
    damping: float,
) -> tuple[FloatArray, list[bool], list[float]]:
    """The sequence of QPs of :mod:`.qp`: per level ``k`` (``rows[k] q̇ = targets[k]``),
    the exact QP if feasible, else the least-violating one, with the velocities achieved
    by the levels above held as equalities. Returns ``(q̇, exact per level, residuals)``."""
    lo, hi = box
    eye = np.eye(lo.shape[0])
    held_rows: list[FloatArray] = []
    held: list[FloatArray] = []
    qd = np.clip(qd0, lo, hi)
    exact, residuals = [], []
    for k, (Jk, xk) in enumerate(zip(rows, targets)):
        A = Jk if not held_rows else np.vstack([*held_rows, Jk])
        b = xk if not held else np.concatenate([*held, xk])
        x = qp.solve(eye, -qd0, A, b, lo, hi)
        if x is None:
            x = solve_exact(qp, qd0, A, b, lo, hi)
        ok = x is not None
        if x is None:
            JW = Jk * task_weights[:, None] if k == 0 and task_weights is not None else Jk
            lam2 = damping**2
            P = JW.T @ Jk + lam2 * eye
            c = -(JW.T @ xk) - lam2 * qd0
            A_held = np.vstack(held_rows) if held_rows else None
            b_held = np.concatenate(held) if held else None
            x = qp.solve(P, c, A_held, b_held, lo, hi)
        if x is not None:
            qd = np.minimum(np.maximum(x, lo), hi)
        achieved = Jk @ qd
        residual = float(np.linalg.norm(achieved - xk))
        exact.append(ok or residual <= MET_TOLERANCE * float(np.linalg.norm(xk)))  # met
        residuals.append(residual)
        held_rows.append(Jk)
        held.append(achieved)
    return qd, exact, residuals
