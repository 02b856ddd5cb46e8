"""The hard-limit step's two QPs: redres' compiled dense solvers next to DAQP and ProxQP.

``QPScheme`` solves, each step, the exact QP ``min ½‖q̇ − q̇_0‖² s.t. J q̇ = ẋ, lo ≤ q̇ ≤ hi``
and, when it is infeasible, the least-violating box QP ``min ½ q̇ᵀP q̇ + cᵀq̇ s.t. lo ≤ q̇ ≤
hi``. This script records both, as ``QPScheme`` hands them to DAQP, along a closed loop on
``benchmarks/step.py``'s saturating Panda problem (gain 50, dt 1 ms, position, velocity
and acceleration limits), and draws random ones of the same sizes (n = 7, m = 6), then
times each solver on the same arrays:

* ``eq_box_qp`` (Goldfarb–Idnani, dual active set) and ``box_qp`` (primal active set) of
  ``redres.resolution.hard_limits._dense_qp_kernels``: from Python (one dispatch per
  solve), and from a compiled loop (what a fused step pays), cold (no active set) and warm
  (the previous QP's active set and answer, as in a control loop);
* DAQP (Arnström, Bemporad, Axehill 2022) through ``daqp.solve`` from Python, cold;
* ProxQP (Bambade et al. 2022) through ``qpsolvers.solve_qp``, cold.

Run: ``python benchmarks/dense_qp.py``. Medians over rounds of the whole sequence, µs per
solve; the load average is printed (the machine is shared: compare rows of one run).
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

os.environ.setdefault("REDRES_COMPILE", "foreground")  # the scheme's compiled kernels, recorded
sys.path.insert(0, str(Path(__file__).parent))

from _common import machine, table
from step import DT, GAIN, problem

from redres.resolution import QPScheme
from redres.resolution.hard_limits import _solvers
from redres.resolution.hard_limits._compiled import kernels
from redres.tasks import FrameTask

K = kernels("_dense_qp_kernels")
ROUNDS = 15


def record_panda(steps: int = 400) -> tuple[list[tuple[Any, ...]], list[tuple[Any, ...]]]:
    """The QPs of ``steps`` closed-loop steps of ``QPScheme`` on step.py's problem (its
    ``step``: DAQP's path, which the compiled one-call step replaces)."""
    exact: list[tuple[Any, ...]] = []
    boxes: list[tuple[Any, ...]] = []
    solve = _solvers.WarmQP.solve

    def recording(qp: Any, H: Any = None, f: Any = None, A: Any = None, bupper: Any = None,
                  blower: Any = None) -> Any:  # fmt: skip
        data = getattr(qp, "_seen", None) or dict(qp._data)
        new = {"H": H, "f": f, "A": A, "bupper": bupper, "blower": blower}
        data.update({k: np.array(v) for k, v in new.items() if v is not None})
        qp._seen = data
        n, m = data["f"].shape[0], data["A"].shape[0]
        if m:
            exact.append((data["A"], data["bupper"][n:], -data["f"], data["blower"][:n],
                          data["bupper"][:n]))  # fmt: skip
        else:
            boxes.append((data["H"], data["f"], data["blower"], data["bupper"]))
        return solve(qp, H, f, A, bupper, blower)

    _solvers.WarmQP.solve = recording  # type: ignore[method-assign]
    try:
        robot, q, target = problem()
        task, scheme = FrameTask(), QPScheme(dt=DT)
        task.set_target(target)
        for _ in range(steps):  # the scheme's own step (a Controller's one-call step has no DAQP)
            state = task.compute(robot, q)
            q = q + scheme.step(robot, q, state.jacobian, state.command(GAIN)).qd * DT
    finally:
        _solvers.WarmQP.solve = solve  # type: ignore[method-assign]
    return exact, boxes


def random_qps(rng: np.random.Generator, count: int) -> tuple[list[tuple[Any, ...]], list]:
    """Exact and box QPs of n = 7, m = 6: Jacobian-like conditioning, boxes of 0.05 to 2
    rad/s, targets feasible or not."""
    exact, boxes = [], []
    for _ in range(count):
        U, _, Vt = np.linalg.svd(rng.normal(size=(6, 7)), full_matrices=False)
        J = (U * 10.0 ** rng.uniform(-1.5, 0.3, 6)) @ Vt
        width = 10.0 ** rng.uniform(-1.3, 0.3)
        lo, hi = -width * rng.uniform(0.1, 1, 7), width * rng.uniform(0.1, 1, 7)
        b = J @ rng.uniform(lo, hi) * rng.choice([1.0, 2.0])
        x0 = 0.1 * rng.normal(size=7)
        exact.append((J, b, x0, lo, hi))
        boxes.append((J.T @ J + 1e-6 * np.eye(7), -J.T @ b - 1e-6 * x0, lo, hi))
    return exact, boxes


def sequence_time(solve_all: Callable[[], object], count: int) -> float:
    """Median over rounds of the time of one pass over ``count`` QPs, µs per QP."""
    solve_all()
    times = []
    for _ in range(ROUNDS):
        t0 = time.perf_counter_ns()
        solve_all()
        times.append((time.perf_counter_ns() - t0) / count / 1e3)
    return statistics.median(times)


