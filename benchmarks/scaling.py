"""Time per control step against the number of joints.

Planar chains of 3 to 50 revolute joints (unit-length links scaled to a 1 m reach; task: the
tip's planar pose x, y, φ — m = 3 rows) and a 14-joint spatial chain (two S-R-S arms in
series; task: the 6-D tip pose). The step is the CLIK step of benchmarks/step.py: kinematics,
pose error, damped inverse with the joint-limit gradient in its null space, integration.

What the algebra predicts for m task rows and n joints: the Jacobian costs O(n) (one pass of
the chain); forming J Jᵀ + λ²I costs O(m² n), its factorisation O(m³), the task term
O(m n) and the projected gradient O(m n) (N is never formed). With m fixed the step is linear
in n plus a constant for the Python and Pinocchio call overhead; the table reports the
measured median and a least-squares fit ``a + b·n``.

Run: ``python benchmarks/scaling.py``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

from _common import machine, median, table, time_calls

import redres as rr
from redres.objectives import JointLimitObjective
from redres.tasks import FrameTask, PlanarTask

SIZES = (3, 5, 7, 10, 15, 20, 30, 40, 50)


def chain_14() -> rr.Robot:
    """Two S-R-S arms in series: a 14-joint spatial chain (standard DH)."""
    d = (0.34, 0.0, 0.40, 0.0, 0.40, 0.0, 0.126)
    alpha = (-np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, -np.pi / 2, np.pi / 2, 0.0)
    links = [
        {"a": 0.0, "alpha": al, "d": di * 0.5, "q_min": -2.9, "q_max": 2.9}
        for _ in range(2)
        for di, al in zip(d, alpha)
    ]
    return rr.Robot.from_dh(links, name="chain14")


def step_time(robot: rr.Robot, task: FrameTask, q: np.ndarray) -> float:
    limits = JointLimitObjective()
    rate_step = rr.linalg.rate_step

    def step() -> np.ndarray:
        state = task.compute(robot, q)
        grad = limits.gradient(robot, q)
        qd, _, _ = rate_step(state.jacobian, state.command(50.0), grad, k_null=1.0, damping=0.05)
        return q + qd * 1e-3

    return median(time_calls(step, batch=100, batches=15))


def main() -> int:
    print(f"Control step against the number of joints, {machine()}")
    rows, ns, times = [], [], []
    for n in SIZES:
        robot = rr.models.planar(np.full(n, 1.0 / n))
        q = robot.random_configuration(n, margin=0.3)
        task = PlanarTask()
        T = robot.fk(q)
        T[:2, 3] += [0.01, -0.01]
        task.set_target(T)
        t = step_time(robot, task, q)
        ns.append(n)
        times.append(t)
        rows.append([f"planar {n}", "3", f"{t:.1f}"])
    a, b = np.polynomial.polynomial.polyfit(ns, times, 1)
    robot = chain_14()
    q = robot.random_configuration(14, margin=0.3)
    task = FrameTask()
    T = robot.fk(q)
    T[:3, 3] += [0.01, 0.0, -0.01]
    task.set_target(T)
    rows.append(["two S-R-S arms in series, 14 joints", "6", f"{step_time(robot, task, q):.1f}"])
    print(table(["chain", "task rows", "median µs per step"], rows))
    residual = np.array(times) - (a + b * np.array(ns))
    print(
        f"\nlinear fit over the planar chains: {a:.1f} µs + {b:.2f} µs per joint "
        f"(largest deviation {np.abs(residual).max():.1f} µs)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
