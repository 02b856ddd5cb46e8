"""Position inverse kinematics on random reachable targets (not a test).

Run from the repository root::

    python benchmarks/ik.py [--targets 1000] [--seed 7] [--robots panda iiwa14]

For each arm, ``--targets`` configurations are drawn uniformly within the joint limits
(seeded), their tip poses are the targets, and ``redres.ik.ik`` solves each from the
robot's neutral configuration with its default budgets (tolerance 1e-6 m and 1e-5 rad,
100 iterations per attempt, up to 50 random restarts, 0.5 s). A solve counts as a success
only if it reports convergence *and* an independent check passes: forward kinematics of
the returned configuration within the tolerances (rotation angle from ``‖R − R_d‖_F``) and
every joint within its limits (zero tolerance). Times are wall-clock per call, including
input validation. The table also reports position-only targets (the tip position).
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time

import numpy as np

try:
    import redres as rr
    from redres.ik import ik
except ImportError:  # not installed: run from a source checkout
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
    import redres as rr
    from redres.ik import ik

TOL_POSITION, TOL_ORIENTATION = 1e-6, 1e-5


def solved(robot: rr.Robot, q: np.ndarray, T: np.ndarray, position_only: bool) -> bool:
    """Independent check of a solution: forward kinematics and joint limits."""
    F = robot.fk(q)
    if np.linalg.norm(F[:3, 3] - T[:3, 3]) > TOL_POSITION or not robot.within_limits(q):
        return False
    if position_only:
        return True
    chord = float(np.linalg.norm(F[:3, :3] - T[:3, :3])) / (2.0 * math.sqrt(2.0))
    return 2.0 * math.asin(min(chord, 1.0)) <= TOL_ORIENTATION


def run(robot: rr.Robot, targets: list[np.ndarray], position_only: bool) -> dict[str, float]:
    times, iterations, restarts = [], [], []
    ok = outside = 0
    clock = time.perf_counter
    for k, T in enumerate(targets):
        target = T[:3, 3] if position_only else T
        t0 = clock()
        result = ik(robot, target, seed=k)
        times.append(clock() - t0)
        iterations.append(result.iterations)
        restarts.append(result.restarts)
        outside += not robot.within_limits(result.q)
        ok += result.converged and solved(robot, result.q, T, position_only)
    ms = np.array(times) * 1e3
    return {
        "success_pct": 100.0 * ok / len(targets),
        "median_ms": float(np.median(ms)),
        "mean_ms": float(ms.mean()),
        "p99_ms": float(np.percentile(ms, 99)),
        "max_ms": float(ms.max()),
        "median_iterations": float(np.median(iterations)),
        "mean_restarts": float(np.mean(restarts)),
        "outside_limits": float(outside),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--robots", nargs="+", default=["panda", "iiwa14"])
    args = parser.parse_args()
    print(f"redres {rr.__version__}, Python {platform.python_version()}, {platform.machine()}")
    print(f"{args.targets} random reachable targets per arm, seed {args.seed}\n")
    header = (
        f"{'robot':8} {'target':9} {'success':>8} {'median':>9} {'mean':>9} {'p99':>9} "
        f"{'max':>9} {'iter.':>6} {'restarts':>9} {'outside':>8}"
    )
    print(header)
    print("-" * len(header))
    for name in args.robots:
        robot = rr.models.load(name)
        rng = np.random.default_rng(args.seed)
        targets = [robot.fk(robot.random_configuration(rng)) for _ in range(args.targets)]
        ik(robot, robot.fk(robot.random_configuration(rng)))  # load the compiled kernels
        for position_only in (False, True):
            r = run(robot, targets, position_only)
            kind = "position" if position_only else "pose"
            print(
                f"{name:8} {kind:9} {r['success_pct']:7.2f}% {r['median_ms']:7.3f}ms "
                f"{r['mean_ms']:7.3f}ms {r['p99_ms']:7.2f}ms {r['max_ms']:7.2f}ms "
                f"{r['median_iterations']:6.0f} {r['mean_restarts']:9.3f} "
                f"{r['outside_limits']:8.0f}"
            )


if __name__ == "__main__":
    main()