def compiled_loops() -> tuple[Callable[..., Any], Callable[..., Any]]:
    """Compiled loops over stacked problems: the solvers' cost without Python's dispatch."""
    import numba

    eq, box = K.eq_box_qp, K.box_qp

    @numba.njit(cache=False)
    def eq_loop(J, b, x0, lo, hi, x, work, active, its, warm):  # pragma: no cover - compiled
        for i in range(J.shape[0]):
            if not warm:
                active[:] = 0
            _, its[i] = eq(J[i], b[i], x0[i], lo[i], hi[i], x, work, active)
        return 0

    @numba.njit(cache=False)
    def box_loop(P, c, lo, hi, x, work, active, its, warm):  # pragma: no cover - compiled
        for i in range(P.shape[0]):
            if not warm:
                active[:] = 0
                x[:] = 0.0
            _, its[i] = box(P[i], c[i], lo[i], hi[i], x, work, active)
        return 0

    return eq_loop, box_loop


def timed_rows(
    label: str, kind: str, loop: Callable[..., object], args: list[Any],
    solvers: tuple[Callable[[], object], ...], count: int, sequence: bool,
) -> list[list[str]]:  # fmt: skip
    """The rows of one kind of QP: our compiled ``loop`` over the stacked ``args`` (its
    last one the iteration counts), cold then warm (only for a ``sequence``), and the
    ``solvers`` ours, DAQP's and ProxQP's from Python: µs per solve, iterations."""
    ours, theirs, prox = solvers
    cases = [
        (f"{kind}, compiled loop, cold", lambda: loop(*args, False), count, False),
        (f"{kind}, compiled loop, warm", lambda: loop(*args, True), count, True),
        (f"{kind} from Python, cold", ours, count, None),
        ("DAQP daqp.solve from Python, cold", theirs, count, None),
        ("ProxQP qpsolvers.solve_qp, cold", prox, min(50, count), None),
    ]
    rows = []
    for name, fn, k, warm in cases:
        if warm and not sequence:
            continue
        us = sequence_time(fn, k)
        iters = ""
        if warm is not None:
            fn()
            its = args[-1]
            iters = f"{its.mean():.2f} (max {its.max()})"
        rows.append([label, name, f"{us:.2f}", iters])
    return rows


def bench(label: str, exact: list, boxes: list, sequence: bool) -> list[list[str]]:
    """Rows of the table; ``sequence``: the QPs are a control loop's, in order (a warm
    start from the previous one is timed too; random QPs have no previous one)."""
    import daqp
    import qpsolvers

    eq_loop, box_loop = compiled_loops()
    n, m = exact[0][0].shape[1], exact[0][0].shape[0]
    work, active, x = np.zeros(K.work_shape(n, m)), np.zeros(n, np.int8), np.zeros(n)
    sense = np.r_[np.zeros(n), np.full(m, 5)].astype(np.intc)
    stacked = [np.ascontiguousarray(np.stack(parts)) for parts in zip(*exact)]
    its = np.zeros(len(exact), np.int64)
    flags = [K.eq_box_qp(J, b, x0, lo, hi, x, work, np.zeros(n, np.int8))[0]
             for J, b, x0, lo, hi in exact]  # fmt: skip
    feasible = sum(f == 1 for f in flags)

    def ours_py() -> None:
        for J, b, x0, lo, hi in exact:
            active[:] = 0
            K.eq_box_qp(J, b, x0, lo, hi, x, work, active)

    def daqp_py() -> None:
        for J, b, x0, lo, hi in exact:
            daqp.solve(np.eye(n), -x0, J, np.concatenate([hi, b]), np.concatenate([lo, b]),
                       sense, primal_tol=1e-10)  # fmt: skip

    def prox_py() -> None:
        for J, b, x0, lo, hi in exact[:50]:
            qpsolvers.solve_qp(np.eye(n), -x0, None, None, J, b, lo, hi, solver="proxqp")

    count = len(exact)
    rows = timed_rows(f"{label}: exact ({feasible}/{count} feasible)", "eq_box_qp", eq_loop,
                      [*stacked, x, work, active, its], (ours_py, daqp_py, prox_py), count,
                      sequence)  # fmt: skip

    if boxes:
        nb = boxes[0][0].shape[0]
        wb, ab, xb = np.zeros(K.work_shape(nb)), np.zeros(nb, np.int8), np.zeros(nb)
        sb = [np.ascontiguousarray(np.stack(parts)) for parts in zip(*boxes)]
        itb = np.zeros(len(boxes), np.int64)
        none = np.zeros((0, nb))

        def box_py() -> None:
            for P, c, lo, hi in boxes:
                ab[:] = 0
                xb[:] = 0.0
                K.box_qp(P, c, lo, hi, xb, wb, ab)

        def daqp_box() -> None:
            for P, c, lo, hi in boxes:
                daqp.solve(P, c, none, hi, lo, np.zeros(nb, np.intc), primal_tol=1e-10)

        def prox_box() -> None:
            for P, c, lo, hi in boxes[:50]:
                qpsolvers.solve_qp(P, c, lb=lo, ub=hi, solver="proxqp")

        count = len(boxes)
        rows += timed_rows(f"{label}: box ({count})", "box_qp", box_loop,
                           [*sb, xb, wb, ab, itb], (box_py, daqp_box, prox_box), count,
                           sequence)  # fmt: skip
    return rows


def main() -> int:
    print(machine())
    print("load average before:", " ".join(f"{v:.2f}" for v in os.getloadavg()))
    exact, boxes = record_panda()
    rows = bench("Panda loop", exact, boxes, True)
    rows += bench("random", *random_qps(np.random.default_rng(0), 400), False)
    print(table(["problems", "solver", "µs per solve (median)", "iterations (mean)"], rows))
    print("load average after:", " ".join(f"{v:.2f}" for v in os.getloadavg()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
