"""Global planning by dynamic programming: time against the grid's size (``rr.plan_path``).

The paths of two built-in scenarios: the Panda joint-limit circle (10 s; ``q7`` as the
redundancy parameter, from the scenario's ``q0``) and the iiwa14 figure eight (10 s; the
arm angle, start free), sampled at ``K`` instants (``dt = 10 s / (K − 1)``) with ``P``
parameter values and 8 branches per sample; objective the max-min joint-limit margin;
velocity limits the robot's. Per size, medians of ``--rounds`` plans: the grid (every
closed-form IK solution, NumPy or the analytic kernel), the DP (sorting, the forward
pass, the backward reachability pass, the components, the second pass that picks the
shortest of the max-min paths), and the whole call (sampling the trajectory included);
on one thread (numba's threads set to 1) and on all cores (the grid's IK kernel is
parallel; the DP kernel is serial). ``pairs`` is how many node pairs the transition test
ran on after the pruning, against ``Σ N_k·N_{k+1}`` (every feasible pair) without it.
Then the same plans with acceleration limits (``qdd_max``: the Panda's published limits,
15/7.5/10/12.5/15/20/20 rad/s²; 10 rad/s² per joint for the iiwa14, whose model has
none), where the DP runs over transitions instead of nodes: the DP's time, the whole
call on one thread, the transition pairs tested and the optimum.

Run: ``PYTHONPATH=src python benchmarks/plan.py [--quick] [--rounds N]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np
from _common import load_text, machine, table

import redres as rr
from redres import _compile
from redres.scenarios.spec import ScenarioSpec, builtin

SIZES = [(100, 36), (250, 90), (500, 180), (1000, 360)]
QUICK = [(50, 18), (100, 36)]


def _qdd(scenario: ScenarioSpec) -> np.ndarray:
    """The acceleration limits planned with: the robot's, else 10 rad/s² per joint."""
    limit = scenario.robot.qdd_max
    return np.where(np.isfinite(limit), limit, 10.0)


def _plan(scenario: ScenarioSpec, K: int, P: int, qdd_max: np.ndarray | None = None
          ) -> rr.PathPlan:  # fmt: skip
    dt = scenario.trajectory.duration / (K - 1)
    if scenario.name == "panda_joint_limit_circle":
        return rr.plan_path(scenario.robot, scenario.trajectory, dt=dt, parameter="q7",
                            resolution=P, q0=scenario.q0, qdd_max=qdd_max)  # fmt: skip
    return rr.plan_path(scenario.robot, scenario.trajectory, dt=dt, parameter="arm_angle",
                        resolution=P, qdd_max=qdd_max)  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    before = os.getloadavg()
    _compile.warm(("plan", "analytic ik", "batch"), quiet=True)
    rows, accel = [], []
    for name, label in (("panda_joint_limit_circle", "Panda circle, q7"),
                        ("iiwa_arm_angle_eight", "iiwa14 eight, arm angle")):  # fmt: skip
        scenario = builtin(name)
        _plan(scenario, 20, 8)  # first calls (imports, caches) outside the timing
        _plan(scenario, 20, 8, _qdd(scenario))
        for K, P in QUICK if args.quick else SIZES:
            timing: dict[str, list[float]] = {"grid": [], "dp": [], "total": [], "grid_all": [],
                                              "total_all": [], "dp_qdd": [],
                                              "total_qdd": []}  # fmt: skip
            for threads in (1, None):
                previous = _compile.threads(threads)
                try:
                    for _ in range(args.rounds):
                        t0 = time.perf_counter()
                        plan = _plan(scenario, K, P)
                        total = time.perf_counter() - t0
                        if threads == 1:
                            timing["grid"].append(plan.stats.seconds_grid)
                            timing["dp"].append(plan.stats.seconds_dp)
                            timing["total"].append(total)
                        else:
                            timing["grid_all"].append(plan.stats.seconds_grid)
                            timing["total_all"].append(total)
                finally:
                    _compile.threads(previous)
            previous = _compile.threads(1)
            try:
                for _ in range(args.rounds):
                    t0 = time.perf_counter()
                    limited = _plan(scenario, K, P, _qdd(scenario))
                    timing["total_qdd"].append(time.perf_counter() - t0)
                    timing["dp_qdd"].append(limited.stats.seconds_dp)
            finally:
                _compile.threads(previous)
            s = plan.stats
            per = s.feasible_per_sample.astype(float)
            every = float(np.sum(per[:-1] * per[1:]))
            med = {k: statistics.median(v) for k, v in timing.items()}
            rows.append([
                label, f"{K} × {P} × 8", f"{s.nodes:,}", f"{s.feasible_nodes:,}",
                f"{s.pairs_checked:,} of {every:,.0f}", f"{s.transitions:,}",
                f"{med['grid']:.2f}", f"{med['grid_all']:.2f}", f"{med['dp']:.2f}",
                f"{med['total']:.2f}", f"{med['total_all']:.2f}",
                f"{plan.objective:.4f}" if plan.feasible else "none",
            ])  # fmt: skip
            ls = limited.stats
            accel.append([
                label, f"{K} × {P} × 8", f"{ls.transitions:,}",
                f"{ls.edge_pairs_checked:,}", f"{ls.edge_pairs:,}", f"{med['dp_qdd']:.2f}",
                f"{med['total_qdd']:.2f}",
                f"{limited.objective:.4f}" if limited.feasible else "none",
                f"{limited.acceleration_ratio:.2f}" if limited.feasible else "-",
            ])  # fmt: skip
    after = os.getloadavg()
    cores = os.cpu_count()
    print(table(["path", "grid K × P × B", "nodes", "feasible", "pairs tested", "transitions",
                 "grid s (1 thread)", f"grid s ({cores} threads)", "DP s",
                 "total s (1 thread)", f"total s ({cores} threads)", "max-min margin rad"],
                rows))  # fmt: skip
    print()
    print("With acceleration limits (qdd_max), one thread:")
    print()
    print(table(["path", "grid K × P × B", "transitions", "transition pairs tested",
                 "allowed", "DP s", "total s", "max-min margin rad", "peak |q̈|/q̈_max"],
                accel))  # fmt: skip
    print()
    print(f"Medians of {args.rounds} plans each; {machine()}; {load_text(before, after)}.")


if __name__ == "__main__":
    main()
