"""Per-call cost of one damped rate-control step on a 6 x 7 Jacobian (not a test).

Run from the repository root::

    python benchmarks/linalg.py [--rounds 21] [--calls 2000]

Times ``qd = J# xd - k (I - J# J) grad`` with ``J# = J^T (J J^T + lambda^2 I)^-1``
through the public functions of ``redres.linalg``, next to NumPy doing the same step with
``numpy.linalg.pinv`` and with a plain ``numpy.linalg.solve``, and a bare
``numpy.linalg.pinv(J)`` call. Cases are interleaved in shuffled order in every round and
the table reports the median over rounds of the mean time per call, so that drifts of the
machine load affect all cases alike. Goal (issue 3): <= 3 us per step and >= 10x faster
than ``numpy.linalg.pinv``.
"""

from __future__ import annotations

import argparse
import os
import platform
import random
import statistics
import sys
import time
from collections.abc import Callable

import numpy as np

try:
    import redres.linalg as rl
except ImportError:  # not installed: run from a source checkout
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
    import redres.linalg as rl

M_ROWS, N_JOINTS = 6, 7
DAMPING = 0.05
K_NULL = 0.5


def problem(seed: int = 7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A well-conditioned 6 x 7 Jacobian (sigma in [0.3, 2]), a task velocity, a gradient."""
    rng = np.random.default_rng(seed)
    U = np.linalg.qr(rng.standard_normal((M_ROWS, M_ROWS)))[0]
    V = np.linalg.qr(rng.standard_normal((N_JOINTS, N_JOINTS)))[0]
    sigma = np.linspace(2.0, 0.3, M_ROWS)
    J = U @ np.diag(sigma) @ V[:M_ROWS]
    return J, rng.standard_normal(M_ROWS), rng.standard_normal(N_JOINTS)


def cases(J: np.ndarray, xd: np.ndarray, g: np.ndarray) -> dict[str, Callable[[], object]]:
    """The timed calls; each returns the joint velocity (or the bare inverse)."""
    lam2 = DAMPING * DAMPING
    eye_m = np.eye(M_ROWS)
    eye_n = np.eye(N_JOINTS)
    rate_step = rl.rate_step
    damped_pinv = rl.damped_pinv
    np_pinv = np.linalg.pinv
    np_solve = np.linalg.solve

    def redres_step() -> object:
        return rate_step(J, xd, g, k_null=K_NULL, damping=DAMPING)[0]

    def redres_matrices() -> object:
        Jp = damped_pinv(J, DAMPING)
        return Jp @ xd - K_NULL * ((eye_n - Jp @ J) @ g)

    def numpy_pinv_step() -> object:
        # numpy.linalg.pinv has no damping: the undamped step is the cheapest it offers.
        Jp = np_pinv(J)
        return Jp @ xd - K_NULL * (g - Jp @ (J @ g))

    def numpy_solve_step() -> object:
        y = np_solve(J @ J.T + lam2 * eye_m, xd + K_NULL * (J @ g))
        return J.T @ y - K_NULL * g

    def numpy_pinv_only() -> object:
        return np_pinv(J)

    def redres_damped_pinv_only() -> object:
        return damped_pinv(J, DAMPING)

    return {
        "redres.linalg.rate_step (damped + null space)": redres_step,
        "redres.linalg.damped_pinv + NumPy products": redres_matrices,
        "numpy.linalg.solve damped step": numpy_solve_step,
        "numpy.linalg.pinv step (undamped)": numpy_pinv_step,
        "numpy.linalg.pinv(J) alone": numpy_pinv_only,
        "redres.linalg.damped_pinv(J) alone": redres_damped_pinv_only,
    }


def check(J: np.ndarray, xd: np.ndarray, g: np.ndarray) -> None:
    """The damped implementations agree before anything is timed."""
    table = cases(J, xd, g)
    ref = np.asarray(table["numpy.linalg.solve damped step"]())
    for name in (
        "redres.linalg.rate_step (damped + null space)",
        "redres.linalg.damped_pinv + NumPy products",
    ):
        got = np.asarray(table[name]())
        if not np.allclose(got, ref, rtol=1e-10, atol=1e-12):
            raise SystemExit(f"{name} disagrees with NumPy: {got} vs {ref}")


def measure(rounds: int, calls: int) -> dict[str, float]:
    """Median over rounds of the mean microseconds per call, cases interleaved."""
    J, xd, g = problem()
    check(J, xd, g)
    table = cases(J, xd, g)
    for fn in table.values():  # warm-up: JIT compilation or cache load, caches
        for _ in range(200):
            fn()
    samples: dict[str, list[float]] = {name: [] for name in table}
    order = list(table)
    shuffle = random.Random(0).shuffle
    clock = time.perf_counter_ns
    for _ in range(rounds):
        shuffle(order)
        for name in order:
            fn = table[name]
            t0 = clock()
            for _ in range(calls):
                fn()
            samples[name].append((clock() - t0) / calls / 1e3)
    return {name: statistics.median(values) for name, values in samples.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=21, help="interleaved rounds")
    parser.add_argument("--calls", type=int, default=2000, help="calls per case and round")
    args = parser.parse_args()
    medians = measure(args.rounds, args.calls)
    ours = medians["redres.linalg.rate_step (damped + null space)"]
    print(
        f"6x7 damped rate step (lambda={DAMPING}, k_null={K_NULL}); median of {args.rounds} "
        f"interleaved rounds x {args.calls} calls; Python {platform.python_version()}, "
        f"NumPy {np.__version__}, {os.cpu_count()} CPUs"
    )
    width = max(len(name) for name in medians)
    print(f"{'case':<{width}}  {'us/call':>8}  {'vs rate_step':>12}")
    for name, value in medians.items():
        print(f"{name:<{width}}  {value:8.2f}  {value / ours:11.1f}x")
    speedup = medians["numpy.linalg.pinv(J) alone"] / ours
    verdict = "met" if ours <= 3.0 and speedup >= 10.0 else "NOT met"
    print(f"goal (<= 3 us, >= 10x numpy.linalg.pinv): {verdict} ({ours:.2f} us, {speedup:.1f}x)")
    inverse = medians["redres.linalg.damped_pinv(J) alone"]
    ratio = medians["numpy.linalg.pinv(J) alone"] / inverse
    verdict = "met" if ratio >= 5.0 else "NOT met"
    print(f"goal (damped_pinv >= 5x numpy.linalg.pinv): {verdict} ({inverse:.2f} us, {ratio:.1f}x)")


if __name__ == "__main__":
    main()
